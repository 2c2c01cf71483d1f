"""Reading a ROS 1 bag through its index: only the chunks that hold messages to decode are read.

A bag (format 2.0) ends with an index: a connection record per connection and a chunk info
record per chunk (its byte, its time span, its messages per connection); each chunk is followed
by one index data record per connection, the (time, offset) of each of its messages. So the
topic table — counts, first and last times — comes from the index without reading a message,
and a chunk is read (and decompressed: none, bz2 or lz4) only when it holds a message to decode.
Inside a chunk, the messages of the decoded connections are found through their offsets with
numpy: a connection's message records have the same header but for the time, so their times
and data are taken for all of them at once (a record that does not fit the pattern is parsed on
its own).

A bag whose index is missing (a recorder killed mid-write), damaged, or does not describe its
chunks is read record by record instead (:mod:`tfrec.formats.rosbag1.reader`), which says what
was lost; a count that disagrees between the chunk info and index data records warns.
"""

from __future__ import annotations

import os
import struct
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import ReadError, TfrecWarning
from tfrec.formats._collect import Collector, ReadOptions, count_differences
from tfrec.formats._compression import decompress
from tfrec.formats.ros.connection import Connection
from tfrec.formats.ros.decode import RawMessages
from tfrec.formats.ros.encode import ns_from_stamps
from tfrec.formats.ros.types import known_ros1_typestore, topic_deserializer
from tfrec.formats.rosbag1.reader import (
    COMPRESSIONS,
    OP_CHUNK,
    OP_CHUNK_INFO,
    OP_CONNECTION,
    OP_INDEX,
    OP_MESSAGE,
    ROS1_MAGIC,
    bag_header,
    connection_of,
    header_fields,
    read_rosbag1_records,
    time_field,
    uint32_field,
)
from tfrec.recording import Recording, TopicStats

__all__ = ["message_spans", "read_rosbag1"]

_ENTRY = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("offset", "<u4")])
"""An index data record's entry (version 1): a message's time and its byte in the decompressed chunk."""


class _Unusable(Exception):
    """The index cannot be used (missing, damaged, or not describing the chunks): read record by record."""


@dataclass
class _Chunk:
    """A chunk, as the index and the records after it give it."""

    pos: int
    counts: dict[int, int]  # connection → messages, from its chunk info record
    compression: str = ""
    size: int = 0
    data_pos: int = 0
    data_len: int = 0
    entries: dict[int, NDArray[np.void]] = field(default_factory=dict)  # connection → index data entries


def _record(stream: IO[bytes], size: int) -> tuple[dict[str, bytes], int, int]:
    """The record at the stream's position: its header fields, and where its data begins and how long it is.

    Raises:
        _Unusable: a record that runs past the end of the file or has a damaged header.
    """
    at = stream.tell()
    raw = stream.read(4)
    if len(raw) < 4:
        raise _Unusable(f"no record at byte {at:,}")
    (header_len,) = struct.unpack("<I", raw)
    if at + 8 + header_len > size:
        raise _Unusable(f"a record at byte {at:,} runs past the end of the file")
    try:
        fields = header_fields(stream.read(header_len))
    except ValueError as err:
        raise _Unusable(f"a damaged record header at byte {at:,} ({err})") from err
    (data_len,) = struct.unpack("<I", stream.read(4))
    data_pos = at + 8 + header_len
    if data_pos + data_len > size:
        raise _Unusable(f"a record at byte {at:,} runs past the end of the file")
    return fields, data_pos, data_len


def _op(fields: dict[str, bytes]) -> int:
    op = fields.get("op", b"")
    if len(op) != 1:
        raise _Unusable("a record without an op")
    return op[0]


class _IndexedBag:
    """One bag read through its index."""

    def __init__(self, stream: IO[bytes], size: int, collector: Collector, where: str) -> None:
        self.stream = stream
        self.size = size
        self.collector = collector
        self.where = where
        self.connections: dict[int, Connection] = {}  # topics as recorded
        self.chunks: list[_Chunk] = []
        self.stats: dict[int, TopicStats] = {}
        self.header_problem = ""  # a damaged bag header record read past

    def read_index(self) -> None:
        """The bag header, the connection and chunk info records, and each chunk's header and index data.

        Raises:
            _Unusable: no index, or one that does not describe the file.
        """
        stream, size = self.stream, self.size
        stream.seek(len(ROS1_MAGIC))
        header = bag_header(stream, size)
        if header is None or not header.fields:
            raise _Unusable(header.problem if header is not None else "a damaged bag header record")
        self.header_problem = header.problem
        fields = header.fields
        try:
            (index_pos,) = struct.unpack("<Q", fields["index_pos"])
            conn_count, chunk_count = uint32_field(fields, "conn_count"), uint32_field(fields, "chunk_count")
        except (KeyError, struct.error, ValueError) as err:
            raise _Unusable(f"a damaged bag header ({err})") from err
        if index_pos == 0 or not header.body_start <= index_pos <= size:
            raise _Unusable("the bag has no index (a recorder stopped before writing it)")
        stream.seek(index_pos)
        try:
            for _ in range(conn_count):
                fields, _, data_len = _record(stream, size)
                if _op(fields) != OP_CONNECTION:
                    raise _Unusable("the index lacks a connection record")
                conn = uint32_field(fields, "conn")
                self.connections[conn] = connection_of(fields, header_fields(stream.read(data_len)))
            for _ in range(chunk_count):
                fields, _, data_len = _record(stream, size)
                if _op(fields) != OP_CHUNK_INFO or uint32_field(fields, "ver") != 1:
                    raise _Unusable("the index lacks a chunk info record")
                (chunk_pos,) = struct.unpack("<Q", fields["chunk_pos"])
                if chunk_pos >= size:  # (a position past 2**63 is past what seek() takes)
                    raise _Unusable(f"a chunk info record points past the end of the file (byte {chunk_pos:,})")
                pairs = np.frombuffer(stream.read(data_len), dtype="<u4").reshape(-1, 2)
                counts = {int(conn): int(count) for conn, count in pairs}
                if len(counts) != uint32_field(fields, "count") or set(counts) - set(self.connections):
                    raise _Unusable("a chunk info record names unknown connections")
                self.chunks.append(_Chunk(chunk_pos, counts))
        except (KeyError, struct.error, ValueError) as err:
            raise _Unusable(f"a damaged index record ({err})") from err
        if stream.tell() != size:
            raise _Unusable("the index goes on past the records the bag header counts (a damaged count)")
        self.chunks.sort(key=lambda chunk: chunk.pos)
        for chunk in self.chunks:
            self._chunk_index(chunk)

    def _chunk_index(self, chunk: _Chunk) -> None:
        """A chunk's header fields and the index data records that follow it."""
        stream, size = self.stream, self.size
        stream.seek(chunk.pos)
        fields, chunk.data_pos, chunk.data_len = _record(stream, size)
        try:
            if _op(fields) != OP_CHUNK:
                raise _Unusable(f"no chunk at byte {chunk.pos:,}, where the index has one")
            chunk.compression = fields["compression"].decode("ascii")
            chunk.size = uint32_field(fields, "size")
            stream.seek(chunk.data_pos + chunk.data_len)
            for _ in range(len(chunk.counts)):
                fields, _, data_len = _record(stream, size)
                if _op(fields) != OP_INDEX or uint32_field(fields, "ver") != 1:
                    raise _Unusable(f"the chunk at byte {chunk.pos:,} is not followed by its index data records")
                conn, count = uint32_field(fields, "conn"), uint32_field(fields, "count")
                if data_len != count * _ENTRY.itemsize or conn not in chunk.counts:
                    raise _Unusable(f"a damaged index data record after the chunk at byte {chunk.pos:,}")
                chunk.entries[conn] = np.frombuffer(stream.read(data_len), dtype=_ENTRY)
        except (KeyError, UnicodeDecodeError, ValueError) as err:
            raise _Unusable(f"a damaged chunk or index data record at byte {chunk.pos:,} ({err})") from err
        if chunk.compression not in COMPRESSIONS:
            raise _Unusable(f"unsupported chunk compression '{chunk.compression}'")

    def read(self) -> dict[int, int]:
        """Count every connection from the index and decode the wanted messages.

        Returns:
            Messages per connection as the chunk info records count them.

        Raises:
            _Unusable: a chunk that does not decompress, or whose records are not where the index says.
        """
        collector = self.collector
        topics = {conn: collector.resolve(c.topic) for conn, c in self.connections.items()}
        decoded = {conn for conn, c in self.connections.items()
                   if collector.decodes(topics[conn], c.msgtype, definition=c.definition, type_hash=c.type_hash)}
        for conn in sorted(decoded):
            collector.set_deserializer(topics[conn], topic_deserializer(
                self.connections[conn].msgtype, where=self.where, topic=topics[conn], ros1=True,
                store=known_ros1_typestore()))
        indexed: dict[int, int] = {}
        for conn, c in self.connections.items():
            self.stats[conn] = TopicStats(c.msgtype, "latched" if c.latched else None)
        for chunk in self.chunks:
            for conn, count in chunk.counts.items():
                indexed[conn] = indexed.get(conn, 0) + count
            for conn, entries in chunk.entries.items():
                if len(entries):
                    times = ns_from_stamps(entries["sec"].astype(np.int64), entries["nsec"].astype(np.int64))
                    stats = self.stats[conn]
                    stats.count += len(entries)
                    stats.add_times(int(times.min()), int(times.max()))
            wanted = [conn for conn in chunk.entries if conn in decoded and collector.remaining(topics[conn]) != 0]
            if wanted:
                self._decode_chunk(chunk, wanted, topics)
        for conn, stats in self.stats.items():
            if stats.count:
                collector.count(topics[conn], stats)
            else:
                collector.topic(topics[conn], stats.type, stats.durability)
        return indexed

    def _decode_chunk(self, chunk: _Chunk, wanted: list[int], topics: dict[int, str]) -> None:
        self.stream.seek(chunk.data_pos)
        try:
            records = decompress(chunk.compression, self.stream.read(chunk.data_len), chunk.size,
                                 supported=COMPRESSIONS)
        except ValueError as err:
            raise _Unusable(f"a damaged chunk at byte {chunk.pos:,} ({err})") from err
        buffer = np.frombuffer(records, dtype=np.uint8)
        found: dict[str, list[tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]]] = {}
        for conn in wanted:  # a topic's publishers (connections) merged in time order
            offsets = np.sort(chunk.entries[conn]["offset"].astype(np.int64))
            found.setdefault(topics[conn], []).append(_messages(buffer, offsets, conn))
        for topic, parts in found.items():
            times, starts, stops = (np.concatenate([part[k] for part in parts]) for k in range(3))
            if len(parts) > 1:
                order = np.argsort(times, kind="stable")
                times, starts, stops = times[order], starts[order], stops[order]
            self.collector.add(topic, RawMessages(records, starts, stops), times)


def _gather(buffer: NDArray[np.uint8], offsets: NDArray[np.int64], width: int) -> NDArray[np.uint8]:
    """The ``width`` bytes at each offset, as rows."""
    rows: NDArray[np.uint8] = buffer[offsets[:, np.newaxis] + np.arange(width)]
    return rows


def _messages(buffer: NDArray[np.uint8], offsets: NDArray[np.int64],
              conn: int) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """The (time, data start, data end) of the message records of connection ``conn`` at ``offsets``.

    Raises:
        _Unusable: an offset that holds no message record of the connection.
    """
    size = len(buffer)
    if not len(offsets):
        return np.zeros(0, np.int64), offsets, offsets
    if offsets[0] < 0 or offsets[-1] + 8 > size:
        raise _Unusable("an index data record points past its chunk")
    header_len = _gather(buffer, offsets, 4).view("<u4").ravel().astype(np.int64)
    first = int(header_len[0])
    template = bytes(buffer[offsets[0] + 4 : offsets[0] + 4 + first])
    try:
        fields = header_fields(template)
        time_at = _field_position(template, "time")
    except ValueError as err:
        raise _Unusable(f"a damaged message record ({err})") from err
    if fields.get("op") != bytes([OP_MESSAGE]) or fields.get("conn") != struct.pack("<I", conn) or time_at is None:
        raise _Unusable("an index data record points to no message of its connection")
    if (header_len == first).all() and offsets[-1] + 8 + first <= size:
        heads = _gather(buffer, offsets + 4, first)
        expected = np.frombuffer(template, dtype=np.uint8).copy()
        mask = np.ones(first, dtype=bool)
        mask[time_at : time_at + 8] = False
        if (heads[:, mask] == expected[mask]).all():
            stamp = np.ascontiguousarray(heads[:, time_at : time_at + 8]).view("<u4")
            times = ns_from_stamps(stamp[:, 0].astype(np.int64), stamp[:, 1].astype(np.int64))
            lengths = _gather(buffer, offsets + 4 + first, 4).view("<u4").ravel().astype(np.int64)
            starts = offsets + 8 + first
            stops = starts + lengths
            if stops[-1] <= size and not (stops[:-1] > offsets[1:]).any():
                return times, starts, stops
    return _one_by_one(buffer, offsets, conn)


def message_spans(buffer: NDArray[np.uint8], offsets: NDArray[np.int64],
                  conn: int) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]] | None:
    """The (time, data start, data end) of the message records of connection ``conn`` at
    ``offsets`` (sorted) in a chunk's records ``buffer``, found with numpy as the index reader
    finds them; None when an offset holds no message record of the connection."""
    try:
        return _messages(buffer, offsets, conn)
    except _Unusable:
        return None


def _field_position(header: bytes, name: str) -> int | None:
    """Where the value of field ``name`` begins in a record header, or None."""
    pos = 0
    key = name.encode() + b"="
    while pos + 4 <= len(header):
        (size,) = struct.unpack_from("<I", header, pos)
        if header[pos + 4 : pos + 4 + len(key)] == key:
            return pos + 4 + len(key)
        pos += 4 + size
    return None


def _one_by_one(buffer: NDArray[np.uint8], offsets: NDArray[np.int64],
                conn: int) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """:func:`_messages` for records that do not share one header layout."""
    data = buffer.tobytes()
    times, starts, stops = [], [], []
    for offset in offsets.tolist():
        try:
            (header_len,) = struct.unpack_from("<I", data, offset)
            fields = header_fields(data[offset + 4 : offset + 4 + header_len])
            (data_len,) = struct.unpack_from("<I", data, offset + 4 + header_len)
            if fields.get("op") != bytes([OP_MESSAGE]) or uint32_field(fields, "conn") != conn:
                raise ValueError("not a message of its connection")
            times.append(time_field(fields, "time"))
        except (struct.error, ValueError) as err:
            raise _Unusable(f"an index data record points to no message of its connection ({err})") from err
        starts.append(offset + 8 + header_len)
        stops.append(offset + 8 + header_len + data_len)
        if stops[-1] > len(data):
            raise _Unusable("a message record runs past the end of its chunk")
    return np.array(times, np.int64), np.array(starts, np.int64), np.array(stops, np.int64)


def read_rosbag1(path: Path, options: ReadOptions) -> Recording:
    """Read a ROS 1 bag: through its index, or record by record when the index cannot be used.

    Raises:
        ReadError: the file cannot be opened, or nothing of it is readable.
    """
    where = os.fspath(path)
    recording = Recording(path=where, format="rosbag1")
    collector = Collector(recording, options, ros1=True)
    try:
        with open(path, "rb") as stream:
            size = os.fstat(stream.fileno()).st_size
            bag = _IndexedBag(stream, size, collector, where)
            problem: str | None = None
            try:
                bag.read_index()
                indexed = bag.read()
            except _Unusable as err:
                problem = str(err)
    except OSError as err:
        raise ReadError(f"{where}: cannot read: {err.strerror or err}") from err
    if problem is not None:
        recording = read_rosbag1_records(path, options, refused=problem)
        if recording.read_error is None:  # an intact bag whose index is wrong
            warnings.warn(f"{where}: {problem}; the bag was read record by record", TfrecWarning, stacklevel=3)
        return recording
    if bag.header_problem:
        warnings.warn(f"{where}: {bag.header_problem}; read through its index, as rosbags reads it", TfrecWarning, stacklevel=3)
    recording.details = {"compression": ", ".join(sorted({chunk.compression for chunk in bag.chunks}))}
    collector.finish()
    read: dict[str, int] = {}
    counted: dict[str, int] = {}
    for conn, connection in bag.connections.items():
        name = collector.resolve(connection.topic)
        read[name] = read.get(name, 0) + bag.stats[conn].count
        counted[name] = counted.get(name, 0) + indexed.get(conn, 0)
    differ = count_differences(read, counted, index="its chunk info records")
    if differ is not None:
        warnings.warn(f"{where}: {differ} (its index data records count otherwise)", TfrecWarning, stacklevel=3)
    return recording
