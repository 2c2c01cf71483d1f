"""Vectorized ROS 1 serialization of the messages tfrec records: JointState, TFMessage, String.

The design of :mod:`tfrec.cdr` with ROS 1's rules: for fixed joint and frame names a
``sensor_msgs/JointState`` or ``tf2_msgs/TFMessage`` has a fixed byte layout, so a whole chunk of
N messages is one (N, size) uint8 array — the template repeated, then the sequence numbers, stamps
and float64 values copied in as strided blocks. The bytes are identical to rosbags'
``typestore.serialize_ros1`` (tests/formats/test_rosbag1_writer.py).

ROS 1 serialization: little-endian, no alignment and no padding; a string is a uint32 byte count
then the bytes (no NUL); a variable-length array is a uint32 count then the elements;
``std_msgs/Header`` is ``uint32 seq``, ``time stamp`` (uint32 secs, uint32 nsecs), ``string frame_id``.

Sequence numbers follow roscpp: a publisher overwrites the ``seq`` of a message's top-level header
with its own counter (0, 1, 2, … per topic), and leaves headers nested deeper alone — so a
JointState carries the counter and the TransformStamped headers inside a TFMessage keep the 0 that
tf2_ros' broadcasters leave there.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S
from tfrec.errors import WriteError
from tfrec.formats.ros._layout import Layout, check_rows, float_bytes

__all__ = [
    "ROS1_TIME_LIMIT_NS",
    "Ros1JointStateEncoder",
    "Ros1TFMessageEncoder",
    "check_ros1_times",
    "encode_ros1_string",
    "ros1_times",
]

U8 = NDArray[np.uint8]

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


class Ros1JointStateEncoder:
    """``sensor_msgs/JointState`` messages (ROS 1) for one fixed list of joint names.

    ``header.frame_id`` is empty and ``effort`` is empty, as joint_state_publisher publishes.

    Args:
        names: the joint names, in the order of the position and velocity columns.
        frame_id: the header's frame id.
    """

    def __init__(self, names: Sequence[str], *, frame_id: str = "") -> None:
        self.names = tuple(names)
        layout = Layout(ros1=True)
        seq, self._stamp = layout.header(frame_id)
        assert seq is not None
        self._seq = seq
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
            first_seq: ``header.seq`` of the first message; the next ones count up (modulo 2**32).

        Returns:
            uint8 (N, size): row i is the ROS 1 bytes of message i.

        Raises:
            WriteError: a stamp outside ROS 1's time range.
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
        rows[:, self._stamp : self._stamp + 8] = ros1_times(time_ns)
        seq = (np.arange(n, dtype=np.int64) + first_seq) % 2**32
        rows[:, self._seq : self._seq + 4] = seq.astype("<u4").view(np.uint8).reshape(n, 4)
        if j:
            width = 8 * j
            rows[:, self._position : self._position + width] = float_bytes(positions, n, width)
            rows[:, self._velocity : self._velocity + width] = float_bytes(velocities, n, width)


class Ros1TFMessageEncoder:
    """``tf2_msgs/TFMessage`` messages (ROS 1) for one fixed list of (parent, child) frames.

    Every TransformStamped gets the message's stamp, ``frame_id`` the parent, ``child_frame_id``
    the child and ``seq`` 0, as robot_state_publisher publishes.

    Args:
        parents: frame ids of the parent frames.
        children: frame ids of the child frames, as many.
    """

    def __init__(self, parents: Sequence[str], children: Sequence[str]) -> None:
        if len(parents) != len(children):
            raise ValueError(f"{len(parents)} parents but {len(children)} children")
        self.parents = tuple(parents)
        self.children = tuple(children)
        layout = Layout(ros1=True)
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
            uint8 (N, size): row i is the ROS 1 bytes of message i.

        Raises:
            WriteError: a stamp outside ROS 1's time range.
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
        stamps = ros1_times(time_ns)
        if k:
            values = np.empty((n, k, 7), dtype="<f8")
            values[:, :, :3] = translation
            values[:, :, 3:] = rotation
            value_bytes = values.view(np.uint8)  # (n, k, 56)
            for i, (stamp, value) in enumerate(zip(self._stamps, self._values)):
                rows[:, stamp : stamp + 8] = stamps
                rows[:, value : value + 56] = value_bytes[:, i, :]


def encode_ros1_string(text: str) -> bytes:
    """A ``std_msgs/String`` message (ROS 1)."""
    data = text.encode("utf-8")
    return struct.pack("<I", len(data)) + data
