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
                                                                            missing: bool) -> None:
    path = _written(_between(marm, missing=missing), tmp_path, kind)
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
