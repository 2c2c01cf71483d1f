"""Columns for Rerun's ``send_columns``: the ROS-time index column, checked stamps, repeated strings.

The columns of the samples (index, scalars, transforms) are built here straight from numpy buffers as the Arrow
arrays Rerun's own converters make (the same types, so the same file): those converters check and copy every
column in Python, and ``pyarrow.array`` of a numpy array imports pandas whenever it is installed; together they
cost more CPU than Rerun's writer spends on the same rows. Each column is a copy of its own: Rerun keeps the
Arrow arrays (no copy) and its writer reads them after ``send_columns`` returns, when a caller may have
reused its arrays."""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa
import rerun as rr
from numpy.typing import NDArray

from tfrec.errors import WriteError
from tfrec.formats.rrd.paths import ELAPSED_TIMELINE, JOINT_COUNT, TIMELINE

__all__ = [
    "ArrowColumn",
    "ArrowTimeColumn",
    "check_stamps",
    "elapsed_column",
    "no_joint_columns",
    "repeated_strings",
    "scalar_column",
    "time_column",
    "transform_columns",
]

_FLOAT32 = pa.field("item", pa.float32(), nullable=False)
_VEC3 = pa.list_(_FLOAT32, 3)  # rerun.components.Translation3D
_QUATERNION = pa.list_(_FLOAT32, 4)  # rerun.components.RotationQuat


class ArrowTimeColumn:
    """An index column already in Arrow (``rr.TimeColumn`` converts its values again)."""

    def __init__(self, timeline: str, times: pa.Array) -> None:
        self._timeline = timeline
        self._times = times

    def timeline_name(self) -> str:
        return self._timeline

    def as_arrow_array(self) -> pa.Array:
        return self._times


class ArrowColumn(rr.ComponentColumn):
    """A component column already in Arrow, one list per row, sent as it is (``rr.ComponentColumn`` builds the
    list array from its batch on every use)."""

    def __init__(self, descriptor: rr.ComponentDescriptor, rows: pa.ListArray) -> None:
        # rerun's __init__ converts its batch; this column has none
        self.descriptor = descriptor
        self._rows = rows

    def as_arrow_array(self) -> pa.Array:
        return self._rows


def _buffer_array(kind: pa.DataType, values: NDArray[Any]) -> pa.Array:
    """``values`` (C-contiguous, of ``kind``'s dtype, no one else's) as an Arrow array of ``kind`` sharing their
    memory."""
    return pa.Array.from_buffers(kind, values.size, [None, pa.py_buffer(values)])


def _one_per_row(values: pa.Array, n: int) -> pa.ListArray:
    """``values`` as ``n`` lists of one value each (Rerun's column layout)."""
    return pa.ListArray.from_arrays(_buffer_array(pa.int32(), np.arange(n + 1, dtype=np.int32)), values)


def scalar_column(values: NDArray[np.float64]) -> ArrowColumn:
    """``rr.Scalars.columns(scalars=values)``'s column, one float64 per row."""
    column = np.array(values, dtype=np.float64, order="C")  # a copy
    return ArrowColumn(rr.Scalars.descriptor_scalars(), _one_per_row(_buffer_array(pa.float64(), column), len(column)))


def transform_columns(translation: NDArray[Any], quaternion: NDArray[Any], parent: str, child: str) -> list[ArrowColumn]:
    """``rr.Transform3D.columns`` of (n, 3) translations and (n, 4) quaternions (x, y, z, w), stored as float32,
    from ``parent`` to ``child`` in every row."""
    n = len(translation)
    vectors = np.array(translation, dtype=np.float32, order="C")  # copies
    rotations = np.array(quaternion, dtype=np.float32, order="C")
    t3 = rr.Transform3D
    return [
        ArrowColumn(t3.descriptor_translation(), _one_per_row(pa.FixedSizeListArray.from_arrays(
            _buffer_array(pa.float32(), vectors), type=_VEC3), n)),
        ArrowColumn(t3.descriptor_quaternion(), _one_per_row(pa.FixedSizeListArray.from_arrays(
            _buffer_array(pa.float32(), rotations), type=_QUATERNION), n)),
        ArrowColumn(t3.descriptor_child_frame(), _one_per_row(repeated_strings(child, n), n)),
        ArrowColumn(t3.descriptor_parent_frame(), _one_per_row(repeated_strings(parent, n), n)),
    ]


def check_stamps(time_ns: NDArray[np.int64]) -> NDArray[np.int64]:
    """``time_ns`` as an int64 (n,) array of stamps.

    Raises:
        WriteError: another dtype or shape.
    """
    stamps = np.asarray(time_ns)
    if stamps.dtype != np.int64 or stamps.ndim != 1:
        raise WriteError(f"time_ns must be int64 of shape (n,), got {stamps.dtype} {stamps.shape}")
    return stamps


def time_column(stamps: NDArray[np.int64]) -> ArrowTimeColumn:
    """The index column of :data:`~tfrec.formats.rrd.paths.TIMELINE` for ``send_columns``: integer
    nanoseconds as timestamps (float seconds would be truncated by Rerun)."""
    return ArrowTimeColumn(TIMELINE, _buffer_array(pa.timestamp("ns"), np.array(stamps, dtype=np.int64, order="C")))


def elapsed_column(stamps: NDArray[np.int64], origin_ns: int) -> ArrowTimeColumn:
    """The index column of :data:`~tfrec.formats.rrd.paths.ELAPSED_TIMELINE`: the time since ``origin_ns`` (the
    recording's start), integer nanoseconds as durations."""
    return ArrowTimeColumn(ELAPSED_TIMELINE, _buffer_array(pa.duration("ns"), np.asarray(stamps, dtype=np.int64) - origin_ns))


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
