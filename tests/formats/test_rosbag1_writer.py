"""The ROS 1 bag writer: its encoders against rosbags' ``serialize_ros1``, its bags read back by
rosbags (``rosbag1.Reader``, ``AnyReader``), by tfrec's reader and record by record here."""

from __future__ import annotations

import itertools
import struct
import tracemalloc
from collections.abc import Iterator, Sequence
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tfrec.conventions import DEFAULT_START_TIME_NS, NS_PER_S
from tfrec.errors import RecordingError
from tfrec.formats.ros.encode import JointStateEncoder, TFMessageEncoder, check_ros1_times, encode_string
from tfrec.formats.ros.types import TF_MESSAGE_DEFINITION, ros1_message_definition
from tfrec.formats.rosbag1 import Ros1BagSink, Ros1BagWriter
from tfrec.kinematics.fk import Transforms, iter_dynamic_chunks, static_transforms

if TYPE_CHECKING:
    from tfrec.model import Robot
    from tfrec.trajectory.types import JointTrajectory

T0 = 1_700_000_000_123_456_789
LAST_NS = 2**32 * NS_PER_S - 1
COMPRESSIONS = ("none", "bz2", "lz4")
property_settings = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@lru_cache(maxsize=1)
def store() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    typestore = get_typestore(Stores.ROS1_NOETIC)
    typestore.register(get_types_from_msg(TF_MESSAGE_DEFINITION, "tf2_msgs/msg/TFMessage"))
    return typestore


def header(seq: int, time_ns: int, frame_id: str) -> Any:
    types = store().types
    sec, nanosec = divmod(int(time_ns), NS_PER_S)
    return types["std_msgs/msg/Header"](
        seq=seq, stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame_id
    )


def reference_joint_state(seq: int, time_ns: int, names: Sequence[str], position: np.ndarray,
                          velocity: np.ndarray) -> bytes:
    msg = store().types["sensor_msgs/msg/JointState"](
        header=header(seq, time_ns, ""), name=list(names), position=position, velocity=velocity, effort=np.zeros(0)
    )
    return bytes(store().serialize_ros1(msg, "sensor_msgs/msg/JointState"))


def reference_tf(time_ns: int, parents: Sequence[str], children: Sequence[str], tr: np.ndarray,
                 rot: np.ndarray) -> bytes:
    types = store().types
    transforms = [
        types["geometry_msgs/msg/TransformStamped"](
            header=header(0, time_ns, parent),
            child_frame_id=child,
            transform=types["geometry_msgs/msg/Transform"](
                translation=types["geometry_msgs/msg/Vector3"](x=tr[k, 0], y=tr[k, 1], z=tr[k, 2]),
                rotation=types["geometry_msgs/msg/Quaternion"](x=rot[k, 0], y=rot[k, 1], z=rot[k, 2], w=rot[k, 3]),
            ),
        )
        for k, (parent, child) in enumerate(zip(parents, children))
    ]
    msg = types["tf2_msgs/msg/TFMessage"](transforms=transforms)
    return bytes(store().serialize_ros1(msg, "tf2_msgs/msg/TFMessage"))


# -- encoders -------------------------------------------------------------------------------------

names_strategy = st.lists(st.text(min_size=0, max_size=9), max_size=6)
floats = st.floats(allow_nan=False, width=64)
# rosbags serializes a ROS 1 time's seconds as int32: compared up to 2038 (ROS 1's are uint32, up to 2106)
stamps_strategy = st.lists(st.integers(0, 2**31 * NS_PER_S - 1), min_size=1, max_size=4)


@property_settings
@given(names=names_strategy, stamps=stamps_strategy, first_seq=st.integers(0, 2**32 - 1), data=st.data())
def test_joint_state_matches_rosbags(names: list[str], stamps: list[int], first_seq: int, data: st.DataObject) -> None:
    n, j = len(stamps), len(names)
    values = data.draw(st.lists(floats, min_size=2 * n * j, max_size=2 * n * j))
    positions = np.array(values[: n * j], dtype=np.float64).reshape(n, j)
    velocities = np.array(values[n * j :], dtype=np.float64).reshape(n, j)
    encoder = JointStateEncoder(names, ros1=True)
    rows = encoder.encode(np.array(stamps, dtype=np.int64), positions, velocities, first_seq=first_seq)
    assert rows.shape == (n, encoder.size)
    for i in range(n):
        seq = (first_seq + i) % 2**32  # a publisher's uint32 counter wraps
        assert rows[i].tobytes() == reference_joint_state(seq, stamps[i], names, positions[i], velocities[i])


@property_settings
@given(names=names_strategy, stamps=stamps_strategy, data=st.data())
def test_tf_message_matches_rosbags(names: list[str], stamps: list[int], data: st.DataObject) -> None:
    n, k = len(stamps), len(names)
    children = [name[::-1] + "ç" for name in names]
    values = data.draw(st.lists(floats, min_size=7 * n * k, max_size=7 * n * k))
    block = np.array(values, dtype=np.float64).reshape(n, k, 7)
    rows = TFMessageEncoder(names, children, ros1=True).encode(np.array(stamps, dtype=np.int64), block[..., :3],
                                                        block[..., 3:])
    for i in range(n):
        assert rows[i].tobytes() == reference_tf(stamps[i], names, children, block[i, :, :3], block[i, :, 3:])


@given(text=st.text())
def test_string_matches_rosbags(text: str) -> None:
    msg = store().types["std_msgs/msg/String"](data=text)
    assert encode_string(text, ros1=True) == bytes(store().serialize_ros1(msg, "std_msgs/msg/String"))


def test_stamps_after_2038_are_unsigned() -> None:
    rows = JointStateEncoder([], ros1=True).encode(np.array([LAST_NS]), np.zeros((1, 0)), np.zeros((1, 0)))
    assert rows[0, 4:12].tobytes() == struct.pack("<II", 2**32 - 1, NS_PER_S - 1)


def test_special_floats_keep_their_bits() -> None:
    values = np.array([[np.nan, np.inf, -0.0, 5e-324]])
    rows = JointStateEncoder(["a", "b", "c", "d"], ros1=True).encode(np.array([T0]), values, -values)
    decoded = store().deserialize_ros1(rows[0].tobytes(), "sensor_msgs/msg/JointState")
    assert decoded.position.tobytes() == values[0].tobytes()


@pytest.mark.parametrize(("stamp", "problem"), [(-1, "before 1970"), (LAST_NS + 1, "past ROS 1's last time")])
def test_encoders_refuse_times_outside_ros1(stamp: int, problem: str) -> None:
    with pytest.raises(RecordingError, match=problem):
        TFMessageEncoder(["a"], ["b"], ros1=True).encode(np.array([stamp]), np.zeros((1, 1, 3)), np.zeros((1, 1, 4)))
    with pytest.raises(RecordingError, match=problem):
        check_ros1_times(0, stamp)


def test_message_definitions_are_ros_ones() -> None:
    assert ros1_message_definition("tf2_msgs/TFMessage")[1] == "94810edda583a504dfda3829e70d7eec"
    assert ros1_message_definition("sensor_msgs/msg/JointState")[1] == "3066dcd76a6cfaef579bd0f34173e9fd"
    text, md5sum = ros1_message_definition("std_msgs/String")
    assert (text, md5sum) == ("string data\n", "992ce8a1687cec8c8bd883ec73ca41d1")


SEPARATOR = "=" * 80 + "\n"


def test_message_definitions_are_the_text_rosbag_record_writes() -> None:
    """genmsg's full text, comments included, as in a bag `rosbag record` wrote (Debian's ROS 1): `rosbag check`
    compares the text, not only the md5sum. The interop tier checks every type against Debian's classes."""
    tf, _ = ros1_message_definition("tf2_msgs/TFMessage")
    assert tf.startswith("geometry_msgs/TransformStamped[] transforms\n\n" + SEPARATOR +
                         "MSG: geometry_msgs/TransformStamped\n# This expresses a transform from coordinate frame "
                         "header.frame_id\n")
    assert [line[5:] for line in tf.splitlines() if line.startswith("MSG: ")] == [
        "geometry_msgs/TransformStamped", "std_msgs/Header", "geometry_msgs/Transform", "geometry_msgs/Vector3",
        "geometry_msgs/Quaternion"]  # depth first, in field order, each once
    assert tf.endswith("float64 z\n" + SEPARATOR + "MSG: geometry_msgs/Quaternion\n# This represents an orientation "
                       "in free space in quaternion form.\n\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n")
    joint_state, _ = ros1_message_definition("sensor_msgs/JointState")
    assert joint_state.startswith("# This is a message that holds data to describe the state of a set of torque "
                                  "controlled joints. \n")
    assert "\nHeader header\n\nstring[] name\n" in joint_state
    assert joint_state.endswith("time stamp\n#Frame this data is associated with\nstring frame_id\n")


def test_every_genmsg_text_has_noetics_md5sum() -> None:
    """Each text of noetic.msg, composed and parsed by rosbags into an empty store, defines the fields of rosbags'
    Noetic type (registering a different definition of a type raises) and gives its md5sum."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from tfrec.formats.ros.types import _noetic_texts, genmsg_definition

    noetic = get_typestore(Stores.ROS1_NOETIC)
    checked = 0
    for msgtype in _noetic_texts():
        full = msgtype.replace("/", "/msg/", 1)
        text = genmsg_definition(msgtype)
        assert text is not None
        if full not in noetic.fielddefs:
            continue  # tf2_msgs: not in rosbags' Noetic store
        fresh = get_typestore(Stores.EMPTY)
        fresh.register({name: noetic.fielddefs[name] for name in noetic.fielddefs if name.startswith("builtin_")})
        fresh.register(get_types_from_msg(text, full))
        assert fresh.generate_msgdef(full, ros_version=1)[1] == noetic.generate_msgdef(full, ros_version=1)[1], msgtype
        noetic.register(get_types_from_msg(text, full))  # the same fields as rosbags' Noetic type
        checked += 1
    assert checked > 100


def test_types_outside_noetics_packages_keep_rosbags_text() -> None:
    from tfrec.formats.ros.types import genmsg_definition, ros1_definition_text

    assert genmsg_definition("nope_msgs/Nope") is None
    assert ros1_definition_text("nope_msgs/Nope", "0" * 32, "int32 x\n") == "int32 x\n"
    text, md5sum = ros1_message_definition("geometry_msgs/PoseStamped")
    assert ros1_definition_text("geometry_msgs/msg/PoseStamped", md5sum, "x") == text != "x"
    assert ros1_definition_text("geometry_msgs/PoseStamped", "0" * 32, "other") == "other"  # another layout


def test_the_header_record_has_rosbags_size_so_its_rewrite_in_place_spares_the_first_chunk(
        tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    """`rosbag reindex` and rosbag's append mode rewrite the bag header record in place, its fields and padding
    4096 bytes long (rosbag/bag.py: _write_record(..., padded_size=_FILE_HEADER_LENGTH)). A shorter record (ours
    was 8 bytes shorter) let the rewrite overwrite the first chunk's start: 0 messages after `rosbag reindex`."""
    from rosbags.rosbag1 import Reader

    path = write_bag(tmp_path / "marm.bag", marm, traj, chunk_bytes=16384)
    ours, _ = fields(path.read_bytes(), 13)
    head = b"".join(struct.pack("<I", len(k) + 1 + len(v)) + k + b"=" + v for k, v in (
        (b"op", b"\x03"), (b"index_pos", ours["index_pos"]), (b"conn_count", ours["conn_count"]),
        (b"chunk_count", ours["chunk_count"])))  # in the order rosbag's Python writer puts them
    rewritten = struct.pack("<I", len(head)) + head + struct.pack("<I", 4096 - len(head)) + b" " * (4096 - len(head))
    with path.open("r+b") as stream:
        stream.seek(13)
        stream.write(rewritten)
    data = path.read_bytes()
    chunk, _ = fields(data, 13 + len(rewritten))  # what `rosbag reindex` reads next: the first chunk, intact
    assert op(chunk) == 5 and struct.unpack("<I", chunk["size"])[0] > 16384
    with Reader(path) as reader:
        assert reader.message_count == 2 + 2 * len(traj.time_ns)  # the index still points at every message


def test_unknown_message_type() -> None:
    with pytest.raises(RecordingError, match="message type 'nope_msgs/Nope' has no ROS 1 definition"):
        ros1_message_definition("nope_msgs/Nope")


# -- the file, record by record -------------------------------------------------------------------


def fields(data: bytes, pos: int = 0) -> tuple[dict[str, bytes], int]:
    """A record header's fields in file order, and where the data length is."""
    (size,) = struct.unpack_from("<I", data, pos)
    out, at = {}, pos + 4
    while at < pos + 4 + size:
        (length,) = struct.unpack_from("<I", data, at)
        name, _, value = data[at + 4 : at + 4 + length].partition(b"=")
        out[name.decode()] = value
        at += 4 + length
    return out, at


def records(data: bytes, pos: int, end: int) -> Iterator[tuple[dict[str, bytes], bytes]]:
    while pos < end:
        head, at = fields(data, pos)
        (length,) = struct.unpack_from("<I", data, at)
        yield head, data[at + 4 : at + 4 + length]
        pos = at + 4 + length


def op(head: dict[str, bytes]) -> int:
    return head["op"][0]


def write_bag(path: Path, robot: Robot, traj: JointTrajectory, **options: Any) -> Path:
    """``robot`` moving along ``traj`` as a bag written by the sink."""
    sink = Ros1BagSink(path, **options)
    sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=DEFAULT_START_TIME_NS)
    for chunk in iter_dynamic_chunks(robot, traj, chunk_samples=37):
        sink.write_chunk(stamp_ns=chunk.time_ns + DEFAULT_START_TIME_NS, joint_names=chunk.names,
                         positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()
    return path


def test_layout_is_rosbags(tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    data = write_bag(tmp_path / "marm.bag", marm, traj, chunk_bytes=16384).read_bytes()
    assert data.startswith(b"#ROSBAG V2.0\n")
    bag_header, _ = fields(data, 13)
    assert list(bag_header) == ["chunk_count", "conn_count", "index_pos", "op"]  # sorted, as rosbag's std::map
    (header_size,) = struct.unpack_from("<I", data, 13)
    (padding,) = struct.unpack_from("<I", data, 13 + 4 + header_size)
    assert header_size + padding == 4096  # as rosbag pads it: the header record ends at byte 13 + 4 + 4096 + 4
    assert data[4117 - padding : 4117] == b" " * padding
    index_pos = struct.unpack("<Q", bag_header["index_pos"])[0]
    chunk_count = struct.unpack("<I", bag_header["chunk_count"])[0]
    assert struct.unpack("<I", bag_header["conn_count"])[0] == 4

    # the data section: each chunk, then its IndexData records
    body = list(records(data, 4117, index_pos))
    chunks = [i for i, (head, _) in enumerate(body) if op(head) == 5]
    assert len(chunks) == chunk_count > 5
    for i in chunks:
        head, chunk = body[i]
        assert len(chunk) == struct.unpack("<I", head["size"])[0]
        inner = list(records(chunk, 0, len(chunk)))
        messages = [(struct.unpack("<I", h["conn"])[0], data_) for h, data_ in inner if op(h) == 2]
        following = [head_ for head_, _ in body[i + 1 : i + 1 + len({conn for conn, _ in messages})]]
        assert [op(h) for h in following] == [4] * len(following)
        assert sum(struct.unpack("<I", h["count"])[0] for h in following) == len(messages)
        assert len(chunk) < 16384 + 2000  # cut after the message that passed chunk_bytes
    first_chunk = list(records(body[chunks[0]][1], 0, len(body[chunks[0]][1])))
    assert [op(h) for h, _ in first_chunk[:6]] == [7, 7, 7, 7, 2, 2]  # connections, then the latched messages

    # the index section: the connection records again, then one ChunkInfo per chunk
    index = list(records(data, index_pos, len(data)))
    assert [op(h) for h, _ in index] == [7] * 4 + [6] * chunk_count
    info = index[4][0]
    assert list(info) == ["chunk_pos", "count", "end_time", "op", "start_time", "ver"]
    raw = index[2][1]  # a connection record's data: the connection header's fields, without their length
    connection, _ = fields(struct.pack("<I", len(raw)) + raw)
    assert connection["topic"] == b"/joint_states" and connection["type"] == b"sensor_msgs/JointState"
    assert connection["callerid"] == b"/tfrec" and connection["latching"] == b"0"
    assert connection["md5sum"] == b"3066dcd76a6cfaef579bd0f34173e9fd"


def test_lz4_chunks_are_frames_roslz4_reads(tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    data = write_bag(tmp_path / "marm.bag", marm, traj, compression="lz4").read_bytes()
    bag_header, _ = fields(data, 13)
    chunk = next(body for head, body in records(data, 4117, struct.unpack("<Q", bag_header["index_pos"])[0])
                 if op(head) == 5)
    assert chunk[:4] == b"\x04\x22\x4d\x18"  # LZ4 frame magic
    # version 1, independent blocks, no block checksums, no content size, content checksum, no dictionary
    assert chunk[4] == 0b0110_0100
    assert 4 <= chunk[5] >> 4 <= 6  # blocks of 64 KiB to 1 MiB (lz4 shrinks them to fit a small chunk)


# -- read back by rosbags and by tfrec ------------------------------------------------------------


@pytest.mark.parametrize("compression", COMPRESSIONS)
def test_round_trip_anyreader(tmp_path: Path, marm: Robot, traj: JointTrajectory, compression: str) -> None:
    from rosbags.highlevel import AnyReader

    path = write_bag(tmp_path / "marm.bag", marm, traj, compression=compression, chunk_bytes=20_000)
    chunks = list(iter_dynamic_chunks(marm, traj))
    names = chunks[0].names
    positions = np.concatenate([chunk.positions for chunk in chunks])
    velocities = np.concatenate([chunk.velocities for chunk in chunks])
    translation = np.concatenate([chunk.transforms.translation for chunk in chunks])
    rotation = np.concatenate([chunk.transforms.rotation for chunk in chunks])
    frames = list(zip(chunks[0].transforms.parents, chunks[0].transforms.children))
    stamps = traj.time_ns + DEFAULT_START_TIME_NS
    static = static_transforms(marm)
    seen: dict[str, int] = {}
    with AnyReader([path]) as reader:
        connections = {c.topic: c for c in reader.connections}
        assert list(connections) == ["/robot_description", "/tf_static", "/joint_states", "/tf"]
        exts: list[Any] = [c.ext for c in connections.values()]
        assert [ext.latching for ext in exts] == [1, 1, 0, 0]
        assert {ext.callerid for ext in exts} == {"/tfrec"}
        assert [c.msgcount for c in connections.values()] == [1, 1, len(traj), len(traj)]  # from the index
        for connection, time_ns, raw in reader.messages():
            msg: Any = reader.deserialize(raw, connection.msgtype)
            i = seen.get(connection.topic, 0)
            seen[connection.topic] = i + 1
            if connection.topic == "/robot_description":
                assert (time_ns, msg.data) == (DEFAULT_START_TIME_NS, marm.urdf)
            elif connection.topic == "/tf_static":
                assert time_ns == DEFAULT_START_TIME_NS
                assert [(t.header.frame_id, t.child_frame_id) for t in msg.transforms] == list(
                    zip(static.parents, static.children))
                got = [[t.transform.translation.x, t.transform.translation.y, t.transform.translation.z]
                       for t in msg.transforms]
                assert np.array_equal(got, static.translation[0])
            elif connection.topic == "/joint_states":
                assert time_ns == stamps[i]
                assert msg.header.seq == i
                assert msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec == stamps[i]
                assert tuple(msg.name) == names
                assert np.array_equal(msg.position, positions[i]) and np.array_equal(msg.velocity, velocities[i])
                assert len(msg.effort) == 0
            else:
                assert time_ns == stamps[i]
                assert [(t.header.frame_id, t.child_frame_id) for t in msg.transforms] == frames
                for k, t in enumerate(msg.transforms):
                    assert t.header.stamp.sec * NS_PER_S + t.header.stamp.nanosec == stamps[i]
                    r = t.transform.rotation
                    assert [t.transform.translation.x, t.transform.translation.y,
                            t.transform.translation.z] == translation[i, k].tolist()
                    assert [r.x, r.y, r.z, r.w] == rotation[i, k].tolist()
    assert seen == {"/robot_description": 1, "/tf_static": 1, "/joint_states": len(traj), "/tf": len(traj)}


@pytest.mark.parametrize("compression", COMPRESSIONS)
def test_read_back_by_tfrec(tmp_path: Path, marm: Robot, traj: JointTrajectory, compression: str) -> None:
    from tfrec.formats.reader import read_recording

    path = write_bag(tmp_path / "marm.bag", marm, traj, compression=compression, chunk_bytes=10_000)
    rec = read_recording(path)
    assert (rec.format, rec.read_error, rec.details["compression"]) == ("rosbag1", None, compression)
    assert rec.robot_description == marm.urdf
    assert {topic: (info.count, info.durability) for topic, info in rec.topics.items()} == {
        "/robot_description": (1, "latched"), "/tf_static": (1, "latched"),
        "/joint_states": (len(traj), None), "/tf": (len(traj), None),
    }
    chunks = list(iter_dynamic_chunks(marm, traj))
    stamps = traj.time_ns + DEFAULT_START_TIME_NS
    assert rec.joint_states is not None
    assert np.array_equal(rec.joint_states.time_ns, stamps)
    assert rec.joint_states.names == chunks[0].names
    assert np.array_equal(rec.joint_states.positions, np.concatenate([chunk.positions for chunk in chunks]))
    transforms = chunks[0].transforms
    assert list(rec.tf) == list(zip(transforms.parents, transforms.children))
    for k, pair in enumerate(rec.tf):
        series = rec.tf[pair]
        assert np.array_equal(series.time_ns, stamps)
        assert np.array_equal(series.translation, np.concatenate([c.transforms.translation[:, k] for c in chunks]))
        assert np.array_equal(series.rotation, np.concatenate([c.transforms.rotation[:, k] for c in chunks]))
    static = static_transforms(marm)
    for k, pair in enumerate(zip(static.parents, static.children)):
        assert np.array_equal(rec.tf_static[pair][0], static.translation[0, k])
        assert np.array_equal(rec.tf_static[pair][1], static.rotation[0, k])
    assert (rec.start_ns, rec.end_ns) == (DEFAULT_START_TIME_NS, int(stamps[-1]))


@pytest.mark.parametrize("compression", COMPRESSIONS)
def test_same_inputs_same_bytes(tmp_path: Path, marm: Robot, traj: JointTrajectory, compression: str) -> None:
    first = write_bag(tmp_path / "a.bag", marm, traj, compression=compression, chunk_bytes=8192).read_bytes()
    second = write_bag(tmp_path / "b.bag", marm, traj, compression=compression, chunk_bytes=8192).read_bytes()
    assert first == second


# -- the low-level writer -------------------------------------------------------------------------


def rosbags_messages(path: Path) -> list[tuple[str, int, bytes]]:
    from rosbags.rosbag1 import Reader

    with Reader(path) as reader:
        return [(connection.topic, time_ns, bytes(raw)) for connection, time_ns, raw in reader.messages()]


def add_three(writer: Ros1BagWriter) -> tuple[int, int, int]:
    msgdef, md5sum = ros1_message_definition("std_msgs/String")
    a = writer.add_connection("/a", "std_msgs/msg/String", msgdef=msgdef, md5sum=md5sum, latching=True)
    b = writer.add_connection("/b", "std_msgs/String", msgdef=msgdef, md5sum=md5sum, callerid=None)
    c = writer.add_connection("/c", "std_msgs/String", msgdef=msgdef, md5sum=md5sum)
    return a, b, c


@property_settings
@given(
    sizes=st.lists(st.integers(0, 300), min_size=1, max_size=40),
    fixed_sizes=st.tuples(st.integers(0, 200), st.integers(0, 200)),
    cuts=st.lists(st.integers(0, 40), max_size=5),
    chunk_bytes=st.integers(1, 3000),
    compression=st.sampled_from(COMPRESSIONS),
)
def test_batches_cut_chunks_like_single_writes(
    tmp_path_factory: pytest.TempPathFactory, sizes: list[int], fixed_sizes: tuple[int, int], cuts: list[int],
    chunk_bytes: int, compression: str,
) -> None:
    folder = tmp_path_factory.mktemp("batches")
    rng = np.random.default_rng(len(sizes))
    n = len(sizes)
    times = T0 + np.cumsum(rng.integers(0, 3 * NS_PER_S, size=n))
    fixed_a = rng.integers(0, 256, size=(n, fixed_sizes[0]), dtype=np.uint8)
    fixed_b = rng.integers(0, 256, size=(n, fixed_sizes[1]), dtype=np.uint8)
    varied = [bytes(rng.integers(0, 256, size=size, dtype=np.uint8)) for size in sizes]
    bounds = [0, *sorted({min(cut, n) for cut in cuts}), n]
    batches = list(itertools.pairwise(bounds))

    with Ros1BagWriter(folder / "single.bag", compression=compression, chunk_bytes=chunk_bytes) as writer:
        a, b, c = add_three(writer)
        for i in range(n):
            writer.write(a, int(times[i]), fixed_a[i].tobytes())
            writer.write(b, int(times[i]), memoryview(fixed_b[i].tobytes()))
        for i in range(n):
            writer.write(c, int(times[i]), varied[i])
        for i in range(n):
            writer.write(a, int(times[i]), fixed_a[i].tobytes())
    with Ros1BagWriter(folder / "batched.bag", compression=compression, chunk_bytes=chunk_bytes) as writer:
        a, b, c = add_three(writer)
        for lo, hi in batches:  # /a and /b interleaved, sample by sample
            writer.write_samples((a, b), times[lo:hi], (fixed_a[lo:hi], fixed_b[lo:hi]))
        for lo, hi in batches:
            writer.write_many(c, times[lo:hi], varied[lo:hi])
        for lo, hi in batches:
            writer.write_many(a, times[lo:hi], fixed_a[lo:hi])
        assert writer.message_counts == (2 * n, n, n)
    single = (folder / "single.bag").read_bytes()
    assert (folder / "batched.bag").read_bytes() == single

    by_topic: dict[str, list[tuple[int, bytes]]] = {}
    for topic, time_ns, raw in rosbags_messages(folder / "batched.bag"):
        by_topic.setdefault(topic, []).append((time_ns, raw))
    assert by_topic["/a"] == sorted(2 * [(int(t), m.tobytes()) for t, m in zip(times, fixed_a)])
    assert by_topic["/b"] == [(int(t), m.tobytes()) for t, m in zip(times, fixed_b)]
    assert by_topic["/c"] == [(int(t), m) for t, m in zip(times, varied)]


def test_long_write_is_flat(tmp_path: Path) -> None:
    """100,000 messages (50,000 samples of two connections) in batches: the writer holds one
    chunk and an index of a few bytes per chunk, never the recording."""
    encoder = JointStateEncoder([f"joint{i}" for i in range(10)], ros1=True)
    tf = TFMessageEncoder([f"link{i}" for i in range(10)], [f"link{i + 1}" for i in range(10)], ros1=True)
    samples, batch = 50_000, 2_000
    msgdef, md5sum = ros1_message_definition("sensor_msgs/JointState")
    tf_def, tf_md5 = ros1_message_definition("tf2_msgs/TFMessage")
    tracemalloc.start()
    try:
        with Ros1BagWriter(tmp_path / "long.bag", compression="lz4") as writer:
            js_conn = writer.add_connection("/joint_states", "sensor_msgs/JointState", msgdef=msgdef, md5sum=md5sum)
            tf_conn = writer.add_connection("/tf", "tf2_msgs/TFMessage", msgdef=tf_def, md5sum=tf_md5)
            for first in range(0, samples, batch):
                time_ns = T0 + np.arange(first, first + batch, dtype=np.int64) * 10_000_000
                values = np.sin(time_ns[:, None] * 1e-9 + np.arange(10))
                js = encoder.encode(time_ns, values, values, first_seq=first)
                tfs = tf.encode(time_ns, np.repeat(values[:, :, None], 3, axis=2),
                                np.repeat(values[:, :, None], 4, axis=2))
                writer.write_samples((js_conn, tf_conn), time_ns, (js, tfs))
                del js, tfs, values
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    written = samples * (encoder.size + tf.size)
    assert written > 50e6
    assert peak < 16e6, f"peak {peak / 1e6:.1f} MB while writing {written / 1e6:.0f} MB of messages"

    from rosbags.rosbag1 import Reader

    with Reader(tmp_path / "long.bag") as reader:
        assert reader.message_count == 2 * samples
        assert reader.start_time == T0 and reader.end_time == T0 + (samples - 1) * 10_000_000 + 1
        last_ns = T0 + (samples - 1) * 10_000_000
        (_, read_ns, raw), _ = reader.messages(start=last_ns)  # the last /joint_states and /tf
    values = np.sin(np.array([last_ns]) * 1e-9 + np.arange(10)[None])
    assert read_ns == last_ns
    assert raw == encoder.encode(np.array([last_ns]), values, values, first_seq=samples - 1)[0].tobytes()


def test_times_out_of_order_are_indexed_in_order(tmp_path: Path) -> None:
    times = [T0 + 5, T0 + 1, T0 + 3, T0]
    with Ros1BagWriter(tmp_path / "order.bag") as writer:
        a, _, _ = add_three(writer)
        for i, time_ns in enumerate(times):
            writer.write(a, time_ns, encode_string(str(i), ros1=True))
    assert [(time_ns, raw) for _, time_ns, raw in rosbags_messages(tmp_path / "order.bag")] == [
        (time_ns, encode_string(str(i), ros1=True)) for i, time_ns in sorted(enumerate(times), key=lambda item: item[1])
    ]


def test_views_are_written_as_their_bytes(tmp_path: Path) -> None:
    values = np.array([1.5, -2.5])
    with Ros1BagWriter(tmp_path / "views.bag") as writer:
        a, b, _ = add_three(writer)
        writer.write(a, T0, values.data)
        writer.write_many(b, np.array([T0]), [values.data])
    assert [raw for _, _, raw in rosbags_messages(tmp_path / "views.bag")] == [values.tobytes()] * 2


def test_empty_bags(tmp_path: Path) -> None:
    from rosbags.rosbag1 import Reader

    with Ros1BagWriter(tmp_path / "nothing.bag"):
        pass
    with Reader(tmp_path / "nothing.bag") as reader:
        assert reader.connections == [] and reader.message_count == 0
    with Ros1BagWriter(tmp_path / "quiet.bag", compression="bz2") as writer:
        add_three(writer)
    with Reader(tmp_path / "quiet.bag") as reader:
        ext: list[Any] = [c.ext for c in reader.connections]
        assert [(c.topic, c.msgcount, e.latching, e.callerid) for c, e in zip(reader.connections, ext)] == [
            ("/a", 0, 1, "/tfrec"), ("/b", 0, 0, None), ("/c", 0, 0, "/tfrec")]


def test_an_exception_leaves_the_bag_without_index(tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    from tfrec.formats.reader import read_recording

    path = tmp_path / "cut.bag"
    with pytest.raises(KeyboardInterrupt), Ros1BagWriter(path, chunk_bytes=1000) as writer:
        a, _, _ = add_three(writer)
        for i in range(100):
            writer.write(a, T0 + i, encode_string("x" * 100, ros1=True))
        raise KeyboardInterrupt
    data = path.read_bytes()
    assert struct.unpack("<Q", fields(data, 13)[0]["index_pos"])[0] == 0  # rosbag: "reindex"
    rec = read_recording(path)  # record by record, up to the last whole chunk
    assert rec.read_error is not None and "without an index" in rec.read_error
    assert 90 <= rec.topics["/a"].count < 100


# -- errors ---------------------------------------------------------------------------------------


def test_unknown_compression(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="ROS 1 bag compression 'zstd' is not one of none, bz2, lz4"):
        Ros1BagWriter(tmp_path / "x.bag", compression="zstd")
    assert not (tmp_path / "x.bag").exists()


def test_cannot_create(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match=r"missing/x\.bag: cannot write ROS 1 bag: No such file or directory"):
        Ros1BagWriter(tmp_path / "missing" / "x.bag")


def test_disk_full() -> None:
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full")
    with (pytest.raises(RecordingError, match="full: cannot write ROS 1 bag: No space left on device"),
          Ros1BagWriter("/dev/full", chunk_bytes=1000) as writer):
        a, _, _ = add_three(writer)
        for i in range(10_000):
            writer.write(a, T0 + i, bytes(1000))


@pytest.mark.parametrize(("time_ns", "problem"), [(-1, "before 1970"), (LAST_NS + 1, "past ROS 1's last time")])
def test_message_time_outside_ros1(tmp_path: Path, time_ns: int, problem: str) -> None:
    with Ros1BagWriter(tmp_path / "x.bag") as writer:
        a, _, c = add_three(writer)
        with pytest.raises(RecordingError, match=f"x.bag: a /a message time .* s is {problem}"):
            writer.write(a, time_ns, b"")
        with pytest.raises(RecordingError, match=f"x.bag: a /c message time .* s is {problem}"):
            writer.write_many(c, np.array([T0, time_ns]), [b"", b""])
        with pytest.raises(RecordingError, match=f"x.bag: a /a message time .* s is {problem}"):
            writer.write_samples((a, c), np.array([time_ns]), (np.zeros((1, 4), np.uint8),) * 2)
        assert writer.message_count == 0


def test_sink_start_time_outside_ros1(tmp_path: Path, marm: Robot) -> None:
    sink = Ros1BagSink(tmp_path / "x.bag")
    with pytest.raises(RecordingError, match="time -1.000000000 s is before 1970"):
        sink.begin(robot_description=marm.urdf, static=static_transforms(marm), start_time_ns=-NS_PER_S)
    sink.abort()


def test_misuse_is_a_programming_error(tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    writer = Ros1BagWriter(tmp_path / "x.bag")
    a, _, _ = add_three(writer)
    with pytest.raises(ValueError, match="no connection 3: 3 were added"):
        writer.write(3, T0, b"")
    with pytest.raises(ValueError, match="2 times but 1 messages"):
        writer.write_many(a, np.array([T0, T0]), [b""])
    with pytest.raises(ValueError, match=r"uint8 arrays of shape \(2, size\)"):
        writer.write_many(a, np.array([T0, T0]), np.zeros((2, 3)))  # type: ignore[arg-type]
    writer.close()
    with pytest.raises(RuntimeError, match="after close"):
        writer.write(a, T0, b"")

    sink = Ros1BagSink(tmp_path / "y.bag")
    chunk = next(iter_dynamic_chunks(marm, traj))
    with pytest.raises(RuntimeError, match="before begin"):
        sink.write_chunk(stamp_ns=chunk.time_ns, joint_names=chunk.names, positions=chunk.positions,
                         velocities=chunk.velocities, transforms=chunk.transforms)
    sink.begin(robot_description="", static=static_transforms(marm), start_time_ns=T0)
    with pytest.raises(ValueError, match="joint names changed"):
        sink.write_chunk(stamp_ns=chunk.time_ns + T0, joint_names=chunk.names, positions=chunk.positions,
                         velocities=chunk.velocities, transforms=chunk.transforms)
        sink.write_chunk(stamp_ns=chunk.time_ns + T0 + NS_PER_S * 100, joint_names=chunk.names[::-1],
                         positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
    moved = Transforms(chunk.transforms.parents[::-1], chunk.transforms.children[::-1],
                       chunk.transforms.translation, chunk.transforms.rotation)
    with pytest.raises(ValueError, match="transform frames changed"):
        sink.write_chunk(stamp_ns=chunk.time_ns + T0 + NS_PER_S * 100, joint_names=chunk.names,
                         positions=chunk.positions, velocities=chunk.velocities, transforms=moved)
    with pytest.raises(ValueError, match="stamps must not decrease"):
        sink.write_chunk(stamp_ns=chunk.time_ns + T0, joint_names=chunk.names, positions=chunk.positions,
                         velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()
    with pytest.raises(RuntimeError, match="twice"):
        sink.finish()
