"""Vectorized serialization of the messages tfrec writes — JointState, TFMessage, String — as ROS 2 (CDR) or
ROS 1 bytes.

For fixed joint and frame names a ``sensor_msgs/JointState`` or ``tf2_msgs/TFMessage`` has a fixed
layout (:class:`tfrec.formats.ros._layout.Layout`): the strings, counts and padding never change, only
the stamps, sequence numbers and float64 values do. So a whole chunk of N messages is one (N, size)
uint8 array: the template bytes repeated, then the stamps and values copied in as strided blocks, one
numpy assignment per block. The bytes are identical to ``rosbags``' ``typestore.serialize_cdr`` and
``serialize_ros1`` (tests/formats/test_cdr.py, tests/formats/test_rosbag1_writer.py).

CDR (XCDR1 little-endian, what ROS 2 writes): a 4-byte encapsulation header ``00 01 00 00``; every
primitive aligned to its size, counted from the end of that header; a string is a uint32 length
(including the NUL) then the bytes and the NUL; a sequence is a uint32 count then the elements, and an
empty float64 sequence adds no alignment padding. ``builtin_interfaces/Time`` is int32 sec, uint32 nanosec.

ROS 1: little-endian, no alignment and no padding; a string is a uint32 byte count then the bytes (no
NUL); ``std_msgs/Header`` is ``uint32 seq``, ``time stamp`` (uint32 secs, uint32 nsecs), ``string
frame_id``. Sequence numbers follow roscpp: a publisher overwrites the ``seq`` of a message's
top-level header with its own counter (0, 1, 2, … per topic) and leaves nested headers alone — so a
JointState carries the counter, and the TransformStamped headers inside a TFMessage keep the 0 that
tf2_ros' broadcasters leave there.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import overload

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S
from tfrec.errors import WriteError
from tfrec.formats.ros._layout import CDR_HEADER, Layout, align, check_rows, float_bytes

__all__ = [
    "CDR_HEADER",
    "ROS1_TIME_LIMIT_NS",
    "JointStateEncoder",
    "TFMessageEncoder",
    "align",
    "check_ros1_times",
    "encode_string",
    "ns_from_stamps",
    "ros1_times",
    "stamps_from_ns",
]

U8 = NDArray[np.uint8]


@overload
def ns_from_stamps(sec: int, nanosec: int) -> int: ...
@overload
def ns_from_stamps(sec: NDArray[np.int64], nanosec: NDArray[np.int64]) -> NDArray[np.int64]: ...
def ns_from_stamps(sec: int | NDArray[np.int64], nanosec: int | NDArray[np.int64]) -> int | NDArray[np.int64]:
    """Nanoseconds of stamps (``builtin_interfaces/Time``, ROS 1 ``time``) from their seconds
    and nanoseconds: ints, or int64 arrays. The inverse of :func:`stamps_from_ns`."""
    return sec * NS_PER_S + nanosec


def stamps_from_ns(time_ns: NDArray[np.int64]) -> U8:
    """``builtin_interfaces/Time`` (int32 sec, uint32 nanosec) of each stamp as (N, 8) bytes.

    Seconds are floored, so nanosec is always in [0, 1e9), as rclcpp's Time does.
    """
    time_ns = np.asarray(time_ns, dtype=np.int64)
    packed = np.empty((len(time_ns), 2), dtype="<u4")
    sec = np.floor_divide(time_ns, NS_PER_S)
    packed[:, 0] = sec.astype("<i4").view("<u4")
    packed[:, 1] = (time_ns - sec * NS_PER_S).astype("<u4")
    return packed.view(np.uint8).reshape(len(time_ns), 8)


ROS1_TIME_LIMIT_NS = 2**32 * NS_PER_S
"""ROS 1 times (uint32 seconds, uint32 nanoseconds) are below this: 2106-02-07."""


def check_ros1_times(first_ns: int, last_ns: int) -> None:
    """Check that times from ``first_ns`` to ``last_ns`` fit ROS 1's ``time``: from 1970 to 2106.

    Raises:
        WriteError: a time outside that range.
    """
    for time_ns in (first_ns, last_ns):
        if not 0 <= time_ns < ROS1_TIME_LIMIT_NS:
            problem = "before 1970" if time_ns < 0 else f"past ROS 1's last time ({ROS1_TIME_LIMIT_NS // NS_PER_S} s)"
            raise WriteError(f"time {time_ns / NS_PER_S:.9f} s is {problem}")


def ros1_times(time_ns: NDArray[np.int64]) -> U8:
    """ROS 1 ``time`` values (uint32 secs, uint32 nsecs) of nanosecond stamps, as (N, 8) bytes.

    Raises:
        WriteError: a stamp before 1970 or past 2106.
    """
    time_ns = np.asarray(time_ns, dtype=np.int64)
    if len(time_ns):
        check_ros1_times(int(time_ns.min()), int(time_ns.max()))
    packed = np.empty((len(time_ns), 2), dtype="<u4")
    secs = time_ns // NS_PER_S
    packed[:, 0] = secs
    packed[:, 1] = time_ns - secs * NS_PER_S
    return packed.view(np.uint8).reshape(len(time_ns), 8)


class JointStateEncoder:
    """``sensor_msgs/JointState`` messages for one fixed list of joint names.

    ``header.frame_id`` is empty and ``effort`` is empty, as joint_state_publisher publishes.

    Args:
        names: the joint names, in the order of the position and velocity columns.
        frame_id: the header's frame id.
        ros1: ROS 1 bytes; else CDR (ROS 2).
    """

    def __init__(self, names: Sequence[str], *, frame_id: str = "", ros1: bool = False) -> None:
        self.names = tuple(names)
        self.ros1 = ros1
        layout = Layout(ros1=ros1)
        self._seq, self._stamp = layout.header(frame_id)
        layout.uint32(len(self.names))
        for name in self.names:
            layout.string(name)
        layout.uint32(len(self.names))
        self._position = layout.float64s(len(self.names))
        layout.uint32(len(self.names))
        self._velocity = layout.float64s(len(self.names))
        layout.uint32(0)  # effort
        self.template = layout.template()
        self.size = len(self.template)
        """Bytes per message."""

    def encode(
        self,
        time_ns: NDArray[np.int64],
        positions: NDArray[np.float64],
        velocities: NDArray[np.float64],
        *,
        first_seq: int = 0,
    ) -> U8:
        """Encode N messages.

        Args:
            time_ns: int64 (N,) header stamps, nanoseconds since the epoch.
            positions: float64 (N, J), J = len(names).
            velocities: float64 (N, J).
            first_seq: ROS 1's ``header.seq`` of the first message; the next count up (modulo 2**32).

        Returns:
            uint8 (N, size): row i is the bytes of message i.

        Raises:
            WriteError: (ROS 1) a stamp outside ROS 1's time range.
        """
        rows = np.tile(self.template, (len(time_ns), 1))
        self.encode_into(rows, time_ns, positions, velocities, first_seq=first_seq)
        return rows

    def encode_into(
        self,
        rows: U8,
        time_ns: NDArray[np.int64],
        positions: NDArray[np.float64],
        velocities: NDArray[np.float64],
        *,
        first_seq: int = 0,
    ) -> None:
        """Like :meth:`encode`, into ``rows`` (N, size) that already hold the template (a view
        into a larger array is fine): only the sequence numbers, stamps and values are written."""
        n, j = len(time_ns), len(self.names)
        if np.shape(positions) != (n, j) or np.shape(velocities) != (n, j):
            raise ValueError(
                f"positions {np.shape(positions)} and velocities {np.shape(velocities)} must be {(n, j)}"
            )
        check_rows(rows, n, self.size)
        rows[:, self._stamp : self._stamp + 8] = _stamp_bytes(time_ns, ros1=self.ros1)
        if self._seq is not None:
            seq = (np.arange(n, dtype=np.int64) + first_seq) % 2**32
            rows[:, self._seq : self._seq + 4] = seq.astype("<u4").view(np.uint8).reshape(n, 4)
        if j:
            width = 8 * j
            rows[:, self._position : self._position + width] = float_bytes(positions, n, width)
            rows[:, self._velocity : self._velocity + width] = float_bytes(velocities, n, width)


class TFMessageEncoder:
    """``tf2_msgs/TFMessage`` messages for one fixed list of (parent, child) frames.

    Every TransformStamped of a message gets the message's stamp, ``frame_id`` the parent and
    ``child_frame_id`` the child (and in ROS 1 ``seq`` 0), as robot_state_publisher publishes.

    Args:
        parents: frame ids of the parent frames.
        children: frame ids of the child frames, as many.
        ros1: ROS 1 bytes; else CDR (ROS 2).
    """

    def __init__(self, parents: Sequence[str], children: Sequence[str], *, ros1: bool = False) -> None:
        if len(parents) != len(children):
            raise ValueError(f"{len(parents)} parents but {len(children)} children")
        self.parents = tuple(parents)
        self.children = tuple(children)
        self.ros1 = ros1
        layout = Layout(ros1=ros1)
        layout.uint32(len(self.children))
        self._stamps: list[int] = []
        self._values: list[int] = []
        for parent, child in zip(self.parents, self.children):
            self._stamps.append(layout.header(parent)[1])
            layout.string(child)
            self._values.append(layout.float64s(7))  # translation x y z, rotation x y z w
        self.template = layout.template()
        self.size = len(self.template)
        """Bytes per message."""

    def encode(
        self, time_ns: NDArray[np.int64], translation: NDArray[np.float64], rotation: NDArray[np.float64]
    ) -> U8:
        """Encode N messages.

        Args:
            time_ns: int64 (N,) stamps, nanoseconds since the epoch.
            translation: float64 (N, K, 3), K = number of frames.
            rotation: float64 (N, K, 4) quaternions (x, y, z, w).

        Returns:
            uint8 (N, size): row i is the bytes of message i.

        Raises:
            WriteError: (ROS 1) a stamp outside ROS 1's time range.
        """
        rows = np.tile(self.template, (len(time_ns), 1))
        self.encode_into(rows, time_ns, translation, rotation)
        return rows

    def encode_into(
        self, rows: U8, time_ns: NDArray[np.int64], translation: NDArray[np.float64], rotation: NDArray[np.float64]
    ) -> None:
        """Like :meth:`encode`, into ``rows`` (N, size) that already hold the template (a view
        into a larger array is fine): only the stamps and values are written."""
        n, k = len(time_ns), len(self.children)
        if np.shape(translation) != (n, k, 3) or np.shape(rotation) != (n, k, 4):
            raise ValueError(
                f"translation {np.shape(translation)} and rotation {np.shape(rotation)} "
                f"must be {(n, k, 3)} and {(n, k, 4)}"
            )
        check_rows(rows, n, self.size)
        stamps = _stamp_bytes(time_ns, ros1=self.ros1)  # ROS 1's range is checked even without frames
        if k:
            values = np.empty((n, k, 7), dtype="<f8")
            values[:, :, :3] = translation
            values[:, :, 3:] = rotation
            value_bytes = values.view(np.uint8)  # (n, k, 56)
            for i, (stamp, value) in enumerate(zip(self._stamps, self._values)):
                rows[:, stamp : stamp + 8] = stamps
                rows[:, value : value + 56] = value_bytes[:, i, :]


def encode_string(text: str, *, ros1: bool = False) -> bytes:
    """A ``std_msgs/String`` message."""
    data = text.encode("utf-8")
    if ros1:
        return struct.pack("<I", len(data)) + data
    return CDR_HEADER + struct.pack("<I", len(data) + 1) + data + b"\0"


def _stamp_bytes(time_ns: NDArray[np.int64], *, ros1: bool) -> U8:
    return ros1_times(time_ns) if ros1 else stamps_from_ns(time_ns)
