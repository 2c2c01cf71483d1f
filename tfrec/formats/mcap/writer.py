"""MCAP output: what ``ros2 bag record -s mcap`` would have recorded from joint_state_publisher
and robot_state_publisher. (The ``metadata.yaml`` of a rosbag2 folder: :mod:`tfrec.formats.rosbag2.metadata`.)

Channels, in id order:

1. ``/robot_description``, ``std_msgs/msg/String``, transient_local: the URDF, once at the start.
2. ``/tf_static``, ``tf2_msgs/msg/TFMessage``, transient_local: all static transforms, once.
3. ``/joint_states``, ``sensor_msgs/msg/JointState``, volatile: one per sample (empty for a robot
   without moving joints).
4. ``/tf``, ``tf2_msgs/msg/TFMessage``, volatile: one per sample; none for a robot without moving joints
   (robot_state_publisher publishes no /tf for an empty joint state).

The writer is tfrec's own (the small records come from :mod:`mcap.records`): a chunk's Message
records have a fixed size for fixed joint and frame names, so a chunk is one numpy array filled by
strided writes (:mod:`tfrec.formats.ros.encode`), and its message index is arithmetic. Nothing depends on the
wall clock or on the file's name, so the same inputs give the same bytes. See docs/recording-format.md.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Callable, Sequence
from functools import cache
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from tfrec._version import __version__
from tfrec.conventions import (
    COMPRESSIONS,
    DEFAULT_START_TIME_NS,
    JOINT_STATES,
    NS_PER_S,
    ROBOT_DESCRIPTION,
    STAMP_LIMIT_NS,
    STAMP_RANGE,
    TF,
    TF_STATIC,
)
from tfrec.errors import WriteError
from tfrec.formats.mcap.records import (
    MCAP_MAGIC,
    MESSAGE_HEAD_SIZE,
    OP_CHANNEL,
    OP_CHUNK,
    OP_CHUNK_INDEX,
    OP_FOOTER,
    OP_MESSAGE,
    OP_MESSAGE_INDEX,
    OP_METADATA_INDEX,
    OP_SCHEMA,
    OP_STATISTICS,
    RECORD,
)
from tfrec.formats.ros.encode import JointStateEncoder, TFMessageEncoder, encode_string
from tfrec.formats.ros.types import typestore
from tfrec.formats.rosbag2.metadata import QOS_LATCHED, QOS_VOLATILE, bag_info, bag_metadata_yaml, qos_yaml
from tfrec.recording import Transforms

__all__ = [
    "DEFAULT_CHUNK_BYTES",
    "DEFAULT_START_TIME_NS",  # re-exported from tfrec.conventions
    "LIBRARY",
    "PROFILE",
    "TOPICS",
    "McapSink",
    "check_time_range",
    "chunk_compressor",
    "message_definition",
    "serialize_records",
]

DEFAULT_CHUNK_BYTES = 1 << 20
"""Uncompressed bytes per MCAP chunk (mcap's Python writer also uses 1 MiB)."""

PROFILE = "ros2"
LIBRARY = f"tfrec {__version__}"
"""The MCAP header's ``library`` field."""

TOPICS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    (ROBOT_DESCRIPTION, "std_msgs/msg/String", QOS_LATCHED),
    (TF_STATIC, "tf2_msgs/msg/TFMessage", QOS_LATCHED),
    (JOINT_STATES, "sensor_msgs/msg/JointState", QOS_VOLATILE),
    (TF, "tf2_msgs/msg/TFMessage", QOS_VOLATILE),
)
"""(topic, type, offered QoS profile) in channel-id order 1..4; robot_state_publisher and
joint_state_publisher publish reliable, /robot_description and /tf_static latched."""

_CH_DESCRIPTION, _CH_TF_STATIC, _CH_JOINT_STATES, _CH_TF = 1, 2, 3, 4


@cache
def message_definition(msgtype: str) -> tuple[str, str]:
    """The ``ros2msg`` schema text of a ROS 2 type (its .msg, then each dependency once) and its
    RIHS01 type hash, from rosbags' ROS 2 Humble type store."""
    store = typestore()
    text, _ = store.generate_msgdef(msgtype, ros_version=2)
    return text, store.hash_rihs01(msgtype)


def check_time_range(first_ns: int, last_ns: int) -> None:
    """Check that stamps fit ROS 2's ``builtin_interfaces/Time`` (int32 seconds) and MCAP's
    unsigned log times: from 1970-01-01 to 2038-01-19.

    Raises:
        WriteError: a stamp outside that range.
    """
    for stamp in (first_ns, last_ns):
        if not 0 <= stamp < STAMP_LIMIT_NS:
            problem = "before 1970" if stamp < 0 else f"out of range: {STAMP_RANGE}"
            seconds, nanoseconds = divmod(stamp, NS_PER_S)  # exact: a stamp past float64 too
            raise WriteError(f"stamp {seconds}.{nanoseconds:09d} s is {problem}")


_ZSTD_BLOCK = 16 * 1024
"""Uncompressed bytes per zstd block: the most a cut inside a zstd chunk loses."""


def chunk_compressor(compression: str) -> tuple[str, Callable[[bytes], bytes]]:
    """The chunk compression field and compressor of ``zstd`` (level 3, a block every 16 KiB so a
    cut file reads up to the cut), ``lz4`` (frame format) or ``none``.

    Raises:
        WriteError: another compression.
    """
    if compression == "zstd":
        import zstandard

        compressor = zstandard.ZstdCompressor(level=3)

        def compress(data: bytes) -> bytes:
            # End a zstd block every _ZSTD_BLOCK bytes: a file cut inside a chunk (a recorder killed
            # mid-write) can then be read up to the cut; costs ~2% of size.
            stream = compressor.compressobj(size=len(data))
            parts = [stream.compress(data[i:i + _ZSTD_BLOCK]) + stream.flush(zstandard.COMPRESSOBJ_FLUSH_BLOCK)
                     for i in range(0, len(data), _ZSTD_BLOCK)]
            parts.append(stream.flush())
            return b"".join(parts)

        return "zstd", compress
    if compression == "lz4":
        import lz4.frame

        return "lz4", lz4.frame.compress
    if compression == "none":
        return "", bytes
    raise WriteError(f"compression '{compression}' is not one of {', '.join(COMPRESSIONS)}")


def serialize_records(*records: Any) -> bytes:
    """mcap's records (:mod:`mcap.records`) as bytes."""
    from mcap.data_stream import RecordBuilder

    builder = RecordBuilder()
    for record in records:
        record.write(builder)
    return bytes(builder.end())  # type: ignore[no-untyped-call]


def _message_record(channel_id: int, sequence: int, time_ns: int, data: bytes) -> bytes:
    return struct.pack(
        "<BQHIQQ", OP_MESSAGE, MESSAGE_HEAD_SIZE + len(data), channel_id, sequence, time_ns, time_ns
    ) + data


class McapSink:
    """Streams a recording into an MCAP file, chunk by chunk, in bounded memory.

    Call :meth:`begin` once, :meth:`write_chunk` for consecutive pieces of the trajectory, then
    :meth:`finish`. The stream must be positioned at its start (a new file or BytesIO); the sink
    neither closes it nor writes anything after :meth:`finish`.

    Args:
        stream: a binary stream to write to.
        compression: chunk compression, one of :data:`~tfrec.conventions.COMPRESSIONS`:
            ``"zstd"`` (default), ``"lz4"`` or ``"none"``.
        chunk_bytes: uncompressed bytes per MCAP chunk (whole samples; at least one).

    Raises:
        WriteError: an unknown compression.
    """

    def __init__(
        self,
        stream: IO[bytes],
        *,
        compression: str = "zstd",
        chunk_bytes: int = DEFAULT_CHUNK_BYTES,
    ) -> None:
        if chunk_bytes < 1:
            raise ValueError(f"chunk size must be positive, got {chunk_bytes}")
        self._stream = stream
        self._compression, self._compress = chunk_compressor(compression)
        self._chunk_bytes = chunk_bytes
        self._offset = 0
        self._state = "new"
        self._chunk_indexes: list[Any] = []
        self._counts = {channel: 0 for channel in range(1, len(TOPICS) + 1)}
        self._start_ns: int | None = None
        self._end_ns = 0
        self._last_sample_ns = -1
        # first-chunk messages (/robot_description, /tf_static): (channel, time, record)
        self._prefix: list[tuple[int, int, bytes]] = []
        # set by the first write_chunk: encoders, and the chunk being filled, one row per sample
        # (a /joint_states Message record then a /tf Message record)
        self._joint_states: JointStateEncoder | None = None
        self._tf: TFMessageEncoder | None = None
        self._rows: NDArray[np.uint8] = np.empty((0, 0), dtype=np.uint8)
        self._row_times: NDArray[np.int64] = np.empty(0, dtype=np.int64)
        self._row_len = self._js_len = self._filled = 0
        self._bag_info: dict[str, Any] = {}

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
        from mcap.records import Channel, Header, Schema

        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        schema_ids: dict[str, int] = {}
        for channel_id, (topic, msgtype, qos) in enumerate(TOPICS, start=1):
            text, type_hash = message_definition(msgtype)
            if msgtype not in schema_ids:
                schema_ids[msgtype] = len(schema_ids) + 1
                schema = Schema(id=schema_ids[msgtype], name=msgtype, encoding="ros2msg", data=text.encode())
                self._schemas.append(schema)
            channel = Channel(
                id=channel_id, topic=topic, message_encoding="cdr", schema_id=schema_ids[msgtype],
                metadata={"offered_qos_profiles": qos_yaml([qos]), "topic_type_hash": type_hash},
            )
            self._channels.append(channel)
        self._write(MCAP_MAGIC + serialize_records(Header(profile=PROFILE, library=LIBRARY), *self._schemas, *self._channels))

        if static.translation.shape[0] != 1:
            raise ValueError(f"static transforms must have N = 1, got {static.translation.shape[0]}")
        tf_static = TFMessageEncoder(static.parents, static.children).encode(
            np.array([start_time_ns], dtype=np.int64), static.translation, static.rotation
        )
        self._prefix = [
            (_CH_DESCRIPTION, start_time_ns,
             _message_record(_CH_DESCRIPTION, 1, start_time_ns, encode_string(robot_description))),
            (_CH_TF_STATIC, start_time_ns, _message_record(_CH_TF_STATIC, 1, start_time_ns, tf_static[0].tobytes())),
        ]
        self._counts[_CH_DESCRIPTION] = self._counts[_CH_TF_STATIC] = 1
        self._start_ns = self._end_ns = start_time_ns
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
        if self._joint_states is None:
            self._setup(tuple(joint_names), transforms.parents, transforms.children)
        assert self._joint_states is not None and self._tf is not None
        if tuple(joint_names) != self._joint_states.names:
            raise ValueError("joint names changed between chunks")
        if transforms.parents != self._tf.parents or transforms.children != self._tf.children:
            raise ValueError("transform frames changed between chunks")
        if int(stamp_ns[0]) < self._last_sample_ns or bool(np.any(np.diff(stamp_ns) < 0)):
            raise ValueError("stamps must not decrease")
        check_time_range(int(stamp_ns[0]), int(stamp_ns[-1]))
        self._last_sample_ns = int(stamp_ns[-1])

        done = 0
        while done < n:
            take = min(n - done, len(self._rows) - self._filled)
            self._fill(slice(done, done + take), stamp_ns, positions, velocities, transforms)
            done += take
            if self._filled == len(self._rows):
                self._flush_chunk()

    def finish(self) -> None:
        """Write the last chunk, the ``rosbag2`` metadata record that ``ros2 bag record`` adds,
        the summary (schemas, channels, statistics, chunk and metadata indexes) and the footer.
        Does not close the stream."""
        if self._state != "open":
            raise RuntimeError(f"McapSink.finish() called {'before begin()' if self._state == 'new' else 'twice'}")
        self._flush_chunk()
        self._write_summary()
        self._state = "done"

    @property
    def message_count(self) -> int:
        return sum(self._counts.values())

    @property
    def bag_info(self) -> dict[str, Any]:
        """The rosbag2 BagMetadata embedded by :meth:`finish` (:func:`tfrec.formats.rosbag2.metadata.bag_info`),
        for the ``metadata.yaml`` of a bag folder (:func:`tfrec.formats.rosbag2.metadata.write_bag_metadata`)."""
        if self._state != "done":
            raise RuntimeError("McapSink.bag_info is known after finish()")
        return self._bag_info

    # -- chunks -------------------------------------------------------------------------------

    def _setup(self, names: tuple[str, ...], parents: tuple[str, ...], children: tuple[str, ...]) -> None:
        """Fix the row layout: a JointState Message record then a TF Message record per sample (no TF
        record without dynamic transforms)."""
        self._joint_states = JointStateEncoder(names)
        self._tf = TFMessageEncoder(parents, children)
        js_len = RECORD.size + MESSAGE_HEAD_SIZE + self._joint_states.size
        row = bytearray()
        row += struct.pack("<BQH", OP_MESSAGE, MESSAGE_HEAD_SIZE + self._joint_states.size, _CH_JOINT_STATES)
        row += bytes(20) + self._joint_states.template.tobytes()
        if self._tf.children:
            row += struct.pack("<BQH", OP_MESSAGE, MESSAGE_HEAD_SIZE + self._tf.size, _CH_TF)
            row += bytes(20) + self._tf.template.tobytes()
        self._row_len = len(row)
        self._js_len = js_len
        samples = max(1, self._chunk_bytes // self._row_len)
        self._rows = np.tile(np.frombuffer(bytes(row), dtype=np.uint8), (samples, 1))
        self._row_times = np.empty(samples, dtype=np.int64)
        self._filled = 0

    def _fill(
        self,
        part: slice,
        time_ns: NDArray[np.int64],
        positions: NDArray[np.float64],
        velocities: NDArray[np.float64],
        transforms: Transforms,
    ) -> None:
        assert self._joint_states is not None and self._tf is not None
        stamps = time_ns[part]
        m = len(stamps)
        rows = self._rows[self._filled : self._filled + m]
        self._row_times[self._filled : self._filled + m] = stamps
        first_seq = self._counts[_CH_JOINT_STATES] + 1
        sequence = np.arange(first_seq, first_seq + m, dtype="<u4").view(np.uint8).reshape(m, 4)
        times = stamps.astype("<u8").view(np.uint8).reshape(m, 8)
        tf = bool(self._tf.children)
        for base in (0, self._js_len)[: 1 + tf]:  # sequence, log time, publish time of each record
            rows[:, base + 11 : base + 15] = sequence
            rows[:, base + 15 : base + 23] = times
            rows[:, base + 23 : base + 31] = times
        data = RECORD.size + MESSAGE_HEAD_SIZE
        self._joint_states.encode_into(
            rows[:, data : data + self._joint_states.size], stamps, positions[part], velocities[part]
        )
        data += self._js_len
        if tf:
            self._tf.encode_into(
                rows[:, data : data + self._tf.size], stamps, transforms.translation[part], transforms.rotation[part]
            )
        self._filled += m
        self._counts[_CH_JOINT_STATES] += m
        self._counts[_CH_TF] += m if tf else 0
        self._end_ns = max(self._end_ns, int(stamps[-1]))

    def _flush_chunk(self) -> None:
        """Compress the queued messages into one Chunk record followed by its MessageIndex records."""
        from mcap.records import ChunkIndex

        filled = self._filled
        if not self._prefix and not filled:
            return
        prefix = b"".join(record for _, _, record in self._prefix)
        # (channel, times, offsets in the uncompressed chunk) per channel, in channel-id order
        entries: list[tuple[int, NDArray[np.int64], NDArray[np.int64]]] = []
        position = 0
        for channel, time, record in self._prefix:
            entries.append((channel, np.array([time]), np.array([position])))
            position += len(record)
        times: list[int] = [time for _, time, _ in self._prefix]
        body = prefix
        if filled:
            rows = self._rows[:filled]
            stamps = self._row_times[:filled]
            offsets = len(prefix) + np.arange(filled, dtype=np.int64) * self._row_len
            entries.append((_CH_JOINT_STATES, stamps, offsets))
            if self._tf is not None and self._tf.children:
                entries.append((_CH_TF, stamps, offsets + self._js_len))
            times += [int(stamps[0]), int(stamps[-1])]
            body = prefix + rows.tobytes()
        start, end = min(times), max(times)
        compressed = self._compress(body)
        header = struct.pack(
            "<BQQQQI", OP_CHUNK, 8 + 8 + 8 + 4 + 4 + len(self._compression) + 8 + len(compressed),
            start, end, len(body), zlib.crc32(body),
        )
        header += struct.pack("<I", len(self._compression)) + self._compression.encode()
        header += struct.pack("<Q", len(compressed))
        chunk_start = self._offset
        self._write(header)
        self._write(compressed)
        chunk_length = self._offset - chunk_start

        index_offsets: dict[int, int] = {}
        index_start = self._offset
        for channel, stamps_, offsets_ in entries:
            pairs = np.empty((len(stamps_), 2), dtype="<u8")
            pairs[:, 0] = stamps_
            pairs[:, 1] = offsets_
            index_offsets[channel] = self._offset
            self._write(
                struct.pack("<BQHI", OP_MESSAGE_INDEX, 2 + 4 + pairs.nbytes, channel, pairs.nbytes) + pairs.tobytes()
            )
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=start, message_end_time=end, chunk_start_offset=chunk_start,
            chunk_length=chunk_length, message_index_offsets=index_offsets,
            message_index_length=self._offset - index_start, compression=self._compression,
            compressed_size=len(compressed), uncompressed_size=len(body),
        ))
        self._prefix = []
        self._filled = 0

    # -- summary ------------------------------------------------------------------------------

    def _write_summary(self) -> None:
        from mcap.records import DataEnd, Footer, Metadata, MetadataIndex, Statistics, SummaryOffset

        start = self._start_ns or 0
        self._bag_info = bag_info(
            [(topic, msgtype, "cdr", [qos], message_definition(msgtype)[1], self._counts[channel])
             for channel, (topic, msgtype, qos) in enumerate(TOPICS, start=1)],
            message_count=self.message_count, start_ns=start, end_ns=self._end_ns,
        )
        metadata = serialize_records(Metadata(name="rosbag2", metadata={"serialized_metadata": bag_metadata_yaml(self._bag_info)}))
        metadata_index = MetadataIndex(offset=self._offset, length=len(metadata), name="rosbag2")
        self._write(metadata + serialize_records(DataEnd(data_section_crc=0)))

        statistics = Statistics(
            message_count=self.message_count, schema_count=len(self._schemas), channel_count=len(self._channels),
            attachment_count=0, metadata_count=1, chunk_count=len(self._chunk_indexes), message_start_time=start,
            message_end_time=self._end_ns, channel_message_counts=dict(self._counts),
        )
        summary_start = self._offset
        summary = b""
        offsets = []
        for opcode, records in (
            (OP_SCHEMA, self._schemas),
            (OP_CHANNEL, self._channels),
            (OP_STATISTICS, [statistics]),
            (OP_CHUNK_INDEX, self._chunk_indexes),
            (OP_METADATA_INDEX, [metadata_index]),
        ):
            if records:
                group = serialize_records(*records)
                offsets.append(SummaryOffset(
                    group_opcode=opcode, group_start=summary_start + len(summary), group_length=len(group),
                ))
                summary += group
        summary_offset_start = summary_start + len(summary)
        summary += serialize_records(*offsets)
        crc = zlib.crc32(summary)
        crc = zlib.crc32(struct.pack("<BQQQ", OP_FOOTER, 8 + 8 + 4, summary_start, summary_offset_start), crc)
        footer = Footer(summary_start=summary_start, summary_offset_start=summary_offset_start, summary_crc=crc)
        self._write(summary + serialize_records(footer) + MCAP_MAGIC)
        self._stream.flush()

    def _write(self, data: bytes) -> None:
        self._stream.write(data)
        self._offset += len(data)
