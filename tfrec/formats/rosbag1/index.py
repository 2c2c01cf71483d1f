"""A ROS 1 bag's index: what :mod:`tfrec.formats.rosbag1.source` walks a bag through.

A bag (format 2.0) ends with an index: a connection record per connection and a chunk info record per chunk (its
byte, its time span, its messages per connection); each chunk is followed by one index data record per connection,
the (time, offset) of each of its messages. :func:`read_index` checks all of it — without reading a message — but
holds only the connections: :meth:`BagIndex.chunks` then gives the chunks one at a time, in the file's order, each
with its index data records, read when the walk reaches it (12 bytes a message: reading them whole held 35 MB for
4 h at 100 Hz). The topic table (counts, first and last times) comes from the index, and :func:`chunk_records`
decompresses (none, bz2 or lz4) only the chunks that hold a message wanted. Inside a chunk, a connection's messages
are found through their offsets with numpy (:func:`message_spans`): a connection's message records have the same
header but for the time, so their times and data are taken for all of them at once (a record that does not fit the
pattern is parsed on its own).

An index that is missing (a recorder killed mid-write), damaged, or does not describe its chunks raises
:class:`IndexUnusable`: the source then walks the bag record by record.
"""

from __future__ import annotations

import struct
from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import IO

import numpy as np
from numpy.typing import NDArray

from tfrec.formats._compression import decompress
from tfrec.formats.ros.connection import Connection
from tfrec.formats.ros.encode import ns_from_stamps
from tfrec.formats.rosbag1.records import (
    COMPRESSIONS,
    OP_CHUNK,
    OP_CHUNK_INFO,
    OP_CONNECTION,
    OP_INDEX_DATA,
    OP_MESSAGE_DATA,
    ROS1_MAGIC,
    RecordDamaged,
    connection_of,
    header_fields,
    read_bag_header,
    read_record,
    time_field,
    uint32_field,
)

__all__ = ["ENTRY", "BagIndex", "IndexUnusable", "IndexedChunk", "chunk_records", "entry_times", "message_spans",
           "read_index", "read_index_data"]

ENTRY = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("offset", "<u4")])
"""An index data record's entry (version 1): a message's time and its byte in the decompressed chunk."""


class IndexUnusable(Exception):
    """The index cannot be used (missing, damaged, or not describing the chunks): walk the bag record by record.

    Attributes:
        resume: where a walk through the index stopped: the byte of a record to walk on from (None: the start).
    """

    def __init__(self, reason: str, resume: int | None = None) -> None:
        super().__init__(reason)
        self.resume = resume


@dataclass
class IndexedChunk:
    """A chunk, as the index and the records after it give it."""

    pos: int
    counts: dict[int, int]  # connection → messages, from its chunk info record
    compression: str = ""
    size: int = 0
    data_pos: int = 0
    data_len: int = 0
    entries: dict[int, NDArray[np.void]] = field(default_factory=dict)  # connection → index data entries


@dataclass
class BagIndex:
    """A bag's index, checked whole but held in part (:func:`read_index`): the chunks are read again, one at a time,
    by :meth:`chunks`.

    Attributes:
        connections: the bag's connection id → its connection (topic as recorded).
        chunk_count: the chunks (chunk info records).
        infos_at: the byte of the first chunk info record.
        order: the bytes of the chunk info records in the order of their chunks in the file, when the index does not
            list them in that order; None when it does (they are then read one after another from ``infos_at``).
        header_problem: what is damaged in the bag header record that was read past, or ``""``.
    """

    connections: dict[int, Connection]
    chunk_count: int = 0
    infos_at: int = 0
    order: NDArray[np.int64] | None = None
    header_problem: str = ""

    def chunks(self, stream: IO[bytes], size: int, *, entries: bool = True) -> Iterator[IndexedChunk]:
        """The chunks, in the file's order: each one's chunk info record, its header and (``entries``) its index data
        records, read as the walk reaches it.

        Raises:
            IndexUnusable: a chunk or record that is not as the index says (``resume``: the chunk's byte, or where
                the chunk before it ends).
        """
        at, resume = self.infos_at, None
        for number in range(self.chunk_count):
            if self.order is not None:
                at = int(self.order[number])
            stream.seek(at)
            try:
                chunk = _chunk_info(stream, size, self.connections)
            except (KeyError, struct.error, ValueError, IndexUnusable) as err:
                raise IndexUnusable(f"a damaged index record ({err})", resume) from err
            at = stream.tell()
            try:
                resume = _chunk_index(stream, size, chunk, entries=entries)
            except IndexUnusable as err:
                raise IndexUnusable(str(err), chunk.pos) from err
            yield chunk


def entry_times(entries: NDArray[np.void]) -> NDArray[np.int64]:
    """The times of index data entries, in ns."""
    return ns_from_stamps(entries["sec"].astype(np.int64), entries["nsec"].astype(np.int64))


def _record(stream: IO[bytes], size: int) -> tuple[dict[str, bytes], int, int]:
    """The record at the stream's position: its header fields, and where its data begins and how long it is.

    Raises:
        IndexUnusable: a record that runs past the end of the file or has a damaged header.
    """
    at = stream.tell()
    raw = stream.read(4)
    if len(raw) < 4:
        raise IndexUnusable(f"no record at byte {at:,}")
    (header_len,) = struct.unpack("<I", raw)
    if at + 8 + header_len > size:
        raise IndexUnusable(f"a record at byte {at:,} runs past the end of the file")
    try:
        fields = header_fields(stream.read(header_len))
    except ValueError as err:
        raise IndexUnusable(f"a damaged record header at byte {at:,} ({err})") from err
    (data_len,) = struct.unpack("<I", stream.read(4))
    data_pos = at + 8 + header_len
    if data_pos + data_len > size:
        raise IndexUnusable(f"a record at byte {at:,} runs past the end of the file")
    return fields, data_pos, data_len


def _op(fields: dict[str, bytes]) -> int:
    op = fields.get("op", b"")
    if len(op) != 1:
        raise IndexUnusable("a record without an op")
    return op[0]


def read_index(stream: IO[bytes], size: int) -> BagIndex:
    """The bag header and the connection records; the chunk info records, each chunk's header and its index data
    records checked (the data of these is not read).

    Raises:
        IndexUnusable: no index, or one that does not describe the file.
    """
    stream.seek(len(ROS1_MAGIC))
    header = read_bag_header(stream, size)
    if header is None or not header.fields:
        raise IndexUnusable(header.problem if header is not None else "a damaged bag header record")
    try:
        (index_pos,) = struct.unpack("<Q", header.fields["index_pos"])
        conn_count = uint32_field(header.fields, "conn_count")
        chunk_count = uint32_field(header.fields, "chunk_count")
    except (KeyError, struct.error, ValueError) as err:
        raise IndexUnusable(f"a damaged bag header ({err})") from err
    if index_pos == 0 or not header.body_start <= index_pos <= size:
        raise IndexUnusable("the bag has no index (a recorder stopped before writing it)")
    stream.seek(index_pos)
    index = BagIndex({}, chunk_count, header_problem=header.problem)
    positions, infos = array("q"), array("q")  # 16 bytes a chunk, while the index is read
    try:
        for _ in range(conn_count):
            fields, _, data_len = _record(stream, size)
            if _op(fields) != OP_CONNECTION:
                raise IndexUnusable("the index lacks a connection record")
            index.connections[uint32_field(fields, "conn")] = connection_of(fields, header_fields(stream.read(data_len)))
        index.infos_at = stream.tell()
        for _ in range(chunk_count):
            infos.append(stream.tell())
            positions.append(_chunk_info(stream, size, index.connections).pos)
    except (KeyError, struct.error, ValueError) as err:
        raise IndexUnusable(f"a damaged index record ({err})") from err
    if stream.tell() != size:
        raise IndexUnusable("the index goes on past the records the bag header counts (a damaged count)")
    by_pos = np.frombuffer(positions, dtype=np.int64)
    if bool(np.any(np.diff(by_pos) < 0)):  # held: 8 bytes a chunk
        index.order = np.frombuffer(infos, dtype=np.int64)[np.argsort(by_pos, kind="stable")]
    for _ in index.chunks(stream, size, entries=False):
        pass
    return index


def _chunk_info(stream: IO[bytes], size: int, connections: dict[int, Connection]) -> IndexedChunk:
    """The chunk info record at the stream's position.

    Raises:
        IndexUnusable: another record, or one that names unknown connections or points past the file.
    """
    fields, _, data_len = _record(stream, size)
    if _op(fields) != OP_CHUNK_INFO or uint32_field(fields, "ver") != 1:
        raise IndexUnusable("the index lacks a chunk info record")
    (chunk_pos,) = struct.unpack("<Q", fields["chunk_pos"])
    if chunk_pos >= size:  # (a position past 2**63 is past what seek() takes)
        raise IndexUnusable(f"a chunk info record points past the end of the file (byte {chunk_pos:,})")
    pairs = np.frombuffer(stream.read(data_len), dtype="<u4").reshape(-1, 2)
    counts = dict(zip(pairs[:, 0].tolist(), pairs[:, 1].tolist(), strict=True))
    if len(counts) != uint32_field(fields, "count") or set(counts) - set(connections):
        raise IndexUnusable("a chunk info record names unknown connections")
    return IndexedChunk(chunk_pos, counts)


def _chunk_index(stream: IO[bytes], size: int, chunk: IndexedChunk, *, entries: bool) -> int:
    """A chunk's header fields and the index data records that follow it (their entries read only with ``entries``);
    where the last of these ends."""
    stream.seek(chunk.pos)
    fields, chunk.data_pos, chunk.data_len = _record(stream, size)
    try:
        if _op(fields) != OP_CHUNK:
            raise IndexUnusable(f"no chunk at byte {chunk.pos:,}, where the index has one")
        chunk.compression = fields["compression"].decode("ascii")
        chunk.size = uint32_field(fields, "size")
        end = chunk.data_pos + chunk.data_len
        for _ in range(len(chunk.counts)):
            stream.seek(end)
            fields, data_pos, data_len = _record(stream, size)
            if _op(fields) != OP_INDEX_DATA or uint32_field(fields, "ver") != 1:
                raise IndexUnusable(f"the chunk at byte {chunk.pos:,} is not followed by its index data records")
            conn, count = uint32_field(fields, "conn"), uint32_field(fields, "count")
            if data_len != count * ENTRY.itemsize or conn not in chunk.counts:
                raise IndexUnusable(f"a damaged index data record after the chunk at byte {chunk.pos:,}")
            if entries:
                chunk.entries[conn] = np.frombuffer(stream.read(data_len), dtype=ENTRY)
            end = data_pos + data_len
    except (KeyError, UnicodeDecodeError, ValueError) as err:
        raise IndexUnusable(f"a damaged chunk or index data record at byte {chunk.pos:,} ({err})") from err
    if chunk.compression not in COMPRESSIONS:
        raise IndexUnusable(f"unsupported chunk compression '{chunk.compression}'")
    return end


def chunk_records(stream: IO[bytes], chunk: IndexedChunk) -> bytes | memoryview:
    """A chunk's records, decompressed (bounded: :func:`tfrec.formats._compression.decompress`).

    Raises:
        IndexUnusable: a chunk that does not decompress.
    """
    stream.seek(chunk.data_pos)
    try:
        return decompress(chunk.compression, stream.read(chunk.data_len), chunk.size, supported=COMPRESSIONS)
    except ValueError as err:
        raise IndexUnusable(f"a damaged chunk at byte {chunk.pos:,} ({err})") from err


def read_index_data(stream: IO[bytes], size: int) -> dict[int, NDArray[np.void]]:
    """The index data records after a chunk, by connection (the stream is left after them); none when one is
    damaged (the chunk is then walked record by record)."""
    entries: dict[int, NDArray[np.void]] = {}
    while True:
        at = stream.tell()
        try:
            fields, _, data_len = read_record(stream, size)
            if fields.get("op") != bytes([OP_INDEX_DATA]):
                stream.seek(at)
                return entries
            conn = uint32_field(fields, "conn")
            data = stream.read(data_len)
            if uint32_field(fields, "ver") != 1 or len(data) % ENTRY.itemsize:
                return {}
            entries[conn] = np.frombuffer(data, dtype=ENTRY)
        except (RecordDamaged, ValueError):
            stream.seek(at)
            return {}


# -- messages through their offsets ------------------------------------------------------------------


def _gather(buffer: NDArray[np.uint8], offsets: NDArray[np.int64], width: int) -> NDArray[np.uint8]:
    """The ``width`` bytes at each offset, as rows."""
    rows: NDArray[np.uint8] = buffer[offsets[:, np.newaxis] + np.arange(width)]
    return rows


Spans = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]
"""(time, data start, data end) of messages in a chunk's records."""


def message_spans(buffer: NDArray[np.uint8], offsets: NDArray[np.int64], conn: int) -> Spans:
    """The (time, data start, data end) of the message records of connection ``conn`` at ``offsets`` (sorted) in a
    chunk's records ``buffer``.

    Raises:
        IndexUnusable: an offset that holds no message record of the connection.
    """
    size = len(buffer)
    if not len(offsets):
        return np.zeros(0, np.int64), offsets, offsets
    if offsets[0] < 0 or offsets[-1] + 8 > size:
        raise IndexUnusable("an index data record points past its chunk")
    header_len = _gather(buffer, offsets, 4).view("<u4").ravel().astype(np.int64)
    first = int(header_len[0])
    template = bytes(buffer[offsets[0] + 4 : offsets[0] + 4 + first])
    try:
        fields = header_fields(template)
        time_at = _field_position(template, "time")
    except ValueError as err:
        raise IndexUnusable(f"a damaged message record ({err})") from err
    if fields.get("op") != bytes([OP_MESSAGE_DATA]) or fields.get("conn") != struct.pack("<I", conn) or time_at is None:
        raise IndexUnusable("an index data record points to no message of its connection")
    if (header_len == first).all() and offsets[-1] + 8 + first <= size:
        spans = _same_heads(buffer, offsets, template, time_at)
        if spans is not None:
            return spans
    return _one_by_one(buffer, offsets, conn)


def _same_heads(buffer: NDArray[np.uint8], offsets: NDArray[np.int64], template: bytes, time_at: int) -> Spans | None:
    """:func:`message_spans` of records whose headers are ``template`` but for the time, with numpy; None when
    some are not."""
    first = len(template)
    size = len(buffer)
    heads = _gather(buffer, offsets + 4, first)
    expected = np.frombuffer(template, dtype=np.uint8).copy()
    mask = np.ones(first, dtype=bool)
    mask[time_at : time_at + 8] = False
    if not (heads[:, mask] == expected[mask]).all():
        return None
    stamp = np.ascontiguousarray(heads[:, time_at : time_at + 8]).view("<u4")
    times = ns_from_stamps(stamp[:, 0].astype(np.int64), stamp[:, 1].astype(np.int64))
    lengths = _gather(buffer, offsets + 4 + first, 4).view("<u4").ravel().astype(np.int64)
    starts = offsets + 8 + first
    stops = starts + lengths
    if stops[-1] > size or (stops[:-1] > offsets[1:]).any():
        return None
    return times, starts, stops


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


def _one_by_one(buffer: NDArray[np.uint8], offsets: NDArray[np.int64], conn: int) -> Spans:
    """:func:`message_spans` for records that do not share one header layout."""
    data = buffer.tobytes()
    times, starts, stops = [], [], []
    for offset in offsets.tolist():
        try:
            (header_len,) = struct.unpack_from("<I", data, offset)
            fields = header_fields(data[offset + 4 : offset + 4 + header_len])
            (data_len,) = struct.unpack_from("<I", data, offset + 4 + header_len)
            if fields.get("op") != bytes([OP_MESSAGE_DATA]) or uint32_field(fields, "conn") != conn:
                raise ValueError("not a message of its connection")
            times.append(time_field(fields, "time"))
        except (struct.error, ValueError) as err:
            raise IndexUnusable(f"an index data record points to no message of its connection ({err})") from err
        starts.append(offset + 8 + header_len)
        stops.append(offset + 8 + header_len + data_len)
        if stops[-1] > len(data):
            raise IndexUnusable("a message record runs past the end of its chunk")
    return np.array(times, np.int64), np.array(starts, np.int64), np.array(stops, np.int64)
