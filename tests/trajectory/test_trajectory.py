"""Joint trajectories: sampling, the four kinds, CSV files, mimic joints."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tfrec.description import load_description, parse_urdf
from tfrec.errors import TfrecWarning, TrajectoryError
from tfrec.kinematics.joints import all_joint_states, apply_mimic
from tfrec.model import JointType, Robot
from tfrec.trajectory.clock import sample_times_ns
from tfrec.trajectory.csv_file import read_csv_trajectory
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.joints import center_positions, joint_bounds
from tfrec.trajectory.types import GeneratedTrajectory, JointTrajectory, TrajectoryKind

TOY_URDF = """<robot name="toy">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
  <link name="e"/><link name="f"/><link name="g"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="2" effort="1" velocity="1"/></joint>
  <joint name="lifted" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>
    <limit lower="0.5" upper="1.5" effort="1" velocity="1"/></joint>
  <joint name="sunk" type="prismatic"><parent link="b"/><child link="c"/><axis xyz="1 0 0"/>
    <limit lower="-0.2" upper="-0.1" effort="1" velocity="1"/></joint>
  <joint name="wheel" type="continuous"><parent link="base"/><child link="d"/><axis xyz="0 1 0"/></joint>
  <joint name="mount" type="fixed"><parent link="base"/><child link="e"/></joint>
  <joint name="follower2" type="revolute"><parent link="f"/><child link="g"/>
    <limit lower="-9" upper="9" effort="1" velocity="1"/>
    <mimic joint="follower" multiplier="-0.5" offset="0.3"/></joint>
  <joint name="follower" type="revolute"><parent link="e"/><child link="f"/>
    <limit lower="-9" upper="9" effort="1" velocity="1"/><mimic joint="shoulder" multiplier="2" offset="0.1"/></joint>
</robot>"""

ACTUATED = ("shoulder", "lifted", "sunk", "wheel")
KINDS = [kind.value for kind in TrajectoryKind]


@pytest.fixture(scope="module")
def toy() -> Robot:
    return parse_urdf(TOY_URDF)


def within_limits(robot: Robot, trajectory: JointTrajectory) -> bool:
    for i, joint in enumerate(robot.actuated_joints):
        lower, upper = joint_bounds(joint)
        if not ((trajectory.positions[:, i] >= lower) & (trajectory.positions[:, i] <= upper)).all():
            return False
    return True


def write(tmp_path: Path, text: str, name: str = "traj.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# Sampling ------------------------------------------------------------------------------------------

def test_samples_include_both_ends_at_integer_nanoseconds(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "center")
    assert trajectory.joint_names == ACTUATED
    assert trajectory.time_ns.dtype == np.int64
    np.testing.assert_array_equal(trajectory.time_ns, np.arange(501) * 20_000_000)
    assert trajectory.positions.shape == trajectory.velocities.shape == (501, 4)


@pytest.mark.parametrize(
    ("duration_s", "rate_hz", "expected"),
    [
        (1.0, 3.0, [0, 333_333_333, 666_666_667, 1_000_000_000]),
        (0.05, 50.0, [0, 20_000_000, 40_000_000]),
        (0.5, 1.0, [0]),
    ],
)
def test_sample_times_round_i_times_period(duration_s: float, rate_hz: float, expected: list[int]) -> None:
    np.testing.assert_array_equal(sample_times_ns(duration_s, rate_hz), expected)


def test_duration_that_is_not_exact_in_binary_keeps_its_last_sample() -> None:
    times = sample_times_ns(2.3, 100.0)  # 2.3 * 100 = 229.99999999999997
    assert len(times) == 231 and times[-1] == 2_300_000_000


# center ------------------------------------------------------------------------------------------

def test_center_is_zero_or_the_middle_of_limits_that_exclude_zero(toy: Robot) -> None:
    np.testing.assert_allclose(center_positions(toy), [0.0, 1.0, -0.15, 0.0], rtol=0, atol=1e-15)
    trajectory = make_trajectory(toy, "center", duration_s=1)
    np.testing.assert_array_equal(trajectory.positions, np.tile(center_positions(toy), (51, 1)))
    np.testing.assert_array_equal(trajectory.velocities, 0.0)


def test_overrides_set_center_values_like_zeros(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "center", duration_s=1, overrides={"lifted": 0.7, "wheel": 7.0})
    np.testing.assert_allclose(trajectory.positions[0], [0.0, 0.7, -0.15, 7.0], rtol=0, atol=1e-15)  # wheel: any value


@pytest.mark.parametrize("kind", ["random", "sine", "sweep"])
def test_overridden_joints_are_held_in_every_kind(toy: Robot, kind: str) -> None:
    trajectory = make_trajectory(toy, kind, duration_s=4, overrides={"shoulder": 1.25}, velocity_limits=False)
    np.testing.assert_array_equal(trajectory.positions[:, 0], 1.25)
    np.testing.assert_array_equal(trajectory.velocities[:, 0], 0.0)
    assert np.ptp(trajectory.positions[:, 1]) > 0


def test_override_of_unknown_joint_is_an_error(toy: Robot) -> None:
    with pytest.raises(TrajectoryError, match=r"^elbow=1.0: 'elbow' is not a joint of robot 'toy'$"):
        make_trajectory(toy, "center", overrides={"elbow": 1.0})


def test_override_beyond_limits_is_an_error(toy: Robot) -> None:
    with pytest.raises(TrajectoryError, match=r"^lifted=2.0: beyond the limits \[0.5, 1.5\] of joint 'lifted'$"):
        make_trajectory(toy, "sine", overrides={"lifted": 2.0})


def test_override_of_mimic_joint_is_an_error(toy: Robot) -> None:
    with pytest.raises(TrajectoryError, match="'follower' is a mimic joint; set 'shoulder' instead"):
        make_trajectory(toy, "center", overrides={"follower": 0.0})


def test_override_of_fixed_joint_is_an_error(toy: Robot) -> None:
    with pytest.raises(TrajectoryError, match="'mount' is a fixed joint, which has no position"):
        make_trajectory(toy, "center", overrides={"mount": 0.0})


def test_non_finite_override_is_an_error(toy: Robot) -> None:
    with pytest.raises(TrajectoryError, match="^wheel=nan: not a finite number$"):
        make_trajectory(toy, "center", overrides={"wheel": math.nan})


# random, sine, sweep -----------------------------------------------------------------------------

@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(KINDS),
    seed=st.integers(0, 2**31),
    duration_s=st.floats(0.01, 30.0),
    rate_hz=st.floats(1.0, 400.0),
    period_s=st.floats(0.05, 5.0),
    amplitude=st.floats(0.0, 1.0),
)
def test_positions_stay_within_limits(kind, seed, duration_s, rate_hz, period_s, amplitude) -> None:
    robot = parse_urdf(TOY_URDF)
    period_s = max(period_s, 1.0 / rate_hz)  # at least the sample interval
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TfrecWarning)  # a sweep the velocity limits cut short
        trajectory = make_trajectory(
            robot, kind, duration_s=duration_s, rate_hz=rate_hz, seed=seed, period_s=period_s, amplitude=amplitude
        )
    assert within_limits(robot, trajectory)
    assert np.isfinite(trajectory.velocities).all()
    assert trajectory.time_ns[0] == 0 and (np.diff(trajectory.time_ns) > 0).all()
    assert trajectory.time_ns[-1] <= round(duration_s * 1e9)


def test_same_seed_same_trajectory_and_longer_duration_extends_it(toy: Robot) -> None:
    first = make_trajectory(toy, "random", duration_s=6, seed=7)
    again = make_trajectory(toy, "random", duration_s=6, seed=7)
    longer = make_trajectory(toy, "random", duration_s=12, seed=7)
    other = make_trajectory(toy, "random", duration_s=6, seed=8)
    np.testing.assert_array_equal(first.positions, again.positions)
    np.testing.assert_array_equal(first.velocities, again.velocities)
    np.testing.assert_array_equal(longer.positions[: len(first)], first.positions)
    assert not np.array_equal(first.positions, other.positions)


def test_random_starts_at_center_and_rests_on_a_waypoint_every_period(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "random", duration_s=6, rate_hz=10, period_s=1.5, seed=3, velocity_limits=False)
    np.testing.assert_array_equal(trajectory.positions[0], center_positions(toy))
    at_waypoints = trajectory.velocities[::15]  # t = 0, 1.5, 3, 4.5, 6
    np.testing.assert_allclose(at_waypoints, 0.0, atol=1e-12)
    assert (np.ptp(trajectory.positions[:, :3], axis=0) > 0).all()
    for j, joint in enumerate(toy.actuated_joints):  # joint j's own stream, default_rng([seed, j])
        expected = np.random.default_rng([3, j]).uniform(*joint_bounds(joint), size=4)
        np.testing.assert_allclose(trajectory.positions[15::15, j], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_velocities_are_the_derivative_of_positions(toy: Robot, kind: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TfrecWarning)  # the sweep the velocity limits cut short
        trajectory = make_trajectory(toy, kind, duration_s=10, rate_hz=2000)
    numeric = np.gradient(trajectory.positions, trajectory.time_ns * 1e-9, axis=0)
    scale = max(np.abs(trajectory.velocities).max(), 1.0)
    np.testing.assert_allclose(trajectory.velocities[1:-1], numeric[1:-1], atol=2e-4 * scale)
    # continuous velocity: no jumps between neighbouring samples
    assert np.abs(np.diff(trajectory.velocities, axis=0)).max() < 0.05 * scale


def test_sine_reaches_amplitude_times_half_range_around_the_middle(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "sine", duration_s=40, rate_hz=200, amplitude=0.5)
    lower, upper = np.array([joint_bounds(j) for j in toy.actuated_joints]).T
    middle, half = (lower + upper) / 2, (upper - lower) / 2
    np.testing.assert_allclose(trajectory.positions.max(axis=0), middle + 0.5 * half, rtol=1e-4, atol=1e-9)
    np.testing.assert_allclose(trajectory.positions.min(axis=0), middle - 0.5 * half, rtol=1e-4, atol=1e-9)
    normalized = (trajectory.positions - middle) / half
    for i in range(4):
        for j in range(i + 1, 4):
            assert np.abs(normalized[:, i] - normalized[:, j]).max() > 0.1  # not in lockstep


def test_sine_joint_j_has_phase_and_period_from_the_golden_ratio_sequence(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "sine", duration_s=3, rate_hz=20, period_s=1.5, amplitude=0.5,
                                 velocity_limits=False)
    t = trajectory.time_ns * 1e-9
    for j, joint in enumerate(toy.actuated_joints):
        lower, upper = joint_bounds(joint)
        fraction = (j * (1 + math.sqrt(5)) / 2) % 1.0  # frac(j·φ): 0, 0.618…, 0.236…, 0.854…
        angle = 2 * math.pi * t / (2 * 1.5 * (1 + fraction)) + 2 * math.pi * fraction
        expected = (lower + upper) / 2 + 0.5 * (upper - lower) / 2 * np.sin(angle)
        np.testing.assert_allclose(trajectory.positions[:, j], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", ["center", "random", "sine"])
def test_appending_a_joint_leaves_the_others_motion_unchanged(toy: Robot, kind: str) -> None:
    extra = """<link name="h"/><joint name="extra" type="revolute"><parent link="g"/><child link="h"/>
      <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""
    bigger = parse_urdf(TOY_URDF.replace("</robot>", extra))
    assert [j.name for j in bigger.actuated_joints] == [*ACTUATED, "extra"]
    before = make_trajectory(toy, kind, duration_s=7, seed=5)
    after = make_trajectory(bigger, kind, duration_s=7, seed=5)
    np.testing.assert_array_equal(after.positions[:, :4], before.positions)
    np.testing.assert_array_equal(after.velocities[:, :4], before.velocities)
    assert np.ptp(after.positions[:, 4]) > 0 or kind == "center"


@pytest.mark.parametrize("kind", ["random", "sine"])
def test_panda_arm_moves_the_same_with_and_without_its_hand(corpus: Path, kind: str) -> None:
    path = corpus / "franka_description" / "robots" / "panda" / "panda.urdf.xacro"
    arm, with_hand = (load_description(path, args={"hand": hand}, package_paths=[corpus]) for hand in ("false", "true"))
    assert len(with_hand.actuated_joints) == len(arm.actuated_joints) + 1 == 8
    alone, handed = make_trajectory(arm, kind, duration_s=5), make_trajectory(with_hand, kind, duration_s=5)
    np.testing.assert_array_equal(handed.positions[:, :7], alone.positions)
    np.testing.assert_array_equal(handed.velocities[:, :7], alone.velocities)


def test_sine_with_full_amplitude_touches_but_never_passes_the_limits(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "sine", duration_s=60, rate_hz=500, amplitude=1.0)
    assert within_limits(toy, trajectory)
    assert np.isclose(trajectory.positions[:, 2].max(), -0.1, atol=1e-7)


def test_sweep_moves_one_joint_at_a_time_through_its_limits(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "sweep", duration_s=8, rate_hz=200, velocity_limits=False)
    center = center_positions(toy)
    moved = np.abs(trajectory.positions - center) > 1e-12
    assert moved.sum(axis=1).max() == 1
    np.testing.assert_array_equal(trajectory.positions[0], center)
    np.testing.assert_allclose(trajectory.positions[-1], center, atol=1e-12)
    for i, joint in enumerate(toy.actuated_joints):
        lower, upper = joint_bounds(joint)
        assert trajectory.positions[:, i].min() == lower
        assert trajectory.positions[:, i].max() == upper
        active = np.flatnonzero(moved[:, i])
        assert 2 * i * 200 <= active[0] and active[-1] <= 2 * (i + 1) * 200  # its own 2 s slot


@pytest.mark.parametrize("name", ["marm.xacro", "mbot.xacro"])
def test_kinds_stay_within_limits_on_the_repository_robots(name: str) -> None:
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*legacy macro calls")  # mbot uses them on purpose
        robot = load_description(Path(__file__).resolve().parents[2] / "robots" / name)
        warnings.simplefilter("ignore", TfrecWarning)  # the sweep the velocity limits cut short
        for kind in KINDS:
            trajectory = make_trajectory(robot, kind, duration_s=5, rate_hz=100)
            assert trajectory.joint_names == tuple(j.name for j in robot.actuated_joints)
            assert within_limits(robot, trajectory)


def test_robot_without_actuated_joints_gets_empty_columns() -> None:
    robot = parse_urdf('<robot name="cube"><link name="box"/></robot>')
    for kind in KINDS:
        trajectory = make_trajectory(robot, kind, duration_s=1, rate_hz=4)
        assert trajectory.positions.shape == (5, 0) and trajectory.joint_names == ()


# options -----------------------------------------------------------------------------------------

@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"duration_s": 0.0}, r"^duration 0.0 s is not a positive number$"),
        ({"duration_s": -1.0}, r"^duration -1.0 s is not a positive number$"),
        ({"duration_s": math.inf}, r"^duration inf s is not a positive number$"),
        ({"rate_hz": 0.0}, r"^rate 0.0 Hz is not a positive number$"),
        ({"period_s": -2.0}, r"^period -2.0 s is not a positive number$"),
        ({"amplitude": 1.5}, r"^amplitude 1.5 is not a fraction between 0 and 1$"),
        ({"seed": -1}, r"^seed -1 is not a non-negative integer$"),
        ({"duration_s": 1e6, "rate_hz": 1e3}, r"^duration 1e\+06 s at 1000 Hz gives more than 10,000,000 samples$"),
        ({"duration_s": 3600, "rate_hz": 1e9}, r"^duration 3600 s at 1e\+09 Hz gives more than 10,000,000 samples$"),
    ],
)
def test_bad_options_are_errors(toy: Robot, options: dict, message: str) -> None:
    with pytest.raises(TrajectoryError, match=message):
        make_trajectory(toy, "sine", **options)


@pytest.mark.parametrize("kind", ["random", "sine"])
def test_period_shorter_than_the_sample_interval_is_an_error(toy: Robot, kind: str) -> None:
    message = r"^period 1e-09 s is shorter than the sample interval 0.02 s of 50 Hz$"
    with pytest.raises(TrajectoryError, match=message):  # not millions of waypoints
        make_trajectory(toy, kind, period_s=1e-9)
    make_trajectory(toy, kind, duration_s=1, period_s=0.02)  # one interval is enough
    make_trajectory(toy, "sweep", rate_hz=0.25, period_s=2)  # kinds without a period ignore it


def test_period_error_is_one_line_from_the_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tfrec.cli import main

    out = tmp_path / "p.mcap"
    robot = str(Path(__file__).resolve().parents[2] / "robots" / "marm.xacro")
    assert main(["record", robot, "--traj", "random", "--period", "1e-9", "-o", str(out), "--no-rrd"]) == 2
    error = "tfrec: error: period 1e-09 s is shorter than the sample interval 0.02 s of 50 Hz\n"
    assert capsys.readouterr().err == error
    assert not out.exists()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"duration_s": 1e300}, r"^duration 1e\+300 s is out of range: ROS 2 stamps hold less than 2147483648 s$"),
        ({"duration_s": 2**31}, r"^duration 2147483648 s is out of range: ROS 2 stamps hold less than 2147483648 s$"),
        ({"duration_s": 3600, "rate_hz": 1e300}, r"^rate 1e\+300 Hz is more than one sample per nanosecond"),
        ({"duration_s": 5e-324, "rate_hz": 2e9}, r"^rate 2e\+09 Hz is more than one sample per nanosecond"),
    ],
)
def test_duration_and_rate_beyond_nanosecond_stamps_are_errors(toy: Robot, options: dict, message: str) -> None:
    with pytest.raises(TrajectoryError, match=message):
        make_trajectory(toy, "center", **options)


def test_tiny_rate_and_long_duration_still_sample() -> None:
    np.testing.assert_array_equal(sample_times_ns(10, 1e-300), [0])  # the next sample is beyond float64
    times = sample_times_ns(2**31 - 1, 1e-3)
    assert times[-1] == 2_147_483_000 * 10**9 and len(times) == 2_147_484  # every 1000 s


def test_unknown_kind_is_an_error(toy: Robot) -> None:
    message = r"^sinus: neither a trajectory kind \(center, random, sine, sweep\) nor a CSV file$"
    with pytest.raises(TrajectoryError, match=message):
        make_trajectory(toy, "sinus")


def test_missing_csv_file_is_an_error_naming_it(toy: Robot, tmp_path: Path) -> None:
    missing = tmp_path / "nope.csv"
    with pytest.raises(TrajectoryError, match=f"^{missing}: no such CSV file$"):
        make_trajectory(toy, str(missing))


# mimic joints ------------------------------------------------------------------------------------

def test_all_joint_states_adds_mimic_chains_in_document_order(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "sine", duration_s=2)
    names, positions, velocities = all_joint_states(toy, trajectory)
    assert names == ("shoulder", "lifted", "sunk", "wheel", "follower2", "follower")
    np.testing.assert_array_equal(positions[:, :4], trajectory.positions)
    shoulder, follower, follower2 = positions[:, 0], positions[:, 5], positions[:, 4]
    np.testing.assert_allclose(follower, 2 * shoulder + 0.1)
    np.testing.assert_allclose(follower2, -0.5 * follower + 0.3)
    np.testing.assert_allclose(velocities[:, 5], 2 * trajectory.velocities[:, 0])
    np.testing.assert_allclose(velocities[:, 4], -trajectory.velocities[:, 0])


def test_apply_mimic_can_fill_only_what_is_missing(toy: Robot) -> None:
    names = tuple(joint.name for joint in toy.moving_joints)  # ..., follower2, follower
    positions = np.full((3, len(names)), np.nan)
    positions[:, 0] = [0.0, 0.5, np.nan]  # shoulder, unknown in the last message
    positions[1, 5] = 7.0  # follower has a position of its own in the second message
    apply_mimic(toy, names, positions, only_missing=True)
    np.testing.assert_array_equal(positions[:, 5], [0.1, 7.0, np.nan])  # 2 · shoulder + 0.1 where missing
    np.testing.assert_array_equal(positions[:, 4], [-0.5 * 0.1 + 0.3, -0.5 * 7.0 + 0.3, np.nan])
    apply_mimic(toy, names, positions)  # all rows
    np.testing.assert_array_equal(positions[:, 5], [0.1, 1.1, np.nan])


def test_all_joint_states_works_on_chunks(toy: Robot) -> None:
    trajectory = make_trajectory(toy, "random", duration_s=3)
    whole = all_joint_states(toy, trajectory)[1]
    pieces = [all_joint_states(toy, chunk)[1] for chunk in trajectory.chunks(40)]
    assert [len(p) for p in pieces] == [40, 40, 40, 31]
    np.testing.assert_array_equal(np.concatenate(pieces), whole)


def test_trajectory_without_an_actuated_joint_is_an_error(toy: Robot) -> None:
    short = JointTrajectory(("shoulder",), np.zeros(1, np.int64), np.zeros((1, 1)), np.zeros((1, 1)))
    with pytest.raises(TrajectoryError, match="trajectory has no position for joint 'lifted' of robot 'toy'"):
        all_joint_states(toy, short)


def test_trajectory_with_a_foreign_joint_is_an_error(toy: Robot) -> None:
    names = (*ACTUATED, "elbow")
    extra = JointTrajectory(names, np.zeros(1, np.int64), np.zeros((1, 5)), np.zeros((1, 5)))
    with pytest.raises(TrajectoryError, match="trajectory joint 'elbow' is not an actuated joint of robot 'toy'"):
        all_joint_states(toy, extra)


def test_joint_trajectory_checks_its_arrays() -> None:
    with pytest.raises(ValueError, match="positions must be float64 of shape"):
        JointTrajectory(("a",), np.zeros(2, np.int64), np.zeros((2, 2)), np.zeros((2, 1)))


# CSV files ---------------------------------------------------------------------------------------

def test_csv_gives_samples_at_its_own_times(toy: Robot, tmp_path: Path) -> None:
    path = write(tmp_path, "\ufefftime, shoulder ,wheel\n0,0,0\n\n0.5,0.5,4\n1.25,1.0,-10\n")
    trajectory = make_trajectory(toy, str(path))
    np.testing.assert_array_equal(trajectory.time_ns, [0, 500_000_000, 1_250_000_000])
    np.testing.assert_array_equal(trajectory.positions[:, 0], [0, 0.5, 1.0])
    np.testing.assert_array_equal(trajectory.positions[:, 3], [0, 4, -10])  # continuous: beyond ±π
    np.testing.assert_allclose(trajectory.positions[:, 1:3], [[1.0, -0.15]] * 3, rtol=0, atol=1e-15)  # center
    np.testing.assert_allclose(trajectory.velocities[:, 0], np.gradient([0, 0.5, 1.0], [0, 0.5, 1.25]))
    np.testing.assert_array_equal(trajectory.velocities[:, 1:3], 0.0)


def test_csv_accepts_a_path_object_and_fills_missing_joints_from_overrides(toy: Robot, tmp_path: Path) -> None:
    path = write(tmp_path, "time,shoulder\n0.1,0\n")
    trajectory = make_trajectory(toy, path, overrides={"lifted": 0.6})
    np.testing.assert_array_equal(trajectory.time_ns, [100_000_000])
    np.testing.assert_allclose(trajectory.positions, [[0.0, 0.6, -0.15, 0.0]], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(trajectory.velocities, 0.0)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("time,elbow\n0,1\n", r"^traj.csv:1: column 'elbow' is not a joint of robot 'toy'$"),
        ("time,follower\n0,1\n", r"^traj.csv:1: column 'follower' is a mimic joint; give 'shoulder' instead$"),
        ("time,mount\n0,1\n", r"^traj.csv:1: column 'mount' is a fixed joint, which has no position$"),
        ("time,wheel,wheel\n0,1,1\n", r"^traj.csv:1: column 'wheel' appears twice$"),
        ("t,wheel\n0,1\n", r"^traj.csv:1: column 't' is not a joint of robot 'toy'$"),
        ("wheel\n0\n", r"^traj.csv:1: no 'time' column$"),
        ("time,shoulder\n0,0\n0.1,0\n0.2,0\n0.3,abc\n", r"^traj.csv:5: 'abc' in column 'shoulder' is not a number$"),
        ("time,shoulder\n0,0\n0.1,\n", r"^traj.csv:3: '' in column 'shoulder' is not a number$"),
        ("time,shoulder\n0,nan\n", r"^traj.csv:2: 'nan' in column 'shoulder' is not a finite number$"),
        ("time,shoulder\n0,1_0\n", r"^traj.csv:2: '1_0' in column 'shoulder' is not a number$"),
        ("time,shoulder\n0,0x10\n", r"^traj.csv:2: '0x10' in column 'shoulder' is not a number$"),
        ("time,shoulder\n0,\u0661\n", r"^traj.csv:2: '\u0661' in column 'shoulder' is not a number$"),
        ("time,shoulder\n0,1 0\n", r"^traj.csv:2: '1 0' in column 'shoulder' is not a number$"),
        ("time,shoulder\n0, -Infinity \n", r"^traj.csv:2: '-Infinity' in column 'shoulder' is not a finite number$"),
        ("time,shoulder\n0,inf\n", r"^traj.csv:2: 'inf' in column 'shoulder' is not a finite number$"),
        ("time,shoulder\n1e400,0\n", r"^traj.csv:2: '1e400' in column 'time' is not a finite number$"),
        ("time,shoulder\n0,0\n0.1\n", r"^traj.csv:3: 1 cells, expected 2 as in the header$"),
        ("time,shoulder\n0,0\n0.1,0\n\n0.3,0\n0.3,0\n", r"^traj.csv:6: time 0.3 does not increase \(previous 0.3\)$"),
        ("time,shoulder\n0,0\n0.3,0\n0.2,0\n", r"^traj.csv:4: time 0.2 does not increase \(previous 0.3\)$"),
        ("time,shoulder\n-0.1,0\n", r"^traj.csv:2: time -0.1 is negative$"),
        ("time,shoulder\n0,0\n1e12,0\n",
         r"^traj.csv:3: time 1000000000000.0 is out of range: ROS 2 stamps hold less than 2147483648 s$"),
        ("time,shoulder\n2147483647.9999999999,0\n",  # rounds to 2**31 s
         r"^traj.csv:2: time 2147483648.0 is out of range: ROS 2 stamps hold less than 2147483648 s$"),
        ("time,wheel\n0,0\n1e-9,1e300\n", r"^traj.csv:2: wheel changes too fast for a finite velocity$"),
        ("time,lifted\n0,1\n1,1.6\n", r"^traj.csv:3: lifted = 1.6 is beyond its limits \[0.5, 1.5\]$"),
        ("", r"^traj.csv: empty file, expected a header with 'time' and joint names$"),
        ("time,shoulder\n", r"^traj.csv: no samples after the header$"),
    ],
)
def test_csv_errors_name_file_and_line(toy: Robot, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                       text: str, message: str) -> None:
    write(tmp_path, text)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(TrajectoryError, match=message):
        make_trajectory(toy, "traj.csv")


def test_csv_numbers_are_plain_decimals_with_spaces_around_allowed(toy: Robot, tmp_path: Path) -> None:
    path = write(tmp_path, "time,shoulder\n  0 ,-.5\n+1.,1.5E-1\n2e0,\t1 \n")
    trajectory = make_trajectory(toy, str(path))
    np.testing.assert_array_equal(trajectory.time_ns, [0, 1_000_000_000, 2_000_000_000])
    np.testing.assert_array_equal(trajectory.positions[:, 0], [-0.5, 0.15, 1.0])


def test_csv_with_byte_order_mark_and_windows_line_endings(toy: Robot, tmp_path: Path) -> None:
    path = tmp_path / "traj.csv"
    path.write_bytes("\ufefftime,shoulder\r\n0,0\r\n\r\n0.5,0.25\r\n".encode())
    trajectory = make_trajectory(toy, str(path))
    assert trajectory.joint_names == ACTUATED
    np.testing.assert_array_equal(trajectory.time_ns, [0, 500_000_000])
    np.testing.assert_array_equal(trajectory.positions[:, 0], [0, 0.25])


def test_csv_with_one_row_is_one_sample_at_rest(toy: Robot, tmp_path: Path) -> None:
    path = write(tmp_path, "time,shoulder,wheel\n2.5,0.5,9\n")
    trajectory = make_trajectory(toy, str(path))
    np.testing.assert_array_equal(trajectory.time_ns, [2_500_000_000])
    np.testing.assert_allclose(trajectory.positions, [[0.5, 1.0, -0.15, 9.0]], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(trajectory.velocities, 0.0)


def test_csv_times_a_nanosecond_apart_far_from_zero_keep_finite_velocities(toy: Robot, tmp_path: Path) -> None:
    path = write(tmp_path, "time,shoulder\n100000,0\n100000.000000001,1e-9\n100000.000000002,2e-9\n")
    trajectory = make_trajectory(toy, str(path))
    assert np.diff(trajectory.time_ns).min() >= 1
    np.testing.assert_allclose(trajectory.velocities[:, 0], 1.0, rtol=0.1)


def test_csv_column_also_overridden_is_an_error(toy: Robot, tmp_path: Path) -> None:
    path = write(tmp_path, "time,shoulder\n0,0\n")
    with pytest.raises(TrajectoryError, match=r"traj.csv:1: column 'shoulder' is also set by an override$"):
        read_csv_trajectory(path, toy, overrides={"shoulder": 0.5})


def test_csv_that_is_not_text_is_an_error(toy: Robot, tmp_path: Path) -> None:
    path = tmp_path / "traj.csv"
    path.write_bytes(b"time,shoulder\n\xff\xfe\x00\n")
    with pytest.raises(TrajectoryError, match=r"traj.csv: cannot read CSV: "):
        read_csv_trajectory(path, toy)


def test_continuous_joint_type_is_exempt_from_csv_limits(toy: Robot, tmp_path: Path) -> None:
    assert toy.joint_by_name["wheel"].type is JointType.CONTINUOUS
    path = write(tmp_path, "time,wheel\n0,100\n")
    assert make_trajectory(toy, str(path)).positions[0, 3] == 100.0


# Lazy evaluation -----------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("size", [1, 7, 64, 10_000])
def test_generated_chunks_are_exactly_the_whole(toy: Robot, kind: str, size: int) -> None:
    """Each piece is evaluated on its own, from its times only, and gives the whole's values bit for bit."""
    def make() -> JointTrajectory:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TfrecWarning)  # the sweep the velocity limits cut short
            return make_trajectory(toy, kind, duration_s=7.3, rate_hz=37.0, period_s=0.9, overrides={"lifted": 1.2})

    lazy = make()
    pieces = list(lazy.chunks(size))
    whole = make()
    assert isinstance(lazy, GeneratedTrajectory)
    assert all(type(piece) is JointTrajectory for piece in pieces)
    assert [len(piece) for piece in pieces][:-1] == [size] * (len(pieces) - 1)
    assert np.array_equal(np.concatenate([p.time_ns for p in pieces]), whole.time_ns)
    for name in ("positions", "velocities"):
        joined = np.concatenate([getattr(p, name) for p in pieces])
        assert joined.tobytes() == getattr(whole, name).tobytes(), name
        assert getattr(whole, name).shape == (len(whole), len(ACTUATED))
    assert [p.positions.tobytes() for p in whole.chunks(size)] == [p.positions.tobytes() for p in pieces]


def test_recording_id_hashes_time_then_positions(toy: Robot) -> None:
    """The id streams the positions chunk by chunk, but hashes the same bytes as the whole arrays."""
    import hashlib
    import uuid

    from tfrec.recorder import recording_id

    trajectory = make_trajectory(toy, "random", duration_s=400.0, rate_hz=50.0)  # several chunks
    assert len(trajectory) > 2 * 8192
    digest = hashlib.sha256(toy.urdf.encode() + b"".join(n.encode() + b"\0" for n in trajectory.joint_names))
    digest.update(trajectory.time_ns.tobytes())
    digest.update(trajectory.positions.tobytes())
    digest.update(b"5|p/")
    expected = str(uuid.UUID(bytes=digest.digest()[:16], version=5))
    assert recording_id(toy, make_trajectory(toy, "random", duration_s=400.0, rate_hz=50.0),
                        start_time_ns=5, frame_prefix="p/") == expected
