"""Generated trajectories move no joint faster than its <limit velocity> (random, sine, sweep), unless asked to;
joint_state_publisher's Randomize is a jump, tfrec's random interpolates."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from tfrec.description import parse_urdf
from tfrec.errors import TfrecWarning
from tfrec.model import Robot
from tfrec.trajectory.generators import make_trajectory

SLOW = """<robot name="slow">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
  <joint name="big" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="0.5"/></joint>
  <joint name="fast" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="100"/></joint>
  <joint name="slide" type="prismatic"><parent link="b"/><child link="c"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.5" effort="1" velocity="0.05"/></joint>
  <joint name="free" type="revolute"><parent link="c"/><child link="d"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="0"/></joint>
</robot>"""
LIMITS = np.array([0.5, 100.0, 0.05, np.inf])


@pytest.fixture(scope="module")
def slow() -> Robot:
    return parse_urdf(SLOW)


def _speeds(trajectory) -> np.ndarray:
    """The largest speed of each joint between consecutive samples, and of the analytic velocities."""
    dt = np.diff(trajectory.time_ns) * 1e-9
    steps = np.abs(np.diff(trajectory.positions, axis=0)) / dt[:, None]
    return np.maximum(steps.max(axis=0), np.abs(trajectory.velocities).max(axis=0))


@pytest.mark.parametrize("kind", ["random", "sine"])
@pytest.mark.parametrize("rate_hz", [10.0, 50.0, 333.0])
def test_generated_kinds_respect_velocity_limits(slow: Robot, kind: str, rate_hz: float) -> None:
    trajectory = make_trajectory(slow, kind, duration_s=40, rate_hz=rate_hz, seed=3, period_s=1.0)
    assert (_speeds(trajectory) <= LIMITS * (1 + 1e-6)).all(), _speeds(trajectory)
    unlimited = make_trajectory(slow, kind, duration_s=40, rate_hz=rate_hz, seed=3, period_s=1.0,
                                velocity_limits=False)
    assert (_speeds(unlimited)[[0, 2]] > LIMITS[[0, 2]] * 2).all()  # what the limits prevent
    # a joint the limit does not bind moves as before; the joint without limit too
    np.testing.assert_array_equal(trajectory.positions[:, [1, 3]], unlimited.positions[:, [1, 3]])


def test_random_visits_each_waypoint_later_not_nearer(slow: Robot) -> None:
    """The limited random trajectory reaches the same random targets, one after the other, in more time."""
    limited = make_trajectory(slow, "random", duration_s=200, rate_hz=20, seed=5, period_s=1.0)
    free = make_trajectory(slow, "random", duration_s=200, rate_hz=20, seed=5, period_s=1.0, velocity_limits=False)
    targets = free.positions[::20, 0][:6]
    for target in targets[1:]:  # each target is reached (at rest there: within a sample, nearly exactly)
        assert np.abs(limited.positions[:, 0] - target).min() < 1e-3
    assert (np.ptp(limited.positions, axis=0)[[0, 2]] > 0.5 * np.ptp(free.positions, axis=0)[[0, 2]]).all()


def test_sweep_takes_the_time_the_limits_need_and_says_what_it_leaves_out(slow: Robot) -> None:
    with pytest.warns(TfrecWarning, match=r"^sweep: within their velocity limits the joints need [\d.]+ s; in 10 s "
                                          r"big, fast, slide, free are not swept to the end \(give a duration of (\d+) s"):
        short = make_trajectory(slow, "sweep", duration_s=10, rate_hz=50)
    assert (_speeds(short) <= LIMITS * (1 + 1e-6)).all()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        whole = make_trajectory(slow, "sweep", duration_s=200, rate_hz=50)
    assert (_speeds(whole) <= LIMITS * (1 + 1e-6)).all()
    for j, (lower, upper) in enumerate([(-3, 3), (-1, 1), (0, 0.5), (-1, 1)]):  # every limit reached
        assert whole.positions[:, j].min() == lower and whole.positions[:, j].max() == upper
