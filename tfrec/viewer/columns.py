"""Columns for Rerun's ``send_columns``: the ROS-time index column, checked stamps, repeated strings."""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa
import rerun as rr
from numpy.typing import NDArray

from tfrec.errors import WriteError
from tfrec.formats.rrd.paths import ELAPSED_TIMELINE, JOINT_COUNT, TIMELINE

__all__ = ["check_stamps", "elapsed_column", "no_joint_columns", "repeated_strings", "time_column"]


def check_stamps(time_ns: NDArray[np.int64]) -> NDArray[np.int64]:
    """``time_ns`` as an int64 (n,) array of stamps.

    Raises:
        WriteError: another dtype or shape.
    """
    stamps = np.asarray(time_ns)
    if stamps.dtype != np.int64 or stamps.ndim != 1:
        raise WriteError(f"time_ns must be int64 of shape (n,), got {stamps.dtype} {stamps.shape}")
    return stamps


def time_column(stamps: NDArray[np.int64]) -> rr.TimeColumn:
    """The index column of :data:`~tfrec.formats.rrd.paths.TIMELINE` for ``send_columns``: integer
    nanoseconds as timestamps (float seconds would be truncated by Rerun)."""
    return rr.TimeColumn(TIMELINE, timestamp=stamps.astype("datetime64[ns]"))


def elapsed_column(stamps: NDArray[np.int64], origin_ns: int) -> rr.TimeColumn:
    """The index column of :data:`~tfrec.formats.rrd.paths.ELAPSED_TIMELINE`: the time since ``origin_ns`` (the
    recording's start), integer nanoseconds as durations."""
    return rr.TimeColumn(ELAPSED_TIMELINE, duration=(stamps - origin_ns).astype("timedelta64[ns]"))


def no_joint_columns(n: int) -> Any:
    """The columns of ``n`` /joint_states messages that name no joint (a robot without moving joints), logged
    at :data:`~tfrec.formats.rrd.paths.NO_JOINTS_ENTITY`: ``AnyValues`` ``joint_count`` 0."""
    counts: dict[str, Any] = {JOINT_COUNT: np.zeros(n, np.uint32)}
    return rr.AnyValues.columns(drop_untyped_nones=True, **counts)


def repeated_strings(text: str, n: int) -> pa.Array:
    """``n`` copies of ``text`` as an Arrow string array, built from buffers (a list of n Python
    strings costs Rerun's converter about as much as everything else in a chunk)."""
    data = text.encode()
    offsets = np.arange(n + 1, dtype=np.int32) * len(data)
    return pa.StringArray.from_buffers(n, pa.py_buffer(offsets), pa.py_buffer(data * n))
