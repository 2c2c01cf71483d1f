"""``tfrec diff``: compare two recordings by meaning, not by bytes.

:func:`compare` reads two recordings of any format (:func:`tfrec.formats.read_recording`) and
compares the robot description as URDF (:mod:`tfrec.diff.urdf`), the topics (presence, message
counts, time span), the joint positions per joint and the transforms per (parent, child) pair,
static and dynamic. The result is a :class:`DiffReport`; :func:`assert_recordings_match` turns
one into a failing test with the readable report.

A /tf_static whose messages hold no transforms (tfrec records one for a robot without fixed
joints; its ``.rrd`` has none) is the same as no /tf_static: the report's notes say so.

Robots (:func:`tfrec.robots.find_robots`): compared robot by robot (:func:`tfrec.robots.pair_robots`),
each difference naming its robot; joint states namespace by namespace. Frame ids as tf2 sees them.

Time: samples are aligned by time since each recording's start, so two recordings made at
different wall-clock times compare; ``absolute=True`` aligns on the stamps. A recording's start
(:func:`tfrec.resample.data_start_ns`) is the first stamp of its time series, /joint_states or /tf, whichever
comes first — not its first message: a latched /robot_description or /tf_static published
seconds before the data does not shift it. ``tfrec replay --start`` counts from the same start.
The topic table's spans are log times, counted from when that first message was logged: sim-time
stamps and the log's wall clock never mix.
Where A's times fall between B's samples, B is interpolated at A's times — linearly for joint
positions and translations, by slerp for rotations — and the report says so (not when B merely
has more samples or a longer span, its samples at A's times where both have data). A's samples
outside B's time span have no counterpart and are reported as such.

Float32: when either recording stores transforms as float32 (an ``.rrd``), a transform compares
within what float32 can tell apart at its magnitude — ``max(pos_tol, 4·eps32·|t|)`` for a
translation ``t`` (m) and ``max(rot_tol, 4·eps32)`` for a rotation (rad), eps32 = 2⁻²³ — so a
recording equals its own ``.rrd``; the report's notes say when and by how much this widened a
tolerance.

Memory: two paths are read piece by piece (:func:`tfrec.formats.reader.read_pieces`), in memory that does not
grow with their length: a first walk finds each series' span (count, first and last stamp), the robots and each
recording's start; a second feeds A's and B's pieces together in time order to one fold per compared series
(:mod:`tfrec.diff.fold`), which keeps B's samples around A's across piece edges and folds what the report says.
A recording of one piece (up to :data:`~tfrec.formats.reader.PIECE_MESSAGES` /tf and /joint_states messages) is
read once and kept as it is. Recordings given as :class:`Recording` objects, ``whole=True`` (``--plot`` draws
every sample) and a series whose stamps go back or repeat (the whole series compares them exactly) are read whole:
one piece each, the same folds. The report's ``whole`` says whether its recordings hold every sample (what
:func:`tfrec.plots.errors_from_diff` plots).

Errors: a translation error is the distance between the two translations (m); a rotation error
is the angle of the relative rotation ``q_a⁻¹ q_b``, ``2·atan2(|v|, |w|)``
(:func:`tfrec.kinematics.rotations.rotation_error`, rad); a joint error is the absolute difference of the
positions (rad or m).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping
from dataclasses import replace
from itertools import chain
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import DIFF_JOINT_TOL as DEFAULT_JOINT_TOL
from tfrec.conventions import DIFF_POS_TOL as DEFAULT_POS_TOL
from tfrec.conventions import DIFF_ROT_TOL as DEFAULT_ROT_TOL
from tfrec.conventions import (
    FLOAT32_TOL,
    JOINT_STATES,
    NS_PER_S,
    ROBOT_DESCRIPTION,
    TF,
    TF_STATIC,
    namespace_name,
    split_topic,
)
from tfrec.diff.fold import ErrorFold, SeriesFold, SeriesSpan
from tfrec.diff.precision import FLOAT32_ULPS, float32_tolerance
from tfrec.diff.report import Difference, DiffReport, Largest, at_time, format_time
from tfrec.diff.topics import renamed_b_topics, same_type
from tfrec.errors import DiffError, TfrecWarning, display_path
from tfrec.formats._collect import decodes_type
from tfrec.formats.reader import read_pieces, read_recording
from tfrec.kinematics.rotations import rotation_error
from tfrec.recording import FrameSeries, JointStates, Recording
from tfrec.resample import Alignment, data_start_ns, log_start_ns
from tfrec.robots import ParsedDescriptions, RecordedRobot, find_robots, pair_robots

__all__ = [
    "DEFAULT_JOINT_TOL",
    "DEFAULT_POS_TOL",
    "DEFAULT_ROT_TOL",
    "FLOAT32_TOL",
    "FLOAT32_ULPS",
    "DiffReport",
    "Difference",
    "compare",
    "data_start_ns",
    "float32_tolerance",
    "rotation_error",
]

Array = NDArray[np.float64]
Pair = tuple[str, str]


def _num(x: float) -> str:
    return f"{x:.3g}"


def _rate(span: SeriesSpan | None) -> str:
    count = 0 if span is None else span.count
    if span is None or count < 2 or span.last == span.first:
        return f"{count} samples"
    return f"{(count - 1) / ((span.last - span.first) / NS_PER_S):.4g} Hz"


class _Comparison:
    def __init__(self, a: Recording, b: Recording, report: DiffReport, topics: Collection[str] | None,
                 absolute: bool, namespace: str | None = None) -> None:
        self.a, self.b, self.report = a, b, report
        self.namespace = namespace  # only this namespace's topics and robots
        self._found: tuple[list[RecordedRobot], list[RecordedRobot]] | None = None
        self.topics = topics
        self.absolute = absolute
        self.pos_tol = report.tolerances["pos_tol"]
        self.rot_tol = report.tolerances["rot_tol"]
        self.joint_tol = report.tolerances["joint_tol"]
        self.interpolated: dict[str, list[str]] = {}  # "(A 50 Hz, B 100 Hz)" → what
        self.float32 = a.float32 or b.float32
        self.widened: dict[str, float] = {}  # quantity → the largest float32 tolerance used above the user's
        self.origin_a = 0 if absolute else data_start_ns(a) or 0
        self.origin_b = 0 if absolute else data_start_ns(b) or 0
        self.log_origin_a = 0 if absolute else log_start_ns(a) or 0  # the topic table's log times count from these
        self.log_origin_b = 0 if absolute else log_start_ns(b) or 0
        self.who = ""  # "robot /robot1: " while comparing one robot of several
        self.spans: dict[SeriesKey, SeriesSpan] = {}  # of the series of A and B, times since each start
        self.feeds: dict[SeriesKey, list[tuple[SeriesFold, tuple[str, ...]]]] = {}  # → the folds it feeds (joints)
        self.folds: list[SeriesFold] | None = None
        self.emitting = False
        self.cursor = 0

    def wants(self, topic: str) -> bool:
        return self.topics is None or topic in self.topics

    def diff(self, kind: str, what: str, detail: str, time_ns: int | None = None, value: float | None = None) -> None:
        self.report.differences.append(Difference(kind, self.who + what, self.who + detail, time_ns, value))

    def largest(self, quantity: str, value: float, what: str, time_ns: int | None) -> None:
        current = self.report.largest.get(quantity)
        if current is None or value > current.value:
            self.report.largest[quantity] = Largest(value, self.who + what, time_ns)

    # -- robots -------------------------------------------------------------------------------

    def robots(self, sides: tuple[Iterable[Recording], Iterable[Recording]]) -> None:
        """Compare the recordings robot by robot (see the module docstring), their time series read from ``sides``
        (A's pieces, B's): the comparisons are planned (each series' fold made), the pieces fed to the folds, then
        everything is reported in the order planned."""
        report = self.report
        notes, differences, largest = len(report.notes), list(report.differences), dict(report.largest)
        self.folds = []
        self._robots()
        del report.notes[notes:]
        report.differences[:], report.largest = differences, largest
        _walk(self, sides)
        self.emitting = True
        self._robots()

    def _robots(self) -> None:
        pairs = pair_robots(*self.found_robots())
        several = len(pairs) > 1
        joint_states: set[tuple[str, str]] = set()
        for ra, rb in pairs:
            self.who = f"{(ra or rb).label}: " if several else ""  # type: ignore[union-attr]
            if ra is None or rb is None:
                side = "A" if rb is None else "B"
                robot = ra or rb
                assert robot is not None
                self.who = ""
                self.diff("robot", robot.label, f"{robot.label} only in {side} ({robot.contents()})")
                continue
            self.description(ra.robot_description, rb.robot_description)
            self.transforms(ra, rb)
            if (ra.joint_states_namespace, rb.joint_states_namespace) not in joint_states:
                joint_states.add((ra.joint_states_namespace, rb.joint_states_namespace))
                self.who = f"{ra.joint_states_namespace or '/'}: " if several else ""
                self.joint_states(ra.joint_states, rb.joint_states,
                                  (ra.joint_states_namespace, rb.joint_states_namespace))
        self.who = ""

    # -- the robot description ----------------------------------------------------------------

    def description(self, da: str | None, db: str | None) -> None:
        if not self.wants(ROBOT_DESCRIPTION) or not self.emitting:  # planning the comparisons: nothing to fold
            return
        for rec, own, other in ((self.a, da, db), (self.b, db, da)):
            if own is None and other is not None and rec.format == "rrd":
                self.report.notes.append(
                    f"the robot description is not in {rec.path} (an .rrd without /robot_description)"
                )
        if da is None or db is None:
            return  # a missing /robot_description topic is reported with the topics
        from tfrec.diff.urdf import diff_urdf_texts

        changes = diff_urdf_texts(da, db, pos_tol=self.pos_tol, rot_tol=self.rot_tol, value_tol=self.joint_tol)
        for change in changes:
            self.diff("description", change.what, change.detail)
        if not changes and da != db:
            self.report.notes.append(
                "the robot descriptions differ as text but not in anything tfrec compares "
                "(names, links, joints, visuals)"
            )

    # -- topics -------------------------------------------------------------------------------

    def found_robots(self) -> tuple[list[RecordedRobot], list[RecordedRobot]]:
        """The robots of A and B (of ``namespace``), found once."""
        if self._found is None:
            parsed = ParsedDescriptions()  # a description A and B share is parsed once
            self._found = (find_robots(self.a, namespace=self.namespace, parsed=parsed),
                           find_robots(self.b, namespace=self.namespace, parsed=parsed))
        return self._found

    def b_topic_names(self) -> dict[str, str]:
        """B's robot topics under A's names (see :func:`tfrec.diff.topics.renamed_b_topics`)."""
        return renamed_b_topics(*self.found_robots(), self.b.topics)

    def topic_table(self) -> None:
        a, b = self.a, self.b
        renamed = self.b_topic_names()
        b_topics = {renamed.get(name, name): info for name, info in b.topics.items()}
        if renamed:
            listed = ", ".join(f"{nb} as {na}" for nb, na in sorted(renamed.items()))
            self.report.notes.append(f"one robot each, in different namespaces: B's {listed}")
        names = sorted(set(a.topics) | set(b_topics))
        ros_types = "rrd" not in (a.format, b.format)
        for name in names:
            if not self.wants(name) or (self.namespace is not None and split_topic(name)[0] != self.namespace):
                continue
            ia, ib = a.topics.get(name), b_topics.get(name)
            if ia is None or ib is None:
                side, info, rec = ("A", ia, a) if ib is None else ("B", ib, b)
                assert info is not None
                namespace = name[: -len(TF_STATIC)]
                if info.count == 0:  # offered, never published on: robot_state_publisher's /tf without moving joints
                    self.report.notes.append(f"{name} only in {side}, without messages: the same as no {name}")
                    continue
                if (name.endswith(TF_STATIC) and not rec.robot_topics(namespace).tf_static
                        and decodes_type(name, info.type)):
                    self.report.notes.append(
                        f"{name} only in {side}, whose {info.count} message{'s' if info.count != 1 else ''} "
                        f"hold{'s' if info.count == 1 else ''} no transforms: the same as no {name}"
                    )
                    continue
                self.diff("topic", name, f"{name} only in {side} ({info.count} messages of {info.type})")
                continue
            if ros_types and same_type(ia.type) != same_type(ib.type):
                self.diff("topic", name, f"{name}: type {ia.type} in A, {ib.type} in B")
            if ia.count != ib.count:
                self.diff("topic", name, f"{name}: {ia.count} messages in A, {ib.count} in B")
            if None not in (ia.first_ns, ia.last_ns, ib.first_ns, ib.last_ns):  # log times, on the log's clock
                span_a = (ia.first_ns - self.log_origin_a, ia.last_ns - self.log_origin_a)  # type: ignore[operator]
                span_b = (ib.first_ns - self.log_origin_b, ib.last_ns - self.log_origin_b)  # type: ignore[operator]
                if span_a != span_b:
                    self.diff(
                        "topic", name,
                        f"{name}: messages from t={format_time(span_a[0])} to {format_time(span_a[1])} s in A, "
                        f"from t={format_time(span_b[0])} to {format_time(span_b[1])} s in B",
                    )

    # -- samples ------------------------------------------------------------------------------

    def coverage(self, kind: str, what: str, fold: SeriesFold) -> None:
        if fold.missing:
            self.diff(
                kind, what,
                f"{what}: {fold.missing} sample(s) of A from t={format_time(fold.missing_first)} "
                f"to {format_time(fold.missing_last)} s have no data in B",
                fold.missing_first,
            )
        if fold.outside:
            self.diff(kind, what, f"{what}: {fold.outside} sample(s) of B lie outside A's time span (no data in A)")

    def errors(self, kind: str, what: str, quantity: str, unit: str, tol: float | None, fold: ErrorFold) -> None:
        """Report the largest error and when it first exceeds its tolerance (``tol``: the one for all samples, or
        None for one per sample)."""
        if fold.count == 0 or fold.worst is None:
            return
        value = fold.worst
        self.largest(quantity, value, what, fold.worst_time)
        if fold.first_over is None:
            return
        first_time, first_tol = fold.first_over
        unit = f" {unit}" if unit else ""
        if math.isinf(value):
            detail = (
                f"{what}: {quantity} in one recording only (NaN in the other) in {fold.missing} of "
                f"{fold.count} samples, first{at_time(fold.first_missing)}"
            )
            finite = fold.finite_max
            if finite is not None and (finite > tol if tol is not None else fold.finite_over):
                detail += f"; elsewhere it differs by up to {_num(finite)}{unit}"
        else:
            detail = (
                f"{what}: {quantity} differs by up to {_num(value)}{unit}{at_time(fold.worst_time)}; "
                f"first above {first_tol:g}{unit}{at_time(first_time)} ({fold.over} of {fold.count} samples)"
            )
        self.diff(kind, what, detail, first_time, value)

    def note_interpolation(self, what: str, fold: SeriesFold) -> None:
        if fold.interpolates:
            self.interpolated.setdefault(f"A {_rate(fold.a)}, B {_rate(fold.b)}", []).append(what)

    def _fold(self, make: Callable[[], SeriesFold]) -> SeriesFold | None:
        """A series' fold: made while the comparisons are planned, the same one when they are reported."""
        if self.folds is None:
            return None
        if self.emitting:
            fold = self.folds[self.cursor]
            self.cursor += 1
            return fold
        fold = make()
        self.folds.append(fold)
        return fold

    def joint_states(self, ja: JointStates | None, jb: JointStates | None, namespaces: tuple[str, str]) -> None:
        if not self.wants(JOINT_STATES) or ja is None or jb is None:
            return
        column_a = {name: k for k, name in enumerate(ja.names)}  # dicts: 50,000 joints are linear
        column_b = {name: k for k, name in enumerate(jb.names)}
        for name in ja.names:
            if name not in column_b:
                self.diff("joint_states", f"joint '{name}'", f"joint '{name}' only in A's /joint_states")
        for name in jb.names:
            if name not in column_a:
                self.diff("joint_states", f"joint '{name}'", f"joint '{name}' only in B's /joint_states")
        common = tuple(name for name in ja.names if name in column_b)
        errors = [ErrorFold() for _ in common]

        def compare(times: NDArray[np.int64], pa: Array, alignment: Alignment, b_values: Array) -> None:
            if not common:
                return
            pb = alignment.linear(b_values)
            nan_a, nan_b = np.isnan(pa), np.isnan(pb)
            error = np.where(nan_a & nan_b, 0.0, np.where(nan_a | nan_b, np.inf, np.abs(pa - pb)))
            for j, fold in enumerate(errors):
                fold.add(error[:, j], self.joint_tol, times)

        def make() -> SeriesFold:
            fold = SeriesFold(self.spans.get(("A", JOINT_STATES, namespaces[0], ())),
                              self.spans.get(("B", JOINT_STATES, namespaces[1], ())), compare)
            fold.errors = errors
            self.feeds.setdefault(("A", JOINT_STATES, namespaces[0], ()), []).append((fold, common))
            self.feeds.setdefault(("B", JOINT_STATES, namespaces[1], ()), []).append((fold, common))
            return fold

        fold = self._fold(make)
        if fold is None or not self.emitting:
            return
        self.note_interpolation("/joint_states", fold)
        self.coverage("joint_states", "/joint_states", fold)
        for name, error in zip(common, fold.errors):
            self.errors("joint_states", f"joint '{name}'", "joint position", "", self.joint_tol, error)

    def transforms(self, a: RecordedRobot, b: RecordedRobot) -> None:
        want_tf, want_static = self.wants(TF), self.wants(TF_STATIC)
        pairs_a = {pair: "tf" for pair in a.tf if want_tf} | {pair: "tf_static" for pair in a.tf_static if want_static}
        pairs_b = {pair: "tf" for pair in b.tf if want_tf} | {pair: "tf_static" for pair in b.tf_static if want_static}
        parents_b = {child: parent for parent, child in pairs_b}
        parents_a = {child: parent for parent, child in pairs_a}
        for pair, where in pairs_a.items():
            label = _pair(pair)
            other = pairs_b.get(pair)
            if other is None:
                parent, child = pair
                if child in parents_b:
                    self.diff("frame", f"frame '{child}'",
                              f"frame '{child}': parent '{parent}' in A, '{parents_b[child]}' in B")
                else:
                    self.diff("frame", label, f"{label} only in A (/{where})")
            elif other != where:
                self.diff("frame", label, f"{label}: on /{where} in A, on /{other} in B")
            elif where == "tf":
                self.frame_series(label, pair, (a.tf_namespace, b.tf_namespace))
            else:
                self.static_pair(label, a.tf_static[pair], b.tf_static[pair])
        for pair, where in pairs_b.items():
            if pair not in pairs_a and pair[1] not in parents_a:
                label = _pair(pair)
                self.diff("frame", label, f"{label} only in B (/{where})")

    def frame_series(self, label: str, pair: tuple[str, str], namespaces: tuple[str, str]) -> None:
        translation, rotation = ErrorFold(), ErrorFold()
        per_sample = self.float32

        def compare(times: NDArray[np.int64], a_values: Array, alignment: Alignment, b_values: Array) -> None:
            translation_a, rotation_a = a_values[:, :3], a_values[:, 3:]
            trans = np.linalg.norm(translation_a - alignment.linear(b_values[:, :3]), axis=1)
            rot = rotation_error(rotation_a, alignment.rotations(b_values[:, 3:]))
            if per_sample:
                pos_tol, rot_tol = self.transform_tolerances(translation_a)
                translation.add(_nan_is_inf(trans), pos_tol, times)
                rotation.add(_nan_is_inf(rot), rot_tol, times)
            else:
                translation.add(_nan_is_inf(trans), self.pos_tol, times)
                rotation.add(_nan_is_inf(rot), self.rot_tol, times)

        def make() -> SeriesFold:
            key_a, key_b = ("A", TF, namespaces[0], pair), ("B", TF, namespaces[1], pair)
            fold = SeriesFold(self.spans.get(key_a), self.spans.get(key_b), compare)
            fold.errors = [translation, rotation]
            self.feeds.setdefault(key_a, []).append((fold, ()))
            self.feeds.setdefault(key_b, []).append((fold, ()))
            return fold

        fold = self._fold(make)
        if fold is None or not self.emitting:
            return
        self.note_interpolation(f"/tf {label}", fold)
        self.coverage("tf", label, fold)
        if not fold.inside:
            return
        self.errors("tf", label, "translation", "m", None if per_sample else self.pos_tol, fold.errors[0])
        self.errors("tf", label, "rotation", "rad", None if per_sample else self.rot_tol, fold.errors[1])

    def static_pair(self, label: str, va: tuple[Array, Array], vb: tuple[Array, Array]) -> None:
        if not self.emitting:  # planning the comparisons: nothing to fold
            return
        trans = float(np.linalg.norm(va[0] - vb[0]))
        rot = float(rotation_error(va[1], vb[1]))
        pos_tol, rot_tol = self.transform_tolerances(va[0][np.newaxis])
        for quantity, unit, tol, value in (("translation", "m", float(pos_tol[0]), trans),
                                           ("rotation", "rad", float(rot_tol[0]), rot)):
            self.largest(quantity, value, label, None)
            if not value <= tol:
                self.diff("tf_static", label, f"{label}: {quantity} differs by {_num(value)} {unit}", None, value)

    def transform_tolerances(self, translation: Array) -> tuple[Array, Array]:
        """The translation and rotation tolerances of each of n transforms (translations (n, 3)):
        the user's, widened to what float32 tells apart when a recording holds float32."""
        n = len(translation)
        if not self.float32:
            return np.full(n, self.pos_tol), np.full(n, self.rot_tol)
        pos = float32_tolerance(self.pos_tol, np.linalg.norm(np.nan_to_num(translation), axis=1))
        rot = float32_tolerance(self.rot_tol, np.ones(n))
        for quantity, tol, user in (("translation", pos, self.pos_tol), ("rotation", rot, self.rot_tol)):
            if n and float(tol.max()) > user:
                self.widened[quantity] = max(self.widened.get(quantity, 0.0), float(tol.max()))
        return pos, rot


SeriesKey = tuple[str, str, str, tuple[str, ...]]
"""(``A`` or ``B``, /joint_states or /tf, namespace, the frame pair of a /tf series or ``()``)."""


class _Scan:
    """What a first walk through a recording's pieces finds of its time series: each one's span (raw stamps), the
    joint names in order of first appearance, and whether the stamps of some series go back or repeat from one
    sample to the next (then the series cannot be compared piece by piece exactly: the whole recording is read)."""

    def __init__(self) -> None:
        self.spans: dict[tuple[str, str, tuple[str, ...]], list[int]] = {}  # → [count, first, last]
        self.names: dict[str, dict[str, None]] = {}  # namespace → joint names
        self.unordered = False
        self.last: Recording | None = None

    def take(self, piece: Recording) -> None:
        self.last = piece
        for ns in ["", *piece.namespaces]:
            topics = piece.robot_topics(ns)
            js = topics.joint_states
            if js is not None and len(js):
                self._span((JOINT_STATES, ns, ()), js.time_ns)
                self.names.setdefault(ns, {}).update(dict.fromkeys(js.names))
            for pair, series in topics.tf.items():
                if len(series):
                    self._span((TF, ns, pair), series.time_ns)

    def _span(self, key: tuple[str, str, tuple[str, ...]], time_ns: NDArray[np.int64]) -> None:
        first, last = int(time_ns[0]), int(time_ns[-1])
        if len(time_ns) > 1 and bool(np.any(np.diff(time_ns) <= 0)):
            self.unordered = True
        span = self.spans.get(key)
        if span is None:
            self.spans[key] = [len(time_ns), first, last]
            return
        if first <= span[2]:
            self.unordered = True
        span[0] += len(time_ns)
        span[2] = last

    def skeleton(self) -> Recording:
        """The last piece (the latched data, the topic table, the damage) with every series as two samples: its
        first and last stamp — what finds the robots and the recording's start."""
        assert self.last is not None
        rec = replace(self.last, namespaces=dict(self.last.namespaces))
        tf: dict[str, dict[Pair, FrameSeries]] = {}
        joint_states: dict[str, JointStates] = {}
        for (kind, ns, pair), (_, first, last) in self.spans.items():
            time_ns = np.array([first, last], dtype=np.int64)
            if kind == TF:
                tf.setdefault(ns, {})[(pair[0], pair[1])] = FrameSeries(time_ns, np.zeros((2, 3)), np.zeros((2, 4)))
            else:
                names = tuple(self.names[ns])
                joint_states[ns] = JointStates(time_ns, names, np.full((2, len(names)), np.nan), ())
        for ns in sorted({"", *rec.namespaces, *tf, *joint_states}):
            if ns:
                robot = rec.namespaces.get(ns) or RecordedRobot(ns)
                rec.namespaces[ns] = replace(robot, joint_states=joint_states.get(ns), tf=tf.get(ns, {}))
            else:
                rec.joint_states, rec.tf = joint_states.get(""), tf.get("", {})
        return rec

    @classmethod
    def of(cls, pieces: Iterable[Recording]) -> _Scan:
        scan = cls()
        for piece in pieces:
            scan.take(piece)
        return scan


def _values(series: FrameSeries | JointStates, common: tuple[str, ...]) -> Array:
    """A piece's samples as rows: a transform's translation and rotation, or the positions of the joints ``common``
    (NaN for one the piece lacks)."""
    if isinstance(series, FrameSeries):
        return np.hstack([series.translation, series.rotation])
    column = {name: k for k, name in enumerate(series.names)}
    if all(name in column for name in common):
        return series.positions[:, [column[name] for name in common]]
    out = np.full((len(series), len(common)), np.nan)
    for j, name in enumerate(common):
        if name in column:
            out[:, j] = series.positions[:, column[name]]
    return out


def _feed(cmp: _Comparison, side: str, piece: Recording) -> tuple[int | None, list[SeriesFold]]:
    """Give one piece of A or B to the folds of its series: its last stamp (time since the start; None without) and
    the folds it fed."""
    origin = cmp.origin_a if side == "A" else cmp.origin_b
    seen: int | None = None
    fed: list[SeriesFold] = []
    robots: dict[str, RecordedRobot] = {}
    for (who, kind, ns, pair), folds in cmp.feeds.items():
        if who != side:
            continue
        topics = robots.get(ns) or robots.setdefault(ns, piece.robot_topics(ns))
        series: FrameSeries | JointStates | None = topics.joint_states if kind == JOINT_STATES else (
            topics.tf.get((pair[0], pair[1])))
        if series is None or not len(series):
            continue
        time_ns = series.time_ns - origin
        seen = int(time_ns[-1]) if seen is None else max(seen, int(time_ns[-1]))
        for fold, common in folds:
            values = _values(series, common)
            (fold.take_a if side == "A" else fold.take_b)(time_ns, values)
            fed.append(fold)
    return seen, fed


def _walk(cmp: _Comparison, sides: tuple[Iterable[Recording], Iterable[Recording]]) -> None:
    """Feed A's and B's pieces to the folds together in time order: the next piece is the one of the side whose
    series are behind (by time since its start), so that each side waits for the other at most about a piece. The
    folds a piece fed compare what they can once the other side has given a piece too (or has none left)."""
    walks = [iter(sides[0]), iter(sides[1])]
    progress: list[int | None] = [None, None]
    live = [0, 1]
    waiting: dict[int, SeriesFold] = {}  # fed since they last ran
    while live:
        k = min(live, key=lambda i: (progress[i] is not None, progress[i] or 0, i))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # reading the recording gave them (its first walk, or reading it whole)
            piece = next(walks[k], None)
        if piece is None:
            live.remove(k)
            continue
        seen, fed = _feed(cmp, "AB"[k], piece)
        if seen is not None:
            progress[k] = seen if progress[k] is None else max(seen, progress[k] or seen)
        waiting.update((id(fold), fold) for fold in fed)
        if progress[1 - k] is not None or (1 - k) not in live:
            for fold in waiting.values():
                fold.run()
            waiting.clear()
    for fold in cmp.folds or []:
        fold.run(final=True)


def _nan_is_inf(error: Array) -> Array:
    return np.where(np.isnan(error), np.inf, error)


def _pair(pair: tuple[str, str]) -> str:
    return f"{pair[0]} → {pair[1]}"


def _check_tolerance(name: str, value: float) -> float:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def _pieces(path: str | os.PathLike[str], options: Mapping[str, Any]) -> Iterator[Recording]:
    for piece, _ in read_pieces(path, **options):
        yield piece


Side = tuple[Recording, _Scan, Iterable[Recording]]


def _side(path: Recording | str | os.PathLike[str], options: Mapping[str, Any]) -> tuple[Side, bool]:
    """One recording as the comparison sees it (what a first walk through its series found, its series to walk)
    and whether it is held whole: a Recording object or a recording of one piece as is, else its pieces."""
    if isinstance(path, Recording):
        return (path, _Scan.of([path]), [path]), True
    pieces = read_pieces(path, **options)
    try:
        first, last = next(pieces)
        if last:  # a short recording: no first walk, no second read
            return (first, _Scan.of([first]), [first]), True
        scan = _Scan.of(chain([first], (piece for piece, _ in pieces)))  # the first walk goes on from its first piece
    finally:
        pieces.close()
    return (scan.skeleton(), scan, _pieces(path, options)), False


def _read(a: Recording | str | os.PathLike[str], b: Recording | str | os.PathLike[str], options: Mapping[str, Any], *,
          whole: bool) -> tuple[tuple[Side, Side], bool]:
    """A and B as the comparison sees them (:func:`_side`), and whether both are held whole: a recording of one
    piece, or any with ``whole``, is read once as one piece; else (paths) a first walk through its pieces finds the
    spans of its series, and a second feeds the comparison — unless some series' stamps go back or repeat, which
    only the whole recording compares exactly."""
    if not whole:
        (side_a, whole_a), (side_b, whole_b) = _side(a, options), _side(b, options)
        if not (side_a[1].unordered or side_b[1].unordered):
            return (side_a, side_b), whole_a and whole_b
        for path, side in ((a, side_a), (b, side_b)):
            if side[1].unordered and not isinstance(path, Recording):
                warnings.warn(f"{display_path(path)}: the stamps of a /joint_states or /tf series go back or repeat (a "
                              "chunk given twice, messages out of order): read whole to compare them, in memory that "
                              "grows with its length", TfrecWarning, stacklevel=3)
    with warnings.catch_warnings():
        if not whole:  # the first walk gave them
            warnings.simplefilter("ignore")
        rec_a = a if isinstance(a, Recording) else read_recording(a, **options)
        rec_b = b if isinstance(b, Recording) else read_recording(b, **options)
    return ((rec_a, _Scan.of([rec_a]), [rec_a]), (rec_b, _Scan.of([rec_b]), [rec_b])), True


def compare(  # noqa: PLR0913 - the keyword-only options of tfrec diff of two recordings
    a: Recording | str | os.PathLike[str],
    b: Recording | str | os.PathLike[str],
    *,
    pos_tol: float = DEFAULT_POS_TOL,
    rot_tol: float = DEFAULT_ROT_TOL,
    joint_tol: float = DEFAULT_JOINT_TOL,
    topics: Iterable[str] | None = None,
    absolute: bool = False,
    namespace: str | None = None,
    remap: Iterable[str] | Mapping[str, str] | None = None,
    use_log_time: bool = False,
    whole: bool = False,
) -> DiffReport:
    """Compare two recordings by meaning, robot by robot.

    Args:
        a, b: recordings, or paths to read (:func:`tfrec.formats.read_recording`).
        pos_tol: metres: the largest translation error that counts as equal.
        rot_tol: radians: the largest rotation angle that counts as equal.
        joint_tol: the largest joint position difference (rad or m) that counts as equal;
            also used for other numbers of the robot description (limits, mimic factors).
        topics: compare only these topics (default: all); each must be in A or B.
        absolute: align samples on their stamps instead of the time since each start
            (:func:`tfrec.resample.data_start_ns`).
        namespace: compare only the robots of this namespace (``/robot1``; ``/`` the root's).
        remap: ``FROM:=TO`` topic remapping rules, applied to both recordings as they are read.
        use_log_time: compare the samples at their log times instead of their header stamps.
        whole: read each recording whole (the report's recordings then hold their series, as
            :func:`tfrec.plots.plot_diff` needs) instead of piece by piece in bounded memory.

    Returns:
        The report; ``report.equal`` is False when anything differs beyond tolerance.

    Raises:
        DiffError: a topic of ``topics`` that is in neither recording.
        ReadError: a path that cannot be read as a recording, a bad remapping rule.
        ValueError: a negative or non-finite tolerance.
    """
    tolerances = {
        "pos_tol": _check_tolerance("pos_tol", pos_tol),
        "rot_tol": _check_tolerance("rot_tol", rot_tol),
        "joint_tol": _check_tolerance("joint_tol", joint_tol),
    }
    wanted = None if topics is None else frozenset(topics)
    # the time series are read whatever the topics, for each recording's start (data_start_ns)
    decoded = wanted if wanted is None or absolute else wanted | {JOINT_STATES, TF}
    options: dict[str, Any] = {"topics": decoded, "namespace": namespace, "remap": remap, "use_log_time": use_log_time}
    (side_a, side_b), held_whole = _read(a, b, options, whole=whole)
    rec_a, rec_b = side_a[0], side_b[0]
    if wanted is not None:
        absent = sorted(topic for topic in wanted if topic not in rec_a.topics and topic not in rec_b.topics)
        if absent:
            raise DiffError(
                f"`topics` {' '.join(absent)}: in neither {rec_a.path} nor {rec_b.path} "
                f"(their topics: {', '.join(sorted(set(rec_a.topics) | set(rec_b.topics))) or 'none'})"
            )
    report = DiffReport(rec_a, rec_b, tolerances=tolerances, absolute=absolute,
                        time_base="log" if "log" in (rec_a.time_base, rec_b.time_base) else "header", whole=held_whole)
    for rec in (rec_a, rec_b):
        if rec.read_error is not None:
            warnings.warn(rec.read_error, TfrecWarning, stacklevel=2)
            report.notes.append(f"damaged file, compared as far as readable: {rec.read_error}")
    ns = None if namespace is None else namespace_name(namespace)
    cmp = _Comparison(rec_a, rec_b, report, wanted, absolute, ns)
    for side, scan, origin in (("A", side_a[1], cmp.origin_a), ("B", side_b[1], cmp.origin_b)):
        for (kind, where, pair), (count, first, last) in scan.spans.items():
            cmp.spans[(side, kind, where, pair)] = SeriesSpan(count, first - origin, last - origin)
    if ns is not None and not any(cmp.found_robots()):
        spaces = sorted(set(rec_a.topic_namespaces()) | set(rec_b.topic_namespaces()))
        raise DiffError(f"{rec_a.path} and {rec_b.path}: no robot in `namespace` {ns or '/'} in either (their "
                        f"namespaces: {', '.join(name or '/' for name in spaces) or 'none'})")
    if not absolute:
        report.origins = (cmp.origin_a, cmp.origin_b)
    cmp.topic_table()
    cmp.robots((side_a[2], side_b[2]))
    if cmp.interpolated:
        groups = []
        for rates, whats in cmp.interpolated.items():
            pairs = [w for w in whats if w.startswith("/tf ")]
            named = [w for w in whats if not w.startswith("/tf ")]
            if len(pairs) > 2:
                named.append(f"{len(pairs)} /tf frame pairs")
            else:
                named.extend(pairs)
            groups.append(f"{' and '.join(named)} ({rates})")
        report.notes.append(
            "some of A's times fall between B's samples, so B was interpolated at A's times (linear for joint "
            f"positions and translations, slerp for rotations): {'; '.join(groups)}"
        )
    float32 = [rec.path for rec in (rec_a, rec_b) if rec.float32]
    if float32 and cmp.widened:
        widened = [f"{quantity}s within up to {tol:.3g} {'m' if quantity == 'translation' else 'rad'}"
                   for quantity, tol in sorted(cmp.widened.items(), reverse=True)]
        report.notes.append(
            f"{' and '.join(float32)} store{'s' if len(float32) == 1 else ''} transforms as float32: they were "
            f"compared at the precision float32 holds, max(`pos_tol`, 4·eps32·|t|) and max(`rot_tol`, 4·eps32) "
            f"(eps32 = 1.19e-07): {', '.join(widened)}"
        )
    return report
