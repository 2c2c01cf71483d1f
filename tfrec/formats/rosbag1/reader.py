"""Reading a ROS 1 bag record by record, as far as it is readable, when its index cannot be used.

A ROS 1 bag is read through its index at the end of the file (:mod:`tfrec.formats.rosbag1.index`),
which a recorder killed mid-write never wrote (or wrote only in part); a chunk that does not
decompress, or an index that does not describe the chunks, stops that reader too. This reader
is the fallback then: the bag (format 2.0) is walked from the
start — connection records, chunks (uncompressed, bz2 or lz4) and the message records inside
them. The complete records of a chunk the file ends inside are kept; a chunk whose data does
not decompress is skipped and reading goes on after it. The index is not needed; when it is there,
its connection records are taken first (a chunk whose connections were defined in a lost chunk is
still read) and its chunk info records give the recording's span. :attr:`Recording.read_error` says where reading stopped
and what was skipped.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from tfrec.errors import ReadError, one_line
from tfrec.formats._collect import Collector, ReadOptions, ReadStopped, read_error_line, with_article
from tfrec.formats._compression import MAX_CHUNK_BYTES, decompress, salvage
from tfrec.formats.ros.connection import Connection
from tfrec.formats.ros.encode import ns_from_stamps
from tfrec.formats.ros.types import known_ros1_typestore, topic_deserializer
from tfrec.formats.rosbag1._records import (
    BAG_HEADER_SIZE,
    OP_BAG_HEADER,
    OP_CHUNK,
    OP_CHUNK_INFO,
    OP_CONNECTION,
    ROS1_MAGIC,
)
from tfrec.formats.rosbag1._records import OP_INDEX_DATA as OP_INDEX
from tfrec.formats.rosbag1._records import OP_MESSAGE_DATA as OP_MESSAGE
from tfrec.recording import Recording, TopicStats

__all__ = [
    "COMPRESSIONS",
    "OP_BAG_HEADER",
    "OP_CHUNK",
    "OP_CHUNK_INFO",
    "OP_CONNECTION",
    "OP_INDEX",
    "OP_MESSAGE",
    "ROS1_MAGIC",
    "BagHeader",
    "RecordDamaged",
    "bag_header",
    "connection_of",
    "header_fields",
    "index_connections",
    "read_record",
    "read_rosbag1_records",
    "time_field",
    "uint32_field",
]

_RECORD_NAMES = {2: "message data", 3: "bag header", 4: "index data", 5: "chunk", 6: "chunk info", 7: "connection"}
COMPRESSIONS = ("none", "bz2", "lz4")
"""The chunk compressions of a ROS 1 bag."""


def header_fields(header: bytes | memoryview) -> dict[str, bytes]:
    """A record header's ``name=value`` fields.

    Raises:
        ValueError: a field that runs past the header, or has no ``=``.
    """
    out: dict[str, bytes] = {}
    pos, end = 0, len(header)
    while pos < end:
        if pos + 4 > end:
            raise ValueError("a header field length runs past the header")
        (size,) = struct.unpack_from("<I", header, pos)
        pos += 4
        if pos + size > end:
            raise ValueError("a header field runs past the header")
        name, sep, value = bytes(header[pos : pos + size]).partition(b"=")
        if not sep:
            raise ValueError("a header field without '='")
        out[name.decode("ascii", "replace")] = value
        pos += size
    return out


def uint32_field(fields: dict[str, bytes], name: str) -> int:
    """A record header's uint32 field.

    Raises:
        ValueError: the field is missing or not 4 bytes long.
    """
    value = fields.get(name, b"")
    if len(value) != 4:
        raise ValueError(f"no 4-byte '{name}' field")
    return int(struct.unpack("<I", value)[0])


def time_field(fields: dict[str, bytes], name: str) -> int:
    """A record header's time field, in ns.

    Raises:
        ValueError: the field is missing or not 8 bytes long.
    """
    value = fields.get(name, b"")
    if len(value) != 8:
        raise ValueError(f"no 8-byte '{name}' field")
    sec, nsec = struct.unpack("<II", value)
    return ns_from_stamps(int(sec), int(nsec))


def connection_of(fields: dict[str, bytes], info: dict[str, bytes]) -> Connection:
    """A connection record as a :class:`~tfrec.formats.ros.connection.Connection` (its topic as
    recorded, not yet resolved), from its header ``fields`` and its data's fields ``info``.

    Raises:
        ValueError: a connection without a message type.
    """
    from rosbags.typesys.msg import normalize_msgtype

    topic = fields.get("topic", info.get("topic", b"")).decode("utf-8", "replace")
    if "type" not in info:
        raise ValueError("a connection without a message type")
    msgdef = info.get("message_definition", b"").decode("utf-8", "replace")
    return Connection(
        topic=topic, msgtype=normalize_msgtype(info["type"].decode("utf-8", "replace")), encoding="ros1",
        definition=msgdef, definition_encoding="ros1msg" if msgdef else "",
        latched=info.get("latching", b"0") not in (b"", b"0"),
        type_hash=info.get("md5sum", b"").decode("ascii", "replace"),
        callerid=info.get("callerid", b"").decode("utf-8", "replace"),
    )


class RecordDamaged(Exception):
    """A record that cannot be read (:func:`read_record`): a walk stops there."""


def read_record(stream: IO[bytes], size: int, *, cut_ok: bool = False) -> tuple[dict[str, bytes], int, int]:
    """The record at the stream's position: its header fields, where its data begins and its
    length; the stream is left at its data.

    Raises:
        RecordDamaged: a record whose header runs past the end of the file or is damaged, or (unless
            ``cut_ok``) whose data does.
    """
    at = stream.tell()
    raw = stream.read(4)
    if len(raw) < 4:
        raise RecordDamaged("the file ends inside a record header")
    (header_len,) = struct.unpack("<I", raw)
    if at + 8 + header_len > size:
        raise RecordDamaged("the file ends inside a record header")
    try:
        fields = header_fields(stream.read(header_len))
    except ValueError as err:
        raise RecordDamaged(f"a damaged record header ({err})") from err
    (data_len,) = struct.unpack("<I", stream.read(4))
    data_pos = at + 8 + header_len
    if data_pos + data_len > size and not cut_ok:
        raise RecordDamaged("the file ends inside a record")
    return fields, data_pos, data_len



@dataclass(frozen=True, slots=True)
class BagHeader:
    """A bag's header record as far as it is readable (:func:`bag_header`).

    Attributes:
        fields: its header fields (``index_pos``, ``conn_count``, ``chunk_count``); empty when damaged.
        body_start: where the records after it begin.
        problem: what is damaged in it, or ``""``.
    """

    fields: dict[str, bytes]
    body_start: int
    problem: str = ""


_FIRST_RECORD = (len(ROS1_MAGIC) + 8 + BAG_HEADER_SIZE, len(ROS1_MAGIC) + BAG_HEADER_SIZE)
"""Where the records after the bag header begin when its length cannot be trusted: as rosbag writes it (its
fields and padding 4096 bytes long), or 8 bytes earlier, as rosbags (and tfrec before issue 22) wrote it."""
_BODY_OPS = (OP_CHUNK, OP_CONNECTION, OP_INDEX, OP_CHUNK_INFO)


def bag_header(stream: IO[bytes], size: int) -> BagHeader | None:
    """The bag header record after the magic (the stream's position). Its padding is nothing to read: a
    damaged padding length, or a damaged header whose records still begin where rosbag (or rosbags) puts them,
    is a :attr:`BagHeader.problem`, and reading goes on there, as rosbags reads such a bag through its index.

    Returns:
        The header, or None when it is damaged and no record begins where one would.
    """
    try:
        fields, data_pos, data_len = read_record(stream, size, cut_ok=True)
        if fields.get("op") != bytes([OP_BAG_HEADER]):
            raise RecordDamaged("no bag header record")
    except RecordDamaged as err:
        reason = str(err).removeprefix("a damaged record header (").removesuffix(")") if "(" in str(err) else str(err)
        fields, body, problem = {}, None, f"a damaged bag header record ({reason})"
    else:
        body = data_pos + data_len if data_pos + data_len <= size else None
        problem = "" if body is not None else f"a damaged bag header record (its padding is {data_len:,} bytes long)"
        if body is not None and _record_at(stream, body, size):
            return BagHeader(fields, body)
    for start in _FIRST_RECORD:
        if start != body and _record_at(stream, start, size):
            return BagHeader(fields, start, problem or f"a damaged bag header record (its padding is "
                                                       f"{data_len:,} bytes long)")
    return None if body is None else BagHeader(fields, body)  # what follows it is damaged: its reader says so


def _record_at(stream: IO[bytes], pos: int, size: int) -> bool:
    """Whether a record a bag holds after its header (a chunk, a connection, the index) begins at ``pos``,
    or ``pos`` is the end of the file (a bag without records)."""
    if pos == size:
        return True
    stream.seek(pos)
    try:
        fields, _, _ = read_record(stream, size, cut_ok=True)
    except RecordDamaged:
        return False
    finally:
        stream.seek(pos)
    op = fields.get("op", b"")
    return len(op) == 1 and op[0] in _BODY_OPS


def index_connections(stream: IO[bytes], header: dict[str, bytes], body_start: int,
                      size: int) -> tuple[int | None, list[tuple[dict[str, bytes], bytes]]]:
    """The connection records of a bag's index section, read before its chunks so that every chunk's
    connections are known even when the chunk that defined one is lost: (where the index begins — the
    chunks end there —, [(header fields, data)]); (None, []) for a bag without an index (a recorder stopped
    before writing it). As far as they are readable: a damaged one ends the list. The stream's position is
    left anywhere.

    Args:
        header: the bag header record's fields (``index_pos``, ``conn_count``).
        body_start: where the records after the bag header begin.
    """
    try:
        index_pos = int(struct.unpack("<Q", header["index_pos"])[0])
        count = uint32_field(header, "conn_count")
    except (KeyError, struct.error, ValueError):
        return None, []
    if index_pos == 0 or not body_start <= index_pos <= size:
        return None, []
    stream.seek(index_pos)
    connections: list[tuple[dict[str, bytes], bytes]] = []
    try:
        for _ in range(count):
            fields, _, data_len = read_record(stream, size)
            if fields.get("op") != bytes([OP_CONNECTION]):
                break
            connections.append((fields, stream.read(data_len)))
    except (RecordDamaged, ValueError):
        pass  # the connections are taken from the chunks then
    return index_pos, connections


class _Connection(TopicStats):
    """A connection: its topic, whether its messages are decoded, and those
    taken (log time, raw message); its count with durability ``latched`` for a latching topic."""

    __slots__ = ("decoded", "messages", "topic")

    def __init__(self, topic: str, msgtype: str, decoded: bool, latched: bool) -> None:
        super().__init__(msgtype, "latched" if latched else None)
        self.topic = topic
        self.decoded = decoded
        self.messages: list[tuple[int, bytes]] = []


class _Ros1Reader:
    """Sequential ROS 1 bag reading: the records of the file, then those inside each chunk."""

    def __init__(self, stream: IO[bytes], collector: Collector, size: int) -> None:
        self.stream = stream
        self.collector = collector
        self.size = size
        self.offset = 0
        self.connections: dict[int, _Connection] = {}
        self.compressions: set[str] = set()
        self.damaged: list[tuple[int, str]] = []  # (byte, problem) of skipped chunks
        self.indexed = False  # the index section's chunk info records were reached
        self.span: tuple[int, int] | None = None  # from the chunk info records

    @property
    def messages(self) -> int:
        return sum(connection.count for connection in self.connections.values())

    def _read(self, size: int) -> bytes:
        data = self.stream.read(size)
        self.offset += len(data)
        return data

    def run(self) -> None:
        """Read records up to the end of the file.

        Raises:
            ReadStopped: the file ends inside a record, or a record is damaged.
        """
        self._read(len(ROS1_MAGIC))
        header = bag_header(self.stream, self.size)
        if header is not None and header.problem:  # read past it, from where its records begin
            self.stream.seek(header.body_start)
            self.offset = header.body_start
            if header.fields:
                self._index_connections(header.fields)
        else:
            self.stream.seek(self.offset)  # an intact header is read as any record (or the damage said below)
        while True:
            start = self.offset
            raw = self._read(4)
            if not raw:
                if not self.indexed:
                    raise ReadStopped(start, "the file ends without an index")
                return
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
            what = _RECORD_NAMES.get(op, f"op 0x{op:02x}")
            (data_len,) = struct.unpack("<I", self._read(4))
            if self.offset + data_len > self.size:
                if op == OP_CHUNK:
                    recovered = self._chunk(fields, self._read(data_len), start, cut=True)
                    reason = f"the file ends inside a chunk record (recovered {recovered:,} messages of it)"
                    raise ReadStopped(self.size, reason)
                raise ReadStopped(start, f"the file ends inside {with_article(what)} record")
            if op == OP_CHUNK:
                self._chunk(fields, self._read(data_len), start, cut=False)
                continue
            if op not in _RECORD_NAMES:
                raise ReadStopped(start, f"a record with unknown op 0x{op:02x}")
            data = self._read(data_len)
            if op == OP_BAG_HEADER:
                self._index_connections(fields)
                continue
            try:
                self._record(op, fields, data)
            except ValueError as err:
                raise ReadStopped(start, f"a damaged {what} record ({err})") from err

    def _index_connections(self, header: dict[str, bytes]) -> None:
        """Take the index section's connection records before the chunks (:func:`index_connections`): a
        chunk whose connection was defined in a lost chunk is still read."""
        _, connections = index_connections(self.stream, header, self.offset, self.size)
        self.stream.seek(self.offset)
        for fields, data in connections:
            try:
                self._record(OP_CONNECTION, fields, data)
            except ValueError:
                return  # a damaged one: the rest come from the chunks

    def _record(self, op: int, fields: dict[str, bytes], data: bytes | memoryview) -> None:
        """One record outside or inside a chunk.

        Raises:
            ValueError: a damaged record, or a message on an unknown connection.
        """
        if op == OP_MESSAGE:
            connection = self.connections.get(uint32_field(fields, "conn"))
            if connection is None:
                raise ValueError(f"a message on unknown connection {uint32_field(fields, 'conn')}")
            time_ns = time_field(fields, "time")
            connection.add(time_ns)
            if connection.decoded:
                connection.messages.append((time_ns, bytes(data)))
        elif op == OP_CONNECTION:
            conn = uint32_field(fields, "conn")
            if conn not in self.connections:
                self._connection(conn, fields, header_fields(data))
        elif op == OP_CHUNK_INFO:
            self.indexed = True
            count = uint32_field(fields, "count")
            if count:
                start, end = time_field(fields, "start_time"), time_field(fields, "end_time")
                self.span = (start, end) if self.span is None else (min(self.span[0], start), max(self.span[1], end))

    def _connection(self, conn: int, fields: dict[str, bytes], info: dict[str, bytes]) -> None:
        found = connection_of(fields, info)
        topic = self.collector.resolve(found.topic)
        decoded = self.collector.decodes(topic, found.msgtype, definition=found.definition, type_hash=found.type_hash)
        self.connections[conn] = _Connection(topic, found.msgtype, decoded, found.latched)

    def _chunk(self, fields: dict[str, bytes], data: bytes, start: int, *, cut: bool) -> int:
        """A chunk record at byte ``start``; returns the messages taken from it."""
        before = self.messages
        try:
            compression = fields["compression"].decode("ascii")
            size = uint32_field(fields, "size")
        except (KeyError, UnicodeDecodeError, ValueError):
            if not cut:
                self.damaged.append((start, "its header is damaged"))
            return 0
        self.compressions.add(compression)
        if cut:
            self._chunk_records(salvage(compression, data, limit=min(size, MAX_CHUNK_BYTES), supported=COMPRESSIONS))
            return self.messages - before
        try:
            records = decompress(compression, data, size, supported=COMPRESSIONS)
        except ValueError as err:
            self.damaged.append((start, str(err)))
            return 0
        problem = self._chunk_records(records)
        if problem is not None:
            self.damaged.append((start, problem))
        return self.messages - before

    def _chunk_records(self, data: bytes | memoryview) -> str | None:
        """Take the records of a chunk's data; returns the problem that stopped them, or None."""
        view = memoryview(data)
        pos, end = 0, len(view)
        while pos < end:
            if pos + 4 > end:
                return "a record runs past the end of the chunk"
            (header_len,) = struct.unpack_from("<I", view, pos)
            if pos + 8 + header_len > end:
                return "a record runs past the end of the chunk"
            (data_len,) = struct.unpack_from("<I", view, pos + 4 + header_len)
            body = pos + 8 + header_len
            if body + data_len > end:
                return "a record runs past the end of the chunk"
            try:
                fields = header_fields(view[pos + 4 : pos + 4 + header_len])
                op = fields["op"][0]
                if op not in (OP_MESSAGE, OP_CONNECTION):
                    return f"{with_article(_RECORD_NAMES.get(op, f'op 0x{op:02x}'))} record inside the chunk"
                self._record(op, fields, view[body : body + data_len])
            except (ValueError, KeyError, IndexError) as err:
                return f"a damaged record ({err})"
            pos = body + data_len
        return None

    def finish(self, where: str) -> None:
        """Decode the messages taken, in log-time order per topic, and count every topic."""
        store = known_ros1_typestore()
        topics: dict[str, list[tuple[int, bytes]]] = {}
        for connection in self.connections.values():
            if connection.count:
                self.collector.count(connection.topic, connection)
            else:
                self.collector.topic(connection.topic, connection.type, connection.durability)
            if connection.decoded and connection.messages:
                if connection.topic not in topics:
                    self.collector.set_deserializer(connection.topic, topic_deserializer(
                        connection.type, where=where, topic=connection.topic, ros1=True, store=store))
                topics.setdefault(connection.topic, []).extend(connection.messages)
        for topic, messages in topics.items():
            self.collector.add_in_time_order(topic, messages)

    def damage_summary(self) -> str:
        byte, problem = self.damaged[0]
        if len(self.damaged) == 1:
            return f"a damaged chunk record at byte {byte:,} ({problem}) was skipped"
        return f"{len(self.damaged)} damaged chunk records, the first at byte {byte:,} ({problem}), were skipped"


def read_rosbag1_records(path: Path, options: ReadOptions, *, refused: str) -> Recording:
    """Read a ROS 1 bag record by record, as far as it is readable.

    Args:
        path: the bag.
        options: what to decode.
        refused: why its index could not be used, for the error when nothing is readable either.

    Raises:
        ReadError: the file cannot be opened, or no connection record is readable.
    """
    where = os.fspath(path)
    recording = Recording(path=where, format="rosbag1")
    collector = Collector(recording, options, ros1=True)
    try:
        with open(path, "rb") as stream:
            size = os.fstat(stream.fileno()).st_size
            reader = _Ros1Reader(stream, collector, size)
            stop: ReadStopped | None = None
            try:
                reader.run()
            except ReadStopped as err:
                stop = err
    except OSError as err:
        raise ReadError(f"{where}: cannot read: {err.strerror or err}") from err
    if not reader.connections:
        where_stopped = f"; reading stopped at byte {stop.offset:,}: {stop.reason}" if stop is not None else ""
        raise ReadError(f"{where}: cannot read ROS 1 bag: {one_line(refused)}{where_stopped}")
    problems = [reader.damage_summary()] if reader.damaged else []
    if stop is not None:
        problems.append(stop.problem(size))
    if problems:
        recording.read_error = read_error_line(where, problems, reader.messages)
    recording.details = {"compression": ", ".join(sorted(reader.compressions))}
    reader.finish(where)
    collector.finish()
    if problems and reader.span is not None and recording.start_ns is not None and reader.span[0] < recording.start_ns:
        recording.start_ns = reader.span[0]  # from the index: messages before the first one read were lost
    return recording
