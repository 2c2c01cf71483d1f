"""One time series of A against B's, folded piece by piece: what ``tfrec diff`` compares of two recordings read
in pieces (:mod:`tfrec.diff.compare`), in memory that does not grow with their length.

A :class:`SeriesFold` takes A's and B's samples of one series (a /tf frame pair, or the common joints of
/joint_states) as they are read, on a common time base and each in stamp order. An A sample is compared once B's
samples around it are known — the last at or before it and the next (or B's last) —, as :func:`tfrec.resample.align`
interpolates B at A's times over the whole series; B keeps only the samples a later A sample may still need. What
the whole comparison reports is folded: the A samples without data in B (count, first and last time), B's samples
outside A's span, whether B was interpolated, and per quantity the largest error (the first of equal ones) and when
it first exceeds its tolerance (:class:`ErrorFold`). Read as one piece, the fold is the whole comparison.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tfrec.resample import Alignment, align

__all__ = ["ErrorFold", "SeriesFold", "SeriesSpan"]

Array = NDArray[np.float64]

Compare = Callable[[NDArray[np.int64], Array, Alignment, Array], None]
"""``compare(times, a_values, alignment, b_values)``: A's samples inside B's span (their times and values) against
B's samples around them."""


@dataclass(frozen=True, slots=True)
class SeriesSpan:
    """How many samples a series has, and its first and last stamp (time since the recording's start)."""

    count: int
    first: int
    last: int


def _worse(new: float, old: float | None) -> bool:
    """Whether ``new`` replaces ``old`` as the largest error: as ``np.argmax`` picks (a NaN first, else the first
    of equal largest values)."""
    if old is None:
        return True
    if math.isnan(old):
        return False
    return math.isnan(new) or new > old


def _nan_max(old: float | None, new: float) -> float:
    if old is None:
        return new
    return math.nan if math.isnan(old) or math.isnan(new) else max(old, new)


class ErrorFold:
    """The errors of one quantity of a series (one per sample), folded piece by piece."""

    def __init__(self) -> None:
        self.count = 0
        self.worst: float | None = None
        self.worst_time = 0
        self.over = 0
        self.first_over: tuple[int, float] | None = None  # (time, tolerance there)
        self.missing = 0  # infinite errors: a value in one recording only
        self.first_missing = 0
        self.finite_max: float | None = None
        self.finite_over = False  # some finite error above its tolerance

    def add(self, error: Array, tol: float | Array, times: NDArray[np.int64]) -> None:
        if len(error) == 0:
            return
        self.count += len(error)
        worst = int(np.argmax(error))  # the first NaN, else the first largest
        largest = float(error[worst])
        if _worse(largest, self.worst):
            self.worst, self.worst_time = largest, int(times[worst])
        if isinstance(tol, float) and largest <= tol:  # every error finite and within (the common case, at once)
            self.finite_max = _nan_max(self.finite_max, largest)
            return
        over = error > tol
        if over.any():
            first = int(np.argmax(over))
            if self.first_over is None:
                self.first_over = (int(times[first]), float(np.broadcast_to(tol, error.shape)[first]))
            self.over += int(over.sum())
        missing = np.isinf(error)
        if missing.any():
            if not self.missing:
                self.first_missing = int(times[int(np.argmax(missing))])
            self.missing += int(missing.sum())
        finite = error[~missing]
        if finite.size:
            self.finite_max = _nan_max(self.finite_max, float(finite.max()))
            self.finite_over = self.finite_over or bool(np.any(finite > np.broadcast_to(tol, error.shape)[~missing]))


class SeriesFold:
    """One series of A against B's (see the module docstring).

    Args:
        a, b: the spans of A's and B's series (None: no samples).
        compare: what is done with A's samples inside B's span and B's samples around them.
    """

    def __init__(self, a: SeriesSpan | None, b: SeriesSpan | None, compare: Compare) -> None:
        self.a, self.b = a, b
        self.compare = compare
        self.errors: list[ErrorFold] = []  # per quantity (a joint's position; a translation, a rotation)
        self.interpolates = False
        self.missing = 0  # A's samples without data in B
        self.missing_first = 0
        self.missing_last = 0
        self.outside = 0  # B's samples outside A's span
        self.inside = 0
        self._a_time = np.zeros(0, np.int64)
        self._a_values: Array = np.zeros((0, 0))
        self._b_time = np.zeros(0, np.int64)
        self._b_values: Array = np.zeros((0, 0))
        self._b_taken = 0
        self._a_done: int | None = None  # the last A stamp compared

    def take_a(self, time_ns: NDArray[np.int64], values: Array) -> None:
        self._a_time, self._a_values = _appended(self._a_time, self._a_values, time_ns, values)

    def take_b(self, time_ns: NDArray[np.int64], values: Array) -> None:
        if self.a is None:
            self.outside += len(time_ns)
        else:
            self.outside += int(np.count_nonzero(time_ns < self.a.first) + np.count_nonzero(time_ns > self.a.last))
        self._b_taken += len(time_ns)
        self._b_time, self._b_values = _appended(self._b_time, self._b_values, time_ns, values)
        if self.a is not None:  # past A's last stamp B needs one sample, the next after it
            beyond = int(np.searchsorted(self._b_time, self.a.last, side="right")) + 1
            if beyond < len(self._b_time):
                self._b_time, self._b_values = self._b_time[:beyond], self._b_values[:beyond]

    def run(self, *, final: bool = False) -> None:
        """Compare the A samples whose B samples around them are known (with ``final``: every one left)."""
        t = self._a_time
        b = self.b
        ready = 0 if not len(t) else len(t) if b is None or final or self._b_taken >= b.count else self._ready(t, b)
        if ready == 0:
            self._forget()  # B's samples before A's first (or next) stamp are not needed, whether A has come or not
            return
        times, values = t[:ready], self._a_values[:ready]
        self._a_time, self._a_values = t[ready:], self._a_values[ready:]
        if b is not None and b.first <= times[0] and times[-1] <= b.last:  # all inside B's span
            self._compare(times, values)
        else:
            inside = np.zeros(ready, dtype=bool) if b is None else (times >= b.first) & (times <= b.last)
            self._missed(times[~inside])
            if inside.any():
                self._compare(times[inside], values[inside])
        self._a_done = int(times[-1])
        self._forget()

    def _ready(self, t: NDArray[np.int64], b: SeriesSpan) -> int:
        """How many of A's samples ``t`` can be compared before more of B is known: those outside B's span, or
        before B's latest sample."""
        decided = (t < b.first) | (t > b.last)
        if len(self._b_time):
            decided |= t < self._b_time[-1]
        return len(t) if decided.all() else int(np.argmin(decided))

    def _compare(self, times: NDArray[np.int64], values: Array) -> None:
        alignment = align(times, self._b_time)
        self.interpolates = self.interpolates or alignment.interpolates
        self.inside += len(times)
        self.compare(times, values, alignment, self._b_values)

    def _missed(self, times: NDArray[np.int64]) -> None:
        if not len(times):
            return
        if not self.missing:
            self.missing_first = int(times[0])
        self.missing += len(times)
        self.missing_last = int(times[-1])

    def _forget(self) -> None:
        """Drop B's samples that no later A sample needs: those before the last at or before A's next stamps."""
        if self.a is None or not len(self._b_time):
            return
        after = self.a.first if self._a_done is None else max(self.a.first, self._a_done)
        if len(self._a_time):
            after = max(after, int(self._a_time[0]))
        keep = max(int(np.searchsorted(self._b_time, after, side="right")) - 1, 0)
        if keep:
            self._b_time, self._b_values = self._b_time[keep:], self._b_values[keep:]


def _appended(time_ns: NDArray[np.int64], values: Array, more_time: NDArray[np.int64],
              more: Array) -> tuple[NDArray[np.int64], Array]:
    if not len(time_ns):
        return more_time, more
    if not len(more_time):
        return time_ns, values
    return np.concatenate([time_ns, more_time]), np.concatenate([values, more])
