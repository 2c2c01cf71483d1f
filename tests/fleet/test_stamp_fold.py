"""The health checks folded piece by piece (:class:`tfrec.fleet.health.StampFold`) find what the whole series shows."""

from __future__ import annotations

import numpy as np
import pytest

from tfrec.fleet.health import StampFold, rate_findings, series_findings, stamp_findings


def _series(seed: int) -> np.ndarray:
    """Stamps at 100 Hz with jitter of a few ns, repeats, zeros at the start and gaps of several lengths."""
    rng = np.random.default_rng(seed)
    periods = 10_000_000 + rng.integers(-3, 4, size=2_000)
    periods[rng.integers(0, 2_000, size=15)] = 0  # repeats
    periods[rng.integers(0, 2_000, size=6)] *= rng.integers(6, 40, size=6)  # gaps
    stamps = 1_700_000_000_000_000_000 + np.cumsum(periods)
    stamps[:3] = 0
    return np.sort(stamps).astype(np.int64)


def _pieces(stamps: np.ndarray, seed: int) -> StampFold:
    rng = np.random.default_rng(seed)
    cuts = np.sort(rng.choice(np.arange(1, len(stamps)), size=40, replace=False))
    fold = StampFold()
    for piece in np.split(stamps, cuts):
        fold.add(piece)
    return fold


@pytest.mark.parametrize("seed", range(6))
def test_pieces_find_what_the_whole_series_shows(seed: int) -> None:
    stamps = _series(seed)
    origin = int(stamps[3])
    fold = _pieces(stamps, seed)
    assert fold.exact
    whole = stamp_findings("/tf", "a", stamps, origin) + rate_findings("/tf", "a", stamps, origin)
    assert len(whole) == 2  # repeats and zeros; gaps
    assert stamp_findings("/tf", "a", fold, origin) + rate_findings("/tf", "a", fold, origin) == whole
    assert fold.median_period() == float(np.median(np.diff(stamps)[np.diff(stamps) > 0]))
    assert series_findings(fold, {("a", "b"): _pieces(stamps, seed + 1)}, origin) == series_findings(
        stamps, {("a", "b"): stamps}, origin)


def test_an_even_count_of_periods_takes_the_middle_two() -> None:
    stamps = np.array([0, 10, 30, 60, 100], dtype=np.int64) + 5  # periods 10 20 30 40: median 25
    fold = StampFold()
    fold.add(stamps[:2])
    fold.add(stamps[2:])
    assert fold.median_period() == 25.0 == float(np.median(np.diff(stamps)))


def test_a_clock_of_many_periods_or_stamps_that_go_back_are_not_folded() -> None:
    stamps = np.cumsum(np.arange(1, 100, dtype=np.int64))  # 99 distinct periods
    fold = StampFold(limit=50)
    fold.add(stamps[:40])
    assert fold.exact
    fold.add(stamps[40:])
    assert not fold.exact and fold.periods == {}
    back = StampFold()
    back.add(stamps[50:])
    back.add(stamps[:50])
    assert not back.exact
