"""The layouts tfrec reads messages with are proven by writing the messages back (:mod:`tfrec.formats.ros.decode`):
whenever tfrec's encoder writes what a layout read back to a message's own bytes, rosbags reads that message the same
way — so ``tfrec info`` needs no rosbags type store. Checked against rosbags' deserialization on every JointState,
TFMessage and String message of every recording at hand (../shared/bags, tests/golden, recordings made here by tfrec
and by rosbags' writers), and on messages built here that the encoder does not write (efforts, transforms of several
stamps, a nested ROS 1 seq, NaN, CDR padding, nanoseconds past a second, a big-endian or cut message)."""

from __future__ import annotations

import contextlib
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.bag_builders import Robot, sim_time, write_bag
from tests.conftest import BAGS, REPO
from tfrec.formats.ros.decode import (
    JointStateAccumulator,
    TFAccumulator,
    message_layout,
    read_string,
    read_transforms,
    stamp_ns,
    transforms_of,
)
from tfrec.formats.ros.definitions import INTERPRETED
from tfrec.formats.ros.types import UndecodableMessage, deserializer
from tfrec.recording import Recording

KINDS = {"tf2_msgs/msg/TFMessage": "tf", "sensor_msgs/msg/JointState": "joint_states", "std_msgs/msg/String": "string"}

Message = tuple[str, bool, bytes]
"""(type, ROS 1, serialized message)."""


class _Declined(Exception):
    """The fast path asked for rosbags' deserializer: it did not take the message."""


def _declined(raw: bytes) -> Any:
    raise _Declined()


def _rosbags(msgtype: str, ros1: bool, raw: bytes) -> Any:
    """rosbags' message, or the UndecodableMessage it raises."""
    try:
        return deserializer(msgtype, ros1=ros1)(raw)
    except UndecodableMessage as err:
        return err


def _bits(values: Any) -> bytes:
    """Float values compared bit for bit (NaN included)."""
    return np.asarray(values, dtype="<f8").tobytes()


def _same_transforms(a: list[Any], b: list[Any]) -> bool:
    return [(pair, time) for pair, time, _ in a] == [(pair, time) for pair, time, _ in b] and all(
        _bits(x) == _bits(y) for (_, _, x), (_, _, y) in zip(a, b))


def check(msgtype: str, ros1: bool, raw: bytes) -> bool:
    """Assert that tfrec reads ``raw`` as rosbags does, whichever way it reads it; True when rosbags was not needed."""
    kind = KINDS[INTERPRETED[msgtype]]
    expected = _rosbags(msgtype, ros1, raw)
    if kind == "string":
        return _check_string(msgtype, ros1, raw, expected)
    try:
        layout = message_layout(kind, raw, ros1=ros1)
    except (ValueError, UnicodeDecodeError):  # the walker refuses it: every message of it goes through rosbags
        taken = False
    else:
        rows = np.frombuffer(raw, dtype=np.uint8).reshape(1, -1)
        accumulator = (TFAccumulator if kind == "tf" else JointStateAccumulator)(_declined, ros1=ros1)
        taken = accumulator.written_back(layout, rows)
        if taken:
            assert not isinstance(expected, UndecodableMessage), f"written back, but rosbags cannot read it: {expected}"
            assert _read_alike(kind, layout, rows, expected), "written back, but rosbags reads other values"
    if kind == "tf":
        deserialize = _declined if taken else deserializer(msgtype, ros1=ros1)
        if isinstance(expected, UndecodableMessage):
            with pytest.raises(UndecodableMessage):
                read_transforms(raw, ros1=ros1, deserialize=deserialize)
        else:
            assert _same_transforms(read_transforms(raw, ros1=ros1, deserialize=deserialize), transforms_of(expected))
    return taken


def _read_alike(kind: str, layout: Any, rows: np.ndarray, msg: Any) -> bool:
    """Whether ``layout`` reads ``rows`` (one message) as rosbags read it (``msg``), bit for bit."""
    if kind == "tf":
        decoded = [(pair, int(time[0]), values[0]) for pair, time, values in TFAccumulator.decode(layout, rows)]
        return _same_transforms(decoded, transforms_of(msg))
    time, names, positions = JointStateAccumulator._decode(layout, rows)
    return (names == tuple(msg.name) and int(time[0]) == stamp_ns(msg.header.stamp)
            and positions.shape == (1, len(msg.position)) and _bits(positions) == _bits(msg.position))


def _check_string(msgtype: str, ros1: bool, raw: bytes, expected: Any) -> bool:
    try:
        text = read_string(raw, ros1=ros1, deserialize=_declined)
    except _Declined:
        if isinstance(expected, UndecodableMessage):
            with pytest.raises(UndecodableMessage):
                read_string(raw, ros1=ros1, deserialize=deserializer(msgtype, ros1=ros1))
        else:
            assert read_string(raw, ros1=ros1, deserialize=deserializer(msgtype, ros1=ros1)) == expected.data
        return False
    assert not isinstance(expected, UndecodableMessage), f"read, but rosbags cannot read it: {expected}"
    assert text == expected.data
    return True


# -- the recordings at hand -------------------------------------------------------------------------------------------


def _mcap_messages(path: Path) -> Iterator[Message]:
    from mcap.reader import make_reader

    with open(path, "rb") as stream:
        for schema, _, message in make_reader(stream).iter_messages():
            name = schema.name if schema is not None else ""
            full = name if "/msg/" in name else name.replace("/", "/msg/", 1)
            if full in INTERPRETED:
                yield full, False, bytes(message.data)


def _ros1_messages(path: Path) -> Iterator[Message]:
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        wanted = [c for c in reader.connections if c.msgtype in INTERPRETED]
        if not wanted:  # messages(connections=[]) would be every message
            return
        for connection, _, raw in reader.messages(connections=wanted):
            yield connection.msgtype, True, bytes(raw)


def _sqlite3_messages(path: Path) -> Iterator[Message]:
    import sqlite3

    with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as db:
        rows = db.execute("SELECT topics.type, messages.data FROM messages JOIN topics ON messages.topic_id = "
                          "topics.id ORDER BY messages.timestamp").fetchall()
    for msgtype, data in rows:
        if msgtype in INTERPRETED:
            yield msgtype, False, bytes(data)


def messages_of(path: Path) -> list[Message]:
    """The messages of the types tfrec reads, by mcap's reader (MCAP files, a rosbag2 folder's), SQLite (a rosbag2
    folder's .db3) or rosbags' (ROS 1 bags)."""
    if path.suffix == ".bag":
        return list(_ros1_messages(path))
    files = sorted(path.iterdir()) if path.is_dir() else [path]
    found: list[Message] = []
    for file in files:
        if file.suffix == ".mcap":
            found += _mcap_messages(file)
        elif file.suffix == ".db3":
            found += _sqlite3_messages(file)
    return found


def _shared() -> list[Path]:
    if not BAGS.is_dir():
        return []
    readable = []
    for path in sorted((BAGS / "rosbag2").iterdir()) + sorted((BAGS / "rosbagjs").glob("*.bag")):
        if path.is_file() and path.stat().st_size == 0:
            continue  # rosbag.js' empty file: no bag for either reader
        readable.append(path)
    return readable


GOLDEN = sorted((REPO / "tests" / "golden").glob("*.mcap"))


@pytest.mark.parametrize("path", _shared() + GOLDEN, ids=lambda path: path.name)
def test_each_message_of_each_bag_at_hand_reads_as_rosbags_reads_it(path: Path) -> None:
    for msgtype, ros1, raw in messages_of(path):
        check(msgtype, ros1, raw)


def test_tfrecs_own_recordings_need_no_rosbags(tmp_path: Path, marm_mcap: Path) -> None:
    """Every message of tfrec's MCAP, ROS 1 bag and rosbag2 folder is read without rosbags (what `info` relies on)."""
    from tfrec.cli import main

    bag, folder = tmp_path / "marm.bag", tmp_path / "bag2"
    for out in (["-o", str(bag)], ["--bag", str(folder)]):
        assert main(["record", str(REPO / "robots" / "marm.xacro"), "--duration", "1", "--no-rrd", *out]) == 0
    for path in (marm_mcap, bag, folder):
        found = messages_of(path)
        assert {msgtype for msgtype, _, _ in found} == set(KINDS)
        assert all(check(msgtype, ros1, raw) for msgtype, ros1, raw in found), path


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1"])
def test_bags_written_by_rosbags_read_as_rosbags_reads_them(tmp_path: Path, marm_rec: Recording, kind: str) -> None:
    """Bags by rosbags' writers (ROS 1 headers with sequence numbers, JointStates without velocities, sim time):
    whatever is not written back is read through rosbags, and what is read the same."""
    path = write_bag(tmp_path / ("b.bag" if kind == "ros1" else "b"),
                     [Robot(marm_rec, header=sim_time(marm_rec.start_ns or 0), frame_prefix="/")], kind=kind)
    found = messages_of(path)
    assert {msgtype for msgtype, _, _ in found} == set(KINDS)
    taken = [check(msgtype, ros1, raw) for msgtype, ros1, raw in found]
    assert any(taken)  # the descriptions at least


# -- messages the encoder does not write --------------------------------------------------------------------------


def _store(ros1: bool) -> Any:
    from tests.recording_helpers import _typestore

    return _typestore(ros1)


def _header(store: Any, ros1: bool, stamp: tuple[int, int], frame: str, seq: int = 0) -> Any:
    t = store.types
    time = t["builtin_interfaces/msg/Time"](sec=stamp[0], nanosec=stamp[1])
    return t["std_msgs/msg/Header"](seq=seq, stamp=time, frame_id=frame) if ros1 else \
        t["std_msgs/msg/Header"](stamp=time, frame_id=frame)


def _joint_state(ros1: bool, *, names: list[str], position: list[float], velocity: list[float], effort: list[float],
                 frame: str = "", stamp: tuple[int, int] = (1_700_000_000, 5), seq: int = 0) -> bytes:
    store = _store(ros1)
    msg = store.types["sensor_msgs/msg/JointState"](
        header=_header(store, ros1, stamp, frame, seq), name=names, position=np.array(position, dtype=np.float64),
        velocity=np.array(velocity, dtype=np.float64), effort=np.array(effort, dtype=np.float64))
    return bytes(store.serialize_ros1(msg, "sensor_msgs/msg/JointState") if ros1 else
                 store.serialize_cdr(msg, "sensor_msgs/msg/JointState"))


def _tf(ros1: bool, transforms: list[tuple[str, str, tuple[int, int], list[float]]], seq: int = 0) -> bytes:
    store = _store(ros1)
    t = store.types
    msg = t["tf2_msgs/msg/TFMessage"](transforms=[
        t["geometry_msgs/msg/TransformStamped"](
            header=_header(store, ros1, stamp, parent, seq), child_frame_id=child,
            transform=t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](x=v[0], y=v[1], z=v[2]),
                rotation=t["geometry_msgs/msg/Quaternion"](x=v[3], y=v[4], z=v[5], w=v[6])))
        for parent, child, stamp, v in transforms])
    return bytes(store.serialize_ros1(msg, "tf2_msgs/msg/TFMessage") if ros1 else
                 store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))


def _string(ros1: bool, text: str) -> bytes:
    store = _store(ros1)
    msg = store.types["std_msgs/msg/String"](data=text)
    return bytes(store.serialize_ros1(msg, "std_msgs/msg/String") if ros1 else
                 store.serialize_cdr(msg, "std_msgs/msg/String"))


def _with_nanosec(raw: bytes, offset: int, nanosec: int) -> bytes:
    return raw[:offset] + struct.pack("<I", nanosec) + raw[offset + 4:]


VALUES = [0.5, -1.0, float("nan"), float("inf"), -0.0, 1e-300, 3.0]


@pytest.mark.parametrize("ros1", [False, True], ids=["cdr", "ros1"])
def test_joint_states_the_encoder_does_not_write_read_as_rosbags_reads_them(ros1: bool) -> None:
    names = ["a", "bb", "ccc"]
    written = _joint_state(ros1, names=names, position=[1.0, float("nan"), -0.0], velocity=[0.0, 1.0, 2.0], effort=[],
                           frame="", seq=41)
    assert check("sensor_msgs/msg/JointState", ros1, written)  # as tfrec writes it: taken
    cases = [
        _joint_state(ros1, names=names, position=[1, 2, 3], velocity=[0, 0, 0], effort=[1, 2, 3]),  # efforts
        _joint_state(ros1, names=names, position=[1, 2, 3], velocity=[], effort=[]),  # no velocities
        _joint_state(ros1, names=names, position=[1, 2], velocity=[0, 0, 0], effort=[]),  # fewer positions
        _joint_state(ros1, names=["a", "a"], position=[1, 2], velocity=[0, 0], effort=[]),  # a name twice
        _joint_state(ros1, names=[], position=[], velocity=[], effort=[]),
        _joint_state(ros1, names=names, position=[1, 2, 3], velocity=[0, 0, 0], effort=[], frame="base_link"),
        _joint_state(ros1, names=["ä"], position=[1], velocity=[0], effort=[], stamp=(0, 0)),
    ]
    if not ros1:
        cases.append(_joint_state(False, names=names, position=[1, 2, 3], velocity=[0, 0, 0], effort=[],
                                  stamp=(-5, 7)))  # before 1970
        cases.append(_with_nanosec(written, 4 + 4, 1_500_000_000))  # nanoseconds past a second
        cases += [written + b"\0" * pad for pad in (1, 3, 4)]  # CDR padding (4 bytes: more than a message)
    else:
        cases.append(_with_nanosec(written, 8, 4_000_000_000))  # nanoseconds past a second
        last = written[:4] + struct.pack("<II", 2**32 - 1, 4_000_000_000) + written[12:]  # ... past ROS 1's last time
        cases.append(last)
        cases.append(written + b"\0")
    for raw in cases:
        check("sensor_msgs/msg/JointState", ros1, raw)
    assert not check("sensor_msgs/msg/JointState", ros1, cases[0])  # efforts: read through rosbags


@pytest.mark.parametrize("ros1", [False, True], ids=["cdr", "ros1"])
def test_tf_messages_the_encoder_does_not_write_read_as_rosbags_reads_them(ros1: bool) -> None:
    stamp = (1_700_000_000, 123)
    written = _tf(ros1, [("world", "base", stamp, VALUES), ("base", "tool", stamp, [1, 2, 3, 0, 0, 0, 1])])
    assert check("tf2_msgs/msg/TFMessage", ros1, written)
    cases = [
        _tf(ros1, [("world", "base", stamp, VALUES), ("base", "tool", (1_700_000_001, 0), VALUES)]),  # two stamps
        _tf(ros1, []),
        _tf(ros1, [("wörld", "bäse", stamp, VALUES)]),
        _tf(ros1, [("/a", "b", stamp, VALUES), ("a", "b", stamp, VALUES), ("/a", "b", stamp, VALUES)]),
        written[:-1],  # cut
    ]
    if ros1:
        cases.append(_tf(True, [("world", "base", stamp, VALUES)], seq=7))  # a nested header's seq
        cases.append(written + b"\0")
    else:
        cases += [written + b"\0" * pad for pad in (1, 3, 4)]
        cases.append(b"\x00\x00" + written[2:])  # big-endian CDR: rosbags reads it, the layout walker does not
    for raw in cases:
        check("tf2_msgs/msg/TFMessage", ros1, raw)
    assert not check("tf2_msgs/msg/TFMessage", ros1, cases[0])  # two stamps: read through rosbags


@pytest.mark.parametrize("ros1", [False, True], ids=["cdr", "ros1"])
def test_strings_read_as_rosbags_reads_them(ros1: bool) -> None:
    for text in ["", "a", "abcd", '<robot name="r"><link name="ä"/></robot>\n']:
        assert check("std_msgs/msg/String", ros1, _string(ros1, text))
    written = _string(ros1, "abc")
    text_at = 4 if ros1 else 8
    cases = [written + b"\0", written[:-1], written[:text_at] + b"\xff" + written[text_at + 1:]]  # not UTF-8
    if not ros1:
        cases += [written + b"\0" * 3, written + b"\0" * 4, written[:-1] + b"x", b"\x00\x00" + written[2:]]
    for raw in cases:
        check("std_msgs/msg/String", ros1, raw)
