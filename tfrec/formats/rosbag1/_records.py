"""The records of a ROS 1 bag (format 2.0) as bytes: headers, the bag header, message heads, chunk compression.

A record is a header — its length, then ``name=value`` fields, each after its own length — then
the data's length and the data. Fields are written sorted by name, as rosbag's C++ writer (a
``std::map``) writes them; readers accept any order.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S

__all__ = [
    "BAG_HEADER_SIZE",
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
    "ROS1_MAGIC",
    "TIME_AT",
    "ChunkInfo",
    "PendingChunk",
    "bag_header",
    "compressor",
    "header",
    "index_data_records",
    "message_head",
    "record",
    "ros1_type_name",
    "time_bytes",
    "u32",
]

ROS1_MAGIC = b"#ROSBAG V2.0\n"
BAG_HEADER_SIZE = 4096
"""The bag header record's header fields plus its padding, in bytes, as rosbag writes it (the record is 8
bytes longer: its two length fields). ``rosbag reindex`` and ``rosbag`` in append mode rewrite the header in
place at this size, so a header record of any other size would overwrite the first chunk's start."""
OP_MESSAGE_DATA, OP_BAG_HEADER, OP_INDEX_DATA, OP_CHUNK, OP_CHUNK_INFO, OP_CONNECTION = 2, 3, 4, 5, 6, 7

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
