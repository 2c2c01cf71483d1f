"""The records of a ROS 1 bag (format 2.0): written as bytes — headers, the bag header, message heads, chunk
compression — and read back — header fields, the bag header (damaged ones too), connection records.

A record is a header — its length, then ``name=value`` fields, each after its own length — then
the data's length and the data. Fields are written sorted by name, as rosbag's C++ writer (a
``std::map``) writes them; readers accept any order.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S
from tfrec.formats.ros.connection import Connection
from tfrec.formats.ros.encode import ns_from_stamps

__all__ = [
    "BAG_HEADER_SIZE",
    "COMPRESSIONS",
    "CONN_AT",
    "LENGTH_AT",
    "MESSAGE_HEAD",
    "MESSAGE_HEAD_SIZE",
    "OP_BAG_HEADER",
    "OP_CHUNK",
    "OP_CHUNK_INFO",
    "OP_CONNECTION",
    "OP_INDEX_DATA",
    "OP_MESSAGE_DATA",
    "RECORD_NAMES",
    "ROS1_MAGIC",
    "TIME_AT",
    "BagHeader",
    "ChunkInfo",
    "PendingChunk",
    "RecordDamaged",
    "bag_header",
    "compressor",
    "connection_of",
    "header",
    "header_fields",
    "index_connections",
    "index_data_records",
    "message_head",
    "read_bag_header",
    "read_record",
    "record",
    "ros1_type_name",
    "ros2_msgtype",
    "time_bytes",
    "time_field",
    "u32",
    "uint32_field",
]

ROS1_MAGIC = b"#ROSBAG V2.0\n"
BAG_HEADER_SIZE = 4096
"""The bag header record's header fields plus its padding, in bytes, as rosbag writes it (the record is 8
bytes longer: its two length fields). ``rosbag reindex`` and ``rosbag`` in append mode rewrite the header in
place at this size, so a header record of any other size would overwrite the first chunk's start."""
OP_MESSAGE_DATA, OP_BAG_HEADER, OP_INDEX_DATA, OP_CHUNK, OP_CHUNK_INFO, OP_CONNECTION = 2, 3, 4, 5, 6, 7
COMPRESSIONS = ("none", "bz2", "lz4")
"""The chunk compressions of a ROS 1 bag."""

LZ4_BLOCK = 6
"""LZ4 frame block size id of rosbag's lz4 chunks (1 MiB blocks)."""


def u32(value: int) -> bytes:
    return struct.pack("<I", value)


def time_bytes(time_ns: int) -> bytes:
    """A ROS 1 ``time`` (uint32 secs, uint32 nsecs) of nanoseconds since the epoch."""
    secs, nsecs = divmod(time_ns, NS_PER_S)
    return struct.pack("<II", secs, nsecs)


def _field(name: str, value: bytes) -> bytes:
    entry = name.encode() + b"=" + value
    return u32(len(entry)) + entry


def header(fields: dict[str, bytes]) -> bytes:
    """A record header: its length, then its ``name=value`` fields sorted by name."""
    body = b"".join(_field(name, value) for name, value in sorted(fields.items()))
    return u32(len(body)) + body


def record(fields: dict[str, bytes], data: bytes) -> bytes:
    """A whole record: header, data length, data."""
    return header(fields) + u32(len(data)) + data


def bag_header(index_pos: int, conn_count: int, chunk_count: int) -> bytes:
    """The bag header record, its fields and their padding (spaces) :data:`BAG_HEADER_SIZE` bytes long, as
    rosbag's ``_write_file_header_record`` and C++ ``Bag::writeFileHeaderRecord`` pad it: the first chunk
    starts at byte 13 + 4 + 4096 + 4 = 4117."""
    head = header({
        "chunk_count": u32(chunk_count), "conn_count": u32(conn_count),
        "index_pos": struct.pack("<Q", index_pos), "op": bytes([OP_BAG_HEADER]),
    })
    padding = BAG_HEADER_SIZE - (len(head) - 4)
    return head + u32(padding) + b" " * padding


MESSAGE_HEAD = header({"conn": bytes(4), "op": bytes([OP_MESSAGE_DATA]), "time": bytes(8)}) + bytes(4)
"""A message data record before the message: header (conn, op, time), then the data length."""
MESSAGE_HEAD_SIZE = len(MESSAGE_HEAD)
"""46 bytes."""
CONN_AT = 4 + len(_field("conn", bytes(4))) - 4
"""Where the connection id sits in :data:`MESSAGE_HEAD`."""
TIME_AT = MESSAGE_HEAD_SIZE - 4 - 8
"""Where the time sits (the header's last field)."""
LENGTH_AT = MESSAGE_HEAD_SIZE - 4
"""Where the data length sits."""
_HEAD = struct.Struct(f"<{CONN_AT}sI{TIME_AT - CONN_AT - 4}sIII")
_HEAD_START, _HEAD_MIDDLE = MESSAGE_HEAD[:CONN_AT], MESSAGE_HEAD[CONN_AT + 4 : TIME_AT]


def message_head(conn_id: int, time_ns: int, size: int) -> bytes:
    """:data:`MESSAGE_HEAD` of a message of ``size`` bytes on ``conn_id`` at ``time_ns``."""
    secs, nsecs = divmod(time_ns, NS_PER_S)
    return _HEAD.pack(_HEAD_START, conn_id, _HEAD_MIDDLE, secs, nsecs, size)


def compressor(compression: str) -> Callable[[bytes], bytes]:
    """The chunk compressor of ``"bz2"`` (level 9, as rosbag) or ``"lz4"``: an LZ4 frame as roslz4
    requires it (independent 1 MiB blocks, a content checksum, no content size); else the identity."""
    if compression == "bz2":
        import bz2

        return lambda data: bz2.compress(data, 9)
    if compression == "lz4":
        import lz4.frame

        def compress(data: bytes) -> bytes:
            return bytes(lz4.frame.compress(
                data, block_size=LZ4_BLOCK, block_linked=False, content_checksum=True, store_size=False,
            ))

        return compress
    return bytes


@dataclass(frozen=True, slots=True)
class ChunkInfo:
    """Where a chunk starts, the times of its first and last messages, and its messages per
    connection as uint32 (k, 2) rows (connection id, count): a ChunkInfo record's content."""

    pos: int
    start_ns: int
    end_ns: int
    counts: NDArray[np.uint32]


@dataclass(frozen=True, slots=True)
class PendingChunk:
    """A chunk on its way to the file: its uncompressed size, its IndexData records, its
    messages per connection and its time span."""

    size: int
    index_records: bytes
    counts: NDArray[np.uint32]
    start_ns: int
    end_ns: int


def index_data_records(index: dict[int, tuple[Any, Any]]) -> tuple[bytes, NDArray[np.uint32]]:
    """A chunk's IndexData records, by connection id with times sorted, and its messages per
    connection as uint32 (k, 2) rows (connection id, count).

    Args:
        index: connection id → (int64 times buffer, int64 offsets buffer) of its messages in the chunk.
    """
    from tfrec.formats.ros.encode import ros1_times

    counts = np.empty((len(index), 2), dtype="<u4")
    records = []
    for row, conn_id in enumerate(sorted(index)):
        times_buf, offsets_buf = index[conn_id]
        times = np.frombuffer(times_buf, dtype=np.int64)
        offsets = np.frombuffer(offsets_buf, dtype=np.int64)
        if len(times) > 1 and bool(np.any(np.diff(times) < 0)):
            order = np.argsort(times, kind="stable")
            times, offsets = times[order], offsets[order]
        entries = np.empty((len(times), 3), dtype="<u4")
        entries[:, :2] = ros1_times(times).view("<u4")
        entries[:, 2] = offsets
        records.append(record(
            {"conn": u32(conn_id), "count": u32(len(times)), "op": bytes([OP_INDEX_DATA]), "ver": u32(1)},
            entries.tobytes(),
        ))
        counts[row] = conn_id, len(times)
    return b"".join(records), counts


def ros1_type_name(msgtype: str) -> str:
    """``pkg/Type``, as ROS 1 names types, of ``pkg/Type`` or ``pkg/msg/Type``."""
    return msgtype.replace("/msg/", "/", 1)


# -- reading ------------------------------------------------------------------------------------------


RECORD_NAMES = {2: "message data", 3: "bag header", 4: "index data", 5: "chunk", 6: "chunk info", 7: "connection"}


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


def ros2_msgtype(name: str) -> str:
    """A ROS 1 type name in ROS 2's form, ``pkg/msg/Type``, as rosbags' ``normalize_msgtype`` gives it (tests
    compare): the rule is written out here, as importing rosbags' type system for it (~15 ms) took longer than
    ``tfrec info`` of a small bag spends reading it."""
    path = PurePosixPath(name)
    if path.parent.name not in ("msg", "action"):
        path = path.parent / "msg" / path.name
    return str(path)


def connection_of(fields: dict[str, bytes], info: dict[str, bytes]) -> Connection:
    """A connection record as a :class:`~tfrec.formats.ros.connection.Connection` (its topic as
    recorded, not yet resolved), from its header ``fields`` and its data's fields ``info``.

    Raises:
        ValueError: a connection without a message type.
    """
    topic = fields.get("topic", info.get("topic", b"")).decode("utf-8", "replace")
    if "type" not in info:
        raise ValueError("a connection without a message type")
    msgdef = info.get("message_definition", b"").decode("utf-8", "replace")
    return Connection(
        topic=topic, msgtype=ros2_msgtype(info["type"].decode("utf-8", "replace")), encoding="ros1",
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
    """A bag's header record as far as it is readable (:func:`read_bag_header`).

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
_BODY_OPS = (OP_CHUNK, OP_CONNECTION, OP_INDEX_DATA, OP_CHUNK_INFO)


def read_bag_header(stream: IO[bytes], size: int) -> BagHeader | None:
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
