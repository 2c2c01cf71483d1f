"""Messages carried between ROS 1 and ROS 2: the bulk translation of TF and joint states against
rosbags' own conversion, and types tfrec knows nothing of — a camera image, a type defined only in
the file — through a ROS 2 → ROS 1 → ROS 2 trip."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.conftest import BAGS, BAGS_ABSENT
from tfrec import cli
from tfrec.convert import convert
from tfrec.formats.reader import read_recording
from tfrec.formats.ros.connection import Connection, raw_messages
from tfrec.formats.translate import Untranslatable, translation

CUSTOM = {
    "my_msgs/msg/Point3": "float64 x\nfloat64 y\nfloat64 z\n",
    "my_msgs/msg/Blob": ("std_msgs/Header header\nstring label\nmy_msgs/Point3[] points\nfloat32[3] gains\n"
                         "uint8[] data\nint64 big\nbool ok\nstring[] tags\nbuiltin_interfaces/Duration wait\n"),
}


def humble() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in CUSTOM.items():
        store.register(get_types_from_msg(text, name))
    return store


def joint_state(store: Any, i: int, names: list[str], *, velocity: bool = True, effort: bool = False) -> Any:
    t = store.types
    values = np.linspace(-1, 1, len(names)) * (i + 1) / 7
    return t["sensor_msgs/msg/JointState"](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=1_700_000_000 + i, nanosec=i * 1000),
                                        frame_id="base" if i % 5 == 0 else ""),
        name=names, position=values, velocity=values * 2 if velocity else np.zeros(0),
        effort=values * 3 if effort else np.zeros(0))


def tf_message(store: Any, i: int, frames: list[tuple[str, str]]) -> Any:
    t = store.types
    return t["tf2_msgs/msg/TFMessage"](transforms=[t["geometry_msgs/msg/TransformStamped"](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=1_700_000_000 + i, nanosec=7),
                                        frame_id=parent),
        child_frame_id=child,
        transform=t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=i * 0.1, y=-k * 1.0, z=np.nan if i == 3 else 1.5),
            rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=np.sin(i / 10), w=np.cos(i / 10))))
        for k, (parent, child) in enumerate(frames)])


def messages_of(store: Any) -> dict[str, list[bytes]]:
    """CDR messages of fixed layouts with others mixed in: other names, other lengths, empty arrays."""
    js = [joint_state(store, i, ["j1", "j2", "j3"]) for i in range(40)]
    js[10] = joint_state(store, 10, ["j1", "j2"])  # fewer joints
    js[11] = joint_state(store, 11, ["j1", "j2", "j3"], velocity=False, effort=True)
    js += [joint_state(store, i, ["wheel_left", "wheel_right"], effort=True) for i in range(40, 100)]  # another layout wins
    frames = [("base", "link1"), ("link1", "link_with_a_longer_name")]
    tf = [tf_message(store, i, frames) for i in range(50)] + [tf_message(store, 50, frames[:1])]
    return {"sensor_msgs/msg/JointState": [bytes(store.serialize_cdr(m, "sensor_msgs/msg/JointState")) for m in js],
            "tf2_msgs/msg/TFMessage": [bytes(store.serialize_cdr(m, "tf2_msgs/msg/TFMessage")) for m in tf]}


@pytest.mark.parametrize("msgtype", ["sensor_msgs/msg/JointState", "tf2_msgs/msg/TFMessage"])
def test_bulk_translation_is_rosbags_conversion(msgtype: str) -> None:
    store = humble()
    cdr = messages_of(store)[msgtype]
    to_ros1 = translation(Connection("/x", msgtype, "cdr"), encoding="ros1")
    assert to_ros1.kind is not None
    for at in range(0, len(cdr), 37):  # batches, so that the layout is learnt and relearnt
        payload, kept = to_ros1.apply(raw_messages(cdr[at : at + 37]))
        assert kept is None
        assert [bytes(m) for m in payload] == [bytes(store.cdr_to_ros1(m, msgtype)) for m in cdr[at : at + 37]]
    ros1 = [bytes(store.cdr_to_ros1(m, msgtype)) for m in cdr]
    target = to_ros1.target
    assert target.encoding == "ros1" and target.definition_encoding == "ros1msg" and len(target.type_hash) == 32
    to_cdr = translation(target, encoding="cdr")
    payload, kept = to_cdr.apply(raw_messages(ros1))
    assert kept is None and [bytes(m) for m in payload] == cdr
    assert to_cdr.target.type_hash == store.hash_rihs01(msgtype)
    names = ["j1", "j2", "j3"] if msgtype.startswith("sensor") else None
    same = [bytes(store.serialize_cdr(joint_state(store, i, names) if names else
                                      tf_message(store, i, [("a", "b")]), msgtype)) for i in (1, 2, 4, 6, 7)]
    rows, kept = to_ros1.apply(raw_messages(same))
    assert isinstance(rows, np.ndarray) and kept is None  # one fixed layout: one array of rows
    assert [r.tobytes() for r in rows] == [bytes(store.cdr_to_ros1(m, msgtype)) for m in same]


def test_messages_rosbags_cannot_convert_are_counted() -> None:
    store = humble()
    good = messages_of(store)["tf2_msgs/msg/TFMessage"][:3]
    tr = translation(Connection("/x", "tf2_msgs/msg/TFMessage", "cdr"), encoding="ros1")
    payload, kept = tr.apply(raw_messages([good[0], b"\x00\x01\x00\x00\xff\xff", good[1]]))
    assert kept is not None and kept.tolist() == [0, 2] and len(payload) == 2
    assert tr.failed == 1 and tr.reason


def test_what_cannot_be_carried_over_says_why() -> None:
    with pytest.raises(Untranslatable, match=r"the file has no message definition of my_msgs/msg/Nope, and ROS 2 "
                                             r"Humble does not know it"):
        translation(Connection("/x", "my_msgs/msg/Nope", "cdr"), encoding="ros1")
    with pytest.raises(Untranslatable, match=r"its message definition does not parse \(rosbags: "):
        translation(Connection("/x", "my_msgs/msg/Bad", "cdr", "int32[ x\n", "ros2msg"), encoding="ros1")
    with pytest.raises(Untranslatable, match="a service event: ROS 1 bags record no services"):
        translation(Connection("/s", "example_interfaces/srv/AddTwoInts_Event", "cdr", "int64 a\n", "ros2msg"),
                    encoding="ros1")
    with pytest.raises(Untranslatable, match="serialized as 'json', which tfrec carries only as it is"):
        translation(Connection("/j", "my/msg/J", "json"), encoding="ros1")
    kept = translation(Connection("/j", "my/msg/J", "json"), encoding="cdr")  # an MCAP holds any encoding
    assert kept.convert is None and kept.target.encoding == "json"


def write_camera_bag(path: Path) -> Path:
    """A rosbag2 MCAP of a camera image, a type defined only in the file, and JointState, by rosbags."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = humble()
    t = store.types
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=1_700_000_001, nanosec=5),
                                      frame_id="camera")
    image = t["sensor_msgs/msg/Image"](header=header, height=2, width=3, encoding="rgb8", is_bigendian=0, step=9,
                                       data=np.arange(18, dtype=np.uint8))
    blob = t["my_msgs/msg/Blob"](header=header, label="ünïcode", points=[t["my_msgs/msg/Point3"](x=1.0, y=2.0, z=3.0)],
                                 gains=np.array([0.5, 1.5, 2.5], dtype=np.float32), data=np.arange(5, dtype=np.uint8),
                                 big=-(2**40), ok=True, tags=["a", "", "c"],
                                 wait=t["builtin_interfaces/msg/Duration"](sec=-3, nanosec=10))
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        for topic, msgtype, msg in (("/camera/image_raw", "sensor_msgs/msg/Image", image),
                                    ("/blob", "my_msgs/msg/Blob", blob),
                                    ("/joint_states", "sensor_msgs/msg/JointState", joint_state(store, 0, ["a", "b"]))):
            connection = writer.add_connection(topic, msgtype, typestore=store)
            for k in range(3):
                writer.write(connection, 1_700_000_001_000_000_000 + k * 10_000_000, store.serialize_cdr(msg, msgtype))
    return path


def all_messages(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    """(log time, CDR bytes re-serialized after deserialization) of every message, per topic, by rosbags."""
    from rosbags.highlevel import AnyReader

    out: dict[str, list[tuple[int, bytes]]] = {}
    with AnyReader([path]) as reader:
        for connection, time_ns, raw in reader.messages():
            msg = reader.deserialize(raw, connection.msgtype)
            data = reader.typestore.serialize_cdr(msg, connection.msgtype) if reader.is2 else bytes(raw)
            out.setdefault(connection.topic, []).append((time_ns, bytes(data)))
    return out


def test_unknown_types_survive_ros2_ros1_ros2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = write_camera_bag(tmp_path / "camera")
    assert cli.main(["convert", str(source), str(tmp_path / "camera.bag")]) == 0
    assert cli.main(["convert", str(tmp_path / "camera.bag"), str(tmp_path / "camera.mcap")]) == 0
    assert capsys.readouterr().err == ""
    before, after = all_messages(source), all_messages(tmp_path / "camera.mcap")
    assert before == after and len(before) == 3
    from rosbags.highlevel import AnyReader

    with AnyReader([tmp_path / "camera.bag"]) as reader:  # the ROS 1 bag: definitions and md5sums rosbags accepts
        types = {c.topic: c.msgtype for c in reader.connections}
        assert types["/blob"] == "my_msgs/msg/Blob"
        blob = next(reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/blob")
        assert blob.label == "ünïcode" and blob.tags == ["a", "", "c"] and blob.header.seq == 0


def test_a_type_without_definition(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A sqlite3 bag of Humble's rosbag2 has no definitions: a type Humble knows is carried with its
    definition, one it does not is dropped from a ROS 1 bag with a line saying why, copied into an MCAP."""
    bag = BAGS / "rosbag2" / "rosbag2_transport__sqlite3_test_bag_for_seek"
    if not bag.is_dir():
        pytest.skip(BAGS_ABSENT)
    assert cli.main(["convert", str(bag), str(tmp_path / "seek.bag")]) == 0
    _, err = capsys.readouterr()
    assert err == (f"tfrec: warning: {bag}: /topic1: 5 messages not written: test_msgs/msg/BasicTypes: the file has "
                   "no message definition of test_msgs/msg/BasicTypes, and ROS 2 Humble does not know it\n")
    assert cli.main(["convert", str(bag), str(tmp_path / "seek.mcap")]) == 0
    assert read_recording(tmp_path / "seek.mcap").topics["/topic1"].count == 5
    talker = BAGS / "rosbag2" / "rosbag2_py__sqlite3_wbag"
    convert(talker, tmp_path / "wbag.bag")
    from rosbags.highlevel import AnyReader

    with AnyReader([tmp_path / "wbag.bag"]) as reader:
        assert {c.msgtype for c in reader.connections} == {"std_msgs/msg/String"}
        assert sum(1 for _ in reader.messages()) == 6074


def test_ros1_tf_becomes_tf2(tmp_path: Path) -> None:
    """ROS 1's old tf/tfMessage is written as tf2_msgs/msg/TFMessage in ROS 2, and its frames read alike."""
    bag = BAGS / "rosbagjs" / "example.bag"
    if not bag.is_file():
        pytest.skip(BAGS_ABSENT)
    convert(bag, tmp_path / "example.mcap")
    before, after = read_recording(bag), read_recording(tmp_path / "example.mcap")
    assert after.topics["/tf"].type == "tf2_msgs/msg/TFMessage"
    assert set(before.tf) == set(after.tf) and before.tf_static.keys() == after.tf_static.keys()
    for pair, series in before.tf.items():
        assert np.array_equal(series.time_ns, after.tf[pair].time_ns)
        assert np.array_equal(series.translation, after.tf[pair].translation)
    assert {name: info.count for name, info in before.topics.items()} == {
        name: info.count for name, info in after.topics.items()}
    assert after.topics["/rosout"].durability == "transient_local"
