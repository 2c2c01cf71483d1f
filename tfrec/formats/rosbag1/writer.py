"""Writing ROS 1 bags (format 2.0), chunked and fully indexed, in bounded memory.

The file is what ``rosbag record`` writes, so ``rosbag info`` answers from the index at once:

- ``#ROSBAG V2.0``, then the bag header record padded to 4096 bytes (``index_pos``, ``conn_count``
  and ``chunk_count`` are filled in by :meth:`Ros1BagWriter.close`);
- chunk records of about ``chunk_bytes`` uncompressed bytes (``none``, ``bz2`` or ``lz4``), each
  followed by one IndexData record per connection with messages in it (time and offset of each);
  a connection record goes into the open chunk when the connection is added;
- at ``index_pos``: every connection record again, then one ChunkInfo record per chunk.

Record header fields are sorted by name, as rosbag's C++ writer (a ``std::map``) writes them;
bz2 is level 9 as rosbag's; lz4 chunks are LZ4 frames as roslz4 requires them (independent
blocks of at most 1 MiB, a content checksum, no content size). Nothing depends on the wall
clock, so the same calls give the same bytes.

Messages of a fixed size go in batches: a batch of N is one (N, record size) numpy array,
headers and payloads copied in as strided blocks, its index arithmetic; a batch is cut into
chunks exactly where message-by-message writing would cut it, so both give the same file.
"""

from __future__ import annotations

import struct
from array import array
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S
from tfrec.errors import WriteError, display_path
from tfrec.formats.ros.encode import ROS1_TIME_LIMIT_NS, ros1_times
from tfrec.formats.rosbag1.records import (
    CONN_AT,
    LENGTH_AT,
    MESSAGE_HEAD,
    MESSAGE_HEAD_SIZE,
    OP_CHUNK,
    OP_CHUNK_INFO,
    OP_CONNECTION,
    ROS1_MAGIC,
    TIME_AT,
    ChunkInfo,
    PendingChunk,
    bag_header,
    compressor,
    header,
    index_data_records,
    message_head,
    record,
    ros1_type_name,
    time_bytes,
    u32,
)

if TYPE_CHECKING:
    from concurrent.futures import Future, ThreadPoolExecutor

    from typing_extensions import Self

__all__ = [
    "CALLERID",
    "COMPRESSIONS",
    "DEFAULT_CHUNK_BYTES",
    "ROS1_MAGIC",
    "Ros1BagWriter",
]

COMPRESSIONS = ("none", "bz2", "lz4")
"""Chunk compressions of ROS 1 bags."""
DEFAULT_CHUNK_BYTES = 768 * 1024
"""Uncompressed bytes per chunk: ``rosbag record``'s default ``--chunksize`` (768 KB)."""
CALLERID = "/tfrec"
"""The ``callerid`` of tfrec's connections: the node that published, as ``rosbag record`` notes it."""
MAX_MESSAGE_BYTES = 2**31 - 1
"""The largest message: chunk offsets are uint32, and a chunk holds up to ``chunk_bytes`` plus one message."""

_WORKERS = 2
"""Threads compressing chunks (bz2 and lz4 release the GIL): at most this many chunks wait in memory."""

U8 = NDArray[np.uint8]
Buffer = bytes | memoryview


class Ros1BagWriter:
    """Writes a ROS 1 bag (format 2.0): connections, messages in chunks, and the index.

    The file is created (or truncated) at once; :meth:`close` writes the index and the final bag
    header, :meth:`abort` only closes the file. Used as a context manager it closes on success and
    aborts on an exception. Messages may come in any time order (the index is sorted per chunk).

    Args:
        path: the bag to write.
        compression: chunk compression, one of :data:`COMPRESSIONS`: ``"none"``, ``"bz2"``, ``"lz4"``.
        chunk_bytes: uncompressed bytes after which a chunk is written.

    Raises:
        WriteError: an unknown compression, or the file cannot be created.
    """

    def __init__(self, path: str | Path, *, compression: str = "none", chunk_bytes: int = DEFAULT_CHUNK_BYTES) -> None:
        if compression not in COMPRESSIONS:
            raise WriteError(f"ROS 1 bag compression '{compression}' is not one of {', '.join(COMPRESSIONS)}")
        if not 0 < chunk_bytes <= MAX_MESSAGE_BYTES:
            raise ValueError(f"chunk size must be in 1..{MAX_MESSAGE_BYTES}, got {chunk_bytes}")
        self.path = Path(path)
        self.compression = compression
        self._compress = compressor(compression)
        self._chunk_size = chunk_bytes
        self._topics: list[str] = []
        self._connections: list[bytes] = []  # connection records
        self._counts: list[int] = []
        self._chunk_infos: list[ChunkInfo] = []
        # the open chunk: its records, their length, (times, offsets) per connection, its time span
        self._pieces: list[Buffer] = []
        self._chunk_len = 0
        self._index: dict[int, tuple[array[int], array[int]]] = {}
        self._start_ns = ROS1_TIME_LIMIT_NS
        self._end_ns = -1
        self._offset = 0
        # chunks being compressed, oldest first, and the threads compressing them
        self._pending: deque[tuple[Future[bytes], PendingChunk]] = deque()
        self._pool: ThreadPoolExecutor | None = None
        self._stream: IO[bytes] | None = None
        self._state = "open"
        try:
            self._stream = open(self.path, "wb")  # noqa: SIM115 - closed by close() or abort()
        except OSError as err:
            raise self._error(err) from err
        self._write(ROS1_MAGIC + bag_header(0, 0, 0))

    # -- connections --------------------------------------------------------------------------

    def add_connection(
        self,
        topic: str,
        msgtype: str,
        *,
        msgdef: str,
        md5sum: str,
        latching: bool = False,
        callerid: str | None = CALLERID,
    ) -> int:
        """Add a connection; its record goes into the open chunk.

        Args:
            topic: the topic, e.g. ``/tf``.
            msgtype: the message type, ``pkg/Type`` or ``pkg/msg/Type`` (written as ``pkg/Type``).
            msgdef: the ROS 1 message definition (:func:`ros1_message_definition`).
            md5sum: the type's md5sum.
            latching: a latched topic (``latching=1``, e.g. /tf_static), else ``latching=0``.
            callerid: the publishing node; None writes no ``callerid`` field.

        Returns:
            The connection id (0, 1, … in the order of the calls).
        """
        self._check_open("add_connection")
        conn = len(self._connections)
        fields = {
            "latching": b"1" if latching else b"0", "md5sum": md5sum.encode(),
            "message_definition": msgdef.encode(), "topic": topic.encode(), "type": ros1_type_name(msgtype).encode(),
        }
        if callerid is not None:
            fields["callerid"] = callerid.encode()
        # the data is the connection header as a publisher sends it: fields without a total length
        connection = record({"conn": u32(conn), "op": bytes([OP_CONNECTION]), "topic": topic.encode()},
                            header(fields)[4:])
        self._connections.append(connection)
        self._topics.append(topic)
        self._counts.append(0)
        self._pieces.append(connection)
        self._chunk_len += len(connection)
        return conn

    # -- messages -----------------------------------------------------------------------------

    def write(self, conn_id: int, time_ns: int, data: bytes | memoryview) -> None:
        """Write one serialized message.

        Args:
            conn_id: a connection from :meth:`add_connection`.
            time_ns: the message's time (the bag's receipt time), nanoseconds since the epoch.
            data: the ROS 1 serialized message (copied).

        Raises:
            WriteError: a time outside ROS 1's range, a message of 2 GiB or more, or a write error.
        """
        self._check_open("write")
        self._check_conn(conn_id)
        time_ns = int(time_ns)
        data = bytes(data)  # a copy, of the bytes whatever the view's format
        self._check_times(conn_id, time_ns, time_ns)
        self._check_size(conn_id, len(data))
        head = message_head(conn_id, time_ns, len(data))
        times, offsets = self._index.setdefault(conn_id, (array("q"), array("q")))
        times.append(time_ns)
        offsets.append(self._chunk_len)
        self._pieces += (head, data)
        self._chunk_len += MESSAGE_HEAD_SIZE + len(data)
        self._start_ns = min(self._start_ns, time_ns)
        self._end_ns = max(self._end_ns, time_ns)
        self._counts[conn_id] += 1
        if self._chunk_len > self._chunk_size:
            self._flush_chunk()

    def write_many(
        self, conn_id: int, time_ns: NDArray[np.int64], data: Sequence[bytes | memoryview] | U8
    ) -> None:
        """Write N serialized messages of one connection; the same file as N calls of :meth:`write`.

        Args:
            conn_id: a connection from :meth:`add_connection`.
            time_ns: int64 (N,) message times, nanoseconds since the epoch.
            data: N messages: a list of bytes, or uint8 (N, size) rows of fixed-size messages (fast).

        Raises:
            WriteError: a time outside ROS 1's range, a message of 2 GiB or more, or a write error.
        """
        self._check_open("write_many")
        time_ns = np.asarray(time_ns, dtype=np.int64).reshape(-1)
        if isinstance(data, np.ndarray):
            self.write_samples((conn_id,), time_ns, (data,))
            return
        self._check_conn(conn_id)
        n = len(time_ns)
        if len(data) != n:
            raise ValueError(f"{n} times but {len(data)} messages")
        if n == 0:
            return
        self._check_times(conn_id, int(time_ns.min()), int(time_ns.max()))
        messages = [bytes(message) for message in data]
        sizes = np.fromiter((len(message) for message in messages), dtype=np.int64, count=n)
        self._check_size(conn_id, int(sizes.max()))
        heads = np.empty((n, MESSAGE_HEAD_SIZE), dtype=np.uint8)
        heads[:] = np.frombuffer(MESSAGE_HEAD, dtype=np.uint8)
        heads[:, CONN_AT : CONN_AT + 4] = np.frombuffer(u32(conn_id), dtype=np.uint8)
        heads[:, TIME_AT : TIME_AT + 8] = ros1_times(time_ns)
        heads[:, LENGTH_AT:] = sizes.astype("<u4").view(np.uint8).reshape(n, 4)
        head_bytes = memoryview(heads.tobytes())

        def pieces(first: int, stop: int) -> list[Buffer]:
            out: list[Buffer] = []
            for i in range(first, stop):
                out += (head_bytes[i * MESSAGE_HEAD_SIZE : (i + 1) * MESSAGE_HEAD_SIZE], messages[i])
            return out

        sizes += MESSAGE_HEAD_SIZE
        self._append(np.full(n, conn_id, dtype=np.int64), time_ns, sizes, pieces)

    def write_samples(self, conn_ids: Sequence[int], time_ns: NDArray[np.int64], messages: Sequence[U8]) -> None:
        """Write N samples of fixed-size messages, one message per connection each, all of a
        sample at its time: sample i is ``messages[0][i]`` on ``conn_ids[0]``, then ``messages[1][i]``
        on ``conn_ids[1]``, … (e.g. a /joint_states and a /tf message per instant). The same file
        as writing them one by one with :meth:`write`.

        Args:
            conn_ids: M connections from :meth:`add_connection`.
            time_ns: int64 (N,) sample times, nanoseconds since the epoch.
            messages: M uint8 arrays (N, size_j): row i is connection j's message of sample i.

        Raises:
            WriteError: a time outside ROS 1's range, a message of 2 GiB or more, or a write error.
        """
        self._check_open("write_samples")
        time_ns = np.asarray(time_ns, dtype=np.int64).reshape(-1)
        n, m = len(time_ns), len(conn_ids)
        if len(messages) != m:
            raise ValueError(f"{m} connections but {len(messages)} message arrays")
        for conn_id, rows in zip(conn_ids, messages):
            self._check_conn(conn_id)
            if rows.dtype != np.uint8 or rows.ndim != 2 or len(rows) != n:
                raise ValueError(f"messages must be uint8 arrays of shape ({n}, size), got {rows.dtype} {rows.shape}")
            self._check_size(conn_id, rows.shape[1])
        if n == 0 or m == 0:
            return
        first, last = int(time_ns.min()), int(time_ns.max())
        self._check_times(conn_ids[0], first, last)
        stamps = ros1_times(time_ns)
        sizes = np.array([MESSAGE_HEAD_SIZE + rows.shape[1] for rows in messages], dtype=np.int64)
        row_len = int(sizes.sum())
        records = np.empty((n, row_len), dtype=np.uint8)
        at = 0
        for conn_id, rows in zip(conn_ids, messages):
            head = bytearray(MESSAGE_HEAD)
            head[CONN_AT : CONN_AT + 4] = u32(conn_id)
            head[LENGTH_AT:] = u32(rows.shape[1])
            records[:, at : at + MESSAGE_HEAD_SIZE] = np.frombuffer(bytes(head), dtype=np.uint8)
            records[:, at + TIME_AT : at + TIME_AT + 8] = stamps
            records[:, at + MESSAGE_HEAD_SIZE : at + MESSAGE_HEAD_SIZE + rows.shape[1]] = rows
            at += MESSAGE_HEAD_SIZE + rows.shape[1]
        flat = records.data.cast("B")
        ends = (np.arange(n, dtype=np.int64)[:, None] * row_len + np.cumsum(sizes)[None, :]).reshape(-1)
        record_sizes = np.tile(sizes, n)

        def pieces(first: int, stop: int) -> list[Buffer]:
            return [flat[ends[first] - record_sizes[first] : ends[stop - 1]]]

        self._append(np.tile(np.asarray(conn_ids, dtype=np.int64), n), np.repeat(time_ns, m), record_sizes, pieces)

    def _append(
        self,
        conns: NDArray[np.int64],
        times: NDArray[np.int64],
        sizes: NDArray[np.int64],
        pieces: Callable[[int, int], list[Buffer]],
    ) -> None:
        """Add message records to the open chunk, writing a chunk wherever :meth:`write` would:
        after the first message that makes the chunk longer than ``chunk_bytes``.

        Args:
            conns, times, sizes: connection, time and record size of each message, in file order.
            pieces: the records of messages [first, stop) as buffers, in order.
        """
        ends = np.cumsum(sizes)
        total = len(ends)
        first = 0
        while first < total:
            base = int(ends[first - 1]) if first else 0  # bytes of the batch already in earlier chunks
            # the chunk is written after the first message that ends past this
            limit = base + self._chunk_size - self._chunk_len
            cut = max(first, int(np.searchsorted(ends, limit, side="right")))
            stop = min(cut + 1, total)
            offsets = self._chunk_len - base + ends[first:stop] - sizes[first:stop]
            part_conns, part_times = conns[first:stop], times[first:stop]
            for conn_id in np.unique(part_conns).tolist():
                mask = part_conns == conn_id
                index_times, index_offsets = self._index.setdefault(conn_id, (array("q"), array("q")))
                index_times.frombytes(part_times[mask].astype(np.int64).tobytes())
                index_offsets.frombytes(offsets[mask].astype(np.int64).tobytes())
                self._counts[conn_id] += int(np.count_nonzero(mask))
            self._pieces += pieces(first, stop)
            self._chunk_len += int(ends[stop - 1]) - base
            self._start_ns = min(self._start_ns, int(part_times.min()))
            self._end_ns = max(self._end_ns, int(part_times.max()))
            if cut < total:
                self._flush_chunk()
            first = stop

    # -- chunks and index ---------------------------------------------------------------------

    def _flush_chunk(self) -> None:
        """Write the open chunk and its IndexData records (by connection id, times sorted). A
        compressed chunk is compressed on a worker thread and written when its turn comes."""
        if not self._pieces:
            return
        index_records, counts = index_data_records(self._index)
        span = (self._start_ns, self._end_ns) if len(counts) else (0, 0)
        chunk = PendingChunk(self._chunk_len, index_records, counts, *span)
        if self.compression == "none":
            self._write_chunk(chunk, self._pieces)
        else:
            if self._pool is None:
                from concurrent.futures import ThreadPoolExecutor

                self._pool = ThreadPoolExecutor(max_workers=_WORKERS, thread_name_prefix="tfrec-rosbag1")
            self._pending.append((self._pool.submit(self._compress, b"".join(self._pieces)), chunk))
            while len(self._pending) > _WORKERS:
                self._write_pending()
        self._pieces = []
        self._chunk_len = 0
        self._index = {}
        self._start_ns, self._end_ns = ROS1_TIME_LIMIT_NS, -1

    def _write_pending(self) -> None:
        """Write the oldest compressed chunk (waiting for its compression)."""
        future, chunk = self._pending.popleft()
        self._write_chunk(chunk, [future.result()])

    def _write_chunk(self, chunk: PendingChunk, data: list[Buffer]) -> None:
        """Write a chunk record of ``data`` (its records, compressed or not) and its index records."""
        pos = self._offset
        self._write(header({
            "compression": self.compression.encode(), "op": bytes([OP_CHUNK]), "size": u32(chunk.size),
        }) + u32(sum(len(piece) for piece in data)))
        for piece in data:
            self._write(piece)
        self._write(chunk.index_records)
        self._chunk_infos.append(ChunkInfo(pos, chunk.start_ns, chunk.end_ns, chunk.counts))

    def close(self) -> None:
        """Write the open chunk, the index (connection and ChunkInfo records) and the final bag
        header, and close the file. A second call does nothing.

        Raises:
            WriteError: a write error (the file is closed, incomplete).
        """
        if self._state != "open":
            return
        self._flush_chunk()
        while self._pending:
            self._write_pending()
        index_pos = self._offset
        index = b"".join(self._connections)
        for info in self._chunk_infos:
            index += record({
                "chunk_pos": struct.pack("<Q", info.pos), "count": u32(len(info.counts)),
                "end_time": time_bytes(info.end_ns), "op": bytes([OP_CHUNK_INFO]),
                "start_time": time_bytes(info.start_ns), "ver": u32(1),
            }, info.counts.tobytes())
        self._write(index)
        assert self._stream is not None
        try:
            self._stream.seek(len(ROS1_MAGIC))
            self._stream.write(bag_header(index_pos, len(self._connections), len(self._chunk_infos)))
            self._stream.close()
        except OSError as err:
            self.abort()
            raise self._error(err) from err
        self._stream = None
        self._shutdown()
        self._state = "closed"

    def abort(self) -> None:
        """Close the file without writing the index (the caller deletes it). A second call does nothing."""
        stream, self._stream = self._stream, None
        self._state = "closed"
        self._pieces = []
        self._shutdown()
        if stream is not None:
            try:
                stream.close()
            except OSError:
                pass  # the file is being given up

    def _shutdown(self) -> None:
        """Stop the compression threads (a running compression is waited for)."""
        pool, self._pool = self._pool, None
        self._pending.clear()
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, traceback: TracebackType | None
    ) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()

    # -- state --------------------------------------------------------------------------------

    @property
    def message_count(self) -> int:
        """Messages written so far."""
        return sum(self._counts)

    @property
    def message_counts(self) -> tuple[int, ...]:
        """Messages written so far per connection, by connection id."""
        return tuple(self._counts)

    @property
    def chunk_count(self) -> int:
        """Chunks completed so far (some may still be on their way to the file)."""
        return len(self._chunk_infos) + len(self._pending)

    def _check_open(self, method: str) -> None:
        if self._state != "open":
            raise RuntimeError(f"Ros1BagWriter.{method}() called after close() or abort()")

    def _check_conn(self, conn_id: int) -> None:
        if not 0 <= conn_id < len(self._connections):
            raise ValueError(f"no connection {conn_id}: {len(self._connections)} were added")

    def _check_times(self, conn_id: int, first_ns: int, last_ns: int) -> None:
        for time_ns in (first_ns, last_ns):
            if not 0 <= time_ns < ROS1_TIME_LIMIT_NS:
                when = "before 1970" if time_ns < 0 else f"past ROS 1's last time ({ROS1_TIME_LIMIT_NS // NS_PER_S} s)"
                raise WriteError(
                    f"{display_path(self.path)}: a {self._topics[conn_id]} message time "
                    f"{time_ns / NS_PER_S:.9f} s is {when}"
                )

    def _check_size(self, conn_id: int, size: int) -> None:
        if size > MAX_MESSAGE_BYTES:
            raise WriteError(
                f"{display_path(self.path)}: a {self._topics[conn_id]} message of {size:,} bytes "
                f"is too large for a ROS 1 bag chunk (at most {MAX_MESSAGE_BYTES:,})"
            )

    def _write(self, data: Buffer) -> None:
        assert self._stream is not None
        try:
            self._stream.write(data)
        except OSError as err:
            self.abort()
            raise self._error(err) from err
        self._offset += len(data)

    def _error(self, err: OSError) -> WriteError:
        return WriteError(f"{display_path(self.path)}: cannot write ROS 1 bag: {err.strerror or err}")
