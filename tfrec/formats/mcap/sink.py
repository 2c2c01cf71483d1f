"""MCAP output of ``tfrec record``: what ``ros2 bag record -s mcap`` would have recorded from joint_state_publisher
and robot_state_publisher — a thin layer over the one MCAP writer (:class:`tfrec.formats.mcap.writer.McapWriter`).
(The ``metadata.yaml`` of a rosbag2 folder: :mod:`tfrec.formats.rosbag2.metadata`.)

Channels, in id order:

1. ``/robot_description``, ``std_msgs/msg/String``, transient_local: the URDF, once at the start.
2. ``/tf_static``, ``tf2_msgs/msg/TFMessage``, transient_local: all static transforms, once.
3. ``/joint_states``, ``sensor_msgs/msg/JointState``, volatile: one per sample (empty for a robot
   without moving joints).
4. ``/tf``, ``tf2_msgs/msg/TFMessage``, volatile: one per sample; none for a robot without moving joints
   (robot_state_publisher publishes no /tf for an empty joint state).

A chunk holds whole samples — a /joint_states then a /tf message each, a fixed number per chunk for fixed joint and
frame names (:data:`~tfrec.formats.mcap.writer.DEFAULT_CHUNK_BYTES` of them), the first chunk the latched messages
before them — encoded with numpy (:mod:`tfrec.formats.ros.encode`) and compressed in line. Nothing depends on the
wall clock or on the file's name, so the same inputs give the same bytes. See docs/recording-format.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.formats.mcap.records import MESSAGE_HEAD_SIZE, RECORD
from tfrec.formats.mcap.writer import (
    DEFAULT_CHUNK_BYTES,
    McapWriter,
    SampleRows,
    check_time_range,
    chunk_compressor,
    message_definition,
)
from tfrec.formats.ros.connection import Connection
from tfrec.formats.ros.encode import JointStateEncoder, TFMessageEncoder, encode_string
from tfrec.recording import Transforms

__all__ = ["TOPICS", "McapSink"]

TOPICS: tuple[tuple[str, str, bool], ...] = (
    (ROBOT_DESCRIPTION, "std_msgs/msg/String", True),
    (TF_STATIC, "tf2_msgs/msg/TFMessage", True),
    (JOINT_STATES, "sensor_msgs/msg/JointState", False),
    (TF, "tf2_msgs/msg/TFMessage", False),
)
"""(topic, type, latched) in channel-id order 1..4; robot_state_publisher and joint_state_publisher publish
reliable, /robot_description and /tf_static latched (transient_local)."""

_CH_DESCRIPTION, _CH_TF_STATIC, _CH_JOINT_STATES, _CH_TF = 1, 2, 3, 4
_HEAD = RECORD.size + MESSAGE_HEAD_SIZE


class McapSink:
    """Streams a recording into an MCAP file, chunk by chunk, in bounded memory (a
    :class:`~tfrec.formats.sink.RecordSink`).

    Call :meth:`begin` once, :meth:`write_chunk` for consecutive pieces of the trajectory, then
    :meth:`finish`. The stream must be positioned at its start (a new file or BytesIO); the sink
    neither closes it nor writes anything after :meth:`finish`.

    Args:
        stream: a binary stream to write to.
        compression: chunk compression, one of :data:`~tfrec.conventions.COMPRESSIONS`:
            ``"zstd"`` (default), ``"lz4"`` or ``"none"``.
        chunk_bytes: uncompressed bytes per MCAP chunk (whole samples; at least one).
        metadata: metadata records (name → map of strings) written after the ``rosbag2`` one, such as the
            recipe :mod:`tfrec.recorder` stores.

    Raises:
        WriteError: an unknown compression.
    """

    def __init__(self, stream: IO[bytes], *, compression: str = "zstd", chunk_bytes: int = DEFAULT_CHUNK_BYTES,
                 metadata: Mapping[str, Mapping[str, str]] | None = None) -> None:
        if chunk_bytes < 1:
            raise ValueError(f"chunk size must be positive, got {chunk_bytes}")
        chunk_compressor(compression)  # checks the name before anything is written
        self._stream = stream
        self._compression = compression
        self._chunk_bytes = chunk_bytes
        self._writer: McapWriter | None = None
        self._state = "new"
        self._last_sample_ns = -1
        # set by the first write_chunk: the encoders, and how many samples a chunk holds
        self._joint_states: JointStateEncoder | None = None
        self._tf: TFMessageEncoder | None = None
        self._rows: SampleRows | None = None  # a chunk's samples
        self._metadata = dict(metadata or {})  # metadata records written at finish() (tfrec's recipe)

    # -- public API ---------------------------------------------------------------------------

    def begin(self, *, robot_description: str, static: Transforms, start_time_ns: int) -> None:
        """Write the header, schemas and channels, and queue /robot_description and /tf_static.

        Args:
            robot_description: the expanded URDF.
            static: the static transforms (N = 1), all stamped ``start_time_ns``.
            start_time_ns: nanoseconds since the epoch.

        Raises:
            WriteError: ``start_time_ns`` outside the range of ROS 2 stamps.
        """
        if self._state != "new":
            raise RuntimeError("McapSink.begin() called twice")
        check_time_range(start_time_ns, start_time_ns)
        if static.translation.shape[0] != 1:
            raise ValueError(f"static transforms must have N = 1, got {static.translation.shape[0]}")
        writer = self._writer = McapWriter(self._stream, compression=self._compression, chunk_bytes=None, threads=0)
        connections = []
        for topic, msgtype, latched in TOPICS:
            text, type_hash = message_definition(msgtype)
            connections.append(Connection(topic, msgtype, "cdr", definition=text, definition_encoding="ros2msg",
                                          latched=latched, type_hash=type_hash))
        writer.add_channels(connections)
        stamp = np.array([start_time_ns], dtype=np.int64)
        writer.write(_CH_DESCRIPTION, stamp, [encode_string(robot_description)])
        writer.write(_CH_TF_STATIC, stamp, TFMessageEncoder(static.parents, static.children).encode(
            stamp, static.translation, static.rotation))
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
            WriteError: a stamp outside the range of ROS 2 stamps.
        """
        if self._state != "open":
            raise RuntimeError(f"McapSink.write_chunk() called {'before begin()' if self._state == 'new' else 'after finish()'}")
        stamp_ns = np.asarray(stamp_ns, dtype=np.int64)
        n = len(stamp_ns)
        if n == 0:
            return
        self._check(stamp_ns, tuple(joint_names), transforms)
        rows, writer = self._rows, self._writer
        assert rows is not None and writer is not None and self._joint_states is not None and self._tf is not None
        done = 0
        while done < n:  # a chunk holds rows.capacity samples (the first one the latched messages too)
            take = min(n - done, rows.capacity - rows.filled)
            part, at = slice(done, done + take), slice(rows.filled, rows.filled + take)
            self._joint_states.encode_into(rows.data[0][at], stamp_ns[part], positions[part], velocities[part])
            if self._tf.children:
                self._tf.encode_into(rows.data[1][at], stamp_ns[part], transforms.translation[part],
                                     transforms.rotation[part])
            writer.write_rows(rows, stamp_ns[part])
            done += take
            if rows.filled == rows.capacity:
                writer.end_chunk()
                rows.filled = 0

    def finish(self) -> None:
        """Write the last chunk, the ``rosbag2`` metadata record that ``ros2 bag record`` adds,
        the summary (schemas, channels, statistics, chunk and metadata indexes) and the footer.
        Does not close the stream."""
        if self._state != "open":
            raise RuntimeError(f"McapSink.finish() called {'before begin()' if self._state == 'new' else 'twice'}")
        assert self._writer is not None
        for name, values in self._metadata.items():
            self._writer.add_metadata(name, values)
        self._writer.finish()
        self._state = "done"

    def abort(self) -> None:
        """Give the file up after an error (the caller deletes it). Safe to call in any state."""
        if self._writer is not None:
            self._writer.abort()
        self._state = "done"

    @property
    def message_count(self) -> int:
        return 0 if self._writer is None else self._writer.message_count

    @property
    def bag_info(self) -> dict[str, Any]:
        """The rosbag2 BagMetadata embedded by :meth:`finish` (:func:`tfrec.formats.rosbag2.metadata.bag_info`),
        for the ``metadata.yaml`` of a bag folder (:func:`tfrec.formats.rosbag2.metadata.write_bag_metadata`)."""
        if self._state != "done" or self._writer is None:
            raise RuntimeError("McapSink.bag_info is known after finish()")
        return self._writer.bag_info

    # -- samples --------------------------------------------------------------------------------

    def _check(self, stamp_ns: NDArray[np.int64], names: tuple[str, ...], transforms: Transforms) -> None:
        """Fix the encoders and the samples per chunk at the first call; check the next ones against them.

        Raises:
            ValueError: other joints or frames than the first call's, or stamps that decrease.
            WriteError: a stamp outside the range of ROS 2 stamps.
        """
        if self._joint_states is None:
            self._joint_states = JointStateEncoder(names)
            self._tf = TFMessageEncoder(transforms.parents, transforms.children)
            channels, templates = [_CH_JOINT_STATES], [self._joint_states.template]
            if self._tf.children:
                channels.append(_CH_TF)
                templates.append(self._tf.template)
            row = sum(_HEAD + len(template) for template in templates)
            self._rows = SampleRows(channels, templates, max(1, self._chunk_bytes // row))
        assert self._tf is not None
        if names != self._joint_states.names:
            raise ValueError("joint names changed between chunks")
        if transforms.parents != self._tf.parents or transforms.children != self._tf.children:
            raise ValueError("transform frames changed between chunks")
        if int(stamp_ns[0]) < self._last_sample_ns or bool(np.any(np.diff(stamp_ns) < 0)):
            raise ValueError("stamps must not decrease")
        check_time_range(int(stamp_ns[0]), int(stamp_ns[-1]))
        self._last_sample_ns = int(stamp_ns[-1])
