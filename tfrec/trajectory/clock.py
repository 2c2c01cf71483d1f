"""The sample clock of generated and resampled trajectories: sample ``i`` at ``round(i * 1e9 / rate_hz)`` ns."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import STAMP_LIMIT_NS, STAMP_RANGE
from tfrec.errors import TrajectoryError

__all__ = ["MAX_SAMPLES", "sample_times_ns"]

MAX_SAMPLES = 10_000_000
"""Most samples a generated trajectory may have (1 h at 1 kHz is 3.6 million)."""


_OUT_OF_RANGE = f"out of range: {STAMP_RANGE}"


def sample_times_ns(duration_s: float, rate_hz: float) -> NDArray[np.int64]:
    """``round(i * 1e9 / rate_hz)`` for every i whose time is at most the duration.

    Raises:
        TrajectoryError: the duration is not below ROS 2's int32 seconds, the rate is above one
            sample per nanosecond, or the samples would be more than :data:`MAX_SAMPLES`.
    """
    if not duration_s * 1e9 < STAMP_LIMIT_NS:
        raise TrajectoryError(f"duration {duration_s!r} s is {_OUT_OF_RANGE}")
    if rate_hz > 1e9:
        raise TrajectoryError(f"rate {rate_hz:g} Hz is more than one sample per nanosecond (1e+09 Hz)")
    duration_ns = round(duration_s * 1e9)
    if not duration_ns * rate_hz / 1e9 < MAX_SAMPLES:  # also inf
        raise TrajectoryError(
            f"duration {duration_s:g} s at {rate_hz:g} Hz gives more than {MAX_SAMPLES:,} samples"
        )
    count = int(duration_ns * rate_hz / 1e9) + 2  # one past the end, dropped below
    with np.errstate(over="ignore"):  # that one may overflow at a tiny rate
        candidates = np.rint(np.arange(count, dtype=np.float64) * 1e9 / rate_hz)
    time_ns = candidates[candidates < STAMP_LIMIT_NS].astype(np.int64)
    return time_ns[time_ns <= duration_ns]
