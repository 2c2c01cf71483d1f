"""``tfrec replay --check``: replay as re-simulation.

The recorded /joint_states go through the robot description (the recording's own, or
``--robot``) with robot_state_publisher's semantics (:func:`tfrec.replay.joint_positions`), and the
result is compared with the recorded /tf and /tf_static, frame by frame. A description that does
not match the data — a wrong offset, axis, joint type, parent or a missing link — shows as the
frames it moves.

Where a recorded transform is stamped between two joint states, the joint positions are
interpolated linearly at its stamp (exact when the stamps coincide, as they do for
robot_state_publisher, which stamps TF with the joint state's stamp), as ``tfrec diff``
interpolates (:func:`tfrec.resample.align`). Errors are the distance between translations (m)
and the angle of the relative rotation (:func:`tfrec.kinematics.rotations.rotation_error`, rad).
"""

from __future__ import annotations

import math
import os
from collections.abc import Collection, Iterable, Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import CHECK_POS_TOL, CHECK_ROT_TOL, NS_PER_S
from tfrec.errors import ReplayError, printable
from tfrec.kinematics.fk import dynamic_components, static_transforms
from tfrec.kinematics.rotations import relative_angle
from tfrec.model import Joint, JointType, Robot
from tfrec.recording import FrameSeries, RecordedRobot
from tfrec.replay.load import joint_positions
from tfrec.replay.pieces import ReplayPiece, replay_pieces
from tfrec.replay.prepared import Replay
from tfrec.resample import align

__all__ = [
    "CheckReport",
    "FrameCheck",
    "FrameErrors",
    "check_pieces",
    "check_recording_pieces",
    "check_replay",
    "format_check",
]

Array = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class FrameErrors:
    """A frame's errors at every compared stamp (for plots; not in the JSON report).

    Attributes:
        time_ns: int64 (n,) stamps (ns since the epoch); one 0 for a latched transform.
        translation_m, rotation_rad: float64 (n,) errors.
    """

    time_ns: NDArray[np.int64]
    translation_m: Array
    rotation_rad: Array


@dataclass(frozen=True, slots=True)
class FrameCheck:
    """The comparison of one recorded frame with its re-simulation.

    Attributes:
        frame: the child frame id, as recorded.
        parent: its parent frame id, as recorded (or as the description has it, when missing).
        joint: the joint of the description whose child the frame is.
        topic: ``/tf`` or ``/tf_static``.
        samples: recorded transforms compared.
        translation_m, rotation_rad: the largest errors (0 when nothing was compared).
        translation_time_s, rotation_time_s: when they occur (seconds from the recording's
            first stamp; None for latched transforms or nothing compared).
        problem: why the frame could not be compared, or None.
        errors: the errors at every compared stamp, or None (not in :meth:`to_dict`).
        robot: the robot's key (``/robot1``; ``""`` for the only robot of a recording).
    """

    frame: str
    parent: str
    joint: str
    topic: str
    samples: int = 0
    translation_m: float = 0.0
    translation_time_s: float | None = None
    rotation_rad: float = 0.0
    rotation_time_s: float | None = None
    problem: str | None = None
    errors: FrameErrors | None = field(default=None, repr=False, compare=False)
    robot: str = ""

    def passed(self, pos_tol: float, rot_tol: float) -> bool:
        return self.problem is None and self.translation_m <= pos_tol and self.rotation_rad <= rot_tol

    def to_dict(self) -> dict[str, Any]:
        out = asdict(replace(self, errors=None))
        del out["errors"]
        return out


@dataclass
class CheckReport:
    """The result of :func:`check_replay`.

    Attributes:
        path: the recording.
        frames: one entry per recorded frame of the robot and per frame of the robot missing
            from the recording, in the description's order.
        pos_tol, rot_tol: the tolerances.
        notes: remarks that are not failures (frames the description does not have).
        origin_ns: the recording's start (``Replay.origin_ns``): times in the report count from it.
        robots: the keys of the robots checked (``[""]`` for the only robot of a recording).
        unchecked: robot key → why it was not checked (no description, no joint states…);
            its frames are not in ``frames``, and the verdict never calls them a pass.
    """

    path: str
    frames: list[FrameCheck]
    pos_tol: float
    rot_tol: float
    notes: list[str] = field(default_factory=list)
    origin_ns: int = 0
    robots: list[str] = field(default_factory=lambda: [""])
    unchecked: dict[str, str] = field(default_factory=dict)

    @property
    def failures(self) -> list[FrameCheck]:
        return [frame for frame in self.frames if not frame.passed(self.pos_tol, self.rot_tol)]

    @property
    def passed(self) -> bool:
        return not self.failures

    def to_dict(self) -> dict[str, Any]:
        return {
            "path": self.path,
            "passed": self.passed,
            "pos_tol": self.pos_tol,
            "rot_tol": self.rot_tol,
            "frames": [frame.to_dict() for frame in self.frames],
            "failures": [frame.frame for frame in self.failures],
            "notes": self.notes,
            "robots": self.robots,
            "unchecked": self.unchecked,
        }


def _tolerance(name: str, value: float) -> float:
    if not (math.isfinite(value) and value >= 0):
        raise ReplayError(f"{name} {value} is not a tolerance >= 0")
    return float(value)


def _largest(errors: Array, times: NDArray[np.int64] | None, replay: Replay) -> tuple[float, float | None]:
    if not len(errors):
        return 0.0, None
    k = int(np.argmax(np.where(np.isnan(errors), np.inf, errors)))
    value = float(errors[k]) if np.isfinite(errors[k]) else math.inf
    return value, None if times is None else replay.seconds(int(times[k]))


def _errors(translation: Array, rotation: Array, want_t: Array, want_q: Array) -> tuple[Array, Array]:
    """Distances (m) and angles (rad) between recorded transforms ((n, 3), (n, 4)) and expected ones given a
    component per row ((3, n), (4, n)): the values of ``np.linalg.norm`` and ``rotation_error``."""
    dx, dy, dz = (translation[:, c] - want_t[c] for c in range(3))
    distance: Array = np.sqrt(dx * dx + dy * dy + dz * dz)
    return distance, relative_angle([rotation[:, c] for c in range(4)], list(want_q))


class _Checker:
    def __init__(self, part: RecordedRobot, replay: Replay) -> None:
        assert part.model is not None
        self.replay = replay
        self.key = part.key
        self.joint_topic = part.namespace + "/joint_states"
        self.robot = part.model
        self.prefix = part.frame_prefix
        self.joint_states = part.joint_states
        self.names: tuple[str, ...] = ()
        self.positions = np.zeros((0, 0))
        if self.joint_states is not None:  # none: a robot without moving joints, only fixed frames to check
            self.names, self.positions = joint_positions(self.robot, self.joint_states)
        self.column = {name: k for k, name in enumerate(self.names)}
        fixed = static_transforms(self.robot, frame_prefix=self.prefix).poses()
        self.fixed = {child: pose for (_, child), pose in fixed.items()}
        self._prefetched: dict[tuple[str, bytes], tuple[Array, Array, NDArray[np.bool_]]] = {}

    def prefetch(self, frames: Iterable[tuple[Joint, NDArray[np.int64]]]) -> None:
        """Compute the expected transforms of many moving joints at once (:meth:`expected` then takes them):
        joints whose recorded stamps are the same (a TFMessage per sample holds every joint) in one
        forward-kinematics call, so that a robot of 100,000 joints is checked in seconds."""
        if self.joint_states is None:
            return
        groups: dict[bytes, tuple[NDArray[np.int64], list[Joint]]] = {}
        for joint, times in frames:
            column = self.column.get(joint.name)
            if not joint.type.moves or column is None or not np.isfinite(self.positions[:, column]).all():
                continue  # alone, in expected()
            groups.setdefault(times.tobytes(), (times, []))[1].append(joint)
        for times, joints in groups.values():
            alignment = align(times, self.joint_states.time_ns)
            q = alignment.linear(self.positions[:, [self.column[joint.name] for joint in joints]])
            components = dynamic_components(self.robot, [joint.name for joint in joints], q)
            for k, joint in enumerate(joints):
                self._prefetched[(joint.name, times.tobytes())] = (components[k, :3], components[k, 3:],
                                                                   alignment.inside)

    def expected(self, joint: Joint, times: NDArray[np.int64]) -> tuple[Array, Array, NDArray[np.bool_]]:
        """The description's transforms at ``times``: (translations (3, m), rotations (4, m) — a component per
        row —, which of the times have one (m of them))."""
        found = self._prefetched.pop((joint.name, times.tobytes()), None)
        if found is not None:
            return found
        child = self.prefix + joint.child
        if not joint.type.moves:
            translation, rotation = self.fixed[child]
            return (np.broadcast_to(translation[:, np.newaxis], (3, len(times))),
                    np.broadcast_to(rotation[:, np.newaxis], (4, len(times))), np.ones(len(times), dtype=bool))
        if self.joint_states is None or joint.name not in self.column:
            return np.zeros((3, 0)), np.zeros((4, 0)), np.zeros(len(times), dtype=bool)
        column = self.positions[:, self.column[joint.name]]
        known = np.isfinite(column)
        if not known.any():
            return np.zeros((3, 0)), np.zeros((4, 0)), np.zeros(len(times), dtype=bool)
        alignment = align(times, self.joint_states.time_ns[known])
        q = alignment.linear(column[known])
        components = dynamic_components(self.robot, [joint.name], q[:, np.newaxis])
        return components[0, :3], components[0, 3:], alignment.inside

    def frame(self, joint: Joint, parent: str, child: str, topic: str, series: FrameSeries | None,
              static: tuple[Array, Array] | None) -> FrameCheck:
        check = FrameCheck(child, parent, joint.name, topic, robot=self.key)
        expected_parent = self.prefix + joint.parent
        if parent != expected_parent:
            return replace(check, problem=f"parent is '{parent}' in the recording, '{expected_parent}' in the "
                                           "description")
        if series is not None:
            times = series.time_ns
            translation, rotation = series.translation, series.rotation
        else:
            assert static is not None
            if joint.type.moves:
                return replace(check, problem=f"on {topic}, but joint '{joint.name}' moves ({joint.type.value})")
            times = np.zeros(1, dtype=np.int64)
            translation, rotation = static[0][np.newaxis], static[1][np.newaxis]
        want_t, want_q, inside = self.expected(joint, times)
        if not inside.any():
            return replace(check, problem=f"no {self.joint_topic} position for joint '{joint.name}' at its stamps")
        if not inside.all():
            times, translation, rotation = times[inside], translation[inside], rotation[inside]
        translation_err, rotation_err = _errors(translation, rotation, want_t, want_q)
        stamps = times if series is not None else None
        t_max, t_at = _largest(translation_err, stamps, self.replay)
        r_max, r_at = _largest(rotation_err, stamps, self.replay)
        errors = FrameErrors(times, translation_err, rotation_err)
        return replace(check, samples=int(inside.sum()), translation_m=t_max, translation_time_s=t_at,
                        rotation_rad=r_max, rotation_time_s=r_at, errors=errors)


def _why_unchecked(part: RecordedRobot) -> str | None:
    """Why a robot cannot be re-simulated (the error of a recording of one robot), or None."""
    ns = part.namespace
    if part.model is None:
        return (f"no robot description to re-simulate with (no {ns}/robot_description in the recording); "
                "give `robot` FILE")
    if not part.model.moving_joints:  # only /tf_static to check
        return None
    if part.joint_states is None or not len(part.joint_states):
        return f"no {ns}/joint_states to re-simulate"
    if not any(len(s) for pair, s in part.tf.items() if pair not in part.derived_dynamic):
        return f"no {ns}/tf to compare the re-simulation with"
    return None


def _check_robot(part: RecordedRobot, replay: Replay, report: CheckReport) -> None:
    """Check one robot's recorded frames, in its description's order; notes name it when there are several."""
    robot = part.model
    assert robot is not None
    who = f"{part.label}: " if part.key else ""
    recorded_tf = {pair: s for pair, s in part.tf.items() if pair not in part.derived_dynamic and len(s)}
    recorded_static = {pair: v for pair, v in part.tf_static.items() if pair not in part.derived_static}
    checker = _Checker(part, replay)
    by_child: dict[str, list[FrameCheck]] = {}
    other: list[tuple[str, str]] = []
    floating: list[str] = []
    joint_of_child = {part.frame_prefix + joint.child: joint for joint in robot.joints}
    checker.prefetch((joint, series.time_ns) for (parent, child), series in recorded_tf.items()
                     if (joint := joint_of_child.get(child)) is not None and parent == part.frame_prefix + joint.parent)
    for topic, pairs in (("/tf_static", recorded_static), ("/tf", recorded_tf)):
        for (parent, child), value in pairs.items():
            joint = joint_of_child.get(child)
            if joint is None:
                other.append((parent, child))
            elif joint.type is JointType.FLOATING:
                floating.append(child)
            else:
                series = value if isinstance(value, FrameSeries) else None
                static = None if isinstance(value, FrameSeries) else value
                by_child.setdefault(child, []).append(checker.frame(joint, parent, child, topic, series, static))
    for joint in robot.joints:
        child = part.frame_prefix + joint.child
        if child in by_child:
            report.frames.extend(by_child[child])
        elif joint.type is not JointType.FLOATING:
            topic = "/tf" if joint.type.moves else "/tf_static"
            report.frames.append(FrameCheck(child, part.frame_prefix + joint.parent, joint.name, topic,
                                            problem=f"not in the recording (joint '{joint.name}' of the description)",
                                            robot=part.key))
    if other:
        shown = ", ".join(f"{p} → {c}" for p, c in other[:3]) + (" …" if len(other) > 3 else "")
        report.notes.append(f"{who}{len(other)} recorded frame pair{'s' if len(other) > 1 else ''} not in the "
                            f"description, not checked: {shown}")
    if floating:
        report.notes.append(f"{who}frames below floating joints are not re-simulated: {', '.join(floating)}")


def check_replay(replay: Replay, *, pos_tol: float = CHECK_POS_TOL, rot_tol: float = CHECK_ROT_TOL) -> CheckReport:
    """Recompute TF from the recorded joint states and compare it with the recorded TF, robot by robot.

    Args:
        replay: from :func:`tfrec.replay.load_replay` (its time window applies).
        pos_tol: metres; a frame whose largest translation error exceeds it fails.
        rot_tol: radians; the same for the rotation angle.

    Returns:
        One :class:`FrameCheck` per frame of each robot's description that the recording has or
        should have; frames of a description missing from the recording fail, frames no
        description has are noted, robots that cannot be checked are listed in ``unchecked``.

    Raises:
        ReplayError: a bad tolerance, or no robot that can be checked: none with a model,
            /joint_states and /tf (for a recording of one robot: which of them it lacks).
    """
    pos_tol = _tolerance("`pos_tol`", pos_tol)
    rot_tol = _tolerance("`rot_tol`", rot_tol)
    replay.report_damage()
    parts = [part for part in replay.robots if not part.unclaimed]
    reasons = {part.key: _why_unchecked(part) for part in parts}
    checkable = [part for part in parts if reasons[part.key] is None]
    if not checkable:
        first = next((reason for reason in reasons.values() if reason is not None),
                     "no robot description to re-simulate with (no /robot_description in the recording); "
                     "give `robot` FILE")
        raise ReplayError(f"{replay.path}: {first}")
    report = CheckReport(replay.path, [], pos_tol, rot_tol, origin_ns=replay.origin_ns,
                         robots=[part.key for part in checkable],
                         unchecked={key: reason for key, reason in reasons.items() if reason is not None})
    for part in checkable:
        _check_robot(part, replay, report)
    for part in replay.robots:
        if part.unclaimed:
            pairs = [*part.tf_static, *part.tf]
            shown = ", ".join(f"{p} → {c}" for p, c in pairs[:3]) + (" …" if len(pairs) > 3 else "")
            report.notes.append(f"{len(pairs)} frame pair{'s' if len(pairs) != 1 else ''} of no robot's "
                                f"description ({part.key}), not checked: {shown}")
    return report


def _number(value: float) -> str:
    return "0" if value == 0 else f"{value:.3g}"


def _time(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def format_check(report: CheckReport) -> str:
    """The report as a table, one row per frame (naming its robot when there are several), then the
    verdict naming the failing frames — per robot, with the robots that could not be checked. Names that hold
    a character that is not printable are shown escaped (:func:`tfrec.errors.printable`), the columns aligned
    on what is shown."""
    several = len(report.robots) + len(report.unchecked) > 1
    header: tuple[str, ...] = ("frame", "parent", "topic", "samples", "max transl. (m)", "at t (s)",
                               "max rot. (rad)", "at t (s)", "")
    if several:
        header = ("robot", *header)
    rows: list[tuple[str, ...]] = []
    for f in report.frames:
        ok = f.passed(report.pos_tol, report.rot_tol)
        row = (printable(f.frame), printable(f.parent), printable(f.topic), str(f.samples),
               _number(f.translation_m), _time(f.translation_time_s if f.translation_m else None),
               _number(f.rotation_rad), _time(f.rotation_time_s if f.rotation_rad else None),
               "ok" if ok else f"FAIL {f.problem or ''}".strip())
        rows.append((printable(f.robot or "/"), *row) if several else row)
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header) - 1)]
    lines = [f"re-simulated TF of {report.path} (tolerances {report.pos_tol:g} m, {report.rot_tol:g} rad)"]
    for cells in [header, *rows] if rows else []:  # no frame (a robot of one link): no table
        lines.append(("  ".join(cell.ljust(width) for cell, width in zip(cells, widths)) + "  " + cells[-1]).rstrip())
    lines.extend(f"note: {note}" for note in report.notes)
    if not several:
        lines.append(_verdict(report.frames, report, "the description"))
    else:
        for key in report.robots:
            frames = [f for f in report.frames if f.robot == key]
            lines.append(f"robot {key or '/'}: " + _verdict(frames, report, "its description"))
        for key, reason in report.unchecked.items():
            lines.append(f"robot {key or '/'}: NOT CHECKED: {reason}")
    return "".join(printable(line) + "\n" for line in lines)


def _verdict(frames: list[FrameCheck], report: CheckReport, description: str) -> str:
    failures = [f for f in frames if not f.passed(report.pos_tol, report.rot_tol)]
    if not frames:
        return f"PASS: {description.replace('its', 'the')} has no joints, so there is no transform to compare"
    if not failures:
        return f"PASS: all {len(frames)} frames match {description}"
    named = []
    for f in failures[:5]:
        if f.problem is not None:
            named.append(f"{f.frame} ({f.problem})")
        elif f.translation_m > report.pos_tol:
            named.append(f"{f.frame} (translation off by {_number(f.translation_m)} m at t={_time(f.translation_time_s)} s)")
        else:
            named.append(f"{f.frame} (rotation off by {_number(f.rotation_rad)} rad at t={_time(f.rotation_time_s)} s)")
    more = f" and {len(failures) - 5} more" if len(failures) > 5 else ""
    return (f"FAIL: {len(failures)} of {len(frames)} frames differ from {description}: "
            + "; ".join(named) + more)


@dataclass
class _Fold:
    """One /tf frame's comparisons over the pieces of a recording: the count, the largest errors and the samples
    that the report names (the largest errors, and the first above each tolerance)."""

    check: FrameCheck
    samples: int = 0
    witnesses: dict[str, tuple[float, int, float, float]] = field(default_factory=dict)  # what → (value, stamp, t, r)

    def add(self, found: FrameCheck, pos_tol: float, rot_tol: float) -> None:
        self.samples += found.samples
        errors = found.errors
        if errors is None or not len(errors.time_ns):
            return
        for what, values, tol in (("t", errors.translation_m, pos_tol), ("r", errors.rotation_rad, rot_tol)):
            ranked = np.where(np.isnan(values), np.inf, values)
            k = int(np.argmax(ranked))
            best = self.witnesses.get(what)
            stamp = int(errors.time_ns[k])
            if best is None or ranked[k] > best[0] or (ranked[k] == best[0] and stamp < best[1]):
                self.witnesses[what] = (float(ranked[k]), stamp, float(errors.translation_m[k]),
                                        float(errors.rotation_rad[k]))
            over = ~(values <= tol)
            first = self.witnesses.get(what + ">")
            if over.any():  # the earliest stamp: a piece may bring transforms stamped before an earlier piece's
                k = int(np.argmax(over))
                if first is None or int(errors.time_ns[k]) < first[1]:
                    self.witnesses[what + ">"] = (0.0, int(errors.time_ns[k]), float(errors.translation_m[k]),
                                                  float(errors.rotation_rad[k]))

    def result(self, origin_ns: int) -> FrameCheck:
        seen = sorted({(stamp, t, r) for _, stamp, t, r in self.witnesses.values()})
        errors = FrameErrors(np.array([s for s, _, _ in seen], dtype=np.int64), np.array([t for _, t, _ in seen]),
                             np.array([r for _, _, r in seen]))
        out = replace(self.check, samples=self.samples, errors=errors)
        best = self.witnesses.get("t")
        if best is not None:
            out = replace(out, translation_m=best[0], translation_time_s=(best[1] - origin_ns) / NS_PER_S)
        best = self.witnesses.get("r")
        if best is not None:
            out = replace(out, rotation_rad=best[0], rotation_time_s=(best[1] - origin_ns) / NS_PER_S)
        return out


@dataclass
class _Pieces:
    """The reports of a recording's pieces, folded into the whole recording's."""

    pos_tol: float
    rot_tol: float
    folds: dict[tuple[str, str, str, str], _Fold] = field(default_factory=dict)
    latched: dict[tuple[str, str, str, str], FrameCheck] = field(default_factory=dict)
    problems: dict[tuple[str, str, str, str], FrameCheck] = field(default_factory=dict)
    placed: set[tuple[str, str]] = field(default_factory=set)  # (robot, child) of frames the recording has
    order: dict[str, dict[str, int]] = field(default_factory=dict)  # robot → joint → its place in the description
    robots: list[str] = field(default_factory=list)
    unchecked: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def add(self, report: CheckReport, replay: Replay) -> None:
        for part in replay.robots:
            if part.model is not None and part.key not in self.order:
                self.order[part.key] = {joint.name: k for k, joint in enumerate(part.model.joints)}
        self.robots += [key for key in report.robots if key not in self.robots]
        for robot, reason in report.unchecked.items():
            self.unchecked.setdefault(robot, reason)
        self.notes += [note for note in report.notes if note not in self.notes]
        for frame in report.frames:
            key = (frame.robot, frame.frame, frame.topic, frame.parent)
            if frame.problem is None or not frame.problem.startswith(_NOT_RECORDED):
                self.placed.add((frame.robot, frame.frame))
            if frame.problem is not None:
                self.problems.setdefault(key, frame)
            elif frame.topic == "/tf_static":
                self.latched.setdefault(key, frame)
            else:
                self.folds.setdefault(key, _Fold(replace(frame, samples=0, errors=None))).add(
                    frame, self.pos_tol, self.rot_tol)

    def frames(self, origin_ns: int) -> list[FrameCheck]:
        found: dict[tuple[str, str, str, str], FrameCheck] = {}
        for key, problem in self.problems.items():
            if key in self.folds or key in self.latched:
                continue  # compared in another piece
            if problem.problem is not None and problem.problem.startswith(_NOT_RECORDED) and key[:2] in self.placed:
                continue  # in the recording, under another parent
            found[key] = problem
        found.update(self.latched)
        found.update({key: fold.result(origin_ns) for key, fold in self.folds.items()})
        robots = {key: k for k, key in enumerate(self.robots)}
        return sorted(found.values(), key=lambda f: (robots.get(f.robot, len(robots)),
                                                     self.order.get(f.robot, {}).get(f.joint, -1),
                                                     f.topic != "/tf_static"))


_NOT_RECORDED = "not in the recording"


def check_pieces(pieces: Iterable[ReplayPiece], *, pos_tol: float = CHECK_POS_TOL,
                 rot_tol: float = CHECK_ROT_TOL) -> tuple[CheckReport, Replay]:
    """:func:`check_replay` of a recording read piece by piece (:func:`tfrec.replay.pieces.replay_pieces`), in memory
    that does not grow with its length: each piece re-simulated, the reports folded into the recording's — the
    same frames, counts, largest errors and their times. A frame's ``errors`` hold only the samples the report names
    (its largest errors, and the first above each tolerance).

    Returns:
        (the report, the last piece's replay: the recording's ``origin_ns``, ``read_error``, robots).

    Raises:
        ReplayError: as :func:`check_replay`, when no piece has a robot that can be checked.
    """
    pos_tol = _tolerance("`pos_tol`", pos_tol)
    rot_tol = _tolerance("`rot_tol`", rot_tol)
    fold = _Pieces(pos_tol, rot_tol)
    failed: ReplayError | None = None
    checked = False
    last: Replay | None = None
    for piece in pieces:
        last = piece.replay
        try:
            report = check_replay(piece.replay, pos_tol=pos_tol, rot_tol=rot_tol)
        except ReplayError as err:
            failed = failed or err
            continue
        checked = True
        fold.add(report, piece.replay)
    assert last is not None, "a recording has one piece at least"
    if not checked:
        assert failed is not None
        raise failed
    report = CheckReport(last.path, fold.frames(last.origin_ns), pos_tol, rot_tol, notes=fold.notes,
                         origin_ns=last.origin_ns, robots=fold.robots,
                         unchecked={key: why for key, why in fold.unchecked.items() if key not in fold.robots})
    return report, last


def check_recording_pieces(path: str | os.PathLike[str], *, robot: Robot | None = None,
                           topics: Collection[str] | None = None, namespace: str | None = None,
                           remap: Iterable[str] | Mapping[str, str] | None = None, use_log_time: bool = False,
                           pos_tol: float = CHECK_POS_TOL, rot_tol: float = CHECK_ROT_TOL,
                           messages: int | None = None) -> CheckReport:
    """``replay --check`` of a recording: :func:`tfrec.replay.load_replay` (without a time window) and
    :func:`check_replay`, read and re-simulated piece by piece (:func:`check_pieces`) in memory that does not grow
    with the recording's length (pieces of about ``messages`` messages). The description is required
    (``need_robot``)."""
    pieces = replay_pieces(path, robot=robot, topics=topics, need_robot=True, namespace=namespace, remap=remap,
                           use_log_time=use_log_time, messages=messages)
    return check_pieces(pieces, pos_tol=pos_tol, rot_tol=rot_tol)[0]
