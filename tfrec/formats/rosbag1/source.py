"""A ROS 1 bag's messages, in one walk: tfrec's one reader of ROS 1 bags (format 2.0).

:class:`Ros1Source` walks a bag through its index (:mod:`tfrec.formats.rosbag1.index`): the connections and every
chunk's messages per connection come from it without reading a message, so a chunk that holds no message of a
connection asked for is counted from its index data records and not read; a chunk that is read (uncompressed, bz2
or lz4) has its messages found through their offsets with numpy and becomes one
:class:`~tfrec.formats.ros.connection.MessageBatch` of the connections asked for. The chunks are walked in the
file's order, each one's index data records read when the walk reaches it: the memory a walk holds does not grow
with the bag.

A bag whose index is missing (a recorder killed mid-write), damaged, or does not describe its chunks is walked
record by record instead — from the start, or from the first chunk the index does not describe: connection records
(the index's first, when it is there, so that a chunk whose connection was defined in a lost chunk is still read),
chunks and the message records inside them (found through the index data records after each chunk when they
describe it). The complete records of a chunk the file ends inside are kept; a chunk whose data does not decompress
is skipped and the walk goes on after it; the index's chunk info records, when the walk reaches them, give the
recording's span. :attr:`~tfrec.formats.ros.connection.MessageSource.read_error` says where reading stopped and what
was skipped. A bag header record that is damaged is read past, where rosbag (or rosbags) puts the records after
it, as rosbags reads such a bag.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import ReadError, one_line
from tfrec.formats._compression import MAX_CHUNK_BYTES, decompress, salvage
from tfrec.formats.ros.connection import (
    Connection,
    MessageBatch,
    MessageSource,
    ReadStopped,
    count_differences,
    distinct,
    warn_reading,
    with_article,
)
from tfrec.formats.ros.decode import RawMessages
from tfrec.formats.rosbag1.index import (
    BagIndex,
    IndexedChunk,
    IndexUnusable,
    chunk_records,
    entry_times,
    message_spans,
    read_index,
    read_index_data,
)
from tfrec.formats.rosbag1.records import (
    COMPRESSIONS,
    OP_BAG_HEADER,
    OP_CHUNK,
    OP_CHUNK_INFO,
    OP_CONNECTION,
    OP_MESSAGE_DATA,
    RECORD_NAMES,
    ROS1_MAGIC,
    connection_of,
    header_fields,
    index_connections,
    read_bag_header,
    time_field,
    uint32_field,
)

__all__ = ["Ros1Source"]

_Found = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]
"""Messages found in a chunk's records: connection ids (the source's), times, data starts and stops."""


class Ros1Source(MessageSource):
    """The messages of a ROS 1 bag.

    Args:
        path: the bag.
        where: the recording, for messages.
        resolve: a recorded topic name → the name it is played under.
    """

    def __init__(self, path: Path, *, where: str, resolve: Callable[[str], str]) -> None:
        super().__init__(where, "rosbag1")
        self.path = path
        self.resolve = resolve
        self.bag_ids: dict[int, int] = {}  # the bag's connection id → connection id
        self.compressions: set[str] = set()

    def _walk(self) -> Iterator[MessageBatch]:
        try:
            stream = open(self.path, "rb")  # noqa: SIM115 - closed below
        except OSError as err:
            raise ReadError(f"{self.where}: cannot read: {err.strerror or err}") from err
        with stream:
            size = os.fstat(stream.fileno()).st_size
            try:
                index = read_index(stream, size)
            except IndexUnusable as err:
                yield from self._record_walk(stream, size, refused=str(err), start=None)
                return
            yield from self._indexed(stream, size, index)

    def add_connection(self, bag_id: int, connection: Connection) -> None:
        """A connection record of the bag (its topic as recorded), once per id of the bag."""
        if bag_id not in self.bag_ids:
            self.bag_ids[bag_id] = self.connection_id(replace(connection, topic=self.resolve(connection.topic)),
                                                      "latched" if connection.latched else None)

    def _record_walk(self, stream: IO[bytes], size: int, *, refused: str, start: int | None) -> Iterator[MessageBatch]:
        walk = _RecordWalk(self, stream, size, start=start)
        yield from walk.batches()
        walk.finish(refused)

    # -- through the index ----------------------------------------------------------------------

    def _indexed(self, stream: IO[bytes], size: int, index: BagIndex) -> Iterator[MessageBatch]:
        for bag_id, connection in index.connections.items():
            self.add_connection(bag_id, connection)
        indexed: dict[int, int] = {}  # messages per connection, as the chunk info records count them
        try:
            for chunk in index.chunks(stream, size):  # one chunk's index data held at a time
                batch = self._indexed_chunk(stream, chunk, indexed)
                if batch is not None:
                    yield batch
        except IndexUnusable as err:  # the chunks from here on, record by record
            yield from self._record_walk(stream, size, refused=str(err), start=err.resume)
            return
        self.details["compression"] = ", ".join(sorted(self.compressions))
        if index.header_problem:
            warn_reading(f"{self.where}: {index.header_problem}; read through its index, as rosbags reads it")
        if self.check_counts:
            self._check_counts(indexed)

    def _indexed_chunk(self, stream: IO[bytes], chunk: IndexedChunk, indexed: dict[int, int]) -> MessageBatch | None:
        """A chunk's messages of the connections asked for (None: none), the others counted from its index.

        Raises:
            IndexUnusable: a chunk that does not decompress, or whose records are not where the index says
                (``resume``: the chunk's byte).
        """
        self.compressions.add(chunk.compression)
        if self.until_ns is not None and _first_ns(chunk.entries) > self.until_ns:
            return None  # its index says every message in it is past what is wanted
        wanted = [bag_id for bag_id in chunk.entries if self.wanted(self.bag_ids[bag_id])]
        try:
            batch = self._decode(stream, chunk, wanted) if wanted else None
        except IndexUnusable as err:
            raise IndexUnusable(str(err), chunk.pos) from err
        self._count(chunk, indexed)
        return batch

    def _count(self, chunk: IndexedChunk, indexed: dict[int, int]) -> None:
        """Count a chunk's messages from its index data records (and note its chunk info's counts)."""
        for bag_id, count in chunk.counts.items():
            indexed[bag_id] = indexed.get(bag_id, 0) + count
        for bag_id, entries in chunk.entries.items():
            if len(entries):
                times = entry_times(entries)
                stats = self.stats[self.bag_ids[bag_id]]
                stats.count += len(entries)
                stats.add_times(int(times.min()), int(times.max()))

    def _decode(self, stream: IO[bytes], chunk: IndexedChunk, wanted: list[int]) -> MessageBatch | None:
        """The messages of the wanted connections (the bag's ids) of a chunk, through its index data records.

        Raises:
            IndexUnusable: a chunk that does not decompress, or whose records are not where the index says.
        """
        buffer = np.frombuffer(chunk_records(stream, chunk), dtype=np.uint8)
        parts = []
        for bag_id in wanted:
            times, starts, stops = message_spans(buffer, np.sort(chunk.entries[bag_id]["offset"].astype(np.int64)),
                                                 bag_id)
            parts.append((np.full(len(times), self.bag_ids[bag_id], np.int64), times, starts, stops))
        conns, times, starts, stops = (np.concatenate([part[k] for part in parts]) for k in range(4))
        if not len(conns):
            return None
        self.messages += len(conns)
        return MessageBatch.of(conns, times, None, RawMessages(buffer, starts, stops))

    def _check_counts(self, indexed: dict[int, int]) -> None:
        """Warn when the index data records count other messages than the chunk info records."""
        read: dict[str, int] = {}
        counted: dict[str, int] = {}
        for bag_id, conn in self.bag_ids.items():
            topic = self.connections[conn].topic
            read[topic] = read.get(topic, 0)
            counted[topic] = counted.get(topic, 0) + indexed.get(bag_id, 0)
        for conn, stats in self.stats.items():
            topic = self.connections[conn].topic
            read[topic] = read.get(topic, 0) + stats.count
        differ = count_differences(read, counted, index="its chunk info records")
        if differ is not None:
            warn_reading(f"{self.where}: {differ} (its index data records count otherwise)")


def _first_ns(entries: dict[int, NDArray[np.void]]) -> int:
    """The earliest time of a chunk's index data entries (ns); -1 without any."""
    times = [int(entry_times(found).min()) for found in entries.values() if len(found)]
    return min(times) if times else -1


class _RecordWalk:
    """The walk over a bag's records, then those inside each chunk, without the index.

    Args:
        start: where to begin: None for the bag's start (its magic and header), else the byte of a chunk.
    """

    def __init__(self, source: Ros1Source, stream: IO[bytes], size: int, *, start: int | None) -> None:
        self.source = source
        self.stream = stream
        self.size = size
        self.start = start
        self.offset = 0
        self.damaged: list[tuple[int, str]] = []  # (byte, problem) of skipped chunks
        self.indexed = False  # the index section's chunk info records were reached
        self.span: tuple[int, int] | None = None  # from the chunk info records
        self.stop: ReadStopped | None = None
        self.singles: list[tuple[int, int, bytes]] = []  # message records outside chunks: connection, time, data

    def batches(self) -> Iterator[MessageBatch]:
        try:
            yield from self._records()
        except ReadStopped as err:
            self.stop = err
        yield from self._flush()

    def _read(self, size: int) -> bytes:
        data = self.stream.read(size)
        self.offset += len(data)
        return data

    def _begin(self) -> None:
        """Go to the first record: after the bag header (its index's connection records taken first), or to
        :attr:`start`."""
        if self.start is not None:
            self.stream.seek(self.start)
            self.offset = self.start
            return
        self._read(len(ROS1_MAGIC))
        header = read_bag_header(self.stream, self.size)
        if header is not None and header.problem:  # read past it, from where its records begin
            self.stream.seek(header.body_start)
            self.offset = header.body_start
            if header.fields:
                self._index_connections(header.fields)
        else:
            self.stream.seek(self.offset)  # an intact header is read as any record (or the damage said below)

    def _records(self) -> Iterator[MessageBatch]:
        """Every record up to the end of the file.

        Raises:
            ReadStopped: the file ends inside a record, or a record is damaged.
        """
        self._begin()
        while True:
            start = self.offset
            fields, op, data_len = self._head(start)
            if fields is None:
                return
            what = RECORD_NAMES.get(op, f"op 0x{op:02x}")
            if self.offset + data_len > self.size:
                if op == OP_CHUNK:
                    yield from self._flush()
                    before = self.source.counted
                    batch = self._chunk(fields, self._read(data_len), start, cut=True)
                    if batch is not None:
                        yield batch
                    raise ReadStopped(self.size, f"the file ends inside a chunk record (recovered "
                                                 f"{self.source.counted - before:,} messages of it)")
                raise ReadStopped(start, f"the file ends inside {with_article(what)} record")
            if op == OP_CHUNK:
                yield from self._flush()
                batch = self._chunk(fields, self._read(data_len), start, cut=False)
                if batch is not None:
                    yield batch
                continue
            if op not in RECORD_NAMES:
                raise ReadStopped(start, f"a record with unknown op 0x{op:02x}")
            self._top_level(op, fields, self._read(data_len), start, what)

    def _head(self, start: int) -> tuple[dict[str, bytes] | None, int, int]:
        """The header of the record at ``start``: its fields (None at the end of a bag that has its index), op
        and data length.

        Raises:
            ReadStopped: the file ends (without an index) or inside the header, or the header is damaged.
        """
        raw = self._read(4)
        if not raw:
            if not self.indexed:
                raise ReadStopped(start, "the file ends without an index")
            return None, 0, 0
        if len(raw) < 4:
            raise ReadStopped(start, "the file ends inside a record")
        (header_len,) = struct.unpack("<I", raw)
        if header_len > self.size:
            raise ReadStopped(start, f"a damaged record (header length {header_len:,})")
        if start + 4 + header_len + 4 > self.size:
            raise ReadStopped(start, "the file ends inside a record")
        try:
            fields = header_fields(self._read(header_len))
            op = fields["op"][0]
        except (ValueError, KeyError, IndexError) as err:
            raise ReadStopped(start, f"a damaged record header ({err})") from err
        (data_len,) = struct.unpack("<I", self._read(4))
        return fields, op, data_len

    def _top_level(self, op: int, fields: dict[str, bytes], data: bytes, start: int, what: str) -> None:
        """A record outside chunks: the bag header, a connection, a message, index records.

        Raises:
            ReadStopped: a damaged one.
        """
        if op == OP_BAG_HEADER:
            self._index_connections(fields)
            return
        try:
            if op == OP_MESSAGE_DATA:
                conn = self._conn(fields)
                self.singles.append((conn, time_field(fields, "time"), data))
            elif op == OP_CONNECTION:
                self._connection(fields, data)
            elif op == OP_CHUNK_INFO:
                self._chunk_info(fields)
        except ValueError as err:
            raise ReadStopped(start, f"a damaged {what} record ({err})") from err

    def _index_connections(self, header: dict[str, bytes]) -> None:
        """Take the index section's connection records before the chunks: a chunk whose connection was defined in
        a lost chunk is still read."""
        _, connections = index_connections(self.stream, header, self.offset, self.size)
        self.stream.seek(self.offset)
        for fields, data in connections:
            try:
                self._connection(fields, data)
            except ValueError:
                return  # a damaged one: the rest come from the chunks

    def _connection(self, fields: dict[str, bytes], data: bytes | memoryview) -> None:
        """A connection record.

        Raises:
            ValueError: a damaged one.
        """
        bag_id = uint32_field(fields, "conn")
        if bag_id not in self.source.bag_ids:
            self.source.add_connection(bag_id, connection_of(fields, header_fields(data)))

    def _conn(self, fields: dict[str, bytes]) -> int:
        """The connection of a message record.

        Raises:
            ValueError: an unknown one.
        """
        bag_id = uint32_field(fields, "conn")
        conn = self.source.bag_ids.get(bag_id)
        if conn is None:
            raise ValueError(f"a message on unknown connection {bag_id}")
        return conn

    def _chunk_info(self, fields: dict[str, bytes]) -> None:
        self.indexed = True
        if uint32_field(fields, "count"):
            start, end = time_field(fields, "start_time"), time_field(fields, "end_time")
            self.span = (start, end) if self.span is None else (min(self.span[0], start), max(self.span[1], end))

    # -- chunks ---------------------------------------------------------------------------------

    def _chunk(self, fields: dict[str, bytes], data: bytes, start: int, *, cut: bool) -> MessageBatch | None:
        """A chunk record at byte ``start``: its messages."""
        try:
            compression = fields["compression"].decode("ascii")
            declared = uint32_field(fields, "size")
        except (KeyError, UnicodeDecodeError, ValueError):
            if not cut:
                self.damaged.append((start, "its header is damaged"))
            return None
        self.source.compressions.add(compression)
        if cut:
            salvaged = salvage(compression, data, limit=min(declared, MAX_CHUNK_BYTES), supported=COMPRESSIONS)
            return self._take(self._chunk_records(salvaged)[0], salvaged)
        entries = read_index_data(self.stream, self.size)
        self.offset = self.stream.tell()
        until = self.source.until_ns
        if until is not None and entries and _first_ns(entries) > until:
            return None  # its index says every message in it is past what is wanted
        try:
            records = decompress(compression, data, declared, supported=COMPRESSIONS)
        except ValueError as err:
            self.damaged.append((start, str(err)))
            return None
        found = self._spans(records, entries) if entries else None
        problem = None
        if found is None:
            found, problem = self._chunk_records(records)
        batch = self._take(found, records)
        if problem is not None:
            self.damaged.append((start, problem))
        return batch

    def _spans(self, records: bytes | memoryview, entries: dict[int, NDArray[np.void]]) -> _Found | None:
        """A chunk's messages through the index data records after it; None when they do not describe it."""
        bag_ids = self.source.bag_ids
        if not all(bag_id in bag_ids for bag_id in entries):
            return None
        buffer = np.frombuffer(records, dtype=np.uint8)
        parts = []
        for bag_id, found in entries.items():
            try:
                spans = message_spans(buffer, np.sort(found["offset"].astype(np.int64)), bag_id)
            except IndexUnusable:
                return None
            parts.append((np.full(len(spans[0]), bag_ids[bag_id], np.int64), *spans))
        if not parts:
            return None
        conns, times, starts, stops = (np.concatenate([part[k] for part in parts]) for k in range(4))
        return conns, times, starts, stops

    def _chunk_records(self, data: bytes | memoryview) -> tuple[_Found, str | None]:
        """The records of a chunk's data one by one: connections taken, messages returned; and the problem that
        stopped the walk (the records before it are taken)."""
        view = memoryview(data)
        pos, end = 0, len(view)
        conns: list[int] = []
        times: list[int] = []
        starts: list[int] = []
        stops: list[int] = []
        problem = None
        while pos < end:
            if pos + 4 > end:
                problem = "a record runs past the end of the chunk"
                break
            (header_len,) = struct.unpack_from("<I", view, pos)
            if pos + 8 + header_len > end:
                problem = "a record runs past the end of the chunk"
                break
            (data_len,) = struct.unpack_from("<I", view, pos + 4 + header_len)
            body = pos + 8 + header_len
            if body + data_len > end:
                problem = "a record runs past the end of the chunk"
                break
            try:
                fields = header_fields(view[pos + 4 : pos + 4 + header_len])
                op = fields["op"][0]
                if op == OP_MESSAGE_DATA:
                    conn, time_ns = self._conn(fields), time_field(fields, "time")  # both, or neither is taken
                    conns.append(conn)
                    times.append(time_ns)
                    starts.append(body)
                    stops.append(body + data_len)
                elif op == OP_CONNECTION:
                    self._connection(fields, view[body : body + data_len])
                else:
                    problem = f"{with_article(RECORD_NAMES.get(op, f'op 0x{op:02x}'))} record inside the chunk"
                    break
            except (ValueError, KeyError, IndexError) as err:
                problem = f"a damaged record ({err})"
                break
            pos = body + data_len
        return (np.array(conns, np.int64), np.array(times, np.int64), np.array(starts, np.int64),
                np.array(stops, np.int64)), problem

    def _take(self, found: _Found, records: bytes | memoryview) -> MessageBatch | None:
        """Count the messages found, and give those of the connections asked for as a batch."""
        conns, times, starts, stops = found
        if not len(conns):
            return None
        source = self.source
        for conn in distinct(conns):
            chosen = times[conns == conn]
            stats = source.stats[conn]
            stats.count += len(chosen)
            stats.add_times(int(chosen.min()), int(chosen.max()))
        keep = np.array([source.wanted(conn) for conn in range(len(source.connections))], dtype=bool)[conns]
        if not keep.any():
            return None
        index = np.flatnonzero(keep)
        source.messages += len(index)
        return MessageBatch.of(conns[index], times[index], None,
                               RawMessages(np.frombuffer(records, dtype=np.uint8), starts[index], stops[index]))

    def _flush(self) -> Iterator[MessageBatch]:
        """The message records outside chunks collected so far, as a batch."""
        if not self.singles:
            return
        singles, self.singles = self.singles, []
        datas = [data for _, _, data in singles]
        sizes = np.fromiter(map(len, datas), dtype=np.int64, count=len(datas))
        stops = np.cumsum(sizes)
        batch = self._take((np.array([conn for conn, _, _ in singles], np.int64),
                            np.array([time for _, time, _ in singles], np.int64), stops - sizes, stops),
                           b"".join(datas))
        if batch is not None:
            yield batch

    # -- the end ----------------------------------------------------------------------------------

    def finish(self, refused: str) -> None:
        """What the walk found: what it lost, the span the index gives, the compressions.

        Args:
            refused: why the index could not be used.

        Raises:
            ReadError: no connection record is readable.
        """
        source, stop = self.source, self.stop
        if not source.bag_ids:
            stopped = f"; reading stopped at byte {stop.offset:,}: {stop.reason}" if stop is not None else ""
            raise ReadError(f"{source.where}: cannot read ROS 1 bag: {one_line(refused)}{stopped}")
        problems = [self._damage_summary()] if self.damaged else []
        if stop is not None:
            problems.append(stop.problem(self.size))
        source.details["compression"] = ", ".join(sorted(source.compressions))
        if problems:
            source.lost(source.where, problems, source.counted)
            if self.span is not None:
                source.true_start_ns = self.span[0]  # from the index: messages before the first one read were lost
        else:  # an intact bag whose index is wrong
            warn_reading(f"{source.where}: {refused}; the bag was read record by record")

    def _damage_summary(self) -> str:
        byte, problem = self.damaged[0]
        if len(self.damaged) == 1:
            return f"a damaged chunk record at byte {byte:,} ({problem}) was skipped"
        return f"{len(self.damaged)} damaged chunk records, the first at byte {byte:,} ({problem}), were skipped"
