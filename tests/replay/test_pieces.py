"""``replay --check`` and ``tfrec check`` read piece by piece (tfrec/replay/pieces.py, tfrec/formats/reader.py's
read_pieces): the same report as the whole recording read at once — transforms stamped between joint states whose
two neighbours are in different pieces, latched data, damaged files — and a peak memory that does not grow with the
recording's length."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tfrec.fleet.tasks import check_recording
from tfrec.kinematics.fk import dynamic_transforms, static_transforms
from tfrec.kinematics.joints import all_joint_states
from tfrec.model import Robot
from tfrec.recording import FrameSeries, JointStates, Recording
from tfrec.replay.check import CheckReport, check_recording_pieces, check_replay
from tfrec.replay.load import load_replay
from tfrec.trajectory.generators import make_trajectory

from ..conftest import ROBOTS
from ..recording_helpers import load_robot, marm_trajectory, write_mcap, write_rosbag1, write_rosbag2

START_NS = 1_700_000_000_000_000_000
JS_PERIOD_NS = 50_000_000  # joint states at 20 Hz
TF_OFFSET_NS = 17_000_000  # each /tf message stamped 17 ms after a joint state: between two of them


@pytest.fixture(scope="module")
def marm() -> Robot:
    return load_robot("marm")


def _between(robot: Robot, *, samples: int = 40, gap_at: int | None = None, missing: bool = False) -> Recording:
    """A recording whose /tf is stamped between its joint states (each transform the FK of the joint state before
    it, so that the errors are interpolation's, all different); ``gap_at``: a 1 s gap in the stamps there;
    ``missing``: one joint without a position in every third joint state (a publisher of a subset)."""
    traj = make_trajectory(robot, "sine", duration_s=(samples - 1) * JS_PERIOD_NS / 1e9, rate_hz=1e9 / JS_PERIOD_NS)
    names, every, _ = all_joint_states(robot, traj)
    time_ns = START_NS + np.arange(len(traj.time_ns), dtype=np.int64) * JS_PERIOD_NS
    if gap_at is not None:
        time_ns[gap_at:] += 1_000_000_000
    positions = every.copy()
    if missing:
        positions[::3, 0] = np.nan
    tfs = dynamic_transforms(robot, list(names), every)
    tf = {(parent, child): FrameSeries(time_ns + TF_OFFSET_NS, np.ascontiguousarray(tfs.translation[:, k]),
                                       np.ascontiguousarray(tfs.rotation[:, k]))
          for k, (parent, child) in enumerate(zip(tfs.parents, tfs.children))}
    return Recording(path="", format="mcap", robot_description=robot.urdf,
                     joint_states=JointStates(time_ns, tuple(names), positions),
                     tf=tf, tf_static=static_transforms(robot).poses(), start_ns=START_NS)


def _whole(path: Path) -> tuple[CheckReport, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = check_replay(load_replay(path, need_robot=True))
    return report, [str(w.message) for w in caught]


def _pieces(path: Path, messages: int) -> tuple[CheckReport, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = check_recording_pieces(path, messages=messages)
    return report, [str(w.message) for w in caught]


def _written(rec: Recording, path: Path, kind: str) -> Path:
    if kind == "rosbag1":
        return write_rosbag1(rec, path / "rec.bag")
    return write_rosbag2(rec, path / "bag", storage=kind)


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "rosbag1"])
@pytest.mark.parametrize("missing", [False, True])
def test_pieces_split_between_joint_states_give_the_whole_recordings_numbers(marm: Robot, tmp_path: Path, kind: str,
                                                                            missing: bool,
                                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    path = _chunked(_between(marm, missing=missing), tmp_path, kind, monkeypatch)  # chunks of a few messages
    whole, said = _whole(path)
    compared = [f for f in whole.frames if f.topic == "/tf"]
    assert compared and all(f.samples > 0 and f.problem is None for f in compared)
    assert any(f.translation_m > 1e-6 for f in compared)  # interpolated between joint states: errors to compare
    for messages in (2, 3, 7, 16, 1000):  # edges everywhere: between each joint state and the transforms after it
        pieces, piece_said = _pieces(path, messages)
        assert pieces.to_dict() == whole.to_dict(), messages
        assert [f.errors is not None for f in pieces.frames] == [f.errors is not None for f in whole.frames]
        assert piece_said == said


def test_a_transform_before_the_first_and_after_the_last_joint_state_is_not_compared(marm: Robot,
                                                                                    tmp_path: Path) -> None:
    rec = _between(marm, samples=12)
    pair = next(iter(rec.tf))
    series = rec.tf[pair]
    early = np.concatenate([[series.time_ns[0] - 10 * JS_PERIOD_NS], series.time_ns])  # before every joint state
    rec.tf = {p: FrameSeries(early, np.concatenate([s.translation[:1], s.translation]),
                             np.concatenate([s.rotation[:1], s.rotation])) for p, s in rec.tf.items()}
    path = write_rosbag2(rec, tmp_path / "bag", storage="mcap")
    whole, _ = _whole(path)
    assert all(f.samples == 11 for f in whole.frames if f.topic == "/tf")  # the first and the last: outside
    for messages in (2, 5):
        assert _pieces(path, messages)[0].to_dict() == whole.to_dict()


def _rows(path: Path) -> list[dict[str, Any]]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [{k: v for k, v in dataclasses.asdict(row).items() if k != "read_s"} for row in check_recording(path)]


def test_check_of_a_recording_in_pieces_gives_the_same_rows(marm: Robot, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """tfrec check: re-simulation findings and the health checks (a gap, a stamp repeated) over pieces."""
    rec = _between(marm, samples=60, gap_at=30)
    assert rec.joint_states is not None
    rec.joint_states.time_ns[45] = rec.joint_states.time_ns[44]  # a stamp repeated
    path = write_rosbag2(rec, tmp_path / "bag", storage="mcap")
    whole = _rows(path)
    assert {row["check"] for row in whole} >= {"summary", "rate", "stamps", "resim"}
    from tfrec.formats import reader

    for messages in (3, 11):
        monkeypatch.setattr(reader, "PIECE_MESSAGES", messages)
        assert _rows(path) == whole


@pytest.mark.parametrize("damage", ["cut", "crc"])
def test_a_damaged_recording_gives_the_same_findings_in_pieces(marm: Robot, tmp_path: Path, damage: str) -> None:
    full = write_mcap(tmp_path / "full.mcap", marm, marm_trajectory(marm, duration_s=30.0, rate_hz=100.0),
                      compression="none")  # 1 MiB chunks: several
    data = bytearray(full.read_bytes())
    if damage == "cut":
        data = data[: len(data) * 3 // 5]
    else:  # a bit flipped in the middle of the file: a chunk whose CRC no longer matches
        data[len(data) // 2] ^= 0x10
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bytes(data))
    whole, said = _whole(path)
    assert any("damaged" in s or "stopped" in s or "CRC" in s or "crc" in s for s in said), said
    for messages in (97, 1000):
        pieces, piece_said = _pieces(path, messages)
        assert pieces.to_dict() == whole.to_dict()
        assert piece_said == said


def _check_rss_kib(path: Path) -> int:
    """Peak RSS (KiB) of ``tfrec replay --check`` of ``path`` in a child process of its own (os.wait4's rusage)."""
    env = {**os.environ, "PYTHONPATH": str(ROBOTS.parent)}
    child = subprocess.Popen([sys.executable, "-m", "tfrec", "replay", str(path), "--check"], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=path.parent)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    assert child.returncode == 0
    return int(usage.ru_maxrss)


def test_check_memory_does_not_grow_with_the_recordings_length(tmp_path: Path) -> None:
    """Ten minutes of a 7-joint arm at 100 Hz (120,000 messages) checked in about the memory of one minute's; the
    whole recording read at once needed ~90 MB more."""
    paths = {}
    for minutes in (1, 10):
        paths[minutes] = tmp_path / f"marm-{minutes}min.mcap"
        subprocess.run([sys.executable, "-m", "tfrec", "record", str(ROBOTS / "marm.xacro"), "--duration",
                        str(60 * minutes), "--rate", "100", "--no-rrd", "-o", str(paths[minutes])], check=True,
                       env={**os.environ, "PYTHONPATH": str(ROBOTS.parent)}, cwd=tmp_path,
                       stdout=subprocess.DEVNULL)
    one, ten = _check_rss_kib(paths[1]), _check_rss_kib(paths[10])
    assert ten < one * 1.25, (one, ten)


def _chunked(rec: Recording, folder: Path, kind: str, monkeypatch: pytest.MonkeyPatch,
             order: Any = None) -> Path:
    """The recording written by rosbags in chunks (batches) of a few messages each, so that pieces of a few
    messages cut it everywhere: MCAP re-chunked by the mcap library (``order``: a function that reorders the
    messages of the file), a ROS 1 bag with a tiny chunk threshold, sqlite3 read a few rows at a time."""
    if kind == "sqlite3":
        from tfrec.formats.rosbag2 import source

        monkeypatch.setattr(source, "BATCH_MESSAGES", 3)
        return write_rosbag2(rec, folder / "bag", storage="sqlite3")
    if kind == "rosbag1":
        return write_rosbag1(rec, folder / "rec.bag", chunk_threshold=300)
    from mcap.reader import make_reader
    from mcap.writer import Writer as McapWriter

    bag = write_rosbag2(rec, folder / "bag", storage="mcap")
    path = folder / "rec.mcap"
    with open(next(bag.glob("*.mcap")), "rb") as stream, open(path, "wb") as out:
        reader = make_reader(stream)
        header, summary = reader.get_header(), reader.get_summary()
        assert summary is not None
        writer = McapWriter(out, chunk_size=600)
        writer.start(profile=header.profile, library="tests")
        schemas = {k: writer.register_schema(s.name, s.encoding, s.data) for k, s in summary.schemas.items()}
        channels = {k: writer.register_channel(c.topic, c.message_encoding, schemas.get(c.schema_id, 0), c.metadata)
                    for k, c in summary.channels.items()}
        messages = [(m.channel_id, m.log_time, m.publish_time, m.data)
                    for _, _, m in reader.iter_messages(log_time_order=False)]
        topics = {k: c.topic for k, c in summary.channels.items()}
        for channel, log_time, publish_time, data in (order(messages, topics) if order else messages):
            writer.add_message(channels[channel], log_time, data, publish_time)
        writer.finish()
    return path


def _paused(rec: Recording, rows: slice) -> Recording:
    """The recording without the joint states of ``rows`` (its /tf goes on through the pause)."""
    js = rec.joint_states
    assert js is not None
    keep = np.ones(len(js), dtype=bool)
    keep[rows] = False
    return dataclasses.replace(rec, joint_states=JointStates(js.time_ns[keep], js.names, js.positions[keep]))


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "rosbag1"])
@pytest.mark.parametrize("rows", [slice(30, 55), slice(60, None)], ids=["pause", "stop"])
def test_transforms_through_a_pause_in_the_joint_states_are_compared_as_in_the_whole_recording(
        marm: Robot, tmp_path: Path, kind: str, rows: slice, monkeypatch: pytest.MonkeyPatch) -> None:
    """Pieces without joint states (a publisher that paused): their transforms wait for the joint state after the
    pause, as the whole recording interpolates them; joint states that stop for good hold nothing back."""
    path = _chunked(_paused(_between(marm, samples=80), rows), tmp_path, kind, monkeypatch)
    whole, said = _whole(path)
    compared = [f for f in whole.frames if f.topic == "/tf"]
    assert compared and all(f.samples == (79 if rows.stop else 59) for f in compared)
    for messages in (2, 5, 16, 1000):
        pieces, piece_said = _pieces(path, messages)
        assert pieces.to_dict() == whole.to_dict(), messages
        assert piece_said == said


def test_a_pause_longer_than_the_hold_compares_with_the_joint_states_before_it(
        marm: Robot, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Past HOLD_SAMPLES waiting transforms, a pause's transforms are compared with what came before (none:
    outside the joint states, not compared) rather than held: memory stays bounded."""
    from tfrec.replay import pieces as replay_pieces

    path = _chunked(_paused(_between(marm, samples=80), slice(20, 70)), tmp_path, "mcap", monkeypatch)
    whole, _ = _whole(path)
    assert _pieces(path, 5)[0].to_dict() == whole.to_dict()
    monkeypatch.setattr(replay_pieces, "HOLD_SAMPLES", 10)
    short, said = _pieces(path, 5)
    expected = ("/joint_states pauses for longer than a check read piece by piece holds transforms (10): those after "
                "its last message before the pause are not compared (`replay --check --start 0` reads the recording "
                "whole)")
    assert [s for s in said if "pauses for longer" in s] == [expected]
    whole_tf = [f for f in whole.frames if f.topic == "/tf"]
    short_tf = [f for f in short.frames if f.topic == "/tf"]
    assert short_tf and all(0 < f.samples < w.samples for f, w in zip(short_tf, whole_tf))


def _tf_after_the_rest(messages: list[Any], topics: dict[int, str]) -> list[Any]:
    """In each run of 24 messages, the /tf ones after the others (as a writer that puts each topic's messages of a
    stretch one after the other: `tfrec convert` did)."""
    out = []
    for start in range(0, len(messages), 24):
        run = messages[start : start + 24]
        out += [m for m in run if topics[m[0]] != "/tf"] + [m for m in run if topics[m[0]] == "/tf"]
    return out


def _tf_drifting_behind(messages: list[Any], topics: dict[int, str]) -> list[Any]:
    """The /tf messages further and further behind the joint states in the file: the k-th after joint state
    k + k // 3 (as `tfrec convert` wrote them, 10 ms further a chunk)."""
    tf = [m for m in messages if topics[m[0]] == "/tf"]
    js = [m for m in messages if topics[m[0]] == "/joint_states"]
    out = [m for m in messages if topics[m[0]] not in ("/tf", "/joint_states")]
    k = 0
    for j, message in enumerate(js):
        out.append(message)
        while k < len(tf) and k + k // 3 <= j:
            out.append(tf[k])
            k += 1
    return out + tf[k:]


@pytest.mark.parametrize("order", [_tf_after_the_rest, _tf_drifting_behind])
def test_transforms_the_file_holds_after_later_joint_states_are_compared_as_in_the_whole_recording(
        marm: Robot, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, order: Any) -> None:
    """A file not in log-time order: a piece's transforms may be stamped before the joint states the piece before
    ended with — by 1.2 s, or by more and more, up to 5 s (20 Hz here: 100 samples)."""
    path = _chunked(_between(marm, samples=400), tmp_path, "mcap", monkeypatch, order=order)
    whole, said = _whole(path)
    assert all(f.samples == 399 for f in whole.frames if f.topic == "/tf")
    for pieces in (30, 53, 1000):
        found, piece_said = _pieces(path, pieces)
        assert found.to_dict() == whole.to_dict(), pieces
        assert piece_said == said


def _ros1_records(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, end, op) of each record of a ROS 1 bag."""
    out, at = [], 13  # after "#ROSBAG V2.0\n"
    while at + 4 <= len(data):
        header_len = int.from_bytes(data[at : at + 4], "little")
        header, fields, op = data[at + 4 : at + 4 + header_len], 0, -1
        while fields < len(header):
            size = int.from_bytes(header[fields : fields + 4], "little")
            name, _, value = header[fields + 4 : fields + 4 + size].partition(b"=")
            if name == b"op":
                op = value[0]
            fields += 4 + size
        data_at = at + 4 + header_len
        end = data_at + 4 + int.from_bytes(data[data_at : data_at + 4], "little")
        out.append((at, end, op))
        at = end
    return out


@pytest.mark.parametrize("damage", ["cut", "twice"])
def test_a_damaged_ros1_bag_says_what_reading_it_whole_says_once(marm: Robot, tmp_path: Path, damage: str) -> None:
    """What reading the latched data said of the file (a chunk given twice, the bag cut) is not said again by the
    walk through the pieces."""
    data = write_rosbag1(_between(marm, samples=400), tmp_path / "rec.bag", chunk_threshold=4000).read_bytes()
    records = _ros1_records(data)
    chunks = [k for k, (_, _, op) in enumerate(records) if op == 5]
    assert len(chunks) > 4
    middle = chunks[len(chunks) // 2]
    if damage == "cut":
        damaged = data[: (records[middle][0] + records[middle][1]) // 2]
    else:  # the chunk and its index data records given twice
        end = next(k for k in range(middle + 1, len(records)) if records[k][2] != 4)
        span = data[records[middle][0] : records[end][0]]
        damaged = data[: records[end][0]] + span + data[records[end][0] :]
    path = tmp_path / "damaged.bag"
    path.write_bytes(damaged)
    whole, said = _whole(path)
    assert said and len(said) == len(set(said)), said
    for messages in (40, 1000):
        pieces, piece_said = _pieces(path, messages)
        assert pieces.to_dict() == whole.to_dict(), messages
        assert piece_said == said, messages
