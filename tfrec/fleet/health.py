"""Health checks of a recording's time series that a fleet needs besides re-simulation.

Pure functions of stamp arrays (:class:`tfrec.readers.JointStates` and :class:`FrameSeries`
stamps, ns since the epoch): each returns :class:`Finding` records, turned into report rows by
:mod:`tfrec.fleet.tasks`.

- Stamps: header stamps that are zero (a publisher that never set them) and stamps that repeat
  the previous one. The readers give each series sorted by stamp, so a stamp that goes back in
  arrival order shows as a repeat or not at all — arrival order is not checked.
- Rate: gaps longer than ``gap_periods`` times the series' median period (the median of the
  positive differences between consecutive stamps).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S

__all__ = ["DEFAULT_GAP_PERIODS", "Finding", "rate_findings", "series_findings", "stamp_findings"]

DEFAULT_GAP_PERIODS = 5.0
"""A gap between consecutive stamps longer than this many median periods is a finding."""


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


def stamp_findings(topic: str, frame: str, time_ns: NDArray[np.int64], origin_ns: int) -> list[Finding]:
    """Zero and repeated header stamps of one series (sorted by stamp).

    Args:
        topic, frame: what the series is, for the finding.
        time_ns: its stamps, non-decreasing.
        origin_ns: the recording's start, which ``first_exceed_s`` counts from.
    """
    zeros = int(np.count_nonzero(time_ns == 0))
    repeats = np.flatnonzero(np.diff(time_ns) == 0) + 1
    repeats = repeats[time_ns[repeats] != 0]  # the zeros are counted once, as zeros
    if not zeros and not len(repeats):
        return []
    what = f"{topic} {frame}".rstrip()
    parts = []
    if zeros:
        parts.append(f"{zeros:,} of {len(time_ns):,} header stamps are zero")
    first = None
    if len(repeats):
        first = _seconds(int(time_ns[repeats[0]]), origin_ns)
        parts.append(f"{_plural(len(repeats), 'stamp')} repeat the previous one (first at t={first:.3f} s)")
    return [Finding("stamps", topic, frame, f"{what}: {'; '.join(parts)}", float(zeros + len(repeats)),
                    "stamps", first)]


def rate_findings(topic: str, frame: str, time_ns: NDArray[np.int64], origin_ns: int, *,
                  gap_periods: float = DEFAULT_GAP_PERIODS) -> list[Finding]:
    """Gaps longer than ``gap_periods`` median periods in one series (sorted by stamp).

    A series of fewer than three distinct stamps has no rate and no finding.
    """
    periods = np.diff(time_ns)
    positive = periods[periods > 0]
    if len(positive) < 2:
        return []
    median = float(np.median(positive))
    gaps = np.flatnonzero(periods > gap_periods * median)
    if not len(gaps):
        return []
    longest = int(gaps[np.argmax(periods[gaps])])
    start = _seconds(int(time_ns[gaps[0]]), origin_ns)
    where = _seconds(int(time_ns[longest]), origin_ns)
    longest_s = float(periods[longest]) / NS_PER_S
    what = f"{topic} {frame}".rstrip()
    detail = (f"{what}: {_plural(len(gaps), 'gap')} longer than {gap_periods:g} periods (median period "
              f"{median / 1e6:.3g} ms, {NS_PER_S / median:.4g} Hz): the first at t={start:.3f} s, the longest "
              f"{longest_s:.3g} s at t={where:.3f} s")
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
    joint_states_ns: NDArray[np.int64] | None,
    tf_ns: Mapping[tuple[str, str], NDArray[np.int64]],
    origin_ns: int,
    *,
    gap_periods: float = DEFAULT_GAP_PERIODS,
) -> list[Finding]:
    """Stamp and rate findings of a recording's /joint_states and /tf series.

    Args:
        joint_states_ns: the /joint_states stamps, or None.
        tf_ns: (parent, child) → stamps of each recorded /tf pair.
        origin_ns: the recording's start (``first_exceed_s`` counts from it).
        gap_periods: see :func:`rate_findings`.

    Returns:
        /joint_states' findings, then /tf's; /tf pairs with the same problem at the same time
        (one publisher's gap) give one finding.
    """
    out: list[Finding] = []
    if joint_states_ns is not None and len(joint_states_ns):
        out += stamp_findings("/joint_states", "", joint_states_ns, origin_ns)
        out += rate_findings("/joint_states", "", joint_states_ns, origin_ns, gap_periods=gap_periods)
    tf: list[Finding] = []
    for (_, child), stamps in tf_ns.items():
        tf += stamp_findings("/tf", child, stamps, origin_ns)
    for (_, child), stamps in tf_ns.items():
        tf += rate_findings("/tf", child, stamps, origin_ns, gap_periods=gap_periods)
    return out + _merged(tf)
