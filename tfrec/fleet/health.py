"""Health checks of a recording's time series that a fleet needs besides re-simulation.

Pure functions of stamp arrays (:class:`tfrec.readers.JointStates` and :class:`FrameSeries`
stamps, ns since the epoch): each returns :class:`Finding` records, turned into report rows by
:mod:`tfrec.fleet.tasks`.

- Stamps: header stamps that are zero (a publisher that never set them) and stamps that repeat
  the previous one. The readers give each series sorted by stamp, so a stamp that goes back in
  arrival order shows as a repeat or not at all — arrival order is not checked.
- Rate: gaps longer than ``gap_periods`` times the series' median period (the median of the
  positive differences between consecutive stamps).

Both are folded (:class:`StampFold`): a series given piece by piece (``tfrec check`` reads a recording so) keeps its
counts and a histogram of its periods — each period in integer nanoseconds, how often it occurs and where first —
from which the median period and the gaps follow exactly, in memory that does not grow with the series' length while
the clock is regular (at most :data:`MAX_PERIODS` distinct periods). An array is one piece.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S

__all__ = ["DEFAULT_GAP_PERIODS", "MAX_PERIODS", "Finding", "StampFold", "rate_findings", "series_findings",
           "stamp_findings"]

DEFAULT_GAP_PERIODS = 5.0
"""A gap between consecutive stamps longer than this many median periods is a finding."""


MAX_PERIODS = 65_536
"""Distinct periods a :class:`StampFold` keeps before it gives up (a clock with that much jitter: the series is then
looked at whole)."""


class StampFold:
    """A series' stamps (non-decreasing, piece after piece) folded into what the health checks need.

    Args:
        limit: the distinct periods kept; past it :attr:`exact` is False (None: no limit).
    """

    def __init__(self, *, limit: int | None = MAX_PERIODS) -> None:
        self.limit = limit
        self.count = 0
        self.zeros = 0
        self.repeats = 0
        self.first_repeat = 0
        self.periods: dict[int, list[int]] = {}  # period (ns, > 0) → [how many, the stamp where it first starts]
        self.last: int | None = None
        self.ordered = True  # no piece starts before the last one's end
        self.overflow = False

    @property
    def exact(self) -> bool:
        """Whether the findings of the fold are those of the whole series."""
        return self.ordered and not self.overflow

    def add(self, time_ns: NDArray[np.int64]) -> None:
        if not len(time_ns):
            return
        self.count += len(time_ns)
        self.zeros += int(np.count_nonzero(time_ns == 0))
        joined = time_ns
        if self.last is not None:
            self.ordered = self.ordered and int(time_ns[0]) >= self.last
            joined = np.concatenate([np.array([self.last], dtype=np.int64), time_ns])
        self.last = int(time_ns[-1])
        periods = np.diff(joined)
        repeats = np.flatnonzero(periods == 0) + 1
        repeats = repeats[joined[repeats] != 0]  # the zeros are counted once, as zeros
        if len(repeats):
            if not self.repeats:
                self.first_repeat = int(joined[repeats[0]])
            self.repeats += len(repeats)
        if self.overflow:
            return
        positive = periods > 0
        values, first, counts = np.unique(periods[positive], return_index=True, return_counts=True)
        starts = joined[:-1][positive][first]
        for value, start, count in zip(values.tolist(), starts.tolist(), counts.tolist()):
            known = self.periods.get(value)
            if known is None:
                self.periods[value] = [count, start]
            else:
                known[0] += count
        if self.limit is not None and len(self.periods) > self.limit:
            self.overflow = True
            self.periods = {}

    @classmethod
    def of(cls, time_ns: NDArray[np.int64] | StampFold) -> StampFold:
        """A whole series folded (a fold as it is)."""
        if isinstance(time_ns, StampFold):
            return time_ns
        fold = cls(limit=None)
        fold.add(time_ns)
        return fold

    def median_period(self) -> float | None:
        """The median of the positive periods, as ``np.median`` gives it; None with fewer than two."""
        n = sum(count for count, _ in self.periods.values())
        if n < 2:
            return None
        wanted = {(n - 1) // 2, n // 2}
        found: dict[int, int] = {}
        seen = 0
        for value in sorted(self.periods):
            count = self.periods[value][0]
            for k in wanted:
                if seen <= k < seen + count:
                    found[k] = value
            seen += count
            if len(found) == len(wanted):
                break
        low, high = found[(n - 1) // 2], found[n // 2]
        return float(low) if low == high else (float(low) + float(high)) / 2


@dataclass(frozen=True, slots=True)
class Finding:
    """One problem of a recording (a report row without the recording's own columns).

    Attributes:
        check: ``stamps``, ``rate``, or the name of the check that found it.
        topic: the topic, or ``""``.
        frame: the child frame, or ``""``.
        detail: one readable line.
        max_error: the size of the problem in ``unit``, or None.
        unit: ``s``, ``stamps``, ``m``, ``rad``… or ``""``.
        first_exceed_s: when it starts, in seconds since the recording's start, or None.
    """

    check: str
    topic: str
    frame: str
    detail: str
    max_error: float | None = None
    unit: str = ""
    first_exceed_s: float | None = None


def _seconds(time_ns: int, origin_ns: int) -> float:
    return (time_ns - origin_ns) / NS_PER_S


def _plural(n: int, word: str) -> str:
    return f"{n:,} {word}{'' if n == 1 else 's'}"


def stamp_findings(topic: str, frame: str, time_ns: NDArray[np.int64] | StampFold, origin_ns: int) -> list[Finding]:
    """Zero and repeated header stamps of one series (sorted by stamp).

    Args:
        topic, frame: what the series is, for the finding.
        time_ns: its stamps, non-decreasing (or folded).
        origin_ns: the recording's start, which ``first_exceed_s`` counts from.
    """
    fold = StampFold.of(time_ns)
    zeros, repeats = fold.zeros, fold.repeats
    if not zeros and not repeats:
        return []
    what = f"{topic} {frame}".rstrip()
    parts = []
    if zeros:
        parts.append(f"{zeros:,} of {fold.count:,} header stamps are zero")
    first = None
    if repeats:
        first = _seconds(fold.first_repeat, origin_ns)
        parts.append(f"{_plural(repeats, 'stamp')} repeat the previous one (first at t={first:.3f} s)")
    return [Finding("stamps", topic, frame, f"{what}: {'; '.join(parts)}", float(zeros + repeats),
                    "stamps", first)]


def rate_findings(topic: str, frame: str, time_ns: NDArray[np.int64] | StampFold, origin_ns: int, *,
                  gap_periods: float = DEFAULT_GAP_PERIODS) -> list[Finding]:
    """Gaps longer than ``gap_periods`` median periods in one series (sorted by stamp, or folded).

    A series of fewer than three distinct stamps has no rate and no finding.
    """
    fold = StampFold.of(time_ns)
    median = fold.median_period()
    if median is None:
        return []
    gaps = [(value, count, start) for value, (count, start) in fold.periods.items()
            if float(value) > gap_periods * median]  # as numpy compares
    if not gaps:
        return []
    start = _seconds(min(first for _, _, first in gaps), origin_ns)
    longest, _, longest_start = max(gaps, key=lambda gap: gap[0])
    where = _seconds(longest_start, origin_ns)
    longest_s = float(longest) / NS_PER_S
    what = f"{topic} {frame}".rstrip()
    detail = (f"{what}: {_plural(sum(count for _, count, _ in gaps), 'gap')} longer than {gap_periods:g} periods "
              f"(median period {median / 1e6:.3g} ms, {NS_PER_S / median:.4g} Hz): the first at t={start:.3f} s, "
              f"the longest {longest_s:.3g} s at t={where:.3f} s")
    return [Finding("rate", topic, frame, detail, longest_s, "s", start)]


def _merged(findings: Iterable[Finding]) -> list[Finding]:
    """Findings of several /tf frame pairs that are the same problem (same check, size and time):
    one finding naming the first frame and counting the others."""
    groups: dict[tuple[str, str, float | None, float | None], list[Finding]] = {}
    for finding in findings:
        groups.setdefault((finding.check, finding.topic, finding.max_error, finding.first_exceed_s), []).append(finding)
    out = []
    for group in groups.values():
        first = group[0]
        if len(group) > 1:
            others = [f.frame for f in group[1:]]
            shown = ", ".join(others[:3]) + (" …" if len(others) > 3 else "")
            first = replace(first, detail=f"{first.detail} (also {_plural(len(others), 'other frame')}: {shown})")
        out.append(first)
    return out


def series_findings(
    joint_states_ns: NDArray[np.int64] | StampFold | None,
    tf_ns: Mapping[tuple[str, str], NDArray[np.int64] | StampFold],
    origin_ns: int,
    *,
    gap_periods: float = DEFAULT_GAP_PERIODS,
) -> list[Finding]:
    """Stamp and rate findings of a recording's /joint_states and /tf series.

    Args:
        joint_states_ns: the /joint_states stamps (or folded), or None.
        tf_ns: (parent, child) → stamps of each recorded /tf pair (or folded).
        origin_ns: the recording's start (``first_exceed_s`` counts from it).
        gap_periods: see :func:`rate_findings`.

    Returns:
        /joint_states' findings, then /tf's; /tf pairs with the same problem at the same time
        (one publisher's gap) give one finding.
    """
    out: list[Finding] = []
    js = None if joint_states_ns is None else StampFold.of(joint_states_ns)
    if js is not None and js.count:
        out += stamp_findings("/joint_states", "", js, origin_ns)
        out += rate_findings("/joint_states", "", js, origin_ns, gap_periods=gap_periods)
    folds = [(child, StampFold.of(stamps)) for (_, child), stamps in tf_ns.items()]
    tf: list[Finding] = []
    for child, fold in folds:
        tf += stamp_findings("/tf", child, fold, origin_ns)
    for child, fold in folds:
        tf += rate_findings("/tf", child, fold, origin_ns, gap_periods=gap_periods)
    return out + _merged(tf)
