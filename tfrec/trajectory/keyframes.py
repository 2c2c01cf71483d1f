"""CSV keyframes resampled onto a clock (``--traj file.csv --rate HZ --interp KIND``).

A CSV file written by hand or exported from a planner often holds keyframes at 1 Hz or less;
played at its own stamps it is a staircase. Resampled, its rows are keyframes and the samples
fall on the clock of :func:`~tfrec.trajectory.clock.sample_times_ns`, counted from the first
keyframe's time, up to the last keyframe:

- ``linear``: straight lines between keyframes; velocity constant on each segment.
- ``cubic``: a monotone piecewise cubic (Fritsch–Carlson, as scipy's ``PchipInterpolator``):
  velocity continuous, and a joint never overshoots its keyframes, so it stays within the
  limits its keyframes respect. At a keyframe where the motion turns, the velocity is 0.
- ``hold``: each keyframe held until the next (the file's steps, on the new clock); velocity 0.

Everything is vectorized over samples and joints.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import TrajectoryError
from tfrec.model import Robot
from tfrec.trajectory.clock import sample_times_ns
from tfrec.trajectory.joints import position_range
from tfrec.trajectory.types import JointTrajectory

__all__ = ["resample_keyframes"]

Array = NDArray[np.float64]


def resample_keyframes(keyframes: JointTrajectory, robot: Robot, *, rate_hz: float, interp: str = "linear") -> JointTrajectory:
    """Samples at ``rate_hz`` through ``keyframes`` (see the module docstring).

    Args:
        keyframes: the rows of a CSV file (:func:`~tfrec.trajectory.csv_file.read_csv_trajectory`).
        robot: the robot (its joint limits clip rounding at the ends).
        rate_hz: the sample rate.
        interp: ``linear``, ``cubic`` or ``hold``.

    Raises:
        TrajectoryError: an unknown ``interp``, or a clock :func:`sample_times_ns` refuses.
    """
    if interp not in ("linear", "cubic", "hold"):
        raise TrajectoryError(f"interpolation '{interp}' is not one of linear, cubic, hold")
    knots_ns = keyframes.time_ns
    first = int(knots_ns[0])
    offsets = sample_times_ns((int(knots_ns[-1]) - first) / 1e9, rate_hz)
    offsets = offsets[offsets <= int(knots_ns[-1]) - first]
    time_ns = offsets + first
    q = keyframes.positions
    if len(knots_ns) == 1:
        positions = np.broadcast_to(q[0], (len(time_ns), q.shape[1])).copy()
        return JointTrajectory(keyframes.joint_names, time_ns, positions, np.zeros_like(positions))
    t = (knots_ns - first) / 1e9  # seconds from the first keyframe: exact enough for the spans
    x = offsets / 1e9
    segment = np.clip(np.searchsorted(knots_ns, time_ns, side="right") - 1, 0, len(knots_ns) - 2)
    h = (t[segment + 1] - t[segment])[:, np.newaxis]
    s = ((x - t[segment])[:, np.newaxis]) / h
    q0, q1 = q[segment], q[segment + 1]
    if interp == "hold":
        positions = q0.copy()
        at_end = time_ns == knots_ns[-1]
        positions[at_end] = q[-1]
        velocities = np.zeros_like(positions)
    elif interp == "linear":
        slope = (q1 - q0) / h
        positions = q0 + slope * h * s
        velocities = slope
    else:
        d = _pchip_slopes(t, q)
        d0, d1 = d[segment], d[segment + 1]
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        positions = h00 * q0 + h10 * h * d0 + h01 * q1 + h11 * h * d1
        dh00, dh10, dh01, dh11 = 6 * s2 - 6 * s, 3 * s2 - 4 * s + 1, -6 * s2 + 6 * s, 3 * s2 - 2 * s
        velocities = (dh00 * q0 + dh01 * q1) / h + dh10 * d0 + dh11 * d1
    exact = np.searchsorted(knots_ns, time_ns)  # samples on a keyframe take it exactly
    on_knot = (exact < len(knots_ns)) & (knots_ns[np.minimum(exact, len(knots_ns) - 1)] == time_ns)
    positions[on_knot] = q[exact[on_knot]]
    if positions.shape[1]:
        bounds = np.array([position_range(joint) for joint in robot.actuated_joints]).reshape(-1, 2)
        np.clip(positions, bounds[:, 0], bounds[:, 1], out=positions)
    return JointTrajectory(keyframes.joint_names, time_ns, positions, np.ascontiguousarray(velocities))


def _pchip_slopes(t: Array, q: Array) -> Array:
    """Fritsch–Carlson slopes (K, J) of a monotone cubic through keyframes ``q`` (K, J) at times ``t`` (K,):
    the weighted harmonic mean of the neighbouring secants where they agree in sign, else 0; the ends
    by the three-point formula, kept monotone (as scipy's ``PchipInterpolator``)."""
    h = np.diff(t)[:, np.newaxis]
    delta = np.diff(q, axis=0) / h
    d = np.zeros_like(q)
    if len(t) == 2:
        d[:] = delta[0]
        return d
    w1 = 2 * h[1:] + h[:-1]
    w2 = h[1:] + 2 * h[:-1]
    same = (np.sign(delta[:-1]) * np.sign(delta[1:])) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        harmonic = (w1 + w2) / (w1 / delta[:-1] + w2 / delta[1:])
    d[1:-1] = np.where(same, harmonic, 0.0)
    d[0] = _end_slope(h[0], h[1], delta[0], delta[1])
    d[-1] = _end_slope(h[-1], h[-2], delta[-1], delta[-2])
    return d


def _end_slope(h0: Array, h1: Array, m0: Array, m1: Array) -> Array:
    slope = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
    slope = np.where(np.sign(slope) != np.sign(m0), 0.0, slope)
    return np.where((np.sign(m0) != np.sign(m1)) & (np.abs(slope) > np.abs(3 * m0)), 3 * m0, slope)
