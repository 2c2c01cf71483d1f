"""Joint trajectories: joint positions on a clock, as joint_state_publisher(_gui) makes them.

A :class:`JointTrajectory` holds the actuated joints of a robot (revolute, continuous and
prismatic joints that mimic nothing, in URDF document order) sampled at integer-nanosecond
times. :func:`make_trajectory` builds one from a kind name (``center``, ``random``, ``sine``,
``sweep``) or a CSV file (:mod:`tfrec.trajectory.csv_file`); :func:`all_joint_states` adds the
mimic joints (:func:`apply_mimic`, which replay uses too), giving every moving joint as
joint_state_publisher publishes it.

Sampling rule of the generated kinds: sample ``i`` is at ``time_ns[i] = round(i * 1e9 / rate_hz)``
for every ``i`` with ``time_ns[i] <= round(duration_s * 1e9)``, so both ends are included when
the duration is a whole number of periods (10 s at 50 Hz gives 501 samples). Positions and
velocities are evaluated at exactly those times. The generated kinds are
:class:`GeneratedTrajectory` objects: only the times are held, and each chunk is evaluated from
its own times when it is streamed, so memory stays flat whatever the duration.

In ``center``, ``random`` and ``sine`` a joint's motion depends only on its own index, bounds
and the options, never on the joints after it: appending a joint (a gripper to an arm) leaves the
others as they were. (``sweep`` shares the duration among the joints, so it cannot.)
"""

from __future__ import annotations

import math
import numbers
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import TfrecWarning, TrajectoryError
from tfrec.model import Robot
from tfrec.trajectory.clock import sample_times_ns
from tfrec.trajectory.joints import bounds_arrays, center_positions, pinned_columns, position_range
from tfrec.trajectory.joints import velocity_limits as joint_velocity_limits
from tfrec.trajectory.types import GeneratedTrajectory, JointTrajectory, Sampler, TrajectoryKind

__all__ = [
    "DEFAULT_DURATION_S",
    "DEFAULT_RATE_HZ",
    "INTERPOLATIONS",
    "center_trajectory",
    "make_trajectory",
    "random_trajectory",
    "sine_trajectory",
    "sweep_trajectory",
]

DEFAULT_DURATION_S = 10.0
"""The length of a generated trajectory unless ``duration_s`` says otherwise."""
DEFAULT_RATE_HZ = 50.0
"""The sample rate of a generated trajectory unless ``rate_hz`` says otherwise."""
INTERPOLATIONS = ("linear", "cubic", "hold")
"""How CSV keyframes are resampled onto a clock (``--interp``)."""



_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
"""frac(φ) of the golden ratio φ: ``frac(j·φ)`` spreads joints evenly, whatever their number."""


Array = NDArray[np.float64]


Floats = NDArray[np.floating[Any]]


def make_trajectory(  # noqa: PLR0913 - the keyword options of `tfrec record`'s trajectory
    robot: Robot,
    kind: str | os.PathLike[str],
    *,
    duration_s: float | None = None,
    rate_hz: float | None = None,
    seed: int = 0,
    period_s: float = 2.0,
    amplitude: float = 0.8,
    overrides: Mapping[str, float] = {},
    soft_limits: bool = True,
    interp: str = "linear",
    velocity_limits: bool = True,
) -> JointTrajectory:
    """Make the trajectory ``--traj KIND`` asks for.

    Args:
        robot: the robot whose actuated joints move.
        kind: a :class:`TrajectoryKind` name, or else the path of a CSV file (a file
            named like a kind is reached as ``./sine``).
        duration_s, rate_hz: length (default 10 s) and sample rate (default 50 Hz) of the
            generated kinds. A CSV file keeps its own stamps, unless ``rate_hz`` is given: its
            rows are then keyframes, resampled onto that clock (``interp``); ``duration_s`` does
            not apply to it.
        seed: seed of ``random`` (same seed, same trajectory).
        period_s: time between the waypoints of ``random``; sets the periods of ``sine``.
            At least the sample interval ``1 / rate_hz`` for those two kinds.
        amplitude: fraction of each joint's half-range that ``sine`` uses, in [0, 1].
        overrides: joint name → position, held constant (``--set``). In ``center`` this is
            joint_state_publisher's ``zeros`` parameter; in a CSV file it gives joints
            without a column.
        soft_limits: narrow each joint's range to its ``<safety_controller>`` soft limits, as
            joint_state_publisher does by default (``use_smallest_joint_limits``); False uses the
            hard limits.
        interp: how CSV keyframes are resampled onto ``rate_hz``: ``linear``, ``cubic`` (monotone
            cubic: continuous velocity, no overshoot between keyframes) or ``hold`` (steps).
        velocity_limits: ``random``, ``sine`` and ``sweep`` move no joint faster than its ``<limit
            velocity>`` (see each); False: as fast as their periods and duration make them (what ``tfrec diff``
            drives two descriptions along, so that both follow the same motion). A CSV file is as it is.

    Raises:
        TrajectoryError: an option is out of range (the duration reaches past what ROS 2
            stamps hold, the samples would be more than :data:`MAX_SAMPLES`, the period is
            shorter than the sample interval), an override is unknown or beyond its joint's
            limits, or the CSV file is missing or malformed.
    """
    duration = DEFAULT_DURATION_S if duration_s is None else duration_s
    rate = DEFAULT_RATE_HZ if rate_hz is None else rate_hz
    if not (isinstance(duration, numbers.Real) and math.isfinite(duration) and duration > 0):
        raise TrajectoryError(f"duration {duration!r} s is not a positive number")
    if not (isinstance(rate, numbers.Real) and math.isfinite(rate) and rate > 0):
        raise TrajectoryError(f"rate {rate!r} Hz is not a positive number")
    if not (isinstance(period_s, numbers.Real) and math.isfinite(period_s) and period_s > 0):
        raise TrajectoryError(f"period {period_s!r} s is not a positive number")
    if not (isinstance(amplitude, numbers.Real) and 0.0 <= amplitude <= 1.0):
        raise TrajectoryError(f"amplitude {amplitude!r} is not a fraction between 0 and 1")
    if not (isinstance(seed, numbers.Integral) and not isinstance(seed, bool) and seed >= 0):
        raise TrajectoryError(f"seed {seed!r} is not a non-negative integer")
    if interp not in INTERPOLATIONS:
        raise TrajectoryError(f"interpolation '{interp}' is not one of {', '.join(INTERPOLATIONS)}")
    if isinstance(kind, str) and kind in TrajectoryKind._value2member_map_:
        which = TrajectoryKind(kind)
        if which in (TrajectoryKind.RANDOM, TrajectoryKind.SINE) and period_s * rate < 1.0 - 1e-12:
            raise TrajectoryError(
                f"period {period_s!r} s is shorter than the sample interval {1.0 / rate:g} s of {rate:g} Hz"
            )
        if which is TrajectoryKind.CENTER:
            return center_trajectory(robot, duration_s=duration, rate_hz=rate, overrides=overrides,
                                     soft_limits=soft_limits)
        if which is TrajectoryKind.RANDOM:
            return random_trajectory(robot, duration_s=duration, rate_hz=rate, seed=seed, period_s=period_s,
                                     overrides=overrides, soft_limits=soft_limits, velocity_limits=velocity_limits)
        if which is TrajectoryKind.SINE:
            return sine_trajectory(robot, duration_s=duration, rate_hz=rate, period_s=period_s, amplitude=amplitude,
                                   overrides=overrides, soft_limits=soft_limits, velocity_limits=velocity_limits)
        return sweep_trajectory(robot, duration_s=duration, rate_hz=rate, overrides=overrides,
                                soft_limits=soft_limits, velocity_limits=velocity_limits)
    path = Path(kind)
    if not path.exists():
        text = os.fspath(kind)
        if isinstance(kind, str) and os.sep not in text and "." not in text:
            names = ", ".join(k.value for k in TrajectoryKind)
            raise TrajectoryError(f"{text}: neither a trajectory kind ({names}) nor a CSV file")
        raise TrajectoryError(f"{text}: no such CSV file")
    from tfrec.trajectory.csv_file import read_csv_trajectory
    from tfrec.trajectory.keyframes import resample_keyframes

    keyframes = read_csv_trajectory(path, robot, overrides=overrides, soft_limits=soft_limits)
    if rate_hz is None:
        return keyframes
    return resample_keyframes(keyframes, robot, rate_hz=rate, interp=interp)


def center_trajectory(
    robot: Robot,
    *,
    duration_s: float = 10.0,
    rate_hz: float = 50.0,
    overrides: Mapping[str, float] = {},
    soft_limits: bool = True,
) -> JointTrajectory:
    """Every actuated joint held at its center (:func:`center_positions`)."""
    center = center_positions(robot, overrides=overrides, soft_limits=soft_limits)
    time_ns = sample_times_ns(duration_s, rate_hz)

    def sample(times: NDArray[np.int64]) -> tuple[Array, Array]:
        positions = np.broadcast_to(center, (len(times), len(center))).copy()
        return positions, np.zeros_like(positions)

    return _trajectory(robot, time_ns, sample)


def random_trajectory(
    robot: Robot,
    *,
    duration_s: float = 10.0,
    rate_hz: float = 50.0,
    seed: int = 0,
    period_s: float = 2.0,
    overrides: Mapping[str, float] = {},
    soft_limits: bool = True,
    velocity_limits: bool = True,
) -> JointTrajectory:
    """The Randomize button pressed every ``period_s`` seconds, with smooth motion between.

    Waypoint 0 (t = 0) is the center; waypoint k (t = k·period) is uniform within each
    joint's bounds (:func:`joint_bounds`). Joint j draws its waypoints in order from its own
    stream, ``numpy.random.default_rng([seed, j])``, so a longer duration extends the same
    trajectory and adding a joint leaves the others' waypoints as they were. Between waypoints
    each joint follows a minimum-jerk (quintic) segment: continuous velocity, at rest on every
    waypoint, never beyond either end. (joint_state_publisher's own Randomize is a jump: the joints
    are at the new positions in the next message.)

    With ``velocity_limits`` a segment lasts at least what the joint's ``<limit velocity>`` needs
    (a minimum-jerk segment peaks at 15/8 of its mean speed): a joint heads for its next waypoint
    when it has reached the last one, at ``period_s`` at the earliest, so it never moves faster
    than its limit.
    """
    pinned = pinned_columns(robot, overrides)
    center = center_positions(robot, overrides=overrides, soft_limits=soft_limits)
    lower, upper = bounds_arrays(robot, soft_limits=soft_limits)
    time_ns = sample_times_ns(duration_s, rate_hz)
    count = math.ceil(duration_s / period_s) + 1
    waypoints = np.empty((count, len(center)))
    waypoints[0] = center
    for j in range(len(center)):
        if j in pinned:
            waypoints[:, j] = pinned[j]
        else:
            rng = np.random.default_rng([seed, j])
            if math.isfinite(float(upper[j]) - float(lower[j])):
                waypoints[1:, j] = rng.uniform(lower[j], upper[j], size=count - 1)
            else:  # a range wider than float64 (limits of ±1.8e308 for "unlimited"): in halves
                middle, half = lower[j] / 2.0 + upper[j] / 2.0, upper[j] / 2.0 - lower[j] / 2.0
                waypoints[1:, j] = middle + half * rng.uniform(-1.0, 1.0, size=count - 1)
    knot_s = np.arange(count) * period_s
    limits = joint_velocity_limits(robot) if velocity_limits else np.full(len(center), np.inf)
    with np.errstate(over="ignore", invalid="ignore"):
        needed = _MIN_JERK_PEAK * np.abs(np.diff(waypoints, axis=0)) / limits * (1.0 + _VELOCITY_MARGIN)
    slow = [j for j in range(len(center)) if j not in pinned and bool((needed[:, j] > period_s).any())]
    own_knots = {j: np.concatenate([[0.0], np.cumsum(np.maximum(needed[:, j], period_s))]) for j in slow}

    def sample(times: NDArray[np.int64]) -> tuple[Array, Array]:
        positions, velocities = _min_jerk(times * 1e-9, knot_s, waypoints)
        for j, knots in own_knots.items():  # joints whose velocity limit stretches their segments
            pos, vel = _min_jerk(times * 1e-9, knots, waypoints[:, j : j + 1])
            positions[:, j], velocities[:, j] = pos[:, 0], vel[:, 0]
        return positions, velocities

    return _trajectory(robot, time_ns, sample)


def sine_trajectory(
    robot: Robot,
    *,
    duration_s: float = 10.0,
    rate_hz: float = 50.0,
    period_s: float = 2.0,
    amplitude: float = 0.8,
    overrides: Mapping[str, float] = {},
    soft_limits: bool = True,
    velocity_limits: bool = True,
) -> JointTrajectory:
    """Every joint oscillates about the middle of its bounds.

    Joint j (actuated order, from 0) follows ``mid + a·sin(2π t / T_j + 2π f_j)`` with
    ``a = amplitude · half-range`` (continuous joints: ``amplitude · π``),
    ``T_j = 2·period_s·(1 + f_j)`` and ``f_j = frac(j·φ)``, φ the golden ratio: no two joints
    share a period and phase, and a joint's motion does not depend on how many joints follow it.
    With ``velocity_limits`` a joint whose peak speed ``a·2π/T_j`` would exceed its ``<limit velocity>``
    oscillates with the longer period that reaches it exactly.
    """
    pinned = pinned_columns(robot, overrides)
    lower, upper = bounds_arrays(robot, soft_limits=soft_limits)
    time_ns = sample_times_ns(duration_s, rate_hz)
    fraction = np.mod(np.arange(len(lower)) * _GOLDEN, 1.0)
    omega = 2.0 * np.pi / (2.0 * period_s * (1.0 + fraction))
    phase = 2.0 * np.pi * fraction
    with np.errstate(over="ignore"):  # a range wider than float64 (limits of ±1.8e308): taken in halves
        middle = np.where(np.isfinite(lower + upper), (lower + upper) / 2.0, lower / 2.0 + upper / 2.0)
        reach = np.where(np.isfinite(upper - lower), amplitude * (upper - lower) / 2.0,
                         amplitude * (upper / 2.0 - lower / 2.0))
        if velocity_limits:  # the longer period whose peak speed reach·ω is the limit
            limits = joint_velocity_limits(robot)
            omega = np.where(reach * omega > limits, limits / np.where(reach > 0, reach, 1.0), omega)

    def sample(times: NDArray[np.int64]) -> tuple[Array, Array]:
        angle = np.outer(times * 1e-9, omega) + phase
        positions = middle + reach * np.sin(angle)
        velocities = reach * omega * np.cos(angle)
        for i, value in pinned.items():
            positions[:, i] = value
            velocities[:, i] = 0.0
        return positions, velocities

    return _trajectory(robot, time_ns, sample)


def sweep_trajectory(
    robot: Robot,
    *,
    duration_s: float = 10.0,
    rate_hz: float = 50.0,
    overrides: Mapping[str, float] = {},
    soft_limits: bool = True,
    velocity_limits: bool = True,
) -> JointTrajectory:
    """One joint at a time goes center → lower → upper → center; the others stay at center.

    Each joint that is not overridden gets an equal slot of the duration, in actuated order;
    within its slot the three moves take time in proportion to their lengths, each a
    minimum-jerk segment (at rest at center and at both limits). The turning points are moved
    to the nearest sample, so the limits themselves are among the positions. With
    ``velocity_limits`` a joint's slot is as long as its ``<limit velocity>`` needs at least; the joints
    whose sweep then ends after the duration are not swept (or not to the end), with a warning saying
    what duration sweeps them all.
    """
    pinned = pinned_columns(robot, overrides)
    center = center_positions(robot, overrides=overrides, soft_limits=soft_limits)
    lower, upper = bounds_arrays(robot, soft_limits=soft_limits)
    time_ns = sample_times_ns(duration_s, rate_hz)
    swept = [i for i in range(len(center)) if i not in pinned]
    slot = duration_s / max(len(swept), 1)
    limits = joint_velocity_limits(robot) if velocity_limits else np.full(len(center), np.inf)
    segments: list[tuple[int, Floats, Floats]] = []  # (column, knot times, knot positions (K, 1))
    start, cut = 0.0, []
    for i in swept:
        values = np.array([center[i], lower[i], upper[i], center[i]])
        lengths = np.abs(np.diff(values / 8.0))  # in proportion only; eighths: limits of ±1.8e308 do not overflow
        if lengths.sum() == 0.0:
            start += slot
            continue
        length = slot
        for _ in range(64):  # longer until no snapped segment is faster than the velocity limit
            knot_s, knot_q = _sweep_knots(start, length, values, lengths, rate_hz, duration_s, len(time_ns) - 1)
            with np.errstate(over="ignore", invalid="ignore"):  # limits of ±1.8e308: refused in _trajectory
                speed = _MIN_JERK_PEAK * np.abs(np.diff(knot_q[:, 0])) / np.diff(knot_s)
                worst = float(np.nanmax(speed / limits[i], initial=0.0))
            if worst <= 1.0 or not math.isfinite(worst):
                break
            length = length * worst * (1.0 + _VELOCITY_MARGIN) + 2.0 / rate_hz
        segments.append((i, knot_s, knot_q))
        start += length
        if start > duration_s * (1.0 + 1e-12) + 0.5 / rate_hz:
            cut.append(robot.actuated_joints[i].name)
    if cut:
        warnings.warn(f"sweep: within their velocity limits the joints need {start:.6g} s; in {duration_s:g} s "
                      f"{', '.join(cut)} {'is' if len(cut) == 1 else 'are'} not swept to the end (give a duration of "
                      f"{math.ceil(start)} s, or ignore the velocity limits)", TfrecWarning, stacklevel=3)

    def sample(times: NDArray[np.int64]) -> tuple[Array, Array]:
        t = times * 1e-9
        positions = np.broadcast_to(center, (len(t), len(center))).copy()
        velocities = np.zeros_like(positions)
        for i, knots, knot_q in segments:
            pos, vel = _min_jerk(t, knots, knot_q)
            positions[:, i] = pos[:, 0]
            velocities[:, i] = vel[:, 0]
        return positions, velocities

    return _trajectory(robot, time_ns, sample)


_MIN_JERK_PEAK = 1.875
"""A minimum-jerk segment's peak speed over its mean speed (15/8)."""
_VELOCITY_MARGIN = 1e-6
"""Segments are this fraction longer than a velocity limit needs: rounding keeps them within it."""


def _sweep_knots(start: float, slot: float, values: Array, lengths: Array, rate_hz: float,
                 duration_s: float, last: int) -> tuple[Array, Array]:
    """One joint's sweep in ``[start, start + slot]``: knot times on samples (so that the limits are among the
    positions; past the duration too, where the sweep does not fit) and positions (K, 1), empty segments left out."""
    fraction = np.cumsum(np.r_[0.0, lengths]) / lengths.sum()  # before `slot`: lengths near 1e308 do not overflow
    knot_s = np.concatenate([[0.0], start + slot * fraction, [max(duration_s, start + slot)]])
    on_sample = np.clip(np.rint(knot_s * rate_hz), 0.0, last if start + slot <= duration_s else None)
    knot_s = np.rint(on_sample * 1e9 / rate_hz).astype(np.int64) * 1e-9  # the sample times' rule (clock.py)
    knot_q = np.concatenate([[values[0]], values, [values[0]]])
    keep = np.diff(knot_s, prepend=-np.inf) > 0.0  # drop empty segments (zero length or less than a sample)
    times: Array = knot_s[keep].astype(np.float64)
    return times, knot_q[keep, np.newaxis].astype(np.float64)


def _min_jerk(t: Floats, knot_s: Floats, knot_q: Floats) -> tuple[Array, Array]:
    """Positions and velocities at times ``t`` of a path through waypoints.

    Args:
        t: (N,) seconds.
        knot_s: (K,) strictly increasing waypoint times, K >= 2; times outside hold the ends.
        knot_q: (K, J) waypoints.

    Each segment is the minimum-jerk blend ``s(τ) = 10τ³ − 15τ⁴ + 6τ⁵``: it starts and ends
    at rest and stays between its two waypoints. Every waypoint is reached exactly.
    """
    if len(knot_s) < 2:
        return np.broadcast_to(knot_q[0], (len(t), knot_q.shape[1])).copy(), np.zeros((len(t), knot_q.shape[1]))
    k = np.clip(np.searchsorted(knot_s, t, side="right") - 1, 0, len(knot_s) - 2)
    span = knot_s[k + 1] - knot_s[k]
    tau = np.clip((t - knot_s[k]) / span, 0.0, 1.0)
    blend = tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau))
    rate = 30.0 * tau**2 * (1.0 - tau) ** 2 / span
    start = knot_q[k]
    delta = knot_q[k + 1] - start
    positions = start + delta * blend[:, np.newaxis]
    positions[t >= knot_s[-1]] = knot_q[-1]  # exactly, as the next segment would start: a longer path extends this one
    return positions, delta * rate[:, np.newaxis]


def _trajectory(robot: Robot, time_ns: NDArray[np.int64], sample: Sampler) -> GeneratedTrajectory:
    """A lazy trajectory of ``sample``, whose positions are clipped of rounding overshoot (a few ulps) at the limits."""
    lower, upper = np.array([position_range(joint) for joint in robot.actuated_joints]).reshape(-1, 2).T

    def clipped(times: NDArray[np.int64]) -> tuple[Array, Array]:
        with np.errstate(over="ignore", invalid="ignore"):  # refused below
            positions, velocities = sample(times)
        if positions.shape[1]:
            np.clip(positions, lower, upper, out=positions)
        bad = np.argwhere(~(np.isfinite(positions) & np.isfinite(velocities)))
        if bad.size:  # limits so far apart that moving between them takes a speed past float64
            j = int(bad[0][1])
            raise TrajectoryError(f"joint '{robot.actuated_joints[j].name}': its limits [{float(lower[j])!r}, "
                                  f"{float(upper[j])!r}] are too far apart to move between in float64; hold it still "
                                  "with `overrides`")
        return positions, velocities

    return GeneratedTrajectory(tuple(joint.name for joint in robot.actuated_joints), time_ns, clipped)
