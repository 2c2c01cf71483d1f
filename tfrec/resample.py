"""Recorded samples on a common time base: a recording's data span, and one series at another's stamps.

``tfrec diff`` aligns two recordings on their starts and interpolates B at A's stamps;
``tfrec replay`` cuts ``--start``/``--end`` from the same start and, with ``--check``,
interpolates the recorded joint positions at the stamps of the recorded /tf. Both use the
functions here, so they agree on where a recording starts and on how values between two
samples are found: linearly (joint positions, translations) or by slerp (rotations).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import CLOCK_GAP_NS, JOINT_STATES, TF, robot_topic_kind
from tfrec.kinematics.rotations import slerp
from tfrec.recording import Recording

__all__ = ["Alignment", "align", "data_end_ns", "data_start_ns", "log_start_ns", "start_of"]

Array = NDArray[np.float64]


def _series(rec: Recording) -> list[NDArray[np.int64]]:
    """The stamps of every namespace's /joint_states and /tf."""
    out = []
    for namespace in rec.namespace_names() or [""]:
        topics = rec.robot_topics(namespace)
        out += [series.time_ns for series in topics.tf.values() if len(series)]
        if topics.joint_states is not None and len(topics.joint_states):
            out.append(topics.joint_states.time_ns)
    return out


def data_start_ns(rec: Recording) -> int | None:
    """A recording's start: the first stamp of its /joint_states or /tf, whichever comes first
    (of any namespace: ``/robot1/tf`` too).

    Header stamps, as the samples compared and replayed carry (log times with
    :attr:`Recording.time_base` ``log``). Latched one-off messages (/robot_description,
    /tf_static) are left out, so one published long before the data does not shift the start.
    A recording without either (or without them decoded) starts at its first message; None when
    it is empty. A damaged file whose first messages were lost starts at its true start (from
    the MCAP summary or chunk headers), so what was read keeps its time.
    """
    return start_of([int(time_ns.min()) for time_ns in _series(rec)], rec)


def start_of(firsts: list[int], rec: Recording) -> int | None:
    """:func:`data_start_ns` of a recording whose time series start at ``firsts`` (read piece by piece: the first
    stamp of each series of each piece), with its topic table, log times and ``read_error``."""
    start = min(firsts) if firsts else rec.start_ns
    if (rec.read_error is not None and rec.start_ns is not None and start is not None
            and abs(start - rec.start_ns) < CLOCK_GAP_NS):  # stamps and log times on one clock
        start = min(start, rec.start_ns)  # a damaged file lost its first messages: keep its true start
    return start


def log_start_ns(rec: Recording) -> int | None:
    """When the recording's first /joint_states or /tf message (of any namespace) was logged: the
    start of :func:`data_start_ns` on the log's clock, which times the topic table (the same
    instant but for the stamp-to-log latency; another clock altogether for sim time). The
    first message's log time without either."""
    firsts = [info.first_ns for name, info in rec.topics.items() if info.first_ns is not None
              and info.count and (found := robot_topic_kind(name)) is not None and found[1] in (JOINT_STATES, TF)]
    return min(firsts) if firsts else rec.start_ns


def data_end_ns(rec: Recording) -> int | None:
    """The last stamp of the recording's /joint_states and /tf (of any namespace), or None without either."""
    lasts = [int(time_ns.max()) for time_ns in _series(rec)]
    return max(lasts) if lasts else None


@dataclass
class Alignment:
    """Where the stamps ``at`` fall among a series' stamps ``known`` (:func:`align`).

    Attributes:
        same: the stamps are the same: values are taken sample by sample.
        inside: which of ``at`` lie within the span of ``known`` (the others have no value).
        index: for each inside stamp, the known sample at or before it.
        frac: and the fraction of the way to the next one (0 on a known stamp).
        outside: the known samples outside the span of ``at``.
    """

    same: bool
    inside: NDArray[np.bool_]
    index: NDArray[np.intp]
    frac: Array
    outside: int

    @property
    def interpolates(self) -> bool:
        """Whether some inside stamp falls between two known ones; else every value is a known
        sample's own (the stamps coincide where both have data)."""
        return not self.same and bool(np.any(self.frac != 0.0))

    def linear(self, values: Array) -> Array:
        """The series' ``values`` (one row per known stamp) at the inside stamps, linearly
        interpolated; a known sample's own values on its stamp."""
        if self.same:
            return values
        if len(values) == 1:
            return np.repeat(values, len(self.index), axis=0)
        lo = values[self.index]
        hi = values[np.minimum(self.index + 1, len(values) - 1)]
        f = self.frac.reshape((-1,) + (1,) * (values.ndim - 1))
        out: Array = np.where(f == 0.0, lo, lo + f * (hi - lo))  # on a known stamp: not NaN from the next one
        return out

    def rotations(self, values: Array) -> Array:
        """The series' quaternions (n, 4) at the inside stamps, by slerp; a known sample's own
        quaternion on its stamp."""
        if self.same:
            return values
        if len(values) == 1:
            return np.repeat(values, len(self.index), axis=0)
        lo: Array = values[self.index]
        between = self.frac != 0.0
        if not between.any():
            return lo
        out: Array = lo.copy()
        out[between] = slerp(lo[between], values[np.minimum(self.index + 1, len(values) - 1)][between],
                             self.frac[between])
        return out


def align(at: NDArray[np.int64], known: NDArray[np.int64]) -> Alignment:
    """Where the stamps ``at`` fall among the increasing stamps ``known`` of a series.

    Values on a known stamp are taken exactly; a stamp between two known ones gets the fraction
    of the way between them; stamps before the first or after the last known one have no value.
    """
    if len(at) == len(known) and np.array_equal(at, known):
        return Alignment(True, np.ones(len(at), dtype=bool), np.arange(len(at)), np.zeros(len(at)), 0)
    if len(known) == 0:
        return Alignment(False, np.zeros(len(at), dtype=bool), np.zeros(0, np.intp), np.zeros(0), 0)
    inside = (at >= known[0]) & (at <= known[-1])
    t = at[inside]
    index = np.clip(np.searchsorted(known, t, side="right") - 1, 0, len(known) - 1)
    nxt = np.minimum(index + 1, len(known) - 1)
    span = (known[nxt] - known[index]).astype(np.float64)
    frac = np.where(span > 0, (t - known[index]).astype(np.float64) / np.where(span > 0, span, 1.0), 0.0)
    outside = int(np.count_nonzero(known < at[0]) + np.count_nonzero(known > at[-1])) if len(at) else len(known)
    return Alignment(False, inside, index, frac, outside)
