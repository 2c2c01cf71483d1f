"""A ROS 1 output carries genmsg's text of each type of Noetic's with Noetic's md5sum — as ``rosbag record`` writes
it — whatever text the input gave (issue 22): a ROS 1 bag (or an MCAP of ROS 1 messages) written by another tool
(rosbags' generated text, without comments) was copied verbatim, and real ``rosbag check`` asked for migrations.
A type outside Noetic's packages, or one of another md5sum, keeps the input's text. The inputs are built here
with rosbags' and mcap's writers; the outputs are read back with rosbags."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter

from tfrec.convert import convert
from tfrec.formats.ros.types import genmsg_definition

START_NS = 1_700_000_000_000_000_000
CUSTOM = "tfrec_test_msgs/msg/Reading"
CUSTOM_TEXT = "# a type of nobody's\nfloat64 value\n"
KNOWN = ("sensor_msgs/msg/JointState", "std_msgs/msg/String", "geometry_msgs/msg/PoseStamped")


def _store() -> object:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg(CUSTOM_TEXT, CUSTOM))
    return store


def _message(store: object, msgtype: str) -> bytes:
    """One message of a type, ROS 1 serialized by rosbags."""
    from rosbags.typesys.stores.ros1_noetic import builtin_interfaces__msg__Time as Time
    from rosbags.typesys.stores.ros1_noetic import std_msgs__msg__Header as Header

    header = Header(seq=0, stamp=Time(sec=1, nanosec=2), frame_id="base")
    cls = store.types[msgtype]  # type: ignore[attr-defined]
    values = {"sensor_msgs/msg/JointState": lambda: cls(header=header, name=["a"], position=np.ones(1),
                                                        velocity=np.zeros(0), effort=np.zeros(0)),
              "std_msgs/msg/String": lambda: cls(data="x"),
              CUSTOM: lambda: cls(value=2.5)}
    if msgtype == "geometry_msgs/msg/PoseStamped":
        types = store.types  # type: ignore[attr-defined]
        pose = types["geometry_msgs/msg/Pose"](position=types["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=3.0),
                                               orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0,
                                                                                                 w=1.0))
        message = cls(header=header, pose=pose)
    else:
        message = values[msgtype]()
    return bytes(store.serialize_ros1(message, msgtype))  # type: ignore[attr-defined]


def _other_tools_bag(path: Path, *, types: tuple[str, ...] = (*KNOWN, CUSTOM)) -> dict[str, str]:
    """A ROS 1 bag as rosbags writes it: its generated definitions (no comments), Noetic's md5sums. Returns the
    definitions it holds, by type."""
    from rosbags.rosbag1 import Writer

    store = _store()
    texts = {}
    with Writer(path) as writer:
        for k, msgtype in enumerate(types):
            connection = writer.add_connection(f"/topic_{k}", msgtype, typestore=store)  # type: ignore[arg-type]
            texts[msgtype] = connection.msgdef.data
            writer.write(connection, START_NS + k, _message(store, msgtype))
    return texts


def _ros1_mcap(path: Path, *, types: tuple[str, ...] = (*KNOWN, CUSTOM)) -> None:
    """An MCAP of ROS 1 messages (profile ``ros1``, ``ros1msg`` schemas), rosbags' definitions, no md5sums."""
    store = _store()
    with open(path, "wb") as stream:
        writer = McapWriter(stream)
        writer.start(profile="", library="test")
        for k, msgtype in enumerate(types):
            text, _ = store.generate_msgdef(msgtype, ros_version=1)  # type: ignore[attr-defined]
            schema = writer.register_schema(msgtype.replace("/msg/", "/"), "ros1msg", text.encode())
            channel = writer.register_channel(f"/topic_{k}", "ros1", schema)
            writer.add_message(channel, log_time=START_NS + k, publish_time=START_NS + k,
                               data=_message(store, msgtype))
        writer.finish()


def _definitions(path: Path) -> dict[str, tuple[str, str]]:
    """Each connection's type → (definition, md5sum), as rosbags reads the bag."""
    from rosbags.rosbag1 import Reader

    with Reader(path) as reader:
        return {c.msgtype: (c.msgdef.data, c.digest) for c in reader.connections}


@pytest.mark.parametrize("origin", ["bag", "mcap"])
def test_known_types_get_genmsg_text_others_keep_theirs(tmp_path: Path, origin: str) -> None:
    source = tmp_path / f"in.{origin}"
    if origin == "bag":
        given = _other_tools_bag(source)
        assert given["sensor_msgs/msg/JointState"] != genmsg_definition("sensor_msgs/msg/JointState")  # no comments
    else:
        _ros1_mcap(source)
    convert(source, tmp_path / "out.bag")
    found = _definitions(tmp_path / "out.bag")
    store = _store()
    for msgtype in KNOWN:
        _, md5sum = store.generate_msgdef(msgtype, ros_version=1)  # type: ignore[attr-defined]
        assert found[msgtype] == (genmsg_definition(msgtype), md5sum), msgtype
    assert _definitions(tmp_path / "out.bag")[CUSTOM][0].strip() == "float64 value"  # the input's (no genmsg text)
    from rosbags.highlevel import AnyReader  # every message decodes with the written definitions

    with AnyReader([tmp_path / "out.bag"]) as reader:
        assert sum(1 for c, _, raw in reader.messages() if reader.deserialize(raw, c.msgtype)) == len(KNOWN) + 1


def test_a_known_type_of_another_md5sum_keeps_its_text(tmp_path: Path) -> None:
    """A std_msgs/String of another layout (and so another md5sum) is not Noetic's: its own text is kept."""
    from rosbags.rosbag1 import Writer

    text = "string data\nint32 count\n"
    with Writer(tmp_path / "in.bag") as writer:
        connection = writer.add_connection("/other", "std_msgs/msg/String", msgdef=text,
                                           md5sum="0123456789abcdef0123456789abcdef")
        writer.write(connection, START_NS, b"\x01\x00\x00\x00x\x07\x00\x00\x00")
    convert(tmp_path / "in.bag", tmp_path / "out.bag")
    assert _definitions(tmp_path / "out.bag")["std_msgs/msg/String"] == (text, "0123456789abcdef0123456789abcdef")
