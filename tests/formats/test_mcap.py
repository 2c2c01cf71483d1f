"""MCAP recordings and rosbag2 folders, read back with independent readers (rosbags, mcap_ros2,
mcap's own reader with CRC checks), and ``summarize`` on them and on foreign files."""

from __future__ import annotations

import io
import json
import re
import struct
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from tests.conftest import ROBOTS
from tfrec.conventions import DEFAULT_START_TIME_NS
from tfrec.description import load_description, parse_urdf
from tfrec.errors import RecordingError
from tfrec.formats.mcap.sink import McapSink
from tfrec.formats.mcap.writer import LIBRARY, check_time_range, message_definition
from tfrec.formats.rosbag2.metadata import QOS_LATCHED, QOS_VOLATILE, qos_yaml, write_bag_metadata
from tfrec.info import format_summary, summarize
from tfrec.kinematics.fk import iter_dynamic_chunks, static_transforms
from tfrec.model import Robot
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.types import JointTrajectory

TOPICS = ["/robot_description", "/tf_static", "/joint_states", "/tf"]

FIXED_ONLY = """<robot name="statue">
  <link name="base"/><link name="head"/>
  <joint name="neck" type="fixed"><parent link="base"/><child link="head"/><origin xyz="0 0 1"/></joint>
</robot>"""


@pytest.fixture(scope="module")
def marm() -> Robot:
    return load_description(ROBOTS / "marm.xacro")


@pytest.fixture(scope="module")
def traj(marm: Robot) -> JointTrajectory:
    return make_trajectory(marm, "sine", duration_s=2.0, rate_hz=50.0)


def record(
    stream: Any,
    robot: Robot,
    trajectory: JointTrajectory,
    *,
    samples_per_call: int = 64,
    start_time_ns: int = DEFAULT_START_TIME_NS,
    **options: Any,
) -> McapSink:
    sink = McapSink(stream, **options)
    sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=start_time_ns)
    for chunk in iter_dynamic_chunks(robot, trajectory, chunk_samples=samples_per_call):
        sink.write_chunk(stamp_ns=chunk.time_ns + start_time_ns, joint_names=chunk.names, positions=chunk.positions,
                         velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()
    return sink


def record_bytes(robot: Robot, trajectory: JointTrajectory, **options: Any) -> bytes:
    buffer = io.BytesIO()
    record(buffer, robot, trajectory, **options)
    return buffer.getvalue()


@pytest.fixture(scope="module")
def marm_mcap(tmp_path_factory: pytest.TempPathFactory, marm: Robot, traj: JointTrajectory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "marm.mcap"
    with open(path, "wb") as stream:
        record(stream, marm, traj, chunk_bytes=16 * 1024)  # several chunks
    return path


def expected(robot: Robot, trajectory: JointTrajectory) -> tuple[Any, Any]:
    (chunk,) = iter_dynamic_chunks(robot, trajectory, chunk_samples=len(trajectory))
    return chunk, static_transforms(robot)


def test_rosbags_reads_everything(marm_mcap: Path, marm: Robot, traj: JointTrajectory) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import ConnectionExtRosbag2, QosDurability, QosReliability

    chunk, static = expected(marm, traj)
    n = len(traj)
    with AnyReader([marm_mcap]) as reader:
        conns = {c.topic: c for c in reader.connections}
        assert [c.topic for c in reader.connections] == TOPICS
        assert {t: conns[t].msgcount for t in TOPICS} == {TOPICS[0]: 1, TOPICS[1]: 1, TOPICS[2]: n, TOPICS[3]: n}
        for topic, durability in zip(TOPICS, ["TRANSIENT_LOCAL"] * 2 + ["VOLATILE"] * 2):
            ext = conns[topic].ext
            assert isinstance(ext, ConnectionExtRosbag2)
            (qos,) = ext.offered_qos_profiles
            assert qos.durability == QosDurability[durability] and qos.reliability == QosReliability.RELIABLE
        seen: dict[str, list[tuple[int, Any]]] = {t: [] for t in TOPICS}
        for conn, timestamp, raw in reader.messages():
            seen[conn.topic].append((timestamp, reader.deserialize(raw, conn.msgtype)))
    ((t_desc, desc),) = seen["/robot_description"]
    assert desc.data == marm.urdf and t_desc == DEFAULT_START_TIME_NS
    ((t_static, tf_static),) = seen["/tf_static"]
    assert t_static == DEFAULT_START_TIME_NS
    assert [(t.header.frame_id, t.child_frame_id) for t in tf_static.transforms] == list(zip(static.parents, static.children))
    stamps = chunk.time_ns + DEFAULT_START_TIME_NS
    for i, (timestamp, msg) in enumerate(seen["/joint_states"]):
        assert timestamp == stamps[i] == msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        assert msg.header.frame_id == "" and tuple(msg.name) == chunk.names and len(msg.effort) == 0
        assert np.array_equal(msg.position, chunk.positions[i]) and np.array_equal(msg.velocity, chunk.velocities[i])
    for i, (timestamp, msg) in enumerate(seen["/tf"]):
        assert timestamp == stamps[i]
        frames = [(t.header.frame_id, t.child_frame_id) for t in msg.transforms]
        assert frames == list(zip(chunk.transforms.parents, chunk.transforms.children))
        for k, t in enumerate(msg.transforms):
            assert t.header.stamp.sec * 10**9 + t.header.stamp.nanosec == stamps[i]
            tr, q = t.transform.translation, t.transform.rotation
            assert [tr.x, tr.y, tr.z] == chunk.transforms.translation[i, k].tolist()
            assert [q.x, q.y, q.z, q.w] == chunk.transforms.rotation[i, k].tolist()


def test_mcap_ros2_decodes_in_order(marm_mcap: Path, marm: Robot, traj: JointTrajectory) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with open(marm_mcap, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        messages = list(reader.iter_decoded_messages(log_time_order=False))  # file order
    assert [channel.topic for _, channel, _, _ in messages] == TOPICS[:2] + TOPICS[2:] * len(traj)
    assert messages[0][3].data == marm.urdf
    for _, channel, message, decoded in messages:
        assert message.log_time == message.publish_time
        stamps = [decoded.header.stamp] if channel.topic == "/joint_states" else [t.header.stamp for t in getattr(decoded, "transforms", [])]
        assert all(message.log_time == stamp.sec * 10**9 + stamp.nanosec for stamp in stamps)


def test_file_layout(marm_mcap: Path) -> None:
    from mcap.reader import make_reader
    from mcap.stream_reader import StreamReader

    with open(marm_mcap, "rb") as stream:
        assert len(list(StreamReader(stream, validate_crcs=True).records)) > 0  # chunk CRCs
    with open(marm_mcap, "rb") as stream:
        records = list(StreamReader(stream, emit_chunks=True).records)
    assert sum(type(r).__name__ == "Chunk" for r in records) > 1
    data = marm_mcap.read_bytes()
    footer = len(data) - 8 - 29
    (summary_start,), (summary_crc,) = struct.unpack_from("<Q", data, footer + 9), struct.unpack_from("<I", data, footer + 25)
    assert zlib.crc32(data[summary_start : footer + 25]) == summary_crc
    with open(marm_mcap, "rb") as stream:
        reader = make_reader(stream, validate_crcs=True)
        header, summary = reader.get_header(), reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert sum(1 for _ in reader.iter_messages()) == summary.statistics.message_count
    assert (header.profile, header.library) == ("ros2", LIBRARY)
    assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    channels = [summary.channels[i] for i in sorted(summary.channels)]
    assert [c.topic for c in channels] == TOPICS
    for channel in channels:
        schema = summary.schemas[channel.schema_id]
        assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
        assert schema.data.decode() == message_definition(schema.name)[0]
        assert channel.metadata["offered_qos_profiles"] == qos_yaml([QOS_LATCHED if channel.id <= 2 else QOS_VOLATILE])
        assert channel.metadata["topic_type_hash"].startswith("RIHS01_")
    assert len(summary.schemas) == 3  # TFMessage shared by /tf_static and /tf


def test_embedded_rosbag2_metadata(tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    """``ros2 bag record`` ends the MCAP with a ``rosbag2`` metadata record (rosbag2 reads the
    metadata version from it to parse the channels' QoS). It names no file: the bytes do not depend on
    the file's name (metadata.yaml of a bag folder names it)."""
    from mcap.reader import make_reader

    path = tmp_path / "named.mcap"
    with open(path, "wb") as stream:
        record(stream, marm, traj)
    with open(path, "rb") as stream:
        (record_,) = list(make_reader(stream).iter_metadata())
    assert record_.name == "rosbag2" and list(record_.metadata) == ["serialized_metadata"]
    info = yaml.safe_load(record_.metadata["serialized_metadata"])
    assert info["version"] == 9 and info["message_count"] == 2 + 2 * len(traj)
    assert info["relative_file_paths"] == [] and info["files"] == []
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert topics["/tf"]["message_count"] == len(traj)
    assert topics["/tf_static"]["topic_metadata"]["offered_qos_profiles"] == [QOS_LATCHED]


LATCHED_TEXT = """\
- history: unknown
  depth: 0
  reliability: reliable
  durability: transient_local
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: automatic
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false"""


def test_qos_channel_metadata_text() -> None:
    """The channel metadata is the text rosbag2 (Jazzy) writes: no anchors for the three equal
    durations, no trailing newline (docs/recording-format.md shows it)."""
    assert qos_yaml([QOS_LATCHED]) == LATCHED_TEXT
    assert qos_yaml([QOS_VOLATILE]) == LATCHED_TEXT.replace("transient_local", "volatile")


def test_byte_identical_whatever_the_pieces(marm: Robot, traj: JointTrajectory) -> None:
    first = record_bytes(marm, traj, samples_per_call=7, chunk_bytes=8000)
    assert first == record_bytes(marm, traj, samples_per_call=7, chunk_bytes=8000)
    assert first == record_bytes(marm, traj, samples_per_call=1000, chunk_bytes=8000)


@pytest.mark.parametrize("compression", ["none", "lz4", "zstd"])
def test_compressions(tmp_path: Path, marm: Robot, traj: JointTrajectory, compression: str) -> None:
    from mcap.reader import make_reader

    path = tmp_path / "c.mcap"
    with open(path, "wb") as stream:
        record(stream, marm, traj, compression=compression)
    with open(path, "rb") as stream:
        reader = make_reader(stream, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        assert {c.compression for c in summary.chunk_indexes} == {"" if compression == "none" else compression}
        assert sum(1 for _ in reader.iter_messages()) == 2 + 2 * len(traj)
    assert summarize(path)["compression"] == compression


def test_no_moving_joints_and_no_samples(tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader

    robot = parse_urdf(FIXED_ONLY)
    trajectory = make_trajectory(robot, "center", duration_s=0.1, rate_hz=50.0)
    path = tmp_path / "statue.mcap"
    with open(path, "wb") as stream:
        record(stream, robot, trajectory)
    empty = tmp_path / "empty.mcap"
    with open(empty, "wb") as stream:
        sink = McapSink(stream)
        sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=0)
        sink.finish()
    with AnyReader([path, empty]) as reader:
        msgs: list[tuple[str, Any]] = [(c.topic, reader.deserialize(raw, c.msgtype)) for c, _, raw in reader.messages()]
    assert [m.name for topic, m in msgs if topic == "/joint_states"] == [[]] * len(trajectory)
    assert not [m for topic, m in msgs if topic == "/tf"]  # robot_state_publisher publishes no /tf for them
    assert sum(topic == "/tf_static" for topic, _ in msgs) == 2
    info = summarize(empty)
    assert info["message_count"] == 2 and info["duration_ns"] == 0 and info["start_time"] == "1970-01-01T00:00:00.000000000Z"


def test_bag_folder(tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    from rosbags.rosbag2 import Reader

    bag = tmp_path / "run1"
    bag.mkdir()
    with open(bag / "run1_0.mcap", "wb") as stream:
        sink = record(stream, marm, traj)
    meta_path = write_bag_metadata(bag, sink.bag_info, file_name="run1_0.mcap")
    text = meta_path.read_text()
    with open(bag / "run1_0.mcap", "rb") as stream:  # the metadata embedded in the MCAP, with the file named
        from mcap.reader import make_reader

        (embedded,) = make_reader(stream).iter_metadata()
    meta = yaml.safe_load(text)["rosbag2_bagfile_information"]
    assert {**meta, "relative_file_paths": [], "files": []} == yaml.safe_load(
        embedded.metadata["serialized_metadata"])
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap"
    assert meta["relative_file_paths"] == ["run1_0.mcap"] and meta["files"][0]["path"] == "run1_0.mcap"
    assert meta["message_count"] == 2 + 2 * len(traj)
    assert meta["starting_time"]["nanoseconds_since_epoch"] == DEFAULT_START_TIME_NS
    assert meta["duration"]["nanoseconds"] == int(traj.time_ns[-1])
    durability = {t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"][0]["durability"]
                  for t in meta["topics_with_message_count"]}
    assert durability == {"/robot_description": "transient_local", "/tf_static": "transient_local",
                          "/joint_states": "volatile", "/tf": "volatile"}
    with Reader(bag) as reader:
        assert reader.message_count == 2 + 2 * len(traj)
        assert [c.topic for c in reader.connections] == TOPICS
        assert sum(1 for _ in reader.messages()) == reader.message_count
    info = summarize(bag)
    assert info["format"] == "rosbag2" and info["files"] == ["run1_0.mcap"] and info["robot_name"] == "marm"
    assert info["message_count"] == meta["message_count"]


def test_summarize(marm_mcap: Path, marm: Robot, traj: JointTrajectory) -> None:
    info = summarize(marm_mcap)
    json.dumps(info)
    chunk, static = expected(marm, traj)
    end = DEFAULT_START_TIME_NS + int(traj.time_ns[-1])
    assert (info["start_time_ns"], info["end_time_ns"]) == (DEFAULT_START_TIME_NS, end)
    assert info["start_time"] == "2023-11-14T22:13:20.000000000Z" and info["duration_s"] == pytest.approx(2.0)
    assert info["robot_name"] == "marm" and info["joints"] == list(chunk.names)
    topics = {t["name"]: t for t in info["topics"]}
    assert list(topics) == TOPICS
    assert topics["/joint_states"]["count"] == len(traj) and topics["/tf"]["rate_hz"] == pytest.approx(50.0)
    assert topics["/tf_static"]["rate_hz"] is None and topics["/tf_static"]["durability"] == "transient_local"
    assert topics["/tf_static"]["type"] == "tf2_msgs/msg/TFMessage"
    frames = {(f["parent"], f["child"]): f["static"] for f in info["tf_frames"]}
    assert frames == {**{pc: True for pc in zip(static.parents, static.children)},
                      **{pc: False for pc in zip(chunk.transforms.parents, chunk.transforms.children)}}
    text = format_summary(info)
    assert "Robot:       marm" in text and "/joint_states" in text and "50.000 Hz" in text
    assert "link0 → link1" in text and "(static)" in text


def test_summarize_foreign_mcap(tmp_path: Path) -> None:
    """An MCAP from mcap_ros2's writer (no QoS metadata), and one with no summary section."""
    from mcap.writer import IndexType, Writer
    from mcap_ros2.writer import Writer as Ros2Writer

    path = tmp_path / "foreign.mcap"
    schema_text, _ = message_definition("sensor_msgs/msg/JointState")
    with open(path, "wb") as stream:
        writer = Ros2Writer(stream)
        schema = writer.register_msgdef("sensor_msgs/msg/JointState", schema_text)
        for i in range(11):
            msg = {"header": {"stamp": {"sec": i, "nanosec": 0}, "frame_id": ""}, "name": ["a", "b"],
                   "position": [0.0, 1.0], "velocity": [], "effort": []}
            writer.write_message("/joint_states", schema, msg, log_time=i * 10**9, publish_time=i * 10**9)
        writer.finish()  # type: ignore[no-untyped-call]
    info = summarize(path)
    assert info["joints"] == ["a", "b"] and info["robot_name"] is None and info["tf_frames"] == []
    (topic,) = info["topics"]
    assert topic["count"] == 11 and topic["rate_hz"] == pytest.approx(1.0) and topic["durability"] is None

    bare = tmp_path / "bare.mcap"
    with open(bare, "wb") as stream:
        plain = Writer(stream, index_types=IndexType.NONE, repeat_channels=False, repeat_schemas=False,
                       use_statistics=False, use_summary_offsets=False)
        plain.start(profile="ros2")
        schema_id = plain.register_schema("std_msgs/msg/String", "ros2msg", b"string data\n")
        channel = plain.register_channel(
            "/robot_description", "cdr", schema_id, {"offered_qos_profiles": qos_yaml([QOS_LATCHED])})
        plain.add_message(channel, log_time=5, publish_time=5,
                          data=bytes.fromhex("00010000") + b"\x15\0\0\0<robot name='bare'/>\0")
        plain.finish()  # type: ignore[no-untyped-call]
    info = summarize(bare)
    assert info["robot_name"] == "bare" and info["message_count"] == 1 and info["start_time_ns"] == 5
    assert info["topics"][0]["durability"] == "transient_local"


def test_summarize_rosbags_bag(tmp_path: Path) -> None:
    """A rosbag2 folder written by rosbags (MCAP storage)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    bag = tmp_path / "other"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store)
        for i in range(3):
            transform = types["geometry_msgs/msg/TransformStamped"](
                header=types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=i, nanosec=0),
                                                    frame_id="odom"),
                child_frame_id="base_link",
                transform=types["geometry_msgs/msg/Transform"](
                    translation=types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                    rotation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)),
            )
            data = store.serialize_cdr(types["tf2_msgs/msg/TFMessage"](transforms=[transform]), "tf2_msgs/msg/TFMessage")
            writer.write(conn, i * 10**9, data)
    info = summarize(bag)
    assert info["format"] == "rosbag2" and info["message_count"] == 3 and info["duration_s"] == 2.0
    assert info["tf_frames"] == [{"parent": "odom", "child": "base_link", "static": False}]
    assert info["joints"] is None and info["topics"][0]["rate_hz"] == pytest.approx(1.0)


def test_summarize_errors(tmp_path: Path, marm_mcap: Path) -> None:
    from mcap.writer import Writer

    text = tmp_path / "notes.mcap"
    text.write_text("not a recording\n")
    with pytest.raises(RecordingError, match=r"notes\.mcap: not a recording \(neither MCAP"):
        summarize(text)
    with pytest.raises(RecordingError, match=r"missing\.mcap: no such file"):
        summarize(tmp_path / "missing.mcap")
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(marm_mcap.read_bytes()[:12])
    with pytest.raises(RecordingError, match=r"truncated\.mcap: unreadable MCAP: the file ends"):
        summarize(truncated)
    garbled = tmp_path / "garbled.mcap"
    with open(garbled, "wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2")
        channel = writer.register_channel(
            "/joint_states", "cdr", writer.register_schema("sensor_msgs/msg/JointState", "ros2msg", b""))
        writer.add_message(channel, log_time=1, publish_time=1, data=b"\0\1\0\0\7")
        writer.finish()  # type: ignore[no-untyped-call]
    with pytest.raises(RecordingError, match=r"garbled\.mcap: a /joint_states message cannot be decoded as sensor_msgs"):
        summarize(garbled)
    folder = tmp_path / "folder"
    folder.mkdir()
    with pytest.raises(RecordingError, match=r"folder: a folder without metadata\.yaml"):
        summarize(folder)
    (folder / "metadata.yaml").write_text(
        "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n  relative_file_paths: [folder_0.db3]\n")
    with pytest.raises(RecordingError, match=r"folder: metadata\.yaml lists folder_0\.db3, which is missing$"):
        summarize(folder)


def test_summarize_damaged_mcap(tmp_path: Path, marm: Robot, capsys: pytest.CaptureFixture[str]) -> None:
    """A file cut short (no summary section, the last chunk cut) is summarized as far as it is
    readable, with one warning saying where reading stopped."""
    from tfrec import cli

    full = tmp_path / "full.mcap"
    with open(full, "wb") as stream:
        record(stream, marm, make_trajectory(marm, "sine", duration_s=10.0, rate_hz=100.0))
    whole = summarize(full)
    data = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.warns(UserWarning, match=rf"^{re.escape(str(cut))}: reading stopped at byte") as caught:
        info = summarize(cut)
    assert len(caught) == 1 and info["read_error"] == str(caught[0].message) and "\n" not in info["read_error"]
    assert info["format"] == "mcap" and info["profile"] == "ros2" and info["library"] == LIBRARY
    assert info["compression"] == "zstd" and info["robot_name"] == "marm" and info["joints"] == whole["joints"]
    assert info["tf_frames"] == whole["tf_frames"] and info["start_time_ns"] == whole["start_time_ns"]
    counts = {t["name"]: t["count"] for t in info["topics"]}
    assert set(counts) == set(TOPICS) and counts["/robot_description"] == counts["/tf_static"] == 1
    assert 0 < counts["/joint_states"] < len(make_trajectory(marm, "sine", duration_s=10.0, rate_hz=100.0))
    assert info["message_count"] == sum(counts.values()) < whole["message_count"]
    assert whole["read_error"] is None
    assert "Robot:       marm" in format_summary(info)

    assert cli.main(["info", str(cut)]) == 0
    out, err = capsys.readouterr()
    assert err.splitlines() == [f"tfrec: warning: {info['read_error']}"] and "Robot:       marm" in out


def test_summarize_every_format(tmp_path: Path, marm_mcap: Path) -> None:
    """info reads what read_recording reads: rosbag2 folders of either storage, ROS 1 bags and
    .rrd files, with the durability the format records."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from tests.recording_helpers import write_rosbag1, write_rosbag2
    from tfrec.formats.reader import read_recording

    rec = read_recording(marm_mcap)
    ref = summarize(marm_mcap)
    for path, fmt, storage in ((write_rosbag2(rec, tmp_path / "sq", storage="sqlite3"), "rosbag2", "sqlite3"),
                               (write_rosbag2(rec, tmp_path / "mc", storage="mcap"), "rosbag2", "mcap"),
                               (write_rosbag1(rec, tmp_path / "one.bag"), "rosbag1", None)):
        info = summarize(path)
        assert (info["format"], info["storage"], info["read_error"]) == (fmt, storage, None)
        for key in ("message_count", "start_time_ns", "end_time_ns", "robot_name", "joints"):
            assert info[key] == ref[key], (path, key)
        assert sorted(map(str, info["tf_frames"])) == sorted(map(str, ref["tf_frames"]))
        assert {t["name"]: t["count"] for t in info["topics"]} == {t["name"]: t["count"] for t in ref["topics"]}
        assert format_summary(info).splitlines()[1].startswith(
            {"sqlite3": "Format:      rosbag2 folder (sqlite3 storage)", "mcap": "Format:      rosbag2 folder (MCAP",
             None: "Format:      ROS 1 bag, uncompressed chunks"}[storage])

    zero = QosTime(sec=0, nsec=0)
    latched = Qos(history=QosHistory.KEEP_LAST, depth=1, reliability=QosReliability.RELIABLE,
                  durability=QosDurability.TRANSIENT_LOCAL, deadline=zero, lifespan=zero,
                  liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=zero,
                  avoid_ros_namespace_conventions=False)
    store = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / "qos"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        conn = writer.add_connection("/robot_description", "std_msgs/msg/String", typestore=store,
                                     offered_qos_profiles=[latched])
        text = store.types["std_msgs/msg/String"](data="<robot name='qos'/>")
        writer.write(conn, 5, store.serialize_cdr(text, "std_msgs/msg/String"))
    info = summarize(bag)
    assert info["robot_name"] == "qos" and info["topics"][0]["durability"] == "transient_local"


def test_stamp_range() -> None:
    check_time_range(0, 2**31 * 10**9 - 1)
    with pytest.raises(RecordingError, match=r"^stamp -1\.000000000 s is before 1970$"):
        check_time_range(-10**9, 0)
    with pytest.raises(RecordingError, match=r"^stamp 2147483648\.000000000 s is out of range: ROS 2 stamps hold "
                                             r"less than 2147483648 s$"):
        McapSink(io.BytesIO()).begin(robot_description="", static=static_transforms(parse_urdf(FIXED_ONLY)),
                                     start_time_ns=2**31 * 10**9)


def test_bad_compression_and_early_bag_info() -> None:
    with pytest.raises(RecordingError, match=r"^compression 'gzip' is not one of none, lz4, zstd$"):
        McapSink(io.BytesIO(), compression="gzip")
    with pytest.raises(RuntimeError, match="after finish"):
        _ = McapSink(io.BytesIO()).bag_info


def test_chunks_must_keep_their_names(marm: Robot, traj: JointTrajectory) -> None:
    sink = McapSink(io.BytesIO())
    sink.begin(robot_description=marm.urdf, static=static_transforms(marm), start_time_ns=0)
    chunks = list(iter_dynamic_chunks(marm, traj, chunk_samples=10))
    c = chunks[0]
    sink.write_chunk(stamp_ns=c.time_ns, joint_names=c.names, positions=c.positions, velocities=c.velocities,
                     transforms=c.transforms)
    with pytest.raises(ValueError, match="joint names changed"):
        sink.write_chunk(stamp_ns=chunks[1].time_ns, joint_names=c.names[::-1], positions=c.positions,
                         velocities=c.velocities, transforms=c.transforms)
    with pytest.raises(ValueError, match="stamps must not decrease"):
        sink.write_chunk(stamp_ns=c.time_ns, joint_names=c.names, positions=c.positions, velocities=c.velocities,
                         transforms=c.transforms)
