"""``tfrec replay``: play a recording back into Rerun, as ``ros2 bag play`` plays one into RViz.

:func:`load_replay` reads any recording :func:`tfrec.formats.read_recording` reads (tfrec's or
``ros2 bag record``'s MCAP, rosbag2 folders with mcap or sqlite3 storage, ROS 1 bags, ``.rrd``)
and prepares what is played: the robot model (the recording's /robot_description, or one given),
/tf_static and /tf per frame pair, and /joint_states, cut to ``start_s``..``end_s``.

The replay behaves as if robot_state_publisher were running beside ``ros2 bag play``: a joint of
the robot whose child frame is on none of the replayed /tf and /tf_static gets its transforms
computed from the replayed /joint_states (fixed joints from the model), so a joint log from a
real robot — /joint_states and /robot_description only — still moves the model. As
robot_state_publisher does, a joint is placed at the stamps of the messages that hold its
position, and a mimic joint that is not in a message follows its master in that message
(``multiplier · master + offset``).

Latched data — /tf_static and /robot_description — is logged as static data, so it is there
whatever ``start_s`` cuts away (``ros2 bag play --start-offset`` loses it).

:func:`tfrec.replay.play.play` sends a prepared replay to a sink in time-ordered batches, paced
for live viewers; :func:`tfrec.replay.check.check_replay` re-simulates it. Times are header
stamps; ``start_s`` and ``end_s`` count from the recording's start, its first /joint_states or
/tf stamp (:func:`tfrec.resample.data_start_ns`, the start ``tfrec diff`` aligns on), whatever
``topics`` selects.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, NS_PER_S, RECORDED_TOPICS, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.errors import DescriptionError, ReplayError
from tfrec.formats.reader import read_recording
from tfrec.kinematics.fk import dynamic_transforms, static_transforms
from tfrec.kinematics.joints import apply_mimic
from tfrec.model import Robot
from tfrec.recording import FrameSeries, JointStates, Recording
from tfrec.resample import data_end_ns, data_start_ns

__all__ = [
    "REPLAYED_TOPICS",
    "Replay",
    "derive_transforms",
    "detect_frame_prefix",
    "joint_positions",
    "load_replay",
]

Array = NDArray[np.float64]
Pair = tuple[str, str]

REPLAYED_TOPICS = RECORDED_TOPICS
"""The topics tfrec replays, those it records; a recording's other topics are skipped."""


@dataclass
class Replay:
    """A recording prepared for playing.

    Attributes:
        path: the recording read.
        format: ``mcap``, ``rosbag2``, ``rosbag1`` or ``rrd``.
        robot: the robot model, or None when there is none (transforms are replayed alone).
        robot_description: the URDF text to log at /robot_description, or None.
        frame_prefix: what the recording's frame ids put in front of the link names.
        static: latched transforms, (parent, child) → (translation (3,), rotation (4,)).
        tf: (parent, child) → transforms within the cut, recorded pairs first.
        joint_states: /joint_states within the cut, or None.
        derived_static: the pairs of ``static`` that are fixed joints of the model, not recorded.
        derived_dynamic: the pairs of ``tf`` computed from the model and the joint states.
        origin_ns: the recording's start, its first /joint_states or /tf stamp: ``start_s`` and
            reported times count from it.
        start_ns, end_ns: the first and last stamp replayed (None when no sample is left).
        read_error: where reading a damaged file stopped, or None.
    """

    path: str
    format: str
    robot: Robot | None
    robot_description: str | None
    frame_prefix: str
    static: dict[Pair, tuple[Array, Array]]
    tf: dict[Pair, FrameSeries]
    joint_states: JointStates | None
    derived_static: frozenset[Pair]
    derived_dynamic: frozenset[Pair]
    origin_ns: int
    start_ns: int | None
    end_ns: int | None
    read_error: str | None = None
    _damage_reported: bool = field(default=False, repr=False)

    @property
    def derived(self) -> frozenset[Pair]:
        """Every pair that robot_state_publisher's part of the replay added (static and dynamic)."""
        return self.derived_static | self.derived_dynamic

    def derived_summary(self) -> str:
        """What the model added, for the replay's summary line, or ``""`` when nothing.

        ``TF of 7 frames computed from the joint states and of 12 fixed frames taken from the
        robot description``.
        """
        parts = []
        if self.derived_dynamic:
            n = len(self.derived_dynamic)
            parts.append(f"{n} frame{'s' if n != 1 else ''} computed from the joint states")
        if self.derived_static:
            n = len(self.derived_static)
            parts.append(f"{n} fixed frame{'s' if n != 1 else ''} taken from the robot description")
        return "TF of " + " and of ".join(parts) if parts else ""

    def seconds(self, time_ns: int) -> float:
        """A stamp as seconds from the recording's start (``origin_ns``)."""
        return (time_ns - self.origin_ns) / NS_PER_S

    def frames(self) -> list[str]:
        """Every frame id of the latched and dynamic transforms, in order of appearance."""
        seen: dict[str, None] = {}
        for parent, child in list(self.static) + list(self.tf):
            seen.setdefault(parent)
            seen.setdefault(child)
        return list(seen)

    def root_frame(self) -> str | None:
        """The frame the 3D view is drawn in: the robot's root, else a frame that is nobody's child."""
        if self.robot is not None:
            return self.frame_prefix + self.robot.root
        children = {child for _, child in list(self.static) + list(self.tf)}
        return next((frame for frame in self.frames() if frame not in children), None)

    def report_damage(self) -> None:
        """Warn once, for a damaged file, where reading stopped and how far the replay went."""
        if self.read_error is None or self._damage_reported:
            return
        self._damage_reported = True
        upto = "" if self.end_ns is None else f"; replayed up to t={self.seconds(self.end_ns):.3f} s"
        warnings.warn(self.read_error + upto, stacklevel=2)


def detect_frame_prefix(robot: Robot, frames: Iterable[str]) -> str:
    """The prefix the recording's frame ids put in front of the robot's link names.

    robot_state_publisher's ``frame_prefix`` (``left/``), or ROS 1's leading ``/``: the prefix that
    turns the most frames into link names; no prefix when the frames are the link names.
    """
    links = {link.name for link in robot.links}
    counts: dict[str, int] = {}
    for frame in set(frames):
        if frame in links:
            counts[""] = counts.get("", 0) + 1
        for link in links:
            if len(frame) > len(link) and frame.endswith(link):
                prefix = frame[: -len(link)]
                counts[prefix] = counts.get(prefix, 0) + 1
    if not counts:
        return ""
    best = max(counts.values())
    if counts.get("", 0) == best:
        return ""
    return min((prefix for prefix, count in counts.items() if count == best), key=lambda p: (len(p), p))


def joint_positions(robot: Robot, joint_states: JointStates) -> tuple[tuple[str, ...], Array]:
    """Positions of the robot's moving joints at every /joint_states stamp, NaN where unknown.

    A mimic joint without a position of its own in a message follows its master in that message,
    ``multiplier · master + offset`` (chains resolved in order); a mimic of a joint that does not
    move stays at ``offset``. Names in the joint states that are not moving joints of the robot
    are ignored, as robot_state_publisher ignores them.

    Returns:
        (names, positions): the moving joints in URDF document order and float64 (N, M).
    """
    names = tuple(joint.name for joint in robot.moving_joints)
    index = {name: k for k, name in enumerate(names)}
    positions = np.full((len(joint_states), len(names)), np.nan)
    for j, name in enumerate(joint_states.names):
        k = index.get(name)
        if k is not None:
            positions[:, k] = joint_states.positions[:, j]
    apply_mimic(robot, names, positions, only_missing=True)
    return names, positions


def derive_transforms(
    robot: Robot, joint_states: JointStates, *, frame_prefix: str = "", joints: Collection[str] | None = None
) -> dict[Pair, FrameSeries]:
    """What robot_state_publisher publishes on /tf for these joint states.

    Args:
        robot: the robot.
        joint_states: the joint states (positions NaN where a message lacks a joint).
        frame_prefix: put in front of every frame id.
        joints: the moving joints to compute (default: all).

    Returns:
        (parent, child) → transforms at the stamps of the messages that give the joint a
        position (mimic joints included); joints with no position at all are absent.
    """
    names, positions = joint_positions(robot, joint_states)
    wanted = [k for k, name in enumerate(names) if joints is None or name in joints]
    given = np.isfinite(positions[:, wanted])
    keep = [k for k, column in zip(wanted, given.T) if column.any()]
    if not keep:
        return {}
    tfs = dynamic_transforms(robot, [names[k] for k in keep], np.nan_to_num(positions[:, keep]),
                             frame_prefix=frame_prefix)
    out: dict[Pair, FrameSeries] = {}
    for i, k in enumerate(keep):
        rows = np.isfinite(positions[:, k])
        every = bool(rows.all())
        out[(tfs.parents[i], tfs.children[i])] = FrameSeries(
            joint_states.time_ns if every else joint_states.time_ns[rows],
            np.ascontiguousarray(tfs.translation[:, i] if every else tfs.translation[rows, i]),
            np.ascontiguousarray(tfs.rotation[:, i] if every else tfs.rotation[rows, i]),
        )
    return out


def _check_window(start_s: float | None, end_s: float | None) -> None:
    for name, value in (("`start_s`", start_s), ("`end_s`", end_s)):
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise ReplayError(f"{name} {value} is not a time in seconds >= 0")
    if start_s is not None and end_s is not None and end_s < start_s:
        raise ReplayError(f"`end_s` {end_s:g} is before `start_s` {start_s:g}")


def _check_topics(topics: Collection[str] | None) -> frozenset[str]:
    if topics is None:
        return frozenset(REPLAYED_TOPICS)
    for topic in topics:
        if topic not in REPLAYED_TOPICS:
            raise ReplayError(f"topic '{topic}' cannot be replayed; tfrec replays {', '.join(REPLAYED_TOPICS)}")
    return frozenset(topics)


def _robot_of(description: str | None, where: str, *, required: bool) -> Robot | None:
    """The model of a recorded /robot_description; an unusable one warns (or raises when required)."""
    if description is None:
        return None
    from tfrec.description.urdf import parse_urdf

    try:
        return parse_urdf(description, source=None, user_lines=False)
    except DescriptionError as err:
        if required:
            raise DescriptionError(f"{where}: /robot_description is not a usable robot description: {err}") from err
        warnings.warn(f"{where}: /robot_description is not a usable robot description ({err}); "
                      "replaying without the robot model (give `robot` FILE)", stacklevel=3)
        return None


def _has(rec: Recording, topic: str) -> bool:
    info = rec.topics.get(topic)
    return info is not None and info.count > 0


def _listed(items: Sequence[str]) -> str:
    """``a``, ``a or b``, ``a, b or c``."""
    return ", ".join(items[:-1]) + " or " + items[-1] if len(items) > 1 else "".join(items)


def _cut_series(series: FrameSeries, lo: int, hi: int) -> FrameSeries:
    a = int(np.searchsorted(series.time_ns, lo, side="left"))
    b = int(np.searchsorted(series.time_ns, hi, side="right"))
    if a == 0 and b == len(series):
        return series
    return FrameSeries(series.time_ns[a:b], series.translation[a:b], series.rotation[a:b])


def _transforms_not_recorded(
    robot: Robot, prefix: str, covered: set[str], joint_states: JointStates | None, where: str
) -> tuple[dict[Pair, tuple[Array, Array]], dict[Pair, FrameSeries]]:
    """What robot_state_publisher would add for the joints whose child frame is not in ``covered``.

    Returns:
        (latched transforms of fixed joints, transforms of moving joints from the joint states).
    """
    fixed = static_transforms(robot, frame_prefix=prefix).poses()
    latched = {pair: pose for pair, pose in fixed.items() if pair[1] not in covered}
    uncovered = [joint.name for joint in robot.moving_joints if prefix + joint.child not in covered]
    computed: dict[Pair, FrameSeries] = {}
    if joint_states is not None and uncovered:
        computed = derive_transforms(robot, joint_states, frame_prefix=prefix, joints=uncovered)
    placed = {child for _, child in computed}
    unplaced = [name for name in uncovered if prefix + robot.joint_by_name[name].child not in placed]
    if unplaced and (joint_states is None or len(joint_states)):
        listed = ", ".join(unplaced[:5]) + (f" and {len(unplaced) - 5} more" if len(unplaced) > 5 else "")
        plural = len(unplaced) > 1
        warnings.warn(f"{where}: no /tf and no /joint_states position for joint{'s' if plural else ''} {listed}; "
                      f"{'their links are' if plural else 'its link is'} not placed", stacklevel=3)
    return latched, computed


def load_replay(
    path: str | os.PathLike[str],
    *,
    robot: Robot | None = None,
    topics: Collection[str] | None = None,
    start_s: float | None = None,
    end_s: float | None = None,
    need_robot: bool = False,
) -> Replay:
    """Read a recording and prepare it for :func:`tfrec.replay.play.play` (or for checking).

    Args:
        path: a recording (``.mcap``, rosbag2 folder, ROS 1 ``.bag``, ``.rrd``).
        robot: a robot model that overrides the recording's /robot_description.
        topics: replay only these of /robot_description, /tf_static, /joint_states and /tf.
        start_s, end_s: replay the samples stamped this many seconds after the recording's
            start, its first /joint_states or /tf stamp (:func:`tfrec.resample.data_start_ns`).
        need_robot: raise, rather than warn, when the recording's description is unusable.

    Returns:
        The prepared replay; a damaged MCAP gives what was readable, with ``read_error`` set.

    Raises:
        ReplayError: an unknown topic, a bad time window, a path that is not a recording, a
            recording with none of the selected topics, or ``start_s`` past its last sample.
        DescriptionError: ``need_robot`` and a /robot_description that is not a valid URDF.
    """
    _check_window(start_s, end_s)
    selected = _check_topics(topics)
    where = os.fspath(path)
    # the time series are read whatever is selected: the recording's start counts from them
    rec = read_recording(path, topics=selected | {JOINT_STATES, TF}
                         | ({ROBOT_DESCRIPTION} if robot is None else set()))
    absent = [topic for topic in REPLAYED_TOPICS if topic in selected and not _has(rec, topic)]
    if len(absent) == len(selected):
        rec_kind = " (an .rrd not written by tfrec?)" if rec.format == "rrd" and not rec.topics else ""
        raise ReplayError(f"{where}: no {_listed(absent)} in the recording{rec_kind}; nothing to replay")
    if topics is not None and absent:
        warnings.warn(f"{where}: no {', '.join(absent)} in the recording", stacklevel=2)
    origin = data_start_ns(rec) or 0
    last = data_end_ns(rec)
    if start_s is not None and origin + round(start_s * NS_PER_S) > (origin if last is None else last):
        end = 0.0 if last is None else (last - origin) / NS_PER_S
        damaged = "" if rec.read_error is None else f"; the file is damaged: {rec.read_error}"
        raise ReplayError(f"{where}: `start_s` {start_s:g} s is beyond the recording's end ({end:g} s){damaged}")
    if robot is None:
        robot = _robot_of(rec.robot_description, where, required=need_robot)
        if rec.robot_description is None and not need_robot:
            what = ("TF is replayed without robot geometry" if _has(rec, TF) or _has(rec, TF_STATIC)
                    else "only the joint positions are replayed, with no robot model to move")
            warnings.warn(f"{where}: no /robot_description in the recording and no `robot`: {what} "
                          "(give `robot` FILE)", stacklevel=2)
    description = None
    if ROBOT_DESCRIPTION in selected:
        description = robot.urdf if robot is not None and robot.urdf else rec.robot_description
    recorded_static = dict(rec.tf_static) if TF_STATIC in selected else {}
    recorded_tf = dict(rec.tf) if TF in selected else {}
    joint_states = rec.joint_states if JOINT_STATES in selected else None
    prefix = ""
    if robot is not None:
        prefix = detect_frame_prefix(robot, [f for pair in list(recorded_static) + list(recorded_tf) for f in pair])

    lo = origin + (0 if start_s is None else round(start_s * NS_PER_S))
    hi = int(np.iinfo(np.int64).max) if end_s is None else origin + round(end_s * NS_PER_S)

    had_samples = any(len(s) for s in recorded_tf.values()) or (joint_states is not None and len(joint_states) > 0)
    static = recorded_static
    tf = {pair: _cut_series(series, lo, hi) for pair, series in recorded_tf.items()}
    if joint_states is not None:
        rows = (joint_states.time_ns >= lo) & (joint_states.time_ns <= hi)
        if not rows.all():
            joint_states = JointStates(joint_states.time_ns[rows], joint_states.names, joint_states.positions[rows])
    latched: dict[Pair, tuple[Array, Array]] = {}
    computed: dict[Pair, FrameSeries] = {}
    if robot is not None:
        covered = {child for _, child in list(recorded_static) + list(recorded_tf)}
        latched, computed = _transforms_not_recorded(robot, prefix, covered, joint_states, where)
        static.update(latched)
        tf.update(computed)
    stamps = [s.time_ns for s in tf.values() if len(s)]
    if joint_states is not None and len(joint_states):
        stamps.append(joint_states.time_ns)
    start_ns = min(int(s[0]) for s in stamps) if stamps else None
    end_ns = max(int(s[-1]) for s in stamps) if stamps else None
    if start_ns is None and had_samples:
        window = f"from {start_s or 0:g} s to " + ("the end" if end_s is None else f"{end_s:g} s")
        warnings.warn(f"{where}: no /joint_states or /tf sample {window}; only latched data is replayed",
                      stacklevel=2)
    return Replay(
        path=where, format=rec.format, robot=robot, robot_description=description, frame_prefix=prefix,
        static=static, tf=tf, joint_states=joint_states, derived_static=frozenset(latched),
        derived_dynamic=frozenset(computed), origin_ns=origin, start_ns=start_ns, end_ns=end_ns,
        read_error=rec.read_error,
    )
