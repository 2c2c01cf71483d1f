"""``tfrec replay``: play a recording back into Rerun, as ``ros2 bag play`` plays one into RViz.

:func:`load_replay` reads any recording :func:`tfrec.formats.read_recording` reads (tfrec's or
``ros2 bag record``'s MCAP, rosbag2 folders with mcap or sqlite3 storage, ROS 1 bags, ``.rrd``)
and prepares what is played (:class:`~tfrec.replay.prepared.Replay`), robot by robot
(:func:`tfrec.robots.find_robots`: one per description and namespace, ``/robot1/tf``…): the
robot model (the recording's description, or one given), /tf_static and /tf per frame pair, and
/joint_states, cut to ``start_s``..``end_s``.

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
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import (
    JOINT_STATES,
    NS_PER_S,
    RECORDED_TOPICS,
    ROBOT_DESCRIPTION,
    TF,
    TF_STATIC,
    global_topic,
    namespace_name,
    offset_ns,
    robot_topic_kind,
)
from tfrec.errors import DescriptionError, LackingWarning, ReplayError, TfrecWarning
from tfrec.formats.reader import read_recording
from tfrec.frames import frame_tree, graph_problems
from tfrec.kinematics.fk import dynamic_transforms, static_transforms
from tfrec.kinematics.joints import apply_mimic
from tfrec.model import Robot
from tfrec.recording import FrameSeries, JointStates, RecordedRobot, Recording
from tfrec.replay.prepared import Replay
from tfrec.resample import data_end_ns, data_start_ns
from tfrec.robots import ParsedDescriptions, detect_frame_prefix, find_robots

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
"""The topics tfrec replays, those it records (in every namespace); a recording's other topics are skipped."""


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


def _check_topics(topics: Collection[str] | None) -> list[str]:
    """The selected topics (kinds like ``/tf``, or one namespace's ``/robot1/tf``), in the order of REPLAYED_TOPICS."""
    if topics is None:
        return list(REPLAYED_TOPICS)
    for topic in topics:
        if robot_topic_kind(topic) is None:
            raise ReplayError(f"topic '{topic}' cannot be replayed; tfrec replays {', '.join(REPLAYED_TOPICS)} "
                              "(of any namespace, e.g. /robot1/tf)")
    names = {global_topic(topic) for topic in topics}
    kinds = [topic for topic in REPLAYED_TOPICS if topic in names]
    return kinds + sorted(names - set(kinds))


def _selects(selected: Collection[str], namespace: str, kind: str) -> bool:
    """Whether one namespace's topic of a kind is replayed: its kind or its own name is selected."""
    return kind in selected or namespace + kind in selected


def _has(rec: Recording, topic: str) -> bool:
    """Whether the recording has messages on ``topic``: a full name, or a kind (``/tf``) in any namespace."""
    if topic in RECORDED_TOPICS:
        return any(info.count > 0 and (kind := robot_topic_kind(name)) is not None and kind[1] == topic
                   for name, info in rec.topics.items())
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
    robot: Robot, prefix: str, covered: set[str], joint_states: JointStates | None, where: str, joint_topic: str
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
        warnings.warn(f"{where}: no /tf and no {joint_topic} position for joint{'s' if plural else ''} {listed}; "
                      f"{'their links are' if plural else 'its link is'} not placed", LackingWarning, stacklevel=4)
    return latched, computed


def _model_of(found: RecordedRobot, where: str, *, required: bool, only: bool) -> Robot | None:
    """The model of a recorded description; an unusable one warns (or raises when required of the only robot)."""
    if found.problem is None:
        return found.model
    topic = found.namespace + ROBOT_DESCRIPTION
    who = "" if only else f"{found.label}: "
    if required and only:
        raise DescriptionError(f"{where}: {topic} is not a usable robot description: {found.problem}")
    warnings.warn(f"{where}: {who}{topic} is not a usable robot description ({found.problem}); "
                  "replaying without the robot model (give `robot` FILE)", TfrecWarning, stacklevel=4)
    return None


def _prepare(found: RecordedRobot, model: Robot | None, override: bool, selected: Collection[str],
             window: tuple[int, int], where: str, *, need_robot: bool, only: bool) -> RecordedRobot:
    """One robot's replay: its data within the window, and what its model adds."""
    if not override and not found.unclaimed:
        model = _model_of(found, where, required=need_robot, only=only)
        if found.robot_description is None and not need_robot:
            what = ("TF is replayed without robot geometry" if found.tf or found.tf_static
                    else "only the joint positions are replayed, with no robot model to move")
            who = "" if only else f"{found.label}: "
            warnings.warn(f"{where}: {who}no {found.namespace}{ROBOT_DESCRIPTION} in the recording and no `robot`: "
                          f"{what} (give `robot` FILE)", TfrecWarning, stacklevel=3)
    description = None
    if _selects(selected, found.namespace, ROBOT_DESCRIPTION):
        description = model.urdf if model is not None and model.urdf else found.robot_description
    static = dict(found.tf_static) if _selects(selected, found.tf_namespace, TF_STATIC) else {}
    recorded_tf = dict(found.tf) if _selects(selected, found.tf_namespace, TF) else {}
    joint_states = found.joint_states if _selects(selected, found.joint_states_namespace, JOINT_STATES) else None
    for problem in graph_problems(frame_tree([*static, *recorded_tf]), parents=False):
        who = "" if only else f"{found.label}: "
        warnings.warn(f"{where}: {who}{problem}; its transforms are replayed as recorded, and the robot is placed "
                      "along the others", TfrecWarning, stacklevel=3)
    prefix = found.frame_prefix
    if model is not None and (override or model is not found.model):
        prefix = detect_frame_prefix(model, [f for pair in list(static) + list(recorded_tf) for f in pair],
                                     namespace=found.namespace)
    lo, hi = window
    tf = {pair: _cut_series(series, lo, hi) for pair, series in recorded_tf.items()}
    if joint_states is not None:
        rows = (joint_states.time_ns >= lo) & (joint_states.time_ns <= hi)
        if not rows.all():
            joint_states = JointStates(joint_states.time_ns[rows], joint_states.names, joint_states.positions[rows])
    latched: dict[Pair, tuple[Array, Array]] = {}
    computed: dict[Pair, FrameSeries] = {}
    if model is not None:
        covered = {child for _, child in list(static) + list(recorded_tf)}
        latched, computed = _transforms_not_recorded(model, prefix, covered, joint_states, where,
                                                     found.joint_states_namespace + JOINT_STATES)
        static.update(latched)
        tf.update(computed)
    return replace(found, descriptions=() if description is None else (description,), model=model,
                   frame_prefix=prefix, tf_static=static, tf=tf, joint_states=joint_states,
                   derived_static=frozenset(latched), derived_dynamic=frozenset(computed))


def _display_prefixes(robots: list[RecordedRobot]) -> list[RecordedRobot]:
    """Robots of several namespaces' /tf that use the same frame ids are shown apart: each
    namespace's frames behind its name (``robot1/base_link``)."""
    frames: dict[str, set[str]] = {}
    for robot in robots:
        frames.setdefault(robot.tf_namespace, set()).update(robot.frames())
    if len(frames) < 2:
        return robots
    shared = {frame for ns, own in frames.items() for other, theirs in frames.items() if other != ns
              for frame in own & theirs}
    return [replace(robot, display_prefix=robot.tf_namespace.strip("/") + "/")
            if shared & frames[robot.tf_namespace] and robot.tf_namespace.strip("/") else robot for robot in robots]


def load_replay(
    path: str | os.PathLike[str],
    *,
    robot: Robot | None = None,
    topics: Collection[str] | None = None,
    start_s: float | None = None,
    end_s: float | None = None,
    need_robot: bool = False,
    namespace: str | None = None,
    remap: Iterable[str] | Mapping[str, str] | None = None,
    use_log_time: bool = False,
) -> Replay:
    """Read a recording and prepare it for :func:`tfrec.replay.play.play` (or for checking).

    Args:
        path: a recording (``.mcap``, rosbag2 folder, ROS 1 ``.bag``, ``.rrd``).
        robot: a robot model that overrides the recording's description (of its only robot,
            or of the robot ``namespace`` picks).
        topics: replay only these of /robot_description, /tf_static, /joint_states and /tf (in
            every namespace), or of one namespace (``/robot1/tf``).
        start_s, end_s: replay the samples stamped this many seconds after the recording's
            start, its first /joint_states or /tf stamp (:func:`tfrec.resample.data_start_ns`).
        need_robot: raise, rather than warn, when the only robot's description is unusable.
        namespace: replay only the robots of this namespace (``/robot1``; ``/`` the root's).
        remap: ``FROM:=TO`` topic remapping rules, applied as ROS applies them.
        use_log_time: replay by log time instead of header stamps (stamps that are 0).

    Returns:
        The prepared replay; a damaged MCAP gives what was readable, with ``read_error`` set.

    Raises:
        ReplayError: an unknown topic, a bad time window, a path that is not a recording, a
            recording with none of the selected topics, no robot in ``namespace``, a ``robot``
            for a recording of several robots, or ``start_s`` past its last sample.
        DescriptionError: ``need_robot`` and a description that is not a valid URDF.
        ReadError: a bad remapping rule, an unreadable file.
    """
    _check_window(start_s, end_s)
    selected = _check_topics(topics)
    rec = read_recording(path, topics=_read_topics(selected, robot), namespace=namespace, remap=remap,
                         use_log_time=use_log_time)
    return _prepare_recording(rec, os.fspath(path), selected, robot=robot, given=topics is not None,
                              window=(start_s, end_s), need_robot=need_robot, namespace=namespace)


def _read_topics(selected: Collection[str], robot: Robot | None) -> set[str]:
    """What is read of a recording to replay ``selected``: the time series whatever is selected (the recording's
    start counts from them), the description unless a robot is given."""
    return {*selected, JOINT_STATES, TF, *(() if robot is not None else (ROBOT_DESCRIPTION,))}


def _prepare_recording(rec: Recording, where: str, selected: list[str], *, robot: Robot | None, given: bool,
                       window: tuple[float | None, float | None], need_robot: bool, namespace: str | None,
                       parsed: ParsedDescriptions | None = None) -> Replay:
    """:func:`load_replay` of a recording read (or of a piece of one, :func:`replay_pieces`, whose descriptions are
    parsed once: ``parsed``)."""
    start_s, end_s = window
    absent = [topic for topic in selected if not _has(rec, topic)]
    if len(absent) == len(selected):
        rec_kind = " (an .rrd not written by tfrec?)" if rec.format == "rrd" and not rec.topics else ""
        raise ReplayError(f"{where}: no {_listed(absent)} in the recording{rec_kind}; nothing to replay")
    if given and absent:
        warnings.warn(f"{where}: no {', '.join(absent)} in the recording", TfrecWarning, stacklevel=3)
    ns = None if namespace is None else namespace_name(namespace)
    found = find_robots(rec, namespace=ns, parsed=parsed)
    if not found:
        names = ", ".join(name or "/" for name in rec.topic_namespaces()) or "none"
        raise ReplayError(f"{where}: no robot in `namespace` {ns or '/'} (the recording's namespaces: {names})")
    robots_found = [r for r in found if not r.unclaimed]
    if robot is not None and len(robots_found) > 1:
        raise ReplayError(f"{where}: `robot` is one model, and the recording holds {len(robots_found)} robots "
                          f"({', '.join(r.key for r in robots_found)}): pick one with `namespace`")
    origin = data_start_ns(rec) or 0
    last = data_end_ns(rec)
    if start_s is not None and origin + offset_ns(start_s) > (origin if last is None else last):
        end = 0.0 if last is None else (last - origin) / NS_PER_S
        damaged = "" if rec.read_error is None else f"; the file is damaged: {rec.read_error}"
        raise ReplayError(f"{where}: `start_s` {start_s:g} s is beyond the recording's end ({end:g} s){damaged}")
    lo = origin + (0 if start_s is None else offset_ns(start_s))
    hi = int(np.iinfo(np.int64).max) if end_s is None else origin + offset_ns(end_s)
    had_samples = any(len(s) for r in found for s in r.tf.values()) or any(
        r.joint_states is not None and len(r.joint_states) > 0 for r in found)
    found = [r for r in found if any(_selects(selected, ns, kind) for ns, kind in (
        (r.namespace, ROBOT_DESCRIPTION), (r.tf_namespace, TF), (r.tf_namespace, TF_STATIC),
        (r.joint_states_namespace, JOINT_STATES)))] or found[:1]  # robots of which nothing is selected are left out
    only = len(found) == 1
    robots = [_prepare(r, robot if robot is not None and not r.unclaimed else r.model,
                       robot is not None and not r.unclaimed, selected, (lo, hi), where,
                       need_robot=need_robot, only=only) for r in found]
    robots = _display_prefixes(robots)
    stamps = [s.time_ns for r in robots for s in r.tf.values() if len(s)]
    stamps += [r.joint_states.time_ns for r in robots if r.joint_states is not None and len(r.joint_states)]
    start_ns = min(int(s[0]) for s in stamps) if stamps else None
    end_ns = max(int(s[-1]) for s in stamps) if stamps else None
    if start_ns is None and had_samples:
        span = f"from {start_s or 0:g} s to " + ("the end" if end_s is None else f"{end_s:g} s")
        warnings.warn(f"{where}: no /joint_states or /tf sample {span}; only latched data is replayed", LackingWarning,
                      stacklevel=2)
    return Replay(path=where, format=rec.format, robots=robots, origin_ns=origin, start_ns=start_ns, end_ns=end_ns,
                  read_error=rec.read_error, time_base=rec.time_base)
