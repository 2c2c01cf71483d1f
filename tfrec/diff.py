"""``tfrec diff``: compare two recordings by meaning, not by bytes.

:func:`compare` reads two recordings of any format (:func:`tfrec.readers.read_recording`) and
compares the robot description as URDF (:mod:`tfrec.urdf_diff`), the topics (presence, message
counts, time span), the joint positions per joint and the transforms per (parent, child) pair,
static and dynamic. The result is a :class:`DiffReport`; :func:`assert_recordings_match` turns
one into a failing test with the readable report.

Time: samples are aligned by time since each recording's start, so two recordings made at
different wall-clock times compare; ``absolute=True`` aligns on the stamps. A recording's start
(:func:`data_start_ns`) is the first stamp of its time series, /joint_states or /tf, whichever
comes first — not its first message: a latched /robot_description or /tf_static published
seconds before the data does not shift it. ``tfrec replay --start`` counts from the same start.
Where B's samples are not at A's times, B is interpolated at A's times — linearly for joint
positions and translations, by slerp for rotations — and the report says so. A's samples
outside B's time span have no counterpart and are reported as such.

Errors: a translation error is the distance between the two translations (m); a rotation error
is the angle of the relative rotation ``q_a⁻¹ q_b``, ``2·atan2(|v|, |w|)`` (rad); a joint error
is the absolute difference of the positions (rad or m).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Collection, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .diff_report import Difference, DiffReport, Largest, at_time, format_time
from .errors import RecordingError
from .readers import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC, FrameSeries, Recording, read_recording

__all__ = [
    "DEFAULT_JOINT_TOL",
    "DEFAULT_POS_TOL",
    "DEFAULT_ROT_TOL",
    "FLOAT32_TOL",
    "DiffReport",
    "Difference",
    "assert_recordings_match",
    "compare",
    "data_start_ns",
    "rotation_error",
]

Array = NDArray[np.float64]

DEFAULT_POS_TOL = 1e-9
"""Metres. Two float64 recordings of the same computation agree far below this."""
DEFAULT_ROT_TOL = 1e-9
"""Radians."""
DEFAULT_JOINT_TOL = 1e-9
"""Radians or metres."""
FLOAT32_TOL = 1e-5
"""A tolerance that absorbs float32 rounding (``.rrd``) for robots of a few metres."""


def data_start_ns(rec: Recording) -> int | None:
    """A recording's start: the first stamp of its /joint_states or /tf, whichever comes first.

    Header stamps, as the samples compared and replayed carry. Latched one-off messages
    (/robot_description, /tf_static) are left out, so one published long before the data does
    not shift the start. A recording without either (or without them decoded) starts at its
    first message; None when it is empty. A damaged file whose first messages were lost starts
    at its true start (from the MCAP summary or chunk headers), so what was read keeps its time.
    """
    firsts = [int(series.time_ns.min()) for series in rec.tf.values() if len(series)]
    if rec.joint_states is not None and len(rec.joint_states):
        firsts.append(int(rec.joint_states.time_ns.min()))
    start = min(firsts) if firsts else rec.start_ns
    if rec.read_error is not None and rec.start_ns is not None and start is not None:
        start = min(start, rec.start_ns)  # a damaged file lost its first messages: keep its true start
    return start


def _num(x: float) -> str:
    return f"{x:.3g}"


def rotation_error(qa: Array, qb: Array) -> Array:
    """The angle (rad) of ``qa⁻¹ qb`` for quaternions (..., 4) in (x, y, z, w) order.

    ``2·atan2(|v|, |w|)`` of the relative rotation: in [0, π], the same for q and -q, and
    accurate for tiny angles (unlike ``acos``). The quaternions need not be normalized.
    """
    va, wa = qa[..., :3], qa[..., 3:4]
    vb, wb = qb[..., :3], qb[..., 3:4]
    v = wa * vb - wb * va - np.cross(va, vb)
    w = (wa * wb)[..., 0] + np.einsum("...i,...i->...", va, vb)
    angle: Array = 2.0 * np.arctan2(np.linalg.norm(v, axis=-1), np.abs(w))  # numpy types einsum and norm as Any
    return angle


def _slerp(q0: Array, q1: Array, frac: Array) -> Array:
    """Spherical interpolation between unit quaternions (n, 4) at fractions (n,)."""
    q0 = q0 / np.linalg.norm(q0, axis=-1, keepdims=True)
    q1 = q1 / np.linalg.norm(q1, axis=-1, keepdims=True)
    dot = np.einsum("ij,ij->i", q0, q1)
    q1 = np.where(dot[:, None] < 0.0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin = np.sin(theta)
    small = sin < 1e-9
    safe = np.where(small, 1.0, sin)
    w0 = np.where(small, 1.0 - frac, np.sin((1.0 - frac) * theta) / safe)
    w1 = np.where(small, frac, np.sin(frac * theta) / safe)
    out = w0[:, None] * q0 + w1[:, None] * q1
    unit: Array = out / np.linalg.norm(out, axis=-1, keepdims=True)  # numpy types norm(axis=...) as Any
    return unit


@dataclass
class _Alignment:
    """Where A's sample times fall among B's."""

    same: bool  # B's times are A's times: compare sample by sample
    inside: NDArray[np.bool_]  # A's samples within B's time span
    index: NDArray[np.intp]  # for each inside sample, B's sample at or before it
    frac: Array  # and the fraction of the way to the next one
    b_outside: int  # B's samples outside A's time span

    def linear(self, values: Array) -> Array:
        if self.same:
            return values
        if len(values) == 1:
            return np.repeat(values, len(self.index), axis=0)
        lo = values[self.index]
        hi = values[np.minimum(self.index + 1, len(values) - 1)]
        f = self.frac.reshape((-1,) + (1,) * (values.ndim - 1))
        return lo + f * (hi - lo)

    def rotations(self, values: Array) -> Array:
        if self.same:
            return values
        if len(values) == 1:
            return np.repeat(values, len(self.index), axis=0)
        return _slerp(values[self.index], values[np.minimum(self.index + 1, len(values) - 1)], self.frac)


def _align(ta: NDArray[np.int64], tb: NDArray[np.int64]) -> _Alignment:
    if len(ta) == len(tb) and np.array_equal(ta, tb):
        return _Alignment(True, np.ones(len(ta), dtype=bool), np.arange(len(ta)), np.zeros(len(ta)), 0)
    if len(tb) == 0:
        return _Alignment(False, np.zeros(len(ta), dtype=bool), np.zeros(0, np.intp), np.zeros(0), 0)
    inside = (ta >= tb[0]) & (ta <= tb[-1])
    t = ta[inside]
    index = np.clip(np.searchsorted(tb, t, side="right") - 1, 0, len(tb) - 1)
    nxt = np.minimum(index + 1, len(tb) - 1)
    span = (tb[nxt] - tb[index]).astype(np.float64)
    frac = np.where(span > 0, (t - tb[index]).astype(np.float64) / np.where(span > 0, span, 1.0), 0.0)
    b_outside = int(np.count_nonzero(tb < ta[0]) + np.count_nonzero(tb > ta[-1])) if len(ta) else len(tb)
    return _Alignment(False, inside, index, frac, b_outside)


def _rate(time_ns: NDArray[np.int64]) -> str:
    if len(time_ns) < 2 or time_ns[-1] == time_ns[0]:
        return f"{len(time_ns)} samples"
    return f"{(len(time_ns) - 1) / ((time_ns[-1] - time_ns[0]) / 1e9):.4g} Hz"


class _Comparison:
    def __init__(self, a: Recording, b: Recording, report: DiffReport, topics: Collection[str] | None,
                 absolute: bool) -> None:
        self.a, self.b, self.report = a, b, report
        self.topics = topics
        self.absolute = absolute
        self.pos_tol = report.tolerances["pos_tol"]
        self.rot_tol = report.tolerances["rot_tol"]
        self.joint_tol = report.tolerances["joint_tol"]
        self.interpolated: dict[str, list[str]] = {}  # "(A 50 Hz, B 100 Hz)" → what
        self.origin_a = 0 if absolute else data_start_ns(a) or 0
        self.origin_b = 0 if absolute else data_start_ns(b) or 0

    def wants(self, topic: str) -> bool:
        return self.topics is None or topic in self.topics

    def diff(self, kind: str, what: str, detail: str, time_ns: int | None = None, value: float | None = None) -> None:
        self.report.differences.append(Difference(kind, what, detail, time_ns, value))

    def origin(self, rec: Recording) -> int:
        return self.origin_a if rec is self.a else self.origin_b

    def largest(self, quantity: str, value: float, what: str, time_ns: int | None) -> None:
        current = self.report.largest.get(quantity)
        if current is None or value > current.value:
            self.report.largest[quantity] = Largest(value, what, time_ns)

    # -- the robot description ----------------------------------------------------------------

    def description(self) -> None:
        if not self.wants(ROBOT_DESCRIPTION):
            return
        da, db = self.a.robot_description, self.b.robot_description
        for rec, other in ((self.a, self.b), (self.b, self.a)):
            if rec.robot_description is None and other.robot_description is not None and rec.format == "rrd":
                self.report.notes.append(
                    f"the robot description is not in {rec.path} (an .rrd without /robot_description)"
                )
        if da is None or db is None:
            return  # a missing /robot_description topic is reported with the topics
        from .urdf_diff import diff_urdf_texts

        changes = diff_urdf_texts(da, db, pos_tol=self.pos_tol, rot_tol=self.rot_tol, value_tol=self.joint_tol)
        for change in changes:
            self.diff("description", change.what, change.detail)
        if not changes and da != db:
            self.report.notes.append(
                "the robot descriptions differ as text but not in anything tfrec compares "
                "(names, links, joints, visuals)"
            )

    # -- topics -------------------------------------------------------------------------------

    def topic_table(self) -> None:
        a, b = self.a, self.b
        names = sorted(set(a.topics) | set(b.topics))
        ros_types = "rrd" not in (a.format, b.format)
        for name in names:
            if not self.wants(name):
                continue
            ia, ib = a.topics.get(name), b.topics.get(name)
            if ia is None or ib is None:
                side, info = ("A", ia) if ib is None else ("B", ib)
                assert info is not None
                self.diff("topic", name, f"{name} only in {side} ({info.count} messages of {info.type})")
                continue
            if ros_types and ia.type.replace("/msg/", "/") != ib.type.replace("/msg/", "/"):
                self.diff("topic", name, f"{name}: type {ia.type} in A, {ib.type} in B")
            if ia.count != ib.count:
                self.diff("topic", name, f"{name}: {ia.count} messages in A, {ib.count} in B")
            if None not in (ia.first_ns, ia.last_ns, ib.first_ns, ib.last_ns):
                span_a = (ia.first_ns - self.origin(a), ia.last_ns - self.origin(a))  # type: ignore[operator]
                span_b = (ib.first_ns - self.origin(b), ib.last_ns - self.origin(b))  # type: ignore[operator]
                if span_a != span_b:
                    self.diff(
                        "topic", name,
                        f"{name}: messages from t={format_time(span_a[0])} to {format_time(span_a[1])} s in A, "
                        f"from t={format_time(span_b[0])} to {format_time(span_b[1])} s in B",
                    )

    # -- samples ------------------------------------------------------------------------------

    def coverage(self, kind: str, what: str, ta: NDArray[np.int64], align: _Alignment) -> None:
        missing = ~align.inside
        if missing.any():
            times = ta[missing]
            self.diff(
                kind, what,
                f"{what}: {int(missing.sum())} sample(s) of A from t={format_time(int(times[0]))} "
                f"to {format_time(int(times[-1]))} s have no data in B",
                int(times[0]),
            )
        if align.b_outside:
            self.diff(kind, what, f"{what}: {align.b_outside} sample(s) of B lie outside A's time span (no data in A)")

    def errors(self, kind: str, what: str, quantity: str, unit: str, tol: float, error: Array,
               times: NDArray[np.int64]) -> None:
        """Report the largest error and when it first exceeds ``tol``."""
        if len(error) == 0:
            return
        worst = int(np.argmax(error))
        value = float(error[worst])
        self.largest(quantity, value, what, int(times[worst]))
        over = error > tol
        if not over.any():
            return
        first = int(np.argmax(over))
        unit = f" {unit}" if unit else ""
        if math.isinf(value):
            missing = np.isinf(error)
            detail = (
                f"{what}: {quantity} in one recording only (NaN in the other) in {int(missing.sum())} of "
                f"{len(error)} samples, first{at_time(int(times[int(np.argmax(missing))]))}"
            )
            finite = error[~missing]
            if finite.size and finite.max() > tol:
                detail += f"; elsewhere it differs by up to {_num(float(finite.max()))}{unit}"
        else:
            detail = (
                f"{what}: {quantity} differs by up to {_num(value)}{unit}{at_time(int(times[worst]))}; "
                f"first above {tol:g}{unit}{at_time(int(times[first]))}"
                f" ({int(over.sum())} of {len(error)} samples)"
            )
        self.diff(kind, what, detail, int(times[first]), value)

    def note_interpolation(self, what: str, ta: NDArray[np.int64], tb: NDArray[np.int64]) -> None:
        self.interpolated.setdefault(f"A {_rate(ta)}, B {_rate(tb)}", []).append(what)

    def joint_states(self) -> None:
        ja, jb = self.a.joint_states, self.b.joint_states
        if not self.wants(JOINT_STATES) or ja is None or jb is None:
            return
        for name in ja.names:
            if name not in jb.names:
                self.diff("joint_states", f"joint '{name}'", f"joint '{name}' only in A's /joint_states")
        for name in jb.names:
            if name not in ja.names:
                self.diff("joint_states", f"joint '{name}'", f"joint '{name}' only in B's /joint_states")
        common = [name for name in ja.names if name in jb.names]
        ta = ja.time_ns - self.origin(self.a)
        tb = jb.time_ns - self.origin(self.b)
        align = _align(ta, tb)
        if not align.same:
            self.note_interpolation("/joint_states", ta, tb)
        self.coverage("joint_states", "/joint_states", ta, align)
        if not common or not align.inside.any():
            return
        cols_a = [ja.names.index(name) for name in common]
        cols_b = [jb.names.index(name) for name in common]
        pa = ja.positions[:, cols_a][align.inside]
        pb = align.linear(jb.positions[:, cols_b])
        nan_a, nan_b = np.isnan(pa), np.isnan(pb)
        error = np.where(nan_a & nan_b, 0.0, np.where(nan_a | nan_b, np.inf, np.abs(pa - pb)))
        times = ta[align.inside]
        for j, name in enumerate(common):
            self.errors("joint_states", f"joint '{name}'", "joint position", "", self.joint_tol, error[:, j], times)

    def transforms(self) -> None:
        a, b = self.a, self.b
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
                self.frame_series(label, a.tf[pair], b.tf[pair])
            else:
                self.static_pair(label, a.tf_static[pair], b.tf_static[pair])
        for pair, where in pairs_b.items():
            if pair not in pairs_a and pair[1] not in parents_a:
                label = _pair(pair)
                self.diff("frame", label, f"{label} only in B (/{where})")

    def frame_series(self, label: str, sa: FrameSeries, sb: FrameSeries) -> None:
        ta = sa.time_ns - self.origin(self.a)
        tb = sb.time_ns - self.origin(self.b)
        align = _align(ta, tb)
        if not align.same:
            self.note_interpolation(f"/tf {label}", ta, tb)
        self.coverage("tf", label, ta, align)
        if not align.inside.any():
            return
        times = ta[align.inside]
        translation_a = sa.translation[align.inside]
        rotation_a = sa.rotation[align.inside]
        trans = np.linalg.norm(translation_a - align.linear(sb.translation), axis=1)
        rot = rotation_error(rotation_a, align.rotations(sb.rotation))
        self.errors("tf", label, "translation", "m", self.pos_tol, _nan_is_inf(trans), times)
        self.errors("tf", label, "rotation", "rad", self.rot_tol, _nan_is_inf(rot), times)

    def static_pair(self, label: str, va: tuple[Array, Array], vb: tuple[Array, Array]) -> None:
        trans = float(np.linalg.norm(va[0] - vb[0]))
        rot = float(rotation_error(va[1], vb[1]))
        for quantity, unit, tol, value in (("translation", "m", self.pos_tol, trans),
                                           ("rotation", "rad", self.rot_tol, rot)):
            self.largest(quantity, value, label, None)
            if not value <= tol:
                self.diff("tf_static", label, f"{label}: {quantity} differs by {_num(value)} {unit}", None, value)


def _nan_is_inf(error: Array) -> Array:
    return np.where(np.isnan(error), np.inf, error)


def _pair(pair: tuple[str, str]) -> str:
    return f"{pair[0]} → {pair[1]}"


def _check_tolerance(name: str, value: float) -> float:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def compare(
    a: Recording | str | os.PathLike[str],
    b: Recording | str | os.PathLike[str],
    *,
    pos_tol: float = DEFAULT_POS_TOL,
    rot_tol: float = DEFAULT_ROT_TOL,
    joint_tol: float = DEFAULT_JOINT_TOL,
    topics: Iterable[str] | None = None,
    absolute: bool = False,
) -> DiffReport:
    """Compare two recordings by meaning.

    Args:
        a, b: recordings, or paths to read (:func:`tfrec.readers.read_recording`).
        pos_tol: metres: the largest translation error that counts as equal.
        rot_tol: radians: the largest rotation angle that counts as equal.
        joint_tol: the largest joint position difference (rad or m) that counts as equal;
            also used for other numbers of the robot description (limits, mimic factors).
        topics: compare only these topics (default: all); each must be in A or B.
        absolute: align samples on their stamps instead of the time since each start
            (:func:`data_start_ns`).

    Returns:
        The report; ``report.equal`` is False when anything differs beyond tolerance.

    Raises:
        RecordingError: a path that cannot be read as a recording, or a topic of ``topics``
            that is in neither recording.
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
    rec_a = a if isinstance(a, Recording) else read_recording(a, topics=decoded)
    rec_b = b if isinstance(b, Recording) else read_recording(b, topics=decoded)
    if wanted is not None:
        absent = sorted(topic for topic in wanted if topic not in rec_a.topics and topic not in rec_b.topics)
        if absent:
            raise RecordingError(
                f"--topics {' '.join(absent)}: in neither {rec_a.path} nor {rec_b.path} "
                f"(their topics: {', '.join(sorted(set(rec_a.topics) | set(rec_b.topics))) or 'none'})"
            )
    report = DiffReport(rec_a, rec_b, tolerances=tolerances, absolute=absolute)
    for rec in (rec_a, rec_b):
        if rec.read_error is not None:
            warnings.warn(rec.read_error, stacklevel=2)
            report.notes.append(f"damaged file, compared as far as readable: {rec.read_error}")
    cmp = _Comparison(rec_a, rec_b, report, wanted, absolute)
    if not absolute:
        report.origins = (cmp.origin_a, cmp.origin_b)
    cmp.description()
    cmp.topic_table()
    cmp.joint_states()
    cmp.transforms()
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
            "B's samples are not at A's times, so B was interpolated at A's times (linear for joint "
            f"positions and translations, slerp for rotations): {'; '.join(groups)}"
        )
    float32 = [rec.path for rec in (rec_a, rec_b) if rec.float32]
    if float32 and min(tolerances["pos_tol"], tolerances["rot_tol"]) < 1e-6:
        report.notes.append(
            f"{' and '.join(float32)} store{'s' if len(float32) == 1 else ''} transforms as float32: "
            f"rounding alone differs by up to ~1e-7; compare with --pos-tol {FLOAT32_TOL:g} --rot-tol {FLOAT32_TOL:g}"
        )
    return report


def assert_recordings_match(
    a: Recording | str | os.PathLike[str],
    b: Recording | str | os.PathLike[str],
    **options: Any,
) -> DiffReport:
    """Fail a test, with the readable report, unless the recordings match.

    Args:
        a, b: recordings or paths.
        **options: :func:`compare`'s keyword arguments (tolerances, topics, absolute).

    Returns:
        The report, when the recordings match.

    Raises:
        AssertionError: the recordings differ; the message is :meth:`DiffReport.to_text`.
    """
    __tracebackhide__ = True  # pytest: show the report, not this frame
    report = compare(a, b, **options)
    if not report.equal:
        raise AssertionError("recordings differ: " + report.to_text())
    return report
