"""Reading recordings back: tfrec's MCAP, rosbag2 folders and ROS 1 bags written by rosbags,
and tfrec's .rrd — checked against independent readers (mcap_ros2, rosbags)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.recording_helpers import (
    cdr_messages,
    deserializer,
    write_mcap,
    write_rosbag1,
    write_rosbag2,
)
from tfrec.errors import RecordingError
from tfrec.formats.mcap.sink import McapSink
from tfrec.formats.mcap.writer import DEFAULT_CHUNK_BYTES, DEFAULT_START_TIME_NS, message_definition
from tfrec.formats.reader import read_recording, recording_format
from tfrec.formats.ros.decode import JointStateAccumulator, TFAccumulator, message_layout
from tfrec.kinematics.fk import iter_dynamic_chunks, static_transforms
from tfrec.model import Robot
from tfrec.recording import JointStates, Recording
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.types import JointTrajectory

GOLDEN = Path(__file__).parents[1] / "golden"


def test_mcap_matches_mcap_ros2(marm_mcap: Path, marm_rec: Recording, marm: Robot, traj: JointTrajectory) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    rec = marm_rec
    assert rec.format == "mcap" and rec.read_error is None and not rec.float32
    assert rec.robot_description == marm.urdf
    assert rec.start_ns == DEFAULT_START_TIME_NS and rec.duration_ns == 2_000_000_000
    assert {name: info.count for name, info in rec.topics.items()} == {
        "/robot_description": 1, "/tf_static": 1, "/joint_states": 101, "/tf": 101}
    assert rec.topics["/tf"].type == "tf2_msgs/msg/TFMessage"
    assert rec.topics["/tf"].first_ns == DEFAULT_START_TIME_NS
    assert rec.topics["/tf"].last_ns == DEFAULT_START_TIME_NS + 2_000_000_000

    js: list[tuple[int, list[str], list[float]]] = []
    tf: dict[tuple[str, str], list[tuple[int, list[float]]]] = {}
    static = {}
    with open(marm_mcap, "rb") as stream:
        for _, channel, _, msg in make_reader(stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            if channel.topic == "/joint_states":
                js.append((msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec, list(msg.name), list(msg.position)))
            elif channel.topic in ("/tf", "/tf_static"):
                for t in msg.transforms:
                    tr, q = t.transform.translation, t.transform.rotation
                    value = [tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w]
                    if channel.topic == "/tf":
                        stamp = t.header.stamp.sec * 10**9 + t.header.stamp.nanosec
                        tf.setdefault((t.header.frame_id, t.child_frame_id), []).append((stamp, value))
                    else:
                        static[(t.header.frame_id, t.child_frame_id)] = value
    assert rec.joint_states is not None
    assert rec.joint_states.names == tuple(js[0][1])
    np.testing.assert_array_equal(rec.joint_states.time_ns, [t for t, _, _ in js])
    np.testing.assert_array_equal(rec.joint_states.positions, [p for _, _, p in js])
    assert list(rec.tf) == list(tf)
    for pair, series in tf.items():
        np.testing.assert_array_equal(rec.tf[pair].time_ns, [t for t, _ in series])
        np.testing.assert_array_equal(np.hstack([rec.tf[pair].translation, rec.tf[pair].rotation]),
                                      [v for _, v in series])
    assert set(rec.tf_static) == set(static)
    for pair, value in static.items():
        np.testing.assert_array_equal(np.hstack(rec.tf_static[pair]), value)


@pytest.mark.parametrize("compression", ["lz4", "none"])
def test_mcap_compressions(tmp_path: Path, marm: Robot, traj: JointTrajectory, marm_rec: Recording,
                           compression: str) -> None:
    rec = read_recording(write_mcap(tmp_path / "x.mcap", marm, traj, compression=compression))
    _assert_same(rec, marm_rec)


def _assert_same(rec: Recording, ref: Recording, *, exact_types: bool = False) -> None:
    assert rec.robot_description == ref.robot_description
    assert {k: v.count for k, v in rec.topics.items()} == {k: v.count for k, v in ref.topics.items()}
    assert rec.start_ns == ref.start_ns and rec.end_ns == ref.end_ns
    assert rec.joint_states is not None and ref.joint_states is not None
    assert rec.joint_states.names == ref.joint_states.names
    np.testing.assert_array_equal(rec.joint_states.time_ns, ref.joint_states.time_ns)
    np.testing.assert_array_equal(rec.joint_states.positions, ref.joint_states.positions)
    assert list(rec.tf) == list(ref.tf)
    for pair, series in ref.tf.items():
        np.testing.assert_array_equal(rec.tf[pair].time_ns, series.time_ns)
        np.testing.assert_array_equal(rec.tf[pair].translation, series.translation)
        np.testing.assert_array_equal(rec.tf[pair].rotation, series.rotation)
    assert {k: np.hstack(v).tolist() for k, v in rec.tf_static.items()} == {
        k: np.hstack(v).tolist() for k, v in ref.tf_static.items()}


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_rosbag2_folder(tmp_path: Path, marm_rec: Recording, storage: str) -> None:
    bag = write_rosbag2(marm_rec, tmp_path / "bag", storage=storage)
    assert recording_format(bag) == "rosbag2"
    rec = read_recording(bag)
    assert rec.format == "rosbag2"
    _assert_same(rec, marm_rec)
    if storage == "sqlite3":  # the .db3 itself names the bag too
        (db3,) = bag.glob("*.db3")
        assert read_recording(db3).topics == rec.topics


def test_tfrec_bag_folder(tmp_path: Path, marm: Robot, traj: JointTrajectory, marm_rec: Recording) -> None:
    from tfrec.recorder import plan_outputs, record

    plan = plan_outputs(stem="marm", bag=tmp_path / "marm_bag", no_rrd=True)
    record(marm, traj, plan)
    rec = read_recording(tmp_path / "marm_bag")
    assert rec.format == "rosbag2" and rec.path == str(tmp_path / "marm_bag")
    _assert_same(rec, marm_rec)


def test_ros1_bag(tmp_path: Path, marm_rec: Recording) -> None:
    bag = write_rosbag1(marm_rec, tmp_path / "marm.bag")
    rec = read_recording(bag)
    assert rec.format == "rosbag1"
    _assert_same(rec, marm_rec)
    assert rec.topics["/tf"].type == "tf2_msgs/msg/TFMessage"


def test_rrd(tmp_path: Path, marm: Robot, traj: JointTrajectory, marm_rec: Recording) -> None:
    from tfrec.recorder import plan_outputs, record

    plan = plan_outputs(stem="marm", out=tmp_path / "marm.mcap")
    record(marm, traj, plan)
    assert plan.rrd is not None
    rec = read_recording(plan.rrd)
    assert rec.format == "rrd" and rec.float32
    assert rec.robot_description == marm.urdf
    assert {k: v.count for k, v in rec.topics.items()} == {
        "/robot_description": 1, "/tf_static": 1, "/joint_states": 101, "/tf": 101}
    assert rec.start_ns == marm_rec.start_ns and rec.end_ns == marm_rec.end_ns
    assert rec.joint_states is not None and marm_rec.joint_states is not None
    assert set(rec.joint_states.names) == set(marm_rec.joint_states.names)
    assert set(rec.tf) == set(marm_rec.tf) and set(rec.tf_static) == set(marm_rec.tf_static)
    for pair, series in marm_rec.tf.items():
        np.testing.assert_array_equal(rec.tf[pair].time_ns, series.time_ns)
        np.testing.assert_allclose(rec.tf[pair].translation, series.translation, atol=1e-7)
        np.testing.assert_allclose(rec.tf[pair].rotation, series.rotation, atol=1e-7)
        assert not np.array_equal(rec.tf[pair].rotation, series.rotation) or pair[0] == "gripper_link"
    for name in marm_rec.joint_states.names:  # Scalars are float64
        np.testing.assert_array_equal(rec.joint_states.positions[:, rec.joint_states.names.index(name)],
                                      marm_rec.joint_states.positions[:, marm_rec.joint_states.names.index(name)])


def test_topics_filter(marm_mcap: Path) -> None:
    rec = read_recording(marm_mcap, topics=["/tf"])
    assert set(rec.topics) == {"/robot_description", "/tf_static", "/joint_states", "/tf"}
    assert rec.joint_states is None and rec.robot_description is None and not rec.tf_static
    assert len(rec.tf) == 8


def test_truncated_mcap(tmp_path: Path, marm: Robot) -> None:
    from tfrec.trajectory.generators import make_trajectory

    long = make_trajectory(marm, "sine", duration_s=20.0, rate_hz=100.0)
    full = write_mcap(tmp_path / "full.mcap", marm, long)
    data = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    rec = read_recording(cut)
    assert rec.read_error is not None and "\n" not in rec.read_error
    assert rec.read_error.startswith(f"{cut}: reading stopped at byte ")
    assert "the file ends inside a chunk record" in rec.read_error
    whole = read_recording(full)
    assert rec.joint_states is not None and whole.joint_states is not None
    n = len(rec.joint_states)
    assert 0 < n < len(whole.joint_states)
    assert rec.topics["/joint_states"].count == n == rec.topics["/tf"].count
    np.testing.assert_array_equal(rec.joint_states.positions, whole.joint_states.positions[:n])
    assert rec.end_ns == int(rec.joint_states.time_ns[-1])

    # a damaged summary loses nothing: reading stops at the data section's end
    cut.write_bytes(data[: len(data) - 10])
    assert read_recording(cut).read_error is None

    # the file ends cleanly after the last chunk
    data_end = data.rfind(b"\x0f" + (4).to_bytes(8, "little"))
    cut.write_bytes(data[:data_end])
    rec = read_recording(cut)
    assert rec.read_error is not None and rec.read_error.endswith(
        f"the file ends without a footer; {2 + 2 * len(whole.joint_states):,} messages read")

    cut.write_bytes(data[:12])
    with pytest.raises(RecordingError, match=r"cut\.mcap: unreadable MCAP: the file ends"):
        read_recording(cut)


def test_damaged_chunk(tmp_path: Path, marm_mcap: Path) -> None:
    data = bytearray(marm_mcap.read_bytes())
    index = data.index(b"zstd")
    data[index + 20 : index + 40] = bytes(20)  # garbage inside the compressed data
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    rec = read_recording(bad)
    assert rec.read_error is not None and re.fullmatch(
        rf"{re.escape(str(bad))}: a damaged chunk record at byte [\d,]+ \(zstd: [^)]+\): "
        r"recovered 0 of its 204 messages; 0 messages read", rec.read_error)

    # the record after the chunk is garbage: the framing is lost there
    data = bytearray(marm_mcap.read_bytes())
    chunk = data.index(b"zstd") - 4 - 4 - 8 - 8 - 8 - 9
    after = chunk + 9 + int.from_bytes(data[chunk + 1 : chunk + 9], "little")
    data[after] = 0x42
    bad.write_bytes(bytes(data))
    assert read_recording(bad).read_error == (
        f"{bad}: reading stopped at byte {after:,} of {len(data):,}: a damaged record (opcode 0x42); "
        "204 messages read")


# -- partial chunks: a recorder killed mid-write, flipped bytes --------------------------------------


def _chunked_mcap(path: Path, robot: Robot, trajectory: JointTrajectory, *, compression: str,
                  chunk_bytes: int = DEFAULT_CHUNK_BYTES) -> tuple[Path, list[Any]]:
    """An MCAP written by tfrec's sink with ``chunk_bytes`` bytes of records per chunk, and its
    chunk indexes as mcap's reader sees them."""
    from mcap.reader import make_reader

    with open(path, "wb") as stream:
        sink = McapSink(stream, compression=compression, chunk_bytes=chunk_bytes)
        sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=DEFAULT_START_TIME_NS)
        for chunk in iter_dynamic_chunks(robot, trajectory):
            sink.write_chunk(stamp_ns=chunk.time_ns + DEFAULT_START_TIME_NS, joint_names=chunk.names,
                             positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
        sink.finish()
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return path, summary.chunk_indexes


def _messages(rec: Recording) -> int:
    return sum(info.count for info in rec.topics.values())


def _samples_of(rec: Recording, whole: Recording) -> int:
    """Check that every /joint_states and /tf sample of ``rec`` is the sample of ``whole`` at the
    same stamp; returns how many /joint_states and /tf messages ``rec`` has."""
    if rec.joint_states is None:
        assert not rec.tf
        return 0
    assert whole.joint_states is not None and rec.joint_states.names == whole.joint_states.names
    at = np.searchsorted(whole.joint_states.time_ns, rec.joint_states.time_ns)
    np.testing.assert_array_equal(whole.joint_states.time_ns[at], rec.joint_states.time_ns)
    np.testing.assert_array_equal(whole.joint_states.positions[at], rec.joint_states.positions)
    assert list(rec.tf) == list(whole.tf)
    for pair, series in rec.tf.items():
        ref = whole.tf[pair]
        at = np.searchsorted(ref.time_ns, series.time_ns)
        np.testing.assert_array_equal(ref.time_ns[at], series.time_ns)
        np.testing.assert_array_equal(ref.translation[at], series.translation)
        np.testing.assert_array_equal(ref.rotation[at], series.rotation)
    tf = {len(series) for series in rec.tf.values()}
    assert len(tf) == 1 and len(rec.joint_states) - tf.pop() in (0, 1)  # a cut may fall between the two
    return rec.topics["/joint_states"].count + rec.topics["/tf"].count


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_cut_inside_the_only_chunk(tmp_path: Path, marm: Robot, compression: str) -> None:
    """A few seconds fit in one chunk: the complete records of the part that is there are read
    (zstd and lz4 give them back block by block)."""
    long = make_trajectory(marm, "sine", duration_s=5.0, rate_hz=100.0)
    full, chunks = _chunked_mcap(tmp_path / "full.mcap", marm, long, compression=compression)
    assert len(chunks) == 1
    whole = read_recording(full)
    data = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    counts = []
    for fraction in (0.25, 0.5, 0.9):
        end = chunks[0].chunk_start_offset + int(chunks[0].chunk_length * fraction)
        cut.write_bytes(data[:end])
        rec = read_recording(cut)
        n = _messages(rec)
        assert rec.read_error == (f"{cut}: reading stopped at byte {end:,} of {end:,}: the file ends inside a chunk "
                                  f"record (recovered {n:,} messages of it); {n:,} messages read")
        assert rec.robot_description == marm.urdf and list(rec.tf_static) == list(whole.tf_static)
        assert n == 2 + _samples_of(rec, whole)
        counts.append(n)
    assert 0 < counts[0] <= counts[1] <= counts[2] < _messages(whole)


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_cut_in_the_last_chunk(tmp_path: Path, marm: Robot, compression: str) -> None:
    long = make_trajectory(marm, "sine", duration_s=10.0, rate_hz=100.0)
    full, chunks = _chunked_mcap(tmp_path / "full.mcap", marm, long, compression=compression, chunk_bytes=400_000)
    assert len(chunks) == 3
    whole = read_recording(full)
    assert whole.joint_states is not None
    last = chunks[-1]
    in_last = 2 * int(np.sum(whole.joint_states.time_ns >= last.message_start_time))
    end = last.chunk_start_offset + int(last.chunk_length * 0.9)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(full.read_bytes()[:end])
    rec = read_recording(cut)
    n = _messages(rec)
    recovered = n - (_messages(whole) - in_last)
    assert 0 < recovered < in_last
    assert rec.read_error == (f"{cut}: reading stopped at byte {end:,} of {end:,}: the file ends inside a chunk "
                              f"record (recovered {recovered:,} messages of it); {n:,} messages read")
    assert n == 2 + _samples_of(rec, whole)  # the first messages: every earlier chunk, part of the last


@pytest.mark.parametrize("compression, flip", [("zstd", "data"), ("lz4", "data"), ("none", "data"), ("zstd", "crc")])
def test_damaged_chunk_in_the_middle_is_skipped(tmp_path: Path, marm: Robot, compression: str, flip: str) -> None:
    """A flipped byte mostly decompresses to wrong data without any error: the chunk's CRC tells,
    so the chunk is skipped, and the chunks after it are read."""
    long = make_trajectory(marm, "sine", duration_s=3.0, rate_hz=100.0)
    full, chunks = _chunked_mcap(tmp_path / "full.mcap", marm, long, compression=compression, chunk_bytes=120_000)
    assert len(chunks) == 3
    middle = chunks[1]
    data = bytearray(full.read_bytes())
    data[middle.chunk_start_offset + (middle.chunk_length // 2 if flip == "data" else 9 + 24)] ^= 0x08
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    whole, rec = read_recording(full), read_recording(bad)
    assert whole.joint_states is not None and rec.joint_states is not None
    stamps = whole.joint_states.time_ns
    lost = (stamps >= middle.message_start_time) & (stamps <= middle.message_end_time)
    assert 0 < lost.sum() < len(stamps)
    n = _messages(rec)
    assert n == _messages(whole) - 2 * lost.sum()
    assert rec.read_error is not None and re.fullmatch(
        rf"{re.escape(str(bad))}: a damaged chunk record at byte {middle.chunk_start_offset:,} "
        rf"\((CRC mismatch|zstd: .+|lz4: .+)\): recovered 0 of its {2 * lost.sum():,} messages; {n:,} messages read",
        rec.read_error)
    _samples_of(rec, whole)
    np.testing.assert_array_equal(rec.joint_states.time_ns, stamps[~lost])


def test_skipped_chunk_with_the_channels(tmp_path: Path, marm_rec: Recording) -> None:
    """mcap's writer puts the schemas and channels in the first chunk: when that chunk is skipped,
    the summary's copies of them stand in."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    assert marm_rec.joint_states is not None
    messages = cdr_messages(marm_rec)
    path = tmp_path / "other.mcap"
    with open(path, "wb") as stream:
        writer = Writer(stream, chunk_size=4096)
        writer.start(profile="ros2", library="test")
        channels = {}
        for topic, msgtype in (("/joint_states", "sensor_msgs/msg/JointState"), ("/tf", "tf2_msgs/msg/TFMessage")):
            schema = writer.register_schema(name=msgtype, encoding="ros2msg",
                                            data=message_definition(msgtype)[0].encode())
            channels[topic] = writer.register_channel(topic=topic, message_encoding="cdr", schema_id=schema)
        for i, stamp in enumerate(marm_rec.joint_states.time_ns.tolist()):
            for topic, channel in channels.items():
                writer.add_message(channel, log_time=stamp, data=messages[topic][i], publish_time=stamp)
        writer.finish()
    whole = read_recording(path)
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    first, last = summary.chunk_indexes[0], summary.chunk_indexes[-1]
    data = bytearray(path.read_bytes())
    data[first.chunk_start_offset + 9 + 24] ^= 0x01  # its CRC
    path.write_bytes(bytes(data))
    rec = read_recording(path)
    in_first = 2 * int(np.sum(marm_rec.joint_states.time_ns <= first.message_end_time))
    n = _messages(whole) - in_first
    assert rec.read_error == (f"{path}: a damaged chunk record at byte {first.chunk_start_offset:,} (CRC mismatch): "
                              f"recovered 0 of its {in_first:,} messages; {n:,} messages read")
    assert _messages(rec) == n
    _samples_of(rec, whole)

    # without a summary, no channel is known
    path.write_bytes(bytes(data[: last.chunk_start_offset]))
    with pytest.raises(RecordingError, match=r"other\.mcap: unreadable MCAP: \d+ damaged chunk records, the first at "
                                             r"byte [\d,]+ \(CRC mismatch\): recovered 0 of their [\d,]+ messages$"):
        read_recording(path)


def test_not_a_recording(tmp_path: Path) -> None:
    garbage = tmp_path / "notes.mcap"
    garbage.write_text("hello\n")
    with pytest.raises(RecordingError, match=r"^.*notes\.mcap: not a recording \(neither MCAP"):
        read_recording(garbage)
    with pytest.raises(RecordingError, match=r"nothing\.mcap: no such file or folder$"):
        read_recording(tmp_path / "nothing.mcap")
    folder = tmp_path / "folder"
    folder.mkdir()
    with pytest.raises(RecordingError, match=r"folder: a folder without metadata.yaml"):
        read_recording(folder)
    empty = tmp_path / "empty.bag"
    empty.write_bytes(b"")
    with pytest.raises(RecordingError, match="not a recording"):
        read_recording(empty)


def test_damaged_rrd(tmp_path: Path) -> None:
    rrd = tmp_path / "x.rrd"
    rrd.write_bytes(b"RRF2" + bytes(40))
    with pytest.raises(RecordingError, match=r"x\.rrd: unreadable Rerun recording: ") as info:
        read_recording(rrd)
    assert "\n" not in str(info.value)


def test_damaged_rosbag2(tmp_path: Path, marm_rec: Recording) -> None:
    """A malformed metadata.yaml is one line naming the file and the line (YAML's own message has several)."""
    from tfrec.info import summarize

    bag = write_rosbag2(marm_rec, tmp_path / "bag")
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    for read in (read_recording, summarize):
        with pytest.raises(RecordingError, match=r"^.*bag/metadata\.yaml:2: not valid YAML: expected the node "
                                                 r"content, but found '<stream end>'$") as info:
            read(bag)
        assert "\n" not in str(info.value)
    (bag / "metadata.yaml").write_text("- just\n- a list\n")
    with pytest.raises(RecordingError, match=r"metadata\.yaml: not a rosbag2 metadata file"):
        read_recording(bag)


def test_cut_sqlite3_bag(tmp_path: Path, marm: Robot) -> None:
    """SQLite refuses a .db3 cut short as malformed: with the page count in its header lowered to
    the pages the file has, the rows before the first missing page are read."""
    long = read_recording(write_mcap(tmp_path / "long.mcap", marm, make_trajectory(marm, "sine", duration_s=10.0,
                                                                                   rate_hz=100.0)))
    bag = write_rosbag2(long, tmp_path / "bag")
    (db3,) = bag.glob("*.db3")
    data = db3.read_bytes()
    db3.write_bytes(data[: len(data) // 2])
    rec = read_recording(bag)
    n = _messages(rec)
    assert rec.read_error is not None and re.fullmatch(
        rf"{re.escape(str(bag))}: reading {db3.name} stopped after {n:,} messages: database disk image is malformed "
        rf"\(the file holds {len(data) // 2:,} of the {len(data):,} bytes its header gives\); {n:,} messages read",
        rec.read_error)
    assert rec.robot_description == marm.urdf and 2 < n < _messages(long)
    assert n == 2 + _samples_of(rec, long)


def _ros1_bag(path: Path, rec: Recording, *, compression: str, chunk_bytes: int) -> Path:
    """The recording as a ROS 1 bag of small chunks, written by rosbags; latched topics marked."""
    from rosbags.rosbag1 import Writer

    from tests.recording_helpers import _Messages, _typestore, recording_messages

    store = _typestore(ros1=True)
    writer = Writer(path)
    if compression != "none":
        writer.set_compression(Writer.CompressionFormat[compression.upper()])
    writer.chunk_threshold = chunk_bytes
    with writer:
        connections: dict[str, Any] = {}
        for topic, msgtype, time_ns, msg in recording_messages(rec, _Messages(store, ros1=True)):
            if topic not in connections:
                latching = 1 if topic in ("/robot_description", "/tf_static") else None
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store, latching=latching)
            writer.write(connections[topic], time_ns, bytes(store.serialize_ros1(msg, msgtype)))
    return path


@pytest.mark.parametrize("compression", ["none", "bz2", "lz4"])
def test_cut_ros1_bag(tmp_path: Path, marm_rec: Recording, compression: str) -> None:
    """rosbags refuses a ROS 1 bag without its index: it is read record by record, up to the cut."""
    full = _ros1_bag(tmp_path / "full.bag", marm_rec, compression=compression, chunk_bytes=8192)
    whole = read_recording(full)
    assert whole.read_error is None and whole.details == {"compression": compression}
    _assert_same(whole, marm_rec)
    data = full.read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[: len(data) // 2])
    rec = read_recording(cut)
    n = _messages(rec)
    assert rec.format == "rosbag1" and rec.read_error is not None and re.fullmatch(
        rf"{re.escape(str(cut))}: reading stopped at byte [\d,]+ of {len(data) // 2:,}: the file ends inside "
        rf"(a chunk record \(recovered [\d,]+ messages of it\)|an? [a-z ]+ record); {n:,} messages read",
        rec.read_error)
    assert rec.robot_description == marm_rec.robot_description and list(rec.tf_static) == list(marm_rec.tf_static)
    assert rec.topics["/tf"].type == "tf2_msgs/msg/TFMessage" and rec.topics["/tf_static"].durability == "latched"
    assert 2 < n < _messages(whole)
    assert n == 2 + _samples_of(rec, whole)

    # a recorder killed after its last chunk: no index at all
    header_len = int.from_bytes(data[13:17], "little")
    header = data[17 : 17 + header_len]
    at = header.index(b"index_pos=") + len(b"index_pos=")
    cut.write_bytes(data[: int.from_bytes(header[at : at + 8], "little")])
    rec = read_recording(cut)
    assert rec.read_error is not None and rec.read_error.endswith(
        f": the file ends without an index; {_messages(whole):,} messages read")
    _assert_same(rec, marm_rec)


def test_damaged_ros1_chunk(tmp_path: Path, marm_rec: Recording) -> None:
    """A bz2 chunk that does not decompress makes rosbags stop; it is skipped and the rest read."""
    full = _ros1_bag(tmp_path / "full.bag", marm_rec, compression="bz2", chunk_bytes=8192)
    whole = read_recording(full)
    data = bytearray(full.read_bytes())
    chunks = [m.start() for m in re.finditer(b"compression=bz2", data)]
    assert len(chunks) > 4
    data[chunks[2] + 100 : chunks[2] + 110] = bytes(10)
    bad = tmp_path / "bad.bag"
    bad.write_bytes(bytes(data))
    rec = read_recording(bad)
    n = _messages(rec)
    assert rec.read_error is not None and re.fullmatch(
        rf"{re.escape(str(bad))}: a damaged chunk record at byte [\d,]+ \(bz2: .+\) was skipped; {n:,} messages read",
        rec.read_error)
    assert 2 < n < _messages(whole) and rec.joint_states is not None and whole.joint_states is not None
    at = np.searchsorted(whole.joint_states.time_ns, rec.joint_states.time_ns)
    np.testing.assert_array_equal(whole.joint_states.positions[at], rec.joint_states.positions)
    assert rec.start_ns == whole.start_ns and rec.end_ns == whole.end_ns


@pytest.mark.parametrize("summary", [True, False])
def test_damaged_first_chunk_keeps_the_start(tmp_path: Path, marm: Robot, summary: bool) -> None:
    """Messages lost at the start do not move the recording's start to the first one read: it
    comes from the summary's statistics, or without a summary from the damaged chunk's header."""
    long = make_trajectory(marm, "sine", duration_s=3.0, rate_hz=100.0)
    full, chunks = _chunked_mcap(tmp_path / "full.mcap", marm, long, compression="zstd", chunk_bytes=120_000)
    assert len(chunks) == 3
    first, last = chunks[0], chunks[-1]
    data = bytearray(full.read_bytes())
    middle = first.chunk_start_offset + first.chunk_length // 2
    data[middle : middle + 200] = bytes(200)
    if summary:  # the chunk header's start time is damaged too: only the statistics tell
        data[first.chunk_start_offset + 9 : first.chunk_start_offset + 17] = bytes(8)
    else:
        data = data[: last.chunk_start_offset + last.chunk_length]
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    whole, rec = read_recording(full), read_recording(bad)
    assert rec.read_error is not None and rec.read_error.startswith(
        f"{bad}: a damaged chunk record at byte {first.chunk_start_offset:,} ")
    assert rec.joint_states is not None and int(rec.joint_states.time_ns[0]) > first.message_end_time
    assert rec.start_ns == whole.start_ns == DEFAULT_START_TIME_NS
    assert rec.end_ns == whole.end_ns


# -- the bulk decoder -----------------------------------------------------------------------------


@pytest.mark.parametrize("ros1", [False, True])
def test_decoder_fast_path_matches_rosbags(marm_rec: Recording, ros1: bool) -> None:
    messages = cdr_messages(marm_rec, ros1=ros1)
    js = JointStateAccumulator(deserializer("sensor_msgs/msg/JointState", ros1=ros1), ros1=ros1)
    js.add(messages["/joint_states"])
    assert js.layout is not None  # the numpy path was taken
    time, names, positions = js.result()
    assert marm_rec.joint_states is not None
    np.testing.assert_array_equal(time, marm_rec.joint_states.time_ns)
    assert names == marm_rec.joint_states.names
    np.testing.assert_array_equal(positions, marm_rec.joint_states.positions)

    tf = TFAccumulator(deserializer("tf2_msgs/msg/TFMessage", ros1=ros1), ros1=ros1)
    tf.add(messages["/tf"])
    assert tf.layout is not None
    result = tf.result()
    assert list(result) == list(marm_rec.tf)
    for pair, (time, values) in result.items():
        np.testing.assert_array_equal(time, marm_rec.tf[pair].time_ns)
        np.testing.assert_array_equal(values[:, :3], marm_rec.tf[pair].translation)


def test_joint_set_varies(marm_rec: Recording) -> None:
    """Messages with other names go through rosbags; the result is the union, NaN where absent."""
    assert marm_rec.joint_states is not None
    js = marm_rec.joint_states
    names = js.names
    varied = Recording(path="x", format="mcap", start_ns=marm_rec.start_ns, joint_states=JointStates(
        js.time_ns, names, js.positions))
    full = cdr_messages(varied)["/joint_states"]
    # every third message lacks the fingers and has an extra joint
    partial = Recording(path="y", format="mcap", start_ns=marm_rec.start_ns, joint_states=JointStates(
        js.time_ns, names[:6] + ("extra",), np.hstack([js.positions[:, :6], np.full((len(js), 1), 7.0)])))
    other = cdr_messages(partial)["/joint_states"]
    mixed = [other[i] if i % 3 == 1 else full[i] for i in range(len(full))]
    acc = JointStateAccumulator(deserializer("sensor_msgs/msg/JointState"), ros1=False)
    acc.add(mixed[:50])
    acc.add(mixed[50:])
    time, got_names, positions = acc.result()
    assert got_names == names + ("extra",)
    np.testing.assert_array_equal(time, js.time_ns)
    odd = np.arange(len(js)) % 3 == 1
    np.testing.assert_array_equal(positions[~odd, :8], js.positions[~odd])
    assert np.isnan(positions[~odd, 8]).all()
    assert np.isnan(positions[odd, 6:8]).all()
    np.testing.assert_array_equal(positions[odd, 8], 7.0)
    np.testing.assert_array_equal(positions[odd, :6], js.positions[odd, :6])


def test_layout_learnt_after_an_odd_first_message(marm_rec: Recording) -> None:
    assert marm_rec.joint_states is not None
    js = marm_rec.joint_states
    odd = Recording(path="o", format="mcap", start_ns=marm_rec.start_ns, joint_states=JointStates(
        js.time_ns[:1] - 1, ("only",), np.ones((1, 1))))
    messages = cdr_messages(odd)["/joint_states"] + cdr_messages(marm_rec)["/joint_states"]
    acc = JointStateAccumulator(deserializer("sensor_msgs/msg/JointState"), ros1=False)
    acc.add(messages)
    assert acc.layout is not None and acc.layout.names == js.names
    time, names, positions = acc.result()
    assert names == ("only",) + js.names and len(time) == len(js) + 1
    np.testing.assert_array_equal(positions[1:, 1:], js.positions)


def test_tf_layout_varies(marm_rec: Recording) -> None:
    """TF messages that carry other frames are decoded one by one and merged per pair."""
    messages = cdr_messages(marm_rec)["/tf"]
    pairs = list(marm_rec.tf)
    first = pairs[0]
    one = Recording(path="z", format="mcap", tf={first: marm_rec.tf[first]})
    single = cdr_messages(one)["/tf"]
    mixed = [single[i] if i % 2 else messages[i] for i in range(len(messages))]
    acc = TFAccumulator(deserializer("tf2_msgs/msg/TFMessage"), ros1=False)
    acc.add(mixed)
    result = acc.result()
    np.testing.assert_array_equal(result[first][0], marm_rec.tf[first].time_ns)
    np.testing.assert_array_equal(result[first][1][:, 3:], marm_rec.tf[first].rotation)
    np.testing.assert_array_equal(result[pairs[1]][0], marm_rec.tf[pairs[1]].time_ns[::2])


def test_entity_paths_parse_back() -> None:
    """parse_entity undoes Rerun's escaping, control characters and \\u{…} escapes included."""
    from tfrec.formats.rrd.paths import joint_entity, pair_entity, parse_entity, tf_entity

    names = ("joint 1", "a/b", "x.y", "ü", "a\\b", "tab\there", "new\nline", "\x00", "\u00a0", "😀", "u{41}", "\\u{41}", "")
    for name in names:
        assert parse_entity(joint_entity(name)) == ("joints", (name,))
        assert parse_entity(pair_entity(name, "child/frame")) == ("tf", (name, "child/frame"))
    assert parse_entity(tf_entity("j")) == ("tf", ("j",))
    assert parse_entity("/robot_description") == ("robot_description", ())
    assert parse_entity("/") == ("", ())


def test_message_layout_refuses_other_bytes() -> None:
    with pytest.raises(ValueError, match="not little-endian CDR"):
        message_layout("tf", b"\x00\x00\x00\x00" + bytes(8), ros1=False)
    with pytest.raises(ValueError, match="too short"):
        message_layout("joint_states", b"\x00\x01\x00\x00" + bytes(6), ros1=False)


def test_unordered_stamps_are_sorted(tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    rec = read_recording(write_mcap(tmp_path / "a.mcap", marm, traj))
    assert rec.joint_states is not None
    shuffled = Recording(path="s", format="mcap", start_ns=rec.start_ns, joint_states=JointStates(
        rec.joint_states.time_ns[::-1].copy(), rec.joint_states.names, rec.joint_states.positions[::-1].copy()))
    acc = JointStateAccumulator(deserializer("sensor_msgs/msg/JointState"), ros1=False)
    acc.add(cdr_messages(shuffled)["/joint_states"])
    time, _, positions = acc.result()
    np.testing.assert_array_equal(time, rec.joint_states.time_ns)
    np.testing.assert_array_equal(positions, rec.joint_states.positions)


def test_golden_files_read(tmp_path: Path) -> None:
    for golden in sorted(GOLDEN.glob("*.mcap")):
        rec = read_recording(golden)
        assert rec.read_error is None and rec.robot_description
        copy = tmp_path / golden.name
        shutil.copy(golden, copy)
        assert read_recording(copy).topics == rec.topics



def _foreign_mcap(path: Path, *, chunking: bool) -> Path:
    """An MCAP written by mcap's writer: small chunks, log times out of order, /tf on two channels."""
    from mcap.writer import CompressionType, Writer

    with open(path, "wb") as stream:
        writer = Writer(stream, chunk_size=300, compression=CompressionType.LZ4, use_chunking=chunking)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        channels = [writer.register_channel(topic, "cdr", schema) for topic in ("/tf", "/tf", "/other")]
        for i, time_ns in enumerate([50, 10, 30, 30, 20, 60, 10, 40] * 5):
            data = b"\0\1\0\0" + len(str(i)).to_bytes(4, "little") + str(i).encode()
            writer.add_message(channels[i % 3], log_time=time_ns + i // 8, data=data, publish_time=0)
        writer.finish()  # type: ignore[no-untyped-call]
    return path


@pytest.mark.parametrize("chunking", [True, False])
def test_chunks_counted_from_their_message_indexes(tmp_path: Path, chunking: bool) -> None:
    """Chunks holding nothing to decode are counted from their message index records, not read:
    the counts and spans equal what mcap's reader finds in the messages."""
    from mcap.reader import make_reader

    path = _foreign_mcap(tmp_path / "foreign.mcap", chunking=chunking)
    with open(path, "rb") as stream:
        theirs: dict[str, list[int]] = {}
        for _, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            theirs.setdefault(channel.topic, []).append(message.log_time)
    rec = read_recording(path)
    assert {name: (info.count, info.first_ns, info.last_ns) for name, info in rec.topics.items()} == {
        name: (len(times), min(times), max(times)) for name, times in theirs.items()}
    assert rec.topics["/tf"].count == 27 and rec.read_error is None


@pytest.mark.parametrize("chunking", [True, False])
def test_out_of_order_log_times(tmp_path: Path, marm_rec: Recording, chunking: bool) -> None:
    """An MCAP whose messages are not in log-time order (the later half first, backwards): each
    topic spans its earliest to its latest message, and the series come out in time order."""
    from mcap.writer import CompressionType, Writer

    from tests.recording_helpers import _Messages, _typestore, recording_messages

    store = _typestore(ros1=False)
    messages = recording_messages(marm_rec, _Messages(store, ros1=False))
    half = len(messages) // 2
    path = tmp_path / "unordered.mcap"
    with open(path, "wb") as stream:
        writer = Writer(stream, chunk_size=4096, compression=CompressionType.ZSTD, use_chunking=chunking)
        writer.start(profile="ros2", library="test")
        channels: dict[str, int] = {}
        for topic, msgtype, time_ns, msg in messages[half:][::-1] + messages[:half]:
            if topic not in channels:
                schema = writer.register_schema(msgtype, "ros2msg", message_definition(msgtype)[0].encode())
                channels[topic] = writer.register_channel(topic, "cdr", schema)
            writer.add_message(channels[topic], log_time=time_ns, publish_time=time_ns,
                               data=bytes(store.serialize_cdr(msg, msgtype)))
        writer.finish()  # type: ignore[no-untyped-call]
    rec = read_recording(path)
    assert rec.read_error is None
    _assert_same(rec, marm_rec)
    assert {k: (v.first_ns, v.last_ns) for k, v in rec.topics.items()} == {
        k: (v.first_ns, v.last_ns) for k, v in marm_rec.topics.items()}


def _index_data_records(data: bytes) -> list[int]:
    """Where the data of each index data record (op 4) of a ROS 1 bag begins."""
    out, pos = [], len(b"#ROSBAG V2.0\n")
    while pos + 4 <= len(data):
        header_len = int.from_bytes(data[pos : pos + 4], "little")
        header = data[pos + 4 : pos + 4 + header_len]
        pos += 4 + header_len
        data_len = int.from_bytes(data[pos : pos + 4], "little")
        if b"op=\x04" in header:
            out.append(pos + 4)
        pos += 4 + data_len
    return out


def test_ros1_bag_that_rosbags_trips_over(tmp_path: Path, marm_rec: Recording,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """rosbags fails an assertion (not one of its errors) on a bz2 bag whose index gives a message
    another time than the message has: the bag is read record by record instead."""
    from rosbags.highlevel import AnyReader

    from tfrec import cli

    full = _ros1_bag(tmp_path / "full.bag", marm_rec, compression="bz2", chunk_bytes=8192)
    data = bytearray(full.read_bytes())
    at = _index_data_records(bytes(data))[1]
    data[at : at + 4] = (int.from_bytes(data[at : at + 4], "little") + 1).to_bytes(4, "little")  # 1 s later
    bad = tmp_path / "bad.bag"
    bad.write_bytes(bytes(data))
    with pytest.raises(AssertionError), AnyReader([bad]) as reader:
        for _ in reader.messages():
            pass
    rec = read_recording(bad)
    assert rec.format == "rosbag1" and rec.details == {"compression": "bz2"}
    _assert_same(rec, marm_rec)
    assert cli.main(["info", str(bad)]) == 0
    out = capsys.readouterr().out
    assert "ROS 1 bag, bz2 chunks" in out and "Traceback" not in out
