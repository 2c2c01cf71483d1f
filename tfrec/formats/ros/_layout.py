"""The fixed byte layout of a message whose names never change, for the vectorized encoders.

A JointState or TFMessage with fixed joint or frame names has the same bytes in every message but
the stamps and float64 values. :class:`Layout` writes one message's template and records where
those fields sit; the encoders (:mod:`tfrec.formats.ros.encode` for ROS 2, :mod:`tfrec.formats.rosbag1`'s
for ROS 1) then copy whole chunks of stamps and values in as strided blocks.

The two serializations differ in three places: CDR starts with a 4-byte encapsulation header and
aligns each value to its size (relative to the end of that header), and ends strings with a NUL
counted in their length; ROS 1 neither aligns nor terminates, and its ``std_msgs/Header`` starts with
a ``seq`` counter.
"""

from __future__ import annotations

import struct

import numpy as np
from numpy.typing import NDArray

__all__ = ["CDR_HEADER", "Layout", "align", "check_rows", "float_bytes"]

CDR_HEADER = b"\x00\x01\x00\x00"
"""Encapsulation header: CDR, little-endian, no options."""

U8 = NDArray[np.uint8]


def align(offset: int, size: int) -> int:
    """``offset`` rounded up to a multiple of ``size``: where a primitive of ``size`` bytes
    starts (CDR offsets count from the end of the encapsulation header)."""
    return offset + -offset % size


class Layout:
    """Builds a message template and records where the variable fields sit.

    Args:
        ros1: ROS 1 serialization; else CDR (ROS 2).
    """

    def __init__(self, *, ros1: bool = False) -> None:
        self.ros1 = ros1
        self.buf = bytearray() if ros1 else bytearray(CDR_HEADER)

    def _align(self, size: int) -> None:
        if not self.ros1:
            offset = len(self.buf) - len(CDR_HEADER)
            self.buf += bytes(align(offset, size) - offset)

    def uint32(self, value: int) -> int:
        """A uint32; returns its offset."""
        self._align(4)
        offset = len(self.buf)
        self.buf += struct.pack("<I", value)
        return offset

    def string(self, text: str) -> None:
        data = text.encode("utf-8")
        if self.ros1:
            self.buf += struct.pack("<I", len(data)) + data
        else:
            self.uint32(len(data) + 1)
            self.buf += data + b"\0"

    def stamp(self) -> int:
        """Space for a time (sec, nanosec as two 32-bit fields); returns its offset."""
        self._align(4)
        offset = len(self.buf)
        self.buf += bytes(8)
        return offset

    def header(self, frame_id: str) -> tuple[int | None, int]:
        """A ``std_msgs/Header`` with an empty stamp (and, in ROS 1, seq 0); returns the offsets of
        seq (None in ROS 2, which has none) and of the stamp."""
        seq = self.uint32(0) if self.ros1 else None
        stamp = self.stamp()
        self.string(frame_id)
        return seq, stamp

    def float64s(self, count: int) -> int:
        """Space for ``count`` contiguous float64 values; returns their offset."""
        if count:
            self._align(8)
        offset = len(self.buf)
        self.buf += bytes(8 * count)
        return offset

    def template(self) -> U8:
        return np.frombuffer(bytes(self.buf), dtype=np.uint8)


def check_rows(rows: U8, n: int, size: int) -> None:
    """``rows`` must be uint8 (n, size): the messages being encoded in place."""
    if rows.dtype != np.uint8 or rows.shape != (n, size):
        raise ValueError(f"rows must be uint8 of shape {(n, size)}, got {rows.dtype} {rows.shape}")


def float_bytes(values: NDArray[np.float64], n: int, width: int) -> U8:
    """float64 values (n, ...) as little-endian bytes (n, width)."""
    return np.ascontiguousarray(values, dtype="<f8").reshape(n, -1).view(np.uint8).reshape(n, width)
