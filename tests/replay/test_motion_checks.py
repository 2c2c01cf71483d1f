"""Motion checks (tfrec/replay/motion_checks.py): what a robot could not have done, found by `tfrec check` in
recordings the tests build — limits, soft limits, velocity, acceleration, jumps, non-finite positions, mimic
joints — and nothing found in clean recordings of every robot of robots/ and ../shared/corpus."""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from tests.bag_builders import Robot as Published
from tests.bag_builders import write_bag
from tfrec.cli import main
from tfrec.description import parse_urdf
from tfrec.fleet.tasks import check_recording
from tfrec.formats.reader import read_recording
from tfrec.recording import JointStates
from tfrec.replay.motion_checks import MotionChecker

from ..conftest import REPO

ARM = """<robot name="arm">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="2"/>
    <safety_controller soft_lower_limit="-0.9" soft_upper_limit="0.9" k_velocity="1"/></joint>
  <joint name="wheel" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>
    <limit effort="1" velocity="4"/></joint>
  <joint name="slide" type="prismatic"><parent link="b"/><child link="c"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.2" effort="1" velocity="0.1"/></joint>
  <joint name="follow" type="revolute"><parent link="c"/><child link="d"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="1" velocity="10"/><mimic joint="shoulder" multiplier="2" offset="0.1"/></joint>
</robot>"""
NAMES = ("shoulder", "wheel", "slide", "follow")


def _clean(n: int = 101, rate_hz: float = 50.0) -> tuple[np.ndarray, np.ndarray]:
    """N samples of a motion within every limit: time_ns (N,), positions (N, 4)."""
    t = np.arange(n) / rate_hz
    shoulder = 0.5 * np.sin(t)
    positions = np.column_stack([shoulder, 3.0 * t, 0.1 + 0.05 * np.sin(t), 2 * shoulder + 0.1])
    return np.round(t * 1e9).astype(np.int64), positions


def _found(positions: np.ndarray, time_ns: np.ndarray | None = None, *, batches: int = 1,
           max_accel: float | None = None) -> list:
    checker = MotionChecker(parse_urdf(ARM), max_accel=max_accel)
    time_ns = _clean(len(positions))[0] if time_ns is None else time_ns
    for part in np.array_split(np.arange(len(positions)), batches):
        checker.feed(NAMES, time_ns[part], positions[part])
    return checker.findings()


def test_a_clean_motion_has_no_finding() -> None:
    _, positions = _clean()
    assert _found(positions, max_accel=5.0) == []


@pytest.mark.parametrize("batches", [1, 3, 101])
def test_each_violation_is_found_with_joint_value_limit_and_first_time(batches: int) -> None:
    _, positions = _clean()
    positions[30:33, 0] = 1.25  # beyond the hard limit (and a jump there and back)
    positions[60, 0] = 0.95  # beyond the soft limit only (a smaller step)
    positions[:, 3] = 2 * positions[:, 0] + 0.1
    positions[80, 3] += 0.01  # the mimic off its master
    positions[45:, 2] = positions[44, 2] + 0.004 * np.arange(1, 57)  # 0.2 m/s: twice the limit (beyond 0.2 m at the end)
    positions[20, 1] = math.inf
    found = {(f.check, f.joint): f for f in _found(positions, batches=batches)}
    limit = found[("limit", "shoulder")]
    assert (limit.value, limit.limit, limit.unit, limit.first_ns, limit.count) == (1.25, 1.0, "rad", 600_000_000, 3)
    soft = found[("soft_limit", "shoulder")]
    assert (soft.value, soft.limit, soft.first_ns) == (0.95, 0.9, 1_200_000_000)
    jump = found[("jump", "shoulder")]
    assert jump.first_ns == 600_000_000 and jump.unit == "rad" and jump.value > 0.5
    mimic = found[("mimic", "follow")]
    assert mimic.first_ns == 1_600_000_000 and mimic.value == pytest.approx(0.01)
    velocity = found[("velocity", "slide")]
    assert velocity.value == pytest.approx(0.2) and velocity.limit == 0.1 and velocity.unit == "m/s"
    assert velocity.first_ns == 900_000_000
    assert found[("limit", "slide")].limit == 0.2
    assert found[("nonfinite", "wheel")].first_ns == 400_000_000
    text = limit.detail(origin_ns=0)
    assert text == "joint 'shoulder': position 1.25 rad beyond its limit 1 rad, first at t=0.600 s (3 samples)"


def test_acceleration_only_with_max_accel() -> None:
    _, positions = _clean()
    positions[:, 0] = np.where(np.arange(101) < 50, 0.0, 0.02 * (np.arange(101) - 50))  # 0 → 1 rad/s in one step
    positions[:, 3] = 2 * positions[:, 0] + 0.1
    assert not [f for f in _found(positions) if f.check == "acceleration"]
    (mimic, accel) = [f for f in _found(positions, max_accel=10.0) if f.check == "acceleration"]  # by time, joint
    assert mimic.joint == "follow" and mimic.value == pytest.approx(100.0)  # twice the master's
    assert accel.joint == "shoulder" and accel.value == pytest.approx(50.0) and accel.first_ns == 1_020_000_000


def test_a_continuous_joint_wrapping_around_is_no_jump() -> None:
    time_ns, positions = _clean()
    positions[:, 1] = np.mod(3.0 * time_ns / 1e9 + math.pi, 2 * math.pi) - math.pi  # wrapped to [-π, π)
    assert _found(positions) == []


def test_a_nan_is_found_where_messages_name_the_joint_not_where_they_leave_it_out() -> None:
    _, positions = _clean()
    bad = positions.copy()
    bad[10, 2] = math.nan  # a message of all four joints with a NaN for slide
    (finding,) = _found(bad)
    assert (finding.check, finding.joint, finding.first_ns) == ("nonfinite", "slide", 200_000_000)
    split = positions.copy()  # two publishers: slide alone in every other message, the others in the rest
    split[::2, 2] = math.nan
    split[1::2, [0, 1, 3]] = math.nan
    assert [f for f in _found(split) if f.check == "nonfinite"] == []


def test_a_joint_without_velocity_limit_jumps_over_half_a_radian() -> None:
    robot = parse_urdf(ARM.replace('velocity="4"', 'velocity="0"'))
    time_ns, positions = _clean()
    positions[50:, 1] += 0.6
    checker = MotionChecker(robot)
    checker.feed(NAMES, time_ns, positions)
    (jump,) = checker.findings()
    assert (jump.check, jump.joint, jump.limit, jump.first_ns) == ("jump", "wheel", 0.5, 1_000_000_000)


# -- in recordings, through `tfrec check` --------------------------------------------------------------


@pytest.fixture(scope="module")
def marm_rec(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("marm") / "clean.mcap"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["record", str(REPO / "robots" / "marm.xacro"), "--traj", "random", "--duration", "6", "-o",
                     str(path), "--no-rrd", "--quiet-legacy"]) == 0
    return path


def _injected(clean: Path, out: Path, change) -> Path:
    """The clean recording with its /joint_states changed, written by rosbags (an independent writer)."""
    rec = read_recording(clean)
    js = rec.joint_states
    assert js is not None
    positions = js.positions.copy()
    change(js.names, positions)
    bad = dataclasses.replace(rec, joint_states=JointStates(js.time_ns, js.names, positions))
    return write_bag(out, [Published(bad)], kind="mcap")


def _motion(rows) -> dict[tuple[str, str], str]:
    return {(row.frame, row.detail.split(": ", 1)[1].split(" ")[0]): row.detail for row in rows if row.check == "motion"}


def test_check_finds_what_was_injected(marm_rec: Path, tmp_path: Path) -> None:
    head, *rows = check_recording(marm_rec)
    assert head.verdict == "pass", head.detail

    def limit(names, positions):
        positions[40:45, names.index("joint2")] = 10.0

    def jump(names, positions):
        positions[100:, names.index("joint3")] += 0.8

    def mimic(names, positions):
        positions[150, names.index("finger_joint2")] += 0.01

    def nan(names, positions):
        positions[77, names.index("joint1")] = math.nan

    for name, change, joint, word in (("limit", limit, "joint2", "position"), ("jump", jump, "joint3", "jumps"),
                                      ("mimic", mimic, "finger_joint2", "differs"),
                                      ("nan", nan, "joint1", "position")):
        head, *rows = check_recording(_injected(marm_rec, tmp_path / name, change))
        assert head.verdict == "fail"
        found = _motion(rows)
        assert (joint, word) in found, (name, found)
    fast = tmp_path / "fast.mcap"  # what --traj random made before: 4× the velocity limit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["record", str(REPO / "robots" / "marm.xacro"), "--traj", "random", "--duration", "6", "-o",
                     str(fast), "--no-rrd", "--ignore-velocity-limits", "--quiet-legacy"]) == 0
    head, *rows = check_recording(fast)
    speeds = [row for row in rows if row.check == "motion" and "over its velocity limit" in row.detail]
    assert speeds and all(row.unit == "rad/s" and row.max_error > 1.0 for row in speeds)


@pytest.mark.parametrize("messages", [7, 64])
def test_check_in_pieces_finds_what_the_whole_recording_has(marm_rec: Path, tmp_path: Path, messages: int,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """`check` reads a recording piece by piece (each piece begins with the last positions of the one before): the
    motion findings are those of the whole recording fed at once — no step across a piece's edge lost or doubled."""
    from tfrec.fleet import tasks

    from ..recording_helpers import write_rosbag2

    rec = read_recording(marm_rec)
    js = rec.joint_states
    assert js is not None
    positions = js.positions.copy()
    positions[40:45, js.names.index("joint2")] = 10.0
    positions[100:, js.names.index("joint3")] += 0.8
    positions[150, js.names.index("finger_joint2")] += 0.01
    positions[77, js.names.index("joint1")] = math.nan
    bad = write_rosbag2(dataclasses.replace(rec, joint_states=JointStates(js.time_ns, js.names, positions)),
                        tmp_path / "bad", storage="sqlite3")

    def motion(rows):
        return [(r.frame, r.detail, r.max_error, r.first_exceed_s) for r in rows[1:] if r.check == "motion"]

    whole = motion(check_recording(bad))
    assert len(whole) >= 4
    fed: list[int] = []
    feed = tasks._Stamps.feed_motion

    def counted(self, replay, max_accel):  # type: ignore[no-untyped-def]
        fed.append(1)
        return feed(self, replay, max_accel)

    monkeypatch.setattr(tasks._Stamps, "feed_motion", counted)
    monkeypatch.setattr("tfrec.formats.rosbag2.source.BATCH_MESSAGES", 5)
    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", messages)
    assert motion(check_recording(bad)) == whole
    assert len(fed) > 5  # read in pieces indeed


def test_check_cli_max_accel_and_one_line_for_a_bad_value(marm_rec: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(marm_rec), "--jobs", "1", "--max-accel", "0.001"]) == 1
    assert "acceleration" in capsys.readouterr().out
    assert main(["check", str(marm_rec), "--jobs", "1", "--max-accel", "-1"]) == 2
    assert "max_accel -1.0 is not a positive number" in capsys.readouterr().err


def test_record_warns_where_a_csv_goes_faster_than_the_limits(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "fast.csv"
    csv.write_text("time,joint1\n0,0\n0.1,0.5\n0.2,0\n")
    assert main(["record", str(REPO / "robots" / "marm.xacro"), "--traj", str(csv), "-o", str(tmp_path / "f.mcap"),
                 "--no-rrd", "--quiet-legacy"]) == 0
    err = capsys.readouterr().err
    assert f"tfrec: warning: {csv}: joint 'joint1': speed 5 rad/s over its velocity limit 1 rad/s" in err, err
    slow = tmp_path / "slow.csv"
    slow.write_text("time,joint1\n0,0\n1,0.5\n2,0\n")
    assert main(["record", str(REPO / "robots" / "marm.xacro"), "--traj", str(slow), "-o", str(tmp_path / "s.mcap"),
                 "--no-rrd", "--quiet-legacy"]) == 0
    assert "velocity limit" not in capsys.readouterr().err


def _corpus() -> Path:
    """../shared/corpus (beside the repository, or the shared folder of these machines)."""
    beside = REPO.parent / "shared" / "corpus"
    return beside if beside.is_dir() else Path("/work/shared/corpus")


def _robots() -> list[tuple[str, Path, dict[str, str]]]:
    found = [(p.name, p, {}) for p in sorted((REPO / "robots").glob("*.xacro")) if p.name != "parameters.xacro"]
    corpus = _corpus()
    for rel, args in (("urdf_tutorial/urdf/08-macroed.urdf.xacro", {}),
                      ("turtlebot3_description/urdf/turtlebot3_burger.urdf.xacro", {}),
                      ("turtlebot3_description/urdf/turtlebot3_waffle_pi.urdf.xacro", {}),
                      ("ur_description/urdf/ur5.xacro", {}), ("ur_description/urdf/ur10e.xacro", {}),
                      ("franka_description/robots/panda/panda.urdf.xacro", {"hand": "true"}),
                      ("robotiq_description/urdf/robotiq_2f_85_gripper.urdf.xacro", {}),
                      ("robotiq_description/urdf/robotiq_2f_140_gripper.urdf.xacro", {})):
        found.append((rel, corpus / rel, args))
    return found


@pytest.mark.parametrize(("name", "path", "args"), _robots(), ids=[r[0] for r in _robots()])
def test_clean_recordings_of_every_robot_pass(name: str, path: Path, args: dict[str, str], tmp_path: Path) -> None:
    if not path.exists():
        pytest.skip(f"{path} is not here")
    packages = [str(_corpus())] if _corpus() in path.parents else []
    argv = ["record", str(path), *(f"{k}:={v}" for k, v in args.items()), "--duration", "4", "--no-rrd",
            "--quiet-legacy", *(w for p in packages for w in ("--package-path", p))]
    for kind in ("random", "sine", "center"):
        out = tmp_path / f"{kind}.mcap"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            assert main([*argv, "--traj", kind, "-o", str(out)]) == 0
        head, *rows = check_recording(out)
        assert head.verdict == "pass", (kind, head.detail, [r.detail for r in rows])
