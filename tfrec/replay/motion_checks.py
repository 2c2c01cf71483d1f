"""What a robot could not have done: joint motion checked against the description's limits.

:class:`MotionChecker` is fed joint-state batches (:meth:`~MotionChecker.feed`: names, stamps, positions) in
time order — the whole recording at once, or batch by batch as a streaming reader yields them; it keeps only
the last sample of each joint and a few numbers per finding, so memory does not grow with the recording —
and gives its findings at the end (:meth:`~MotionChecker.findings`). Each finding names the joint, the worst
value, the limit and the stamp of the first sample concerned:

- ``limit``: a position outside the joint's hard ``<limit lower upper>`` (revolute, prismatic);
- ``soft_limit``: within the hard limits but outside the ``<safety_controller>`` soft limits;
- ``velocity``: a speed between consecutive samples over the ``<limit velocity>`` (0 or none: no limit);
- ``acceleration``: a change of speed over ``max_accel`` (when given; URDF has no acceleration limit);
- ``jump``: one step that would need more than :data:`JUMP_FACTOR` times the velocity limit — a teleport, such
  as joint_state_publisher's Randomize button makes — or, for a joint without velocity limit, a step over
  :data:`JUMP_RAD` rad (revolute, continuous) or :data:`JUMP_M` m (prismatic);
- ``nonfinite``: an infinite position, or a NaN one in a message that names the joint (a message that leaves the
  joint out has no position for it: rows of the same messages that give it tell the two apart);
- ``mimic``: a mimic joint whose recorded position is not ``multiplier · master + offset``.

A continuous joint's steps are taken modulo 2π (a position wrapped from π to −π is no jump).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S
from tfrec.model import Joint, JointType, Robot

__all__ = ["JUMP_FACTOR", "JUMP_M", "JUMP_RAD", "MotionChecker", "MotionFinding"]

Array = NDArray[np.float64]

LIMIT_TOL = 1e-6
"""Positions within this (rad or m) beyond a limit are on it (rounding of a driver, float32)."""
VELOCITY_TOL = 0.01
"""A speed within this fraction above the velocity limit is within it (stamps are rounded to ns)."""
MIMIC_TOL = 1e-6
"""A mimic joint within this (rad or m, scaled by the size of the value) of ``multiplier · master + offset`` follows it."""
JUMP_FACTOR = 10.0
"""A step that would need more than this many times the velocity limit is a jump."""
JUMP_RAD = 0.5
"""A step of a joint without velocity limit beyond this many radians is a jump."""
JUMP_M = 0.05
"""A step of a prismatic joint without velocity limit beyond this many metres is a jump."""


@dataclass(frozen=True, slots=True)
class MotionFinding:
    """One thing a joint could not have done.

    Attributes:
        check: ``limit``, ``soft_limit``, ``velocity``, ``acceleration``, ``jump``, ``nonfinite`` or ``mimic``.
        joint: the joint.
        value: the worst value (a position, a speed, an acceleration, a step, a mimic's deviation; for
            ``nonfinite`` the value itself, NaN or ±inf).
        limit: the limit it crossed (the nearer bound for positions; NaN for ``nonfinite``).
        unit: ``rad``, ``m``, ``rad/s``, ``m/s``, ``rad/s²``, ``m/s²``.
        first_ns: the stamp of the first sample concerned.
        count: the samples (or steps) concerned.
    """

    check: str
    joint: str
    value: float
    limit: float
    unit: str
    first_ns: int
    count: int

    def detail(self, origin_ns: int = 0) -> str:
        """One line, with the first time in seconds since ``origin_ns``."""
        when = f"first at t={(self.first_ns - origin_ns) / NS_PER_S:.3f} s ({self.count} sample{'s' if self.count != 1 else ''})"
        what = {
            "limit": f"position {self.value:.6g} {self.unit} beyond its limit {self.limit:.6g} {self.unit}",
            "soft_limit": f"position {self.value:.6g} {self.unit} beyond its soft limit {self.limit:.6g} {self.unit} "
                          "(<safety_controller>)",
            "velocity": f"speed {self.value:.6g} {self.unit} over its velocity limit {self.limit:.6g} {self.unit}",
            "acceleration": f"acceleration {self.value:.6g} {self.unit} over the limit {self.limit:.6g} {self.unit}",
            "jump": f"jumps {self.value:.6g} {self.unit} in one step (more than {self.limit:.6g} {self.unit})",
            "nonfinite": f"position {self.value} (not a finite number)",
            "mimic": f"differs by {self.value:.6g} {self.unit} from what its master gives (mimic)",
        }[self.check]
        return f"joint '{self.joint}': {what}, {when}"


@dataclass
class _Tally:
    first_ns: int
    value: float
    limit: float
    count: int = 0


@dataclass
class _Joint:
    """One checked joint: its limits, and its last sample (and speed) from the batches before."""

    joint: Joint
    lower: float = -math.inf
    upper: float = math.inf
    soft_lower: float = -math.inf
    soft_upper: float = math.inf
    velocity: float = 0.0
    last_ns: int | None = None
    last_position: float = math.nan
    last_speed: float | None = None
    last_dt: float = 0.0
    tallies: dict[str, _Tally] = field(default_factory=dict)

    @property
    def unit(self) -> str:
        return "m" if self.joint.type is JointType.PRISMATIC else "rad"


def _joint_state(joint: Joint) -> _Joint:
    state = _Joint(joint)
    if joint.limit is not None:
        if joint.type is not JointType.CONTINUOUS:
            state.lower, state.upper = joint.limit.lower, joint.limit.upper
        if math.isfinite(joint.limit.velocity) and joint.limit.velocity > 0:
            state.velocity = joint.limit.velocity
    safety = joint.safety
    if safety is not None and joint.type is not JointType.CONTINUOUS:
        state.soft_lower = state.lower if safety.soft_lower_limit is None else max(state.lower, safety.soft_lower_limit)
        state.soft_upper = state.upper if safety.soft_upper_limit is None else min(state.upper, safety.soft_upper_limit)
        if state.soft_lower > state.soft_upper:  # soft limits that leave no range are not used (joint_bounds' rule)
            state.soft_lower, state.soft_upper = state.lower, state.upper
    return state


class MotionChecker:
    """Joint motion checked against a robot's limits, batch by batch (see the module's docstring).

    Args:
        robot: the description whose limits apply.
        max_accel: the largest acceleration (rad/s² or m/s²) any joint may have; None: not checked.
    """

    def __init__(self, robot: Robot, *, max_accel: float | None = None) -> None:
        self._robot = robot
        self._max_accel = max_accel
        self._joints = {joint.name: _joint_state(joint) for joint in robot.moving_joints}
        self._signatures: set[bytes] = set()  # which joints messages give together (finite positions)
        self._nan: dict[tuple[bytes, str], _Tally] = {}  # a NaN position where a message with that joint would be

    def feed(self, names: Sequence[str], time_ns: NDArray[np.int64], positions: Array) -> None:
        """Check N more joint states, later than those fed before.

        Args:
            names: the J joints of the columns (names the robot does not have are ignored).
            time_ns: int64 (N,) stamps, non-decreasing.
            positions: float64 (N, J); NaN where a message has no position for a joint.
        """
        positions = np.asarray(positions, dtype=np.float64)
        time_ns = np.asarray(time_ns, dtype=np.int64)
        if not len(time_ns):
            return
        self._nan_positions(names, time_ns, positions)
        for j, name in enumerate(names):
            state = self._joints.get(name)
            if state is not None:
                self._column(state, time_ns, positions[:, j])
        self._mimics(names, time_ns, positions)

    def findings(self) -> list[MotionFinding]:
        """Everything found so far, by first time."""
        found = [MotionFinding(check, name, tally.value, tally.limit, self._unit(name, check), tally.first_ns,
                               tally.count)
                 for name, state in self._joints.items() for check, tally in state.tallies.items()]
        nan: dict[str, _Tally] = {}
        for (signature, name), tally in self._nan.items():
            if signature in self._signatures:
                seen = nan.setdefault(name, _Tally(tally.first_ns, math.nan, math.nan))
                seen.first_ns, seen.count = min(seen.first_ns, tally.first_ns), seen.count + tally.count
        found += [MotionFinding("nonfinite", name, math.nan, math.nan, self._unit(name, "nonfinite"), tally.first_ns,
                                tally.count) for name, tally in nan.items()]
        return sorted(found, key=lambda f: (f.first_ns, f.joint, f.check))

    def _unit(self, name: str, check: str) -> str:
        unit = self._joints[name].unit
        return {"velocity": f"{unit}/s", "acceleration": f"{unit}/s²"}.get(check, unit)

    # -- per joint -----------------------------------------------------------------------------------

    def _column(self, state: _Joint, time_ns: NDArray[np.int64], column: Array) -> None:
        infinite = np.isinf(column)
        if infinite.any():
            first = int(np.argmax(infinite))
            self._tally(state, "nonfinite", time_ns[infinite], np.abs(column[infinite]), math.nan, value=column[first])
        given = np.isfinite(column)
        if not given.any():
            return
        t, p = time_ns[given], column[given]
        self._positions(state, t, p)
        if state.last_ns is not None:
            t = np.concatenate([[state.last_ns], t])
            p = np.concatenate([[state.last_position], p])
        self._steps(state, t, p)
        state.last_ns, state.last_position = int(t[-1]), float(p[-1])

    def _positions(self, state: _Joint, t: NDArray[np.int64], p: Array) -> None:
        for check, low, high, inside in (("limit", state.lower, state.upper, None),
                                         ("soft_limit", state.soft_lower, state.soft_upper,
                                          (p >= state.lower - LIMIT_TOL) & (p <= state.upper + LIMIT_TOL))):
            below, above = p < low - LIMIT_TOL, p > high + LIMIT_TOL
            if inside is not None:
                below, above = below & inside, above & inside
            out = below | above
            if out.any():
                excess = np.where(below, low - p, p - high)
                worst = int(np.argmax(np.where(out, excess, -np.inf)))
                self._tally(state, check, t[out], excess[out], low if below[worst] else high, value=p[worst])

    def _steps(self, state: _Joint, t: NDArray[np.int64], p: Array) -> None:
        if len(t) < 2:
            return
        dt = np.diff(t).astype(np.float64) / NS_PER_S
        step = np.diff(p)
        if state.joint.type is JointType.CONTINUOUS:
            step = (step + math.pi) % (2.0 * math.pi) - math.pi
        moving = dt > 0
        speed = np.where(moving, np.abs(step) / np.where(moving, dt, 1.0), 0.0)
        if state.velocity > 0:
            over = moving & (speed > state.velocity * (1.0 + VELOCITY_TOL))
            if over.any():
                self._tally(state, "velocity", t[1:][over], speed[over], state.velocity)
            jump_limit = state.velocity * JUMP_FACTOR * dt
        else:
            jump_limit = np.full(len(dt), JUMP_M if state.joint.type is JointType.PRISMATIC else JUMP_RAD)
        jumps = np.abs(step) > jump_limit
        if jumps.any():
            size = np.abs(step[jumps])
            worst = int(np.argmax(size))
            self._tally(state, "jump", t[1:][jumps], size, float(jump_limit[jumps][worst]), value=float(size[worst]))
        if self._max_accel is not None:
            self._accelerations(state, t, step, dt, moving)

    def _accelerations(self, state: _Joint, t: NDArray[np.int64], step: Array, dt: Array,
                       moving: NDArray[np.bool_]) -> None:
        assert self._max_accel is not None
        velocity = np.where(moving, step / np.where(moving, dt, 1.0), np.nan)  # each step's, at its end t[1:]
        span, times = dt, t[2:]
        if state.last_speed is not None:
            velocity = np.concatenate([[state.last_speed], velocity])
            span, times = np.concatenate([[state.last_dt], dt]), t[1:]
        if len(velocity) >= 2:
            mid = (span[1:] + span[:-1]) / 2.0
            with np.errstate(invalid="ignore"):
                accel = np.abs(np.diff(velocity)) / np.where(mid > 0, mid, np.inf)
                over = np.isfinite(accel) & (accel > self._max_accel * (1.0 + VELOCITY_TOL))
            if over.any():
                self._tally(state, "acceleration", times[over], accel[over], self._max_accel)
        state.last_speed, state.last_dt = float(velocity[-1]), float(span[-1])

    @staticmethod
    def _tally(state: _Joint, check: str, times: NDArray[np.int64], sizes: Array, limit: float, *,
               value: float | None = None) -> None:
        """Count samples of a finding; keep the first time and the worst size (``value``: what is shown for it)."""
        worst = float(value if value is not None else sizes.max())
        tally = state.tallies.get(check)
        if tally is None:
            state.tallies[check] = _Tally(int(times[0]), worst, limit, len(times))
            return
        tally.count += len(times)
        if check in ("limit", "soft_limit"):
            worse = abs(worst - limit) > abs(tally.value - tally.limit)
        else:
            worse = check == "nonfinite" or abs(worst) > abs(tally.value)
        if worse:
            tally.value, tally.limit = worst, limit

    # -- across joints ---------------------------------------------------------------------------------

    def _nan_positions(self, names: Sequence[str], time_ns: NDArray[np.int64], positions: Array) -> None:
        """Remember which joints messages give together, and where a joint is NaN in a message shaped like those
        that give it (:meth:`findings` decides once every batch is in)."""
        given = ~np.isnan(positions)
        known = np.array([name in self._joints for name in names], dtype=bool)
        signatures = np.packbits(given, axis=1)
        prefix = np.frombuffer(len(names).to_bytes(4, "little") + "\0".join(names).encode(), dtype=np.uint8)
        same = len(signatures) > 0 and bool((signatures == signatures[0]).all())  # the common case, at once
        for row in signatures[:1] if same else np.unique(signatures, axis=0):
            self._signatures.add(prefix.tobytes() + row.tobytes())
        for j in np.flatnonzero(known & ~given.all(axis=0)):
            rows = np.flatnonzero(~given[:, j])
            with_joint = given[rows].copy()
            with_joint[:, j] = True
            keys, first, counts = np.unique(np.packbits(with_joint, axis=1), axis=0, return_index=True,
                                            return_counts=True)
            for key, at, count in zip(keys, first, counts):
                entry = self._nan.setdefault((prefix.tobytes() + key.tobytes(), names[int(j)]),
                                             _Tally(int(time_ns[rows[at]]), math.nan, math.nan))
                entry.count += int(count)

    def _mimics(self, names: Sequence[str], time_ns: NDArray[np.int64], positions: Array) -> None:
        index = {name: j for j, name in enumerate(names)}
        for joint in self._robot.mimic_order:
            assert joint.mimic is not None
            k, m = index.get(joint.name), index.get(joint.mimic.joint)
            if k is None or m is None:
                continue
            expected = joint.mimic.multiplier * positions[:, m] + joint.mimic.offset
            deviation = np.abs(positions[:, k] - expected)
            tol = MIMIC_TOL * np.maximum(1.0, np.abs(expected))
            off = np.isfinite(deviation) & (deviation > tol)
            if off.any():
                self._tally(self._joints[joint.name], "mimic", time_ns[off], deviation[off], MIMIC_TOL)
