"""tfrec's one MCAP writer (profile ``ros2``): serialized messages on any channels, chunked and indexed.

:class:`McapWriter` writes the header, a schema per message definition and a channel per connection (offered QoS
and type hash in the channel metadata, as rosbag2's MCAP plugin writes them) before the first chunk that uses them;
chunks of about ``chunk_bytes`` uncompressed (or where the caller ends them), each followed by its message index
records; an input's attachment and metadata records, copied as they are; the ``rosbag2`` metadata record; the
summary (schemas, channels, statistics, chunk, attachment and metadata indexes) and the footer. Messages of a fixed
size come as (n, size) arrays and become their records with a handful of numpy operations (:meth:`McapWriter.write`,
:meth:`McapWriter.write_rows`); a chunk's message index is arithmetic; chunks are compressed on worker threads
(zstd and lz4 release the GIL) while the next one fills, or in line.

``tfrec convert`` writes through it (:mod:`tfrec.formats.output`), and ``tfrec record`` through the sink over it
(:class:`tfrec.formats.mcap.sink.McapSink`). Nothing depends on the wall clock or on the file's name, so the same
calls give the same bytes. See docs/recording-format.md.
"""

from __future__ import annotations

import math
import struct
import threading
import zlib
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from functools import cache
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from tfrec._version import __version__
from tfrec.conventions import (
    COMPRESSIONS,
    DEFAULT_START_TIME_NS,
    NS_PER_S,
    STAMP_LIMIT_NS,
    STAMP_RANGE,
)
from tfrec.errors import ReadError, WriteError
from tfrec.formats.mcap.records import (
    MCAP_MAGIC,
    MESSAGE_HEAD_SIZE,
    OP_ATTACHMENT_INDEX,
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
from tfrec.formats.ros.connection import Connection, Extra
from tfrec.formats.ros.types import typestore
from tfrec.formats.rosbag2.metadata import bag_info, bag_metadata_yaml, offered_qos_profiles, qos_yaml

__all__ = [
    "DEFAULT_CHUNK_BYTES",
    "DEFAULT_START_TIME_NS",  # re-exported from tfrec.conventions
    "LIBRARY",
    "MAX_IDS",
    "PROFILE",
    "McapWriter",
    "SampleRows",
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

_ZSTD_LEVEL = 1
"""zstd's compression level of MCAP chunks."""


def chunk_compressor(compression: str) -> tuple[str, Callable[[bytes], bytes]]:
    """The chunk compression field and compressor of ``zstd`` (level 1, a block every 16 KiB so a
    cut file reads up to the cut), ``lz4`` (frame format) or ``none``. Level 1 compresses ~1.3x faster
    than 3 (the mcap libraries' default) for ~3 % more bytes, at the same 16 KiB a cut may lose
    (benchmarks/bench_limits.py --only zstd, docs/performance.md).

    Raises:
        WriteError: another compression.
    """
    if compression == "zstd":
        import zstandard

        compressor = zstandard.ZstdCompressor(level=_ZSTD_LEVEL)

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


_WORKERS = 2
"""Threads compressing chunks: at most this many chunks wait in memory."""
_COPY_PIECE = 1 << 20
"""Bytes of an attachment copied at once: a large one never lies in memory whole."""
_HEAD = RECORD.size + MESSAGE_HEAD_SIZE
"""Bytes of a Message record before its data."""

Buffer = bytes | memoryview

_UNBOUNDED = 1 << 62
"""``chunk_bytes`` of a writer whose caller ends its chunks."""

MAX_IDS = 65_535
"""Channels, and schemas, an MCAP holds at most: their ids are uint16 (0 is no schema)."""


class SampleRows:
    """Samples of fixed-size messages laid out as Message records, one per channel per sample, for
    :meth:`McapWriter.write_rows`: each channel's record head is written once, and its data region is a view, row i
    the message of sample i, to encode into (reused chunk after chunk, only the variable fields written).

    Args:
        channels: M channels of a writer.
        templates: M uint8 (size_j,) templates: the bytes every row of channel j starts from.
        capacity: samples it holds.

    Attributes:
        records: uint8 (capacity, row length), the records of the samples.
        data: M uint8 (capacity, size_j) views of ``records``: channel j's messages.
        filled: samples written so far (set back to 0 by the caller once their chunk is written).
    """

    def __init__(self, channels: Sequence[int], templates: Sequence[NDArray[np.uint8]], capacity: int) -> None:
        self.channels = tuple(channels)
        row = bytearray()
        self.heads: list[int] = []
        for channel, template in zip(channels, templates):
            self.heads.append(len(row))
            row += struct.pack("<BQH", OP_MESSAGE, MESSAGE_HEAD_SIZE + len(template), channel) + bytes(20)
            row += template.tobytes()
        self.capacity = capacity
        self.records = np.tile(np.frombuffer(bytes(row), dtype=np.uint8), (capacity, 1))
        self.data = [self.records[:, at + _HEAD : at + _HEAD + len(template)]
                     for at, template in zip(self.heads, templates)]
        self.filled = 0


class McapWriter:
    """Writes an MCAP file (profile ``ros2``) of serialized messages on any channels.

    Call :meth:`add_channel` (or :meth:`add_channels`) for each connection (before its messages), :meth:`write` or
    :meth:`write_rows` for messages in any order, then :meth:`finish`; :meth:`abort` stops the compression
    threads after an error. The stream must be at its start; it is neither closed nor written after
    :meth:`finish`.

    Args:
        stream: a binary stream to write to.
        compression: chunk compression, ``zstd`` (default), ``lz4`` or ``none``.
        chunk_bytes: uncompressed bytes after which a chunk is written; None: where the caller ends chunks
            (:meth:`end_chunk`).
        threads: threads compressing chunks while the next one fills; 0: each chunk is compressed in line, by
            one compressor.

    Raises:
        WriteError: an unknown compression.
    """

    def __init__(self, stream: IO[bytes], *, compression: str = "zstd", chunk_bytes: int | None = DEFAULT_CHUNK_BYTES,
                 threads: int = _WORKERS) -> None:
        from mcap.records import Header

        self._stream = stream
        self._compression, self._compress = chunk_compressor(compression)  # (checks the name)
        self._local = threading.local()
        self._threads = threads
        self._chunk_bytes = _UNBOUNDED if chunk_bytes is None else max(1, chunk_bytes)
        self._ordered = True  # the open chunk's records lie in log-time order
        self._last_time = -1
        self._offset = 0
        self._schemas: list[Any] = []
        self._schema_ids: dict[tuple[str, str, str], int] = {}
        self._channels: list[Any] = []
        self._topics: list[tuple[str, str, list[dict[str, Any]], str]] = []  # topic, type, QoS, type hash
        self._counts: list[int] = []
        self._start_ns: int | None = None
        self._end_ns = 0
        # the open chunk: its records, their length, (times, offsets) per channel, its span
        self._pieces: list[Buffer] = []
        self._chunk_len = 0
        self._index: dict[int, list[tuple[NDArray[np.int64], NDArray[np.int64]]]] = {}
        self._chunk_span: tuple[int, int] | None = None
        self._chunk_indexes: list[Any] = []
        self._pending: deque[tuple[Future[tuple[bytes, int]], int, dict[int, bytes], tuple[int, int]]] = deque()
        self._pool: ThreadPoolExecutor | None = None
        self._bag_info: dict[str, Any] = {}
        self._extra_indexes: list[Any] = []  # AttachmentIndex and MetadataIndex of the records copied
        self._metadata: list[tuple[str, dict[str, str]]] = []  # written after the rosbag2 record
        self._state = "open"
        self._write(MCAP_MAGIC + serialize_records(Header(profile=PROFILE, library=LIBRARY)))

    # -- channels -----------------------------------------------------------------------------

    def add_channel(self, connection: Connection) -> int:
        """Add a channel (and its schema, unless one of the same definition is there); its records
        are written at once, before any chunk that holds its messages.

        Args:
            connection: the topic, type, message encoding (``cdr``), definition (``ros2msg`` or
                ``ros2idl``; without one, a schema of the type's name, encoding ``""``: none is
                available), offered QoS (any rosbag2 version's YAML: written as version 9
                names it; without one, reliable and transient_local for a latched topic, else
                volatile) and type hash.

        Returns:
            The channel id (1, 2, … in the order of the calls).
        """
        return self.add_channels([connection])[0]

    def add_channels(self, connections: Sequence[Connection]) -> list[int]:
        """Add channels as :meth:`add_channel` does, their new schemas first, then the channels.

        Returns:
            Their channel ids.

        Raises:
            WriteError: more channels or schemas than an MCAP numbers.
        """
        from mcap.records import Channel, Schema

        self._check_open()
        schemas: list[Any] = []
        channels: list[Any] = []
        for connection in connections:
            if len(self._channels) >= MAX_IDS or len(self._schema_ids) >= MAX_IDS:
                raise WriteError(f"{connection.topic}: more than {MAX_IDS:,} channels (or schemas) to write: an MCAP "
                                 "numbers them with 16 bits (leave topics out, or write a ROS 1 bag)")
            schema_id = 0
            if connection.msgtype:
                encoding = (connection.definition_encoding or "ros2msg") if connection.definition else ""  # "": none
                key = (connection.msgtype, encoding, connection.definition)
                schema_id = self._schema_ids.get(key, 0)
                if not schema_id:
                    schema_id = self._schema_ids[key] = len(self._schema_ids) + 1
                    schemas.append(Schema(id=schema_id, name=key[0], encoding=key[1], data=key[2].encode()))
            profiles = offered_qos_profiles(connection.qos, latched=connection.latched)
            metadata = {"offered_qos_profiles": qos_yaml(profiles)}
            if connection.type_hash:
                metadata["topic_type_hash"] = connection.type_hash
            channels.append(Channel(id=len(self._channels) + 1, topic=connection.topic,
                                    message_encoding=connection.encoding, schema_id=schema_id, metadata=metadata))
            self._channels.append(channels[-1])
            self._topics.append((connection.topic, connection.msgtype, profiles, connection.type_hash))
            self._counts.append(0)
        self._schemas += schemas
        self._write(serialize_records(*schemas, *channels))
        return [int(channel.id) for channel in channels]

    # -- messages -----------------------------------------------------------------------------

    def write(self, channel: int, log_time: NDArray[np.int64], data: NDArray[np.uint8] | Sequence[Buffer],
              publish_time: NDArray[np.int64] | None = None) -> None:
        """Write N messages of one channel.

        Args:
            channel: a channel from :meth:`add_channel`.
            log_time: int64 (N,) log times, ns since the epoch.
            data: the messages: (N, size) uint8 rows of fixed-size messages (fast), or one by one.
            publish_time: int64 (N,) publish times; the log times when None.

        Raises:
            WriteError: a time before 1970 (MCAP times are unsigned), or a write error.
        """
        self._check_open()
        times = np.asarray(log_time, dtype=np.int64).reshape(-1)
        n = len(times)
        if n == 0:
            return
        publish = times if publish_time is None else np.asarray(publish_time, dtype=np.int64).reshape(-1)
        if int(min(times.min(), publish.min())) < 0:
            raise WriteError(f"a {self._topics[channel - 1][0]} message time is before 1970")
        first_seq = self._counts[channel - 1] + 1
        self._counts[channel - 1] += n
        self._start_ns = int(times.min()) if self._start_ns is None else min(self._start_ns, int(times.min()))
        self._end_ns = max(self._end_ns, int(times.max()))
        heads = np.empty((n, _HEAD), dtype=np.uint8)
        heads[:, 0] = OP_MESSAGE
        heads[:, 9:11] = np.frombuffer(struct.pack("<H", channel), dtype=np.uint8)
        heads[:, 11:15] = (np.arange(first_seq, first_seq + n, dtype=np.int64) % 2**32).astype("<u4").view(
            np.uint8).reshape(n, 4)
        heads[:, 15:23] = times.astype("<u8").view(np.uint8).reshape(n, 8)
        heads[:, 23:31] = publish.astype("<u8").view(np.uint8).reshape(n, 8)
        if isinstance(data, np.ndarray):
            size = data.shape[1]
            heads[:, 1:9] = np.frombuffer(struct.pack("<Q", MESSAGE_HEAD_SIZE + size), dtype=np.uint8)
            self._rows(channel, times, np.concatenate([heads, data], axis=1))
        else:
            sizes = np.fromiter(map(len, data), dtype=np.int64, count=n)
            heads[:, 1:9] = (sizes + MESSAGE_HEAD_SIZE).astype("<u8").view(np.uint8).reshape(n, 8)
            self._messages(channel, times, heads, data, sizes)

    def write_rows(self, rows: SampleRows, log_time: NDArray[np.int64]) -> None:
        """Write the next N samples of ``rows`` (from :attr:`SampleRows.filled` on, their data encoded into
        :attr:`SampleRows.data` by the caller), stamped ``log_time`` (their log and publish times). They go into the
        open chunk whole; ``rows`` is written over again only after :meth:`end_chunk`.

        Raises:
            WriteError: a time before 1970 (MCAP times are unsigned), or a write error.
            ValueError: more samples than ``rows`` has room for.
        """
        self._check_open()
        times = np.asarray(log_time, dtype=np.int64).reshape(-1)
        n, first = len(times), rows.filled
        if n == 0:
            return
        if first + n > rows.capacity:
            raise ValueError(f"{n} samples past the {rows.capacity - first} rows left")
        if int(times.min()) < 0:
            raise WriteError(f"a {self._topics[rows.channels[0] - 1][0]} message time is before 1970")
        part = rows.records[first : first + n]
        stamps = times.astype("<u8").view(np.uint8).reshape(n, 8)
        row_len = rows.records.shape[1]
        index = []
        for channel, at in zip(rows.channels, rows.heads):
            first_seq = self._counts[channel - 1] + 1
            self._counts[channel - 1] += n
            part[:, at + 11 : at + 15] = (np.arange(first_seq, first_seq + n, dtype=np.int64) % 2**32).astype(
                "<u4").view(np.uint8).reshape(n, 4)
            part[:, at + 15 : at + 23] = stamps
            part[:, at + 23 : at + 31] = stamps
            index.append((channel, times, self._chunk_len + at + np.arange(n, dtype=np.int64) * row_len))
        rows.filled += n
        self._start_ns = int(times.min()) if self._start_ns is None else min(self._start_ns, int(times.min()))
        self._end_ns = max(self._end_ns, int(times.max()))
        self._add_records(index, part.reshape(-1).data, n * row_len)

    def _rows(self, channel: int, times: NDArray[np.int64], records: NDArray[np.uint8]) -> None:
        """Fixed-size records, as many per chunk as fit."""
        n, size = records.shape
        done = 0
        while done < n:
            room = max(1, math.ceil((self._chunk_bytes - self._chunk_len) / size))
            stop = min(n, done + room)
            offsets = self._chunk_len + np.arange(stop - done, dtype=np.int64) * size
            self._add(channel, times[done:stop], offsets, records[done:stop].reshape(-1).data, (stop - done) * size)
            done = stop

    def _messages(self, channel: int, times: NDArray[np.int64], heads: NDArray[np.uint8], data: Sequence[Buffer],
                  sizes: NDArray[np.int64]) -> None:
        """Records of any sizes, as many per chunk as fit."""
        ends = np.cumsum(sizes + _HEAD)
        head_bytes = memoryview(heads.tobytes())
        done = 0
        while done < len(times):
            base = int(ends[done - 1]) if done else 0
            limit = base + self._chunk_bytes - self._chunk_len  # the chunk is written after the record that ends there
            stop = min(len(times), max(done, int(np.searchsorted(ends, limit, side="left"))) + 1)
            offsets = self._chunk_len + (ends[done:stop] - sizes[done:stop] - _HEAD) - base
            pieces: list[Buffer] = []
            for i in range(done, stop):
                pieces += (head_bytes[i * _HEAD : (i + 1) * _HEAD], data[i])
            self._add(channel, times[done:stop], offsets, pieces, int(ends[stop - 1]) - base)
            done = stop

    def _add(self, channel: int, times: NDArray[np.int64], offsets: NDArray[np.int64], pieces: Buffer | list[Buffer],
             length: int) -> None:
        self._add_records([(channel, times, offsets)], pieces, length)

    def _add_records(self, index: list[tuple[int, NDArray[np.int64], NDArray[np.int64]]],
                     pieces: Buffer | list[Buffer], length: int) -> None:
        """Records for the open chunk: (channel, log times, offsets in the chunk) of their messages, their bytes."""
        for channel, times, offsets in index:
            self._index.setdefault(channel, []).append((times, offsets))
        if isinstance(pieces, list):
            self._pieces += pieces
        else:
            self._pieces.append(pieces)
        self._chunk_len += length
        times = index[0][1]
        first, last = int(times.min()), int(times.max())
        for _, other, _ in index[1:]:
            first, last = min(first, int(other.min())), max(last, int(other.max()))
        if self._ordered and not self._in_order(index, first):
            self._ordered = False  # sorted when the chunk is written
        self._last_time = max(self._last_time, last)
        span = self._chunk_span
        self._chunk_span = (first, last) if span is None else (min(span[0], first), max(span[1], last))
        if self._chunk_len >= self._chunk_bytes:
            self._flush_chunk()

    def _in_order(self, index: list[tuple[int, NDArray[np.int64], NDArray[np.int64]]], first: int) -> bool:
        """Whether records lie in log-time order after those of the open chunk: one run of times (a sample's
        messages share it), sorted, none before the chunk's latest."""
        times = index[0][1]
        return (first >= self._last_time and all(other is times for _, other, _ in index)
                and (len(times) < 2 or not bool(np.any(np.diff(times) < 0))))

    def end_chunk(self) -> None:
        """Write the open chunk now (with ``chunk_bytes`` None, the caller decides where chunks end)."""
        self._check_open()
        self._flush_chunk()

    # -- chunks -------------------------------------------------------------------------------

    def _flush_chunk(self) -> None:
        """Queue the open chunk for compression; write the chunks whose compression is done, in order."""
        if not self._pieces:
            return
        body = b"".join(self._pieces)
        columns = {channel: (np.concatenate([t for t, _ in parts]), np.concatenate([o for _, o in parts]))
                   for channel, parts in self._index.items()}
        if not self._ordered:
            body, columns = _in_time_order(body, columns)
        indexes: dict[int, bytes] = {}
        for channel in sorted(columns):
            times, offsets = columns[channel]
            order = np.lexsort((offsets, times))
            pairs = np.empty((len(times), 2), dtype="<u8")
            pairs[:, 0] = times[order]
            pairs[:, 1] = offsets[order]
            indexes[channel] = struct.pack("<BQHI", OP_MESSAGE_INDEX, 2 + 4 + pairs.nbytes, channel,
                                           pairs.nbytes) + pairs.tobytes()
        assert self._chunk_span is not None
        if self._threads:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(max_workers=self._threads, thread_name_prefix="tfrec-mcap")
            future = self._pool.submit(self._compressed, body)
        else:
            future = Future()
            future.set_result((self._compress(body), zlib.crc32(body)))
        self._pending.append((future, len(body), indexes, self._chunk_span))
        self._pieces, self._chunk_len, self._index, self._chunk_span = [], 0, {}, None
        self._ordered, self._last_time = True, -1
        while len(self._pending) > self._threads:
            self._write_pending()

    def _compressed(self, body: bytes) -> tuple[bytes, int]:
        """A chunk compressed, and its CRC (on a worker thread: each has its own compressor, as a
        zstd compressor must not be used by two threads at once)."""
        compress = getattr(self._local, "compress", None)
        if compress is None:
            compress = self._local.compress = chunk_compressor(self._compression or "none")[1]
        return compress(body), zlib.crc32(body)

    def _write_pending(self) -> None:
        from mcap.records import ChunkIndex

        future, size, indexes, (start, end) = self._pending.popleft()
        compressed, crc = future.result()
        name = self._compression.encode()
        chunk_start = self._offset
        self._write(struct.pack("<BQQQQI", OP_CHUNK, 8 + 8 + 8 + 4 + 4 + len(name) + 8 + len(compressed),
                                start, end, size, crc) + struct.pack("<I", len(name)) + name
                    + struct.pack("<Q", len(compressed)))
        self._write(compressed)
        chunk_length = self._offset - chunk_start
        index_start = self._offset
        index_offsets = {}
        for channel, record in indexes.items():
            index_offsets[channel] = self._offset
            self._write(record)
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=start, message_end_time=end, chunk_start_offset=chunk_start,
            chunk_length=chunk_length, message_index_offsets=index_offsets,
            message_index_length=self._offset - index_start, compression=self._compression,
            compressed_size=len(compressed), uncompressed_size=size,
        ))

    # -- attachments and metadata ------------------------------------------------------------

    def copy_extras(self, extras: Sequence[Extra]) -> list[tuple[str, str]]:
        """Copy attachment and metadata records of an input as they are (their bytes, piece by piece), after
        the messages written so far; :meth:`finish` indexes them in the summary.

        Returns:
            The records left out and why: (``attachment 'x'``, ``its CRC fails``).

        Raises:
            WriteError: a write error; ReadError: an input that cannot be read any more.
        """
        from mcap.records import AttachmentIndex, MetadataIndex

        self._check_open()
        self._flush_chunk()
        while self._pending:
            self._write_pending()
        left_out = []
        for extra in extras:
            offset = self._offset
            if not self._copy_record(extra):
                self._stream.seek(offset)
                self._stream.truncate()
                self._offset = offset
                left_out.append((extra.shown, "its CRC fails"))
                continue
            self._extra_indexes.append(
                AttachmentIndex(offset=offset, length=extra.length, log_time=extra.log_time,
                                create_time=extra.create_time, data_size=extra.data_size, name=extra.name,
                                media_type=extra.media_type) if extra.kind == "attachment"
                else MetadataIndex(offset=offset, length=extra.length, name=extra.name))
        return left_out

    def _copy_record(self, extra: Extra) -> bool:
        """Copy one record; an attachment's CRC (over its fields and data) is checked on the way: False when it
        fails (the caller takes back what was written)."""
        crc_end = extra.length - 4 if extra.kind == "attachment" else RECORD.size  # the CRC field: not summed
        crc, at, tail = 0, 0, b""
        try:
            with open(extra.path, "rb") as source:
                source.seek(extra.offset)
                while at < extra.length:
                    piece = source.read(min(_COPY_PIECE, extra.length - at))
                    if not piece:
                        raise ReadError(f"{extra.path}: the file ends inside {extra.shown}")
                    lo, hi = max(at, RECORD.size), min(at + len(piece), crc_end)
                    if hi > lo:
                        crc = zlib.crc32(piece[lo - at : hi - at], crc)
                    tail = (tail + piece[-4:])[-4:]
                    self._write(piece)
                    at += len(piece)
        except OSError as err:
            raise ReadError(f"{extra.path}: cannot read: {err.strerror or err}") from err
        return extra.kind != "attachment" or int.from_bytes(tail, "little") in (0, crc)  # 0: no CRC written

    def add_metadata(self, name: str, values: Mapping[str, str]) -> None:
        """Write a metadata record ``name`` (a map of strings) after the ``rosbag2`` one, at :meth:`finish`
        (tfrec's ``tfrec.recipe``: how a recording was made)."""
        self._check_open()
        self._metadata.append((name, dict(values)))

    # -- the end ------------------------------------------------------------------------------

    def finish(self) -> None:
        """Write the last chunk, the ``rosbag2`` metadata record, the summary and the footer.

        Raises:
            WriteError: a write error.
        """
        self._check_open()
        self._flush_chunk()
        while self._pending:
            self._write_pending()
        self._shutdown()
        self._write_summary()
        self._state = "done"

    def abort(self) -> None:
        """Stop the compression threads (after an error); the caller deletes the file."""
        self._state = "done"
        self._pending.clear()
        self._shutdown()

    def _shutdown(self) -> None:
        pool, self._pool = self._pool, None
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)

    @property
    def message_count(self) -> int:
        return sum(self._counts)

    @property
    def bag_info(self) -> dict[str, Any]:
        """The rosbag2 BagMetadata embedded by :meth:`finish`, for a bag folder's ``metadata.yaml``."""
        if self._state != "done" or not self._bag_info:
            raise RuntimeError("McapWriter.bag_info is known after finish()")
        return self._bag_info

    def _write_summary(self) -> None:
        from mcap.records import DataEnd, Footer, Metadata, MetadataIndex, Statistics, SummaryOffset

        start = self._start_ns or 0
        self._bag_info = bag_info(
            [(topic, msgtype, channel.message_encoding, profiles, type_hash, count)
             for (topic, msgtype, profiles, type_hash), channel, count in zip(self._topics, self._channels, self._counts)],
            message_count=self.message_count, start_ns=start, end_ns=self._end_ns,
        )
        metadata = b""
        metadata_indexes = []
        for name, values in [("rosbag2", {"serialized_metadata": bag_metadata_yaml(self._bag_info)}), *self._metadata]:
            record = serialize_records(Metadata(name=name, metadata=values))
            metadata_indexes.append(MetadataIndex(offset=self._offset + len(metadata), length=len(record), name=name))
            metadata += record
        metadata_indexes += [index for index in self._extra_indexes if isinstance(index, MetadataIndex)]
        attachment_indexes = [index for index in self._extra_indexes if not isinstance(index, MetadataIndex)]
        self._write(metadata + serialize_records(DataEnd(data_section_crc=0)))
        statistics = Statistics(
            message_count=self.message_count, schema_count=len(self._schemas), channel_count=len(self._channels),
            attachment_count=len(attachment_indexes), metadata_count=len(metadata_indexes),
            chunk_count=len(self._chunk_indexes), message_start_time=start, message_end_time=self._end_ns,
            channel_message_counts={channel.id: count for channel, count in zip(self._channels, self._counts)},
        )
        summary_start = self._offset
        summary = b""
        offsets = []
        for opcode, records in ((OP_SCHEMA, self._schemas), (OP_CHANNEL, self._channels), (OP_STATISTICS, [statistics]),
                                (OP_CHUNK_INDEX, self._chunk_indexes), (OP_ATTACHMENT_INDEX, attachment_indexes),
                                (OP_METADATA_INDEX, metadata_indexes)):
            if records:
                group = serialize_records(*records)
                offsets.append(SummaryOffset(group_opcode=opcode, group_start=summary_start + len(summary),
                                             group_length=len(group)))
                summary += group
        summary_offset_start = summary_start + len(summary)
        summary += serialize_records(*offsets)
        crc = zlib.crc32(summary)
        crc = zlib.crc32(struct.pack("<BQQQ", OP_FOOTER, 8 + 8 + 4, summary_start, summary_offset_start), crc)
        footer = Footer(summary_start=summary_start, summary_offset_start=summary_offset_start, summary_crc=crc)
        self._write(summary + serialize_records(footer) + MCAP_MAGIC)
        self._stream.flush()

    def _check_open(self) -> None:
        if self._state != "open":
            raise RuntimeError("McapWriter used after finish() or abort()")

    def _write(self, data: Buffer) -> None:
        self._stream.write(data)
        self._offset += len(data)


def _in_time_order(body: bytes, columns: dict[int, tuple[NDArray[np.int64], NDArray[np.int64]]]
                   ) -> tuple[bytes, dict[int, tuple[NDArray[np.int64], NDArray[np.int64]]]]:
    """A chunk's message records in log-time order (ties in the order written), and each channel's
    (times, offsets) moved with them. Messages come channel by channel (a converted topic of several
    connections, one write per connection): a reader that takes a chunk's records as they lie — and
    one that reads only the first messages of a topic, as ``tfrec info`` does — then sees them in time."""
    channels = np.concatenate([np.full(len(t), c, np.int64) for c, (t, _) in columns.items()])
    times = np.concatenate([t for t, _ in columns.values()])
    offsets = np.concatenate([o for _, o in columns.values()])
    by_offset = np.argsort(offsets, kind="stable")
    times_written = times[by_offset]
    if len(times_written) < 2 or bool((np.diff(times_written) >= 0).all()):
        return body, columns
    starts = offsets[by_offset]
    lengths = np.diff(np.append(starts, len(body)))
    order = np.argsort(times_written, kind="stable")
    moved_lengths = lengths[order]
    destinations = np.concatenate([[0], np.cumsum(moved_lengths)[:-1]])
    # one slice per record (a byte-wise gather needs an 8-byte index per byte: twice the CPU)
    view = memoryview(body)
    firsts = starts[order]
    moved = b"".join([view[first:last] for first, last in zip(firsts.tolist(), (firsts + moved_lengths).tolist())])
    new_offsets = np.empty_like(starts)
    new_offsets[order] = destinations
    placed = np.empty_like(offsets)
    placed[by_offset] = new_offsets  # back to the order of `times` and `channels`
    return moved, {c: (times[channels == c], placed[channels == c]) for c in columns}
