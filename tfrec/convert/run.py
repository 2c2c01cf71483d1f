"""``tfrec convert IN OUT``: a recording cut, filtered and written as another format.

:func:`convert` checks every option and the target before anything is read, reads the input's
summary (:func:`tfrec.formats.read_recording` with ``summary=True``: from the file's index) for
its span and robots, plans the TF computed from joint states (:mod:`tfrec.convert.joints`), and
streams the messages through a :class:`~tfrec.convert.stream.Copier` into a temporary file beside
the target, renamed when complete (:class:`tfrec._atomic.AtomicOutputs`). An ``.rrd`` target is
written as ``tfrec replay --save`` writes one.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from tfrec._atomic import AtomicOutputs
from tfrec._outputs import OutputKind, check_target
from tfrec.conventions import (
    COMPRESSIONS,
    NS_PER_S,
    RECORDED_TOPICS,
    ROS1_COMPRESSIONS,
    global_topic,
    namespace_name,
    offset_ns,
    split_topic,
)
from tfrec.convert.joints import plan_derivations
from tfrec.convert.stream import Copier, CopyReport
from tfrec.errors import ConvertError, TfrecWarning
from tfrec.formats.kinds import MCAP, ROS1_BAG, ROSBAG2, RRD
from tfrec.formats.output import open_output
from tfrec.formats.reader import identify_recording, read_recording
from tfrec.formats.ros.joint_names import repeated_joints
from tfrec.formats.source import listed_extras, open_messages
from tfrec.model import Robot
from tfrec.recording import Recording
from tfrec.resample import log_start_ns
from tfrec.robots import find_robots

__all__ = ["ConvertResult", "check_convert_target", "convert", "output_kind"]

_KINDS = {".mcap": "mcap", ".bag": "rosbag1", ".rrd": "rrd"}
_NAMES = {"mcap": "ROS 2 MCAP", "rosbag1": "ROS 1 bag", "rosbag2": "rosbag2 folder", "rrd": "Rerun recording"}
_OUTPUT_KINDS: dict[str, OutputKind] = {"mcap": MCAP, "rosbag1": ROS1_BAG, "rosbag2": ROSBAG2, "rrd": RRD}


@dataclass
class ConvertResult:
    """What :func:`convert` wrote.

    Attributes:
        target: the output (a file, or a rosbag2 folder).
        kind: ``mcap``, ``rosbag1``, ``rosbag2`` or ``rrd``.
        report: messages written, dropped, left out, latched, TF computed (None for an ``.rrd``).
        window: the cut, seconds from the recording's start (None for either bound: none).
    """

    target: Path
    kind: str
    report: CopyReport | None
    window: tuple[float | None, float | None] = (None, None)

    @property
    def description(self) -> str:
        """``ROS 1 bag``, ``rosbag2 folder``…"""
        return _NAMES[self.kind]


def output_kind(target: str | os.PathLike[str] | None, bag: str | os.PathLike[str] | None) -> tuple[Path, str]:
    """The output and its kind: ``mcap``, ``rosbag1``, ``rrd`` (by the target's extension) or
    ``rosbag2`` (``bag``, a folder).

    Raises:
        ConvertError: neither or both of `target` and `bag`, or an extension that is none of
            ``.mcap``, ``.bag``, ``.rrd``.
    """
    if (target is None) == (bag is None):
        raise ConvertError("give an output: OUT.mcap, OUT.bag or OUT.rrd, or `bag` for a rosbag2 folder"
                           if target is None else "OUT and `bag` exclude each other: one output at a time")
    if bag is not None:
        return Path(bag), "rosbag2"
    path = Path(target)  # type: ignore[arg-type]  # not None here
    kind = _KINDS.get(path.suffix)
    if kind is None:
        raise ConvertError(f"{path}: the output's name must end in .mcap (ROS 2), .bag (ROS 1) or .rrd (Rerun), "
                           "or give `bag` for a rosbag2 folder")
    return path, kind


def check_convert_target(target: Path, kind: str, *, compression: str | None, force: bool,
                         inputs: Sequence[str | os.PathLike[str] | None] = ()) -> None:
    """Check the output before anything is read: its compression, and that it may be written
    (:func:`tfrec._outputs.check_target`).

    Args:
        inputs: what the conversion reads (the recording, ``--robot``'s description): never the output.

    Raises:
        ConvertError: a compression the format does not have.
        WriteError: an existing output without ``force``, one that is not what tfrec writes there (a file where
            a folder goes, a folder with other files…), or an input.
    """
    allowed = {"mcap": COMPRESSIONS, "rosbag2": COMPRESSIONS, "rosbag1": ROS1_COMPRESSIONS, "rrd": ()}[kind]
    if compression is not None and compression not in allowed:
        if not allowed:
            raise ConvertError(f"`compression` does not apply to a {_NAMES[kind]}")
        raise ConvertError(f"`compression` '{compression}' is not one of {', '.join(allowed)} for a {_NAMES[kind]}")
    check_target(target, _OUTPUT_KINDS[kind], force=force, inputs=inputs)


def _check_window(start_s: float | None, end_s: float | None) -> None:
    for name, value in (("`start_s`", start_s), ("`end_s`", end_s)):
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise ConvertError(f"{name} {value} is not a time in seconds >= 0")
    if start_s is not None and end_s is not None and end_s < start_s:
        raise ConvertError(f"`end_s` {end_s:g} is before `start_s` {start_s:g}")


def convert(  # noqa: PLR0913 - the keyword-only options of tfrec convert
    source: str | os.PathLike[str],
    target: str | os.PathLike[str] | None = None,
    *,
    bag: str | os.PathLike[str] | None = None,
    start_s: float | None = None,
    end_s: float | None = None,
    topics: Collection[str] | None = None,
    exclude: Collection[str] = (),
    namespace: str | None = None,
    remap: Iterable[str] | Mapping[str, str] | None = None,
    tf_from_joints: bool | None = None,
    robot: Robot | None = None,
    compression: str | None = None,
    force: bool = False,
    package_paths: Sequence[str | os.PathLike[str]] = (),
) -> ConvertResult:
    """Convert a recording: cut it, filter its topics, add the TF its joint states imply, and write
    it as a ROS 2 MCAP, a rosbag2 folder, a ROS 1 bag or a Rerun recording.

    Args:
        source: an MCAP file, a rosbag2 folder or a ROS 1 bag (for an ``.rrd`` target, anything
            ``replay`` plays).
        target: ``OUT.mcap``, ``OUT.bag`` or ``OUT.rrd``.
        bag: a rosbag2 folder to write instead (``metadata.yaml`` + MCAP).
        start_s, end_s: keep the messages logged this many seconds after the recording's start
            (when its first /joint_states or /tf message was logged, as ``replay`` counts), up to
            ``end_s``. The last message before ``start_s`` of every latched topic is written at the cut.
        topics: write only these topics (names as played, after `remap`); None: all.
        exclude: leave these topics out.
        namespace: only this namespace's topics, and the root's /tf, /tf_static and /joint_states
            its robots read.
        remap: ``FROM:=TO`` topic remapping rules, applied as ROS applies them.
        tf_from_joints: compute /tf (and /tf_static) from the joint states and the description for
            the joints the recorded TF lacks: True always, False never, None (default) when a
            robot's /tf lacks some of its moving joints.
        robot: a robot model for the only robot (or `namespace`'s): its TF is computed with it,
            and its URDF replaces the recorded /robot_description.
        compression: MCAP (and rosbag2) ``zstd`` (default), ``lz4`` or ``none``; ROS 1 ``none``
            (default), ``bz2`` or ``lz4``.
        force: overwrite an existing output.
        package_paths: where meshes' packages are found (an ``.rrd``'s geometry).

    Returns:
        What was written; warnings (``warnings.warn``) name every topic dropped and why, and what
        a damaged input lost.

    Raises:
        ConvertError: bad options, an output name with another extension, a cut that starts
            after the recording's end.
        ReadError: a missing or unreadable input, a bad `remap` rule.
        WriteError: an existing output without ``force``, or one that cannot be written.
    """
    path, kind = output_kind(target, bag)
    _check_window(start_s, end_s)
    if kind == "rrd":
        return _to_rerun(source, path, start_s=start_s, end_s=end_s, topics=topics, exclude=exclude,
                         namespace=namespace, remap=remap, tf_from_joints=tf_from_joints, robot=robot,
                         compression=compression, force=force, package_paths=package_paths)
    check_convert_target(path, kind, compression=compression, force=force, inputs=[source])
    found = identify_recording(source)
    where = os.fspath(found.path)
    if found.format == "rrd":
        raise ConvertError(f"{where}: a Rerun recording converts only to an .rrd (it holds no ROS messages)")
    summary = read_recording(found, summary=True, remap=remap)
    ns = None if namespace is None else namespace_name(namespace)
    origin = log_start_ns(summary)
    lo = hi = None
    if origin is not None:
        lo = None if start_s is None else origin + offset_ns(start_s)
        hi = None if end_s is None else origin + offset_ns(end_s)
        end = summary.end_ns if summary.end_ns is not None else origin
        if lo is not None and lo > end:
            raise ConvertError(f"{where}: `start_s` {start_s:g} s is beyond the recording's end "
                               f"({(end - origin) / NS_PER_S:g} s)")
    derivations = [] if tf_from_joints is False else plan_derivations(summary, mode=tf_from_joints, robot=robot,
                                                                        namespace=ns)
    produced = {topic for d in derivations for topic in (d.tf_topic, d.static_topic, d.description_topic)}
    selected = _selection(summary, topics=topics, exclude=exclude, namespace=ns, produced=produced)
    with AtomicOutputs(replace=force) as outputs:
        temp = outputs.path(path, kind=_OUTPUT_KINDS[kind])
        writer = open_output(temp, kind=kind, compression=compression, name=path.name)
        try:
            with open_messages(found, remap=remap) as messages:
                report = Copier(messages, writer, selected=selected, lo=lo, hi=hi,
                                start_ns=summary.start_ns or 0, derivations=derivations).run()
            writer.finish()
        except BaseException:
            writer.abort()
            raise
        outputs.commit()
    _warn(report, where)
    for d in derivations:
        unseen = {name: count for name, count in d.repeated.items() if name not in d.warned}
        if unseen:
            warnings.warn(repeated_joints(where, d.joint_topic, unseen), TfrecWarning, stacklevel=2)
    return ConvertResult(path, kind, report, (start_s, end_s))


def _selection(summary: Recording, *, topics: Collection[str] | None, exclude: Collection[str],
               namespace: str | None, produced: set[str]) -> _Selected:
    """What is written, from the options; a topic named that the recording does not have (and the
    copy does not write either: ``produced``) warns.

    Raises:
        ConvertError: a `namespace` that holds no topic.
    """
    chosen = None if topics is None else {global_topic(t) for t in topics}
    left = {global_topic(t) for t in exclude}
    shared: set[str] = set()
    if namespace is not None:
        spaces = {split_topic(t)[0] for t in summary.topics}
        if not any(split_topic(t)[0] == namespace or t.startswith(namespace + "/") for t in summary.topics):
            listed = ", ".join(sorted(space or "/" for space in spaces)) or "none"
            raise ConvertError(f"{summary.path}: no topic in `namespace` {namespace or '/'} (the recording's "
                               f"namespaces: {listed})")
        for r in find_robots(summary, namespace=namespace):
            shared |= {r.tf_namespace + "/tf", r.tf_namespace + "/tf_static", r.joint_states_namespace + "/joint_states"}
    recorded = set(summary.topics) | produced
    absent = sorted(t for t in (chosen or set()) | left if t not in recorded)
    if absent:
        warnings.warn(f"{summary.path}: no {', '.join(absent)} in the recording", TfrecWarning, stacklevel=3)
    return _Selected(chosen, left, namespace, shared)


@dataclass(frozen=True)
class _Selected:
    """Whether a topic is written: chosen (or all), not excluded, and in the namespace."""

    chosen: set[str] | None
    excluded: set[str]
    namespace: str | None
    shared: set[str]

    def __call__(self, topic: str) -> bool:
        if topic in self.excluded or (self.chosen is not None and topic not in self.chosen):
            return False
        if self.namespace is None or topic in self.shared:
            return True
        return topic.startswith(self.namespace + "/") if self.namespace else split_topic(topic)[0] == ""


def _warn(report: CopyReport, where: str) -> None:
    for topic, note in report.notes.items():
        warnings.warn(f"{where}: {topic}: {note}", TfrecWarning, stacklevel=3)
    for topic, (count, reason) in report.dropped.items():
        warnings.warn(f"{where}: {topic}: {count:,} message{'s' if count != 1 else ''} not written: {reason}", TfrecWarning,
                      stacklevel=3)
    reasons: dict[str, list[str]] = {}
    for what, why in report.extras_left_out:
        reasons.setdefault(why, []).append(what)
    for why, whats in reasons.items():
        warnings.warn(f"{where}: {', '.join(whats)} not written: {why}", TfrecWarning, stacklevel=3)
    if report.read_error is not None:
        warnings.warn(f"{report.read_error}; converted up to there", TfrecWarning, stacklevel=3)


def _to_rerun(  # noqa: PLR0913 - convert's options, for an .rrd
        source: str | os.PathLike[str], target: Path, *, start_s: float | None, end_s: float | None,
        topics: Collection[str] | None, exclude: Collection[str], namespace: str | None,
        remap: Iterable[str] | Mapping[str, str] | None, tf_from_joints: bool | None, robot: Robot | None,
        compression: str | None, force: bool, package_paths: Sequence[str | os.PathLike[str]]) -> ConvertResult:
    """An ``.rrd``, as ``tfrec replay --save`` writes it."""
    from tfrec.replay.load import load_replay
    from tfrec.replay.play import check_play_options, replay_to_rerun

    check_convert_target(target, "rrd", compression=compression, force=force, inputs=[source])
    if tf_from_joints is False:
        raise ConvertError("`no_tf_from_joints` does not apply to an .rrd: it is written as replay plays, with "
                           "the TF that /tf lacks computed from /joint_states")
    check_play_options(save=target, connect=None, rate=1.0, loop=False, force=force, inputs=[source])
    chosen = list(RECORDED_TOPICS) if topics is None else [global_topic(t) for t in topics]
    left = {global_topic(t) for t in exclude}
    replay = load_replay(source, robot=robot, topics=[t for t in chosen if t not in left], start_s=start_s,
                         end_s=end_s, namespace=namespace, remap=remap)
    replay.report_damage()
    replay_to_rerun(replay, save=target, package_paths=package_paths, force=force, checked=True)
    extras = listed_extras(identify_recording(source))
    if extras:
        warnings.warn(f"{os.fspath(source)}: {', '.join(extra.shown for extra in extras)} not written: a Rerun "
                      "recording of the replay holds no attachments or metadata records", TfrecWarning, stacklevel=3)
    return ConvertResult(target, "rrd", None, (start_s, end_s))
