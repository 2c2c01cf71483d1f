"""ROS 1 bag output of ``tfrec record``: what ``rosbag record`` would have recorded from
joint_state_publisher and robot_state_publisher.

Connections, in id order, all published by :data:`~tfrec.formats.rosbag1.writer.CALLERID`:

0. ``/robot_description``, ``std_msgs/String``, latching: the URDF, once at the start.
1. ``/tf_static``, ``tf2_msgs/TFMessage``, latching: all static transforms, once.
2. ``/joint_states``, ``sensor_msgs/JointState``: one per sample, ``header.seq`` 0, 1, 2, … (empty for
   a robot without moving joints).
3. ``/tf``, ``tf2_msgs/TFMessage``: one per sample; none for a robot without moving joints.

Every message's bag time is its header stamp. A thin layer over the one ROS 1 writer
(:class:`~tfrec.formats.rosbag1.writer.Ros1BagWriter`), behind the :class:`~tfrec.formats.sink.RecordSink`
protocol, so the record pipeline drives it as it drives the MCAP and Rerun sinks.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.formats.ros.encode import JointStateEncoder, TFMessageEncoder, check_ros1_times, encode_string
from tfrec.formats.ros.types import ros1_message_definition
from tfrec.formats.rosbag1.writer import CALLERID, DEFAULT_CHUNK_BYTES, Ros1BagWriter
from tfrec.recording import Transforms

__all__ = ["TOPICS", "Ros1BagSink"]

TOPICS: tuple[tuple[str, str, bool], ...] = (
    (ROBOT_DESCRIPTION, "std_msgs/String", True),
    (TF_STATIC, "tf2_msgs/TFMessage", True),
    (JOINT_STATES, "sensor_msgs/JointState", False),
    (TF, "tf2_msgs/TFMessage", False),
)
"""(topic, type, latching) in connection-id order 0..3."""

_CONN_DESCRIPTION, _CONN_TF_STATIC, _CONN_JOINT_STATES, _CONN_TF = 0, 1, 2, 3


class Ros1BagSink:
    """Streams a recording into a ROS 1 bag, chunk by chunk, in bounded memory.

    Call :meth:`begin` once, :meth:`write_chunk` for consecutive pieces of the trajectory, then
    :meth:`finish`; after an error, :meth:`abort` closes the file without its index (the caller
    deletes it). The file is created at once.

    Args:
        path: the bag to write (the caller's temporary file).
        compression: chunk compression: ``"none"`` (default, as ``rosbag record``), ``"bz2"`` or ``"lz4"``.
        chunk_bytes: uncompressed bytes per chunk.

    Raises:
        WriteError: an unknown compression, or the file cannot be created.
    """

    def __init__(self, path: str | Path, *, compression: str = "none", chunk_bytes: int = DEFAULT_CHUNK_BYTES) -> None:
        self._writer = Ros1BagWriter(path, compression=compression, chunk_bytes=chunk_bytes)
        self._state = "new"
        self._joint_states: JointStateEncoder | None = None
        self._tf: TFMessageEncoder | None = None
        self._last_sample_ns = -1

    def begin(self, *, robot_description: str, static: Transforms, start_time_ns: int) -> None:
        """Add the connections and write /robot_description and /tf_static.

        Args:
            robot_description: the expanded URDF.
            static: the static transforms (N = 1), all stamped ``start_time_ns``.
            start_time_ns: nanoseconds since the epoch.

        Raises:
            WriteError: ``start_time_ns`` outside ROS 1's time range, or a write error.
        """
        if self._state != "new":
            raise RuntimeError("Ros1BagSink.begin() called twice")
        if static.translation.shape[0] != 1:
            raise ValueError(f"static transforms must have N = 1, got {static.translation.shape[0]}")
        check_ros1_times(start_time_ns, start_time_ns)
        for topic, msgtype, latching in TOPICS:
            msgdef, md5sum = ros1_message_definition(msgtype)
            self._writer.add_connection(topic, msgtype, msgdef=msgdef, md5sum=md5sum, latching=latching,
                                        callerid=CALLERID)
        self._writer.write(_CONN_DESCRIPTION, start_time_ns, encode_string(robot_description, ros1=True))
        tf_static = TFMessageEncoder(static.parents, static.children, ros1=True).encode(
            np.array([start_time_ns], dtype=np.int64), static.translation, static.rotation
        )
        self._writer.write(_CONN_TF_STATIC, start_time_ns, tf_static[0].tobytes())
        self._state = "open"

    def write_chunk(
        self,
        *,
        stamp_ns: NDArray[np.int64],
        joint_names: Sequence[str],
        positions: NDArray[np.float64],
        velocities: NDArray[np.float64],
        transforms: Transforms,
    ) -> None:
        """Add N samples: one /joint_states and one /tf message each, stamped ``stamp_ns``; no /tf
        message when there are no dynamic transforms (K = 0), as robot_state_publisher.

        Args:
            stamp_ns: int64 (N,) absolute stamps (ns since the epoch), increasing across calls.
            joint_names: the moving joints (the same in every call).
            positions, velocities: float64 (N, J).
            transforms: the dynamic transforms, translation (N, K, 3), rotation (N, K, 4); the
                same frames in every call.

        Raises:
            WriteError: a stamp outside ROS 1's time range, or a write error.
        """
        if self._state != "open":
            raise RuntimeError(
                f"Ros1BagSink.write_chunk() called {'before begin()' if self._state == 'new' else 'after finish()'}"
            )
        stamp_ns = np.asarray(stamp_ns, dtype=np.int64)
        if len(stamp_ns) == 0:
            return
        if self._joint_states is None or self._tf is None:
            self._joint_states = JointStateEncoder(joint_names, ros1=True)
            self._tf = TFMessageEncoder(transforms.parents, transforms.children, ros1=True)
        if tuple(joint_names) != self._joint_states.names:
            raise ValueError("joint names changed between chunks")
        if transforms.parents != self._tf.parents or transforms.children != self._tf.children:
            raise ValueError("transform frames changed between chunks")
        if int(stamp_ns[0]) < self._last_sample_ns or bool(np.any(np.diff(stamp_ns) < 0)):
            raise ValueError("stamps must not decrease")
        check_ros1_times(int(stamp_ns[0]), int(stamp_ns[-1]))
        self._last_sample_ns = int(stamp_ns[-1])
        first_seq = self._writer.message_counts[_CONN_JOINT_STATES]
        joint_states = self._joint_states.encode(stamp_ns, positions, velocities, first_seq=first_seq)
        if not self._tf.children:
            self._writer.write_samples((_CONN_JOINT_STATES,), stamp_ns, (joint_states,))
            return
        tf = self._tf.encode(stamp_ns, transforms.translation, transforms.rotation)
        self._writer.write_samples((_CONN_JOINT_STATES, _CONN_TF), stamp_ns, (joint_states, tf))

    def finish(self) -> None:
        """Write the last chunk and the index, and close the file.

        Raises:
            WriteError: a write error.
        """
        if self._state != "open":
            raise RuntimeError(f"Ros1BagSink.finish() called {'before begin()' if self._state == 'new' else 'twice'}")
        self._writer.close()
        self._state = "done"

    def abort(self) -> None:
        """Close the file without its index; the caller deletes it. Safe to call in any state."""
        self._writer.abort()
        self._state = "done"

    @property
    def message_count(self) -> int:
        """Messages written so far."""
        return self._writer.message_count
