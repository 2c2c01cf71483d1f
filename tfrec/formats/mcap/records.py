"""MCAP format facts shared by tfrec's MCAP writer and readers: magic, opcodes, fixed record layouts.

Cheap to import (``struct`` only). See https://mcap.dev/spec.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator

__all__ = [
    "CHUNK_HEAD",
    "COMPRESSIONS",
    "FOOTER",
    "MCAP_MAGIC",
    "MESSAGE",
    "MESSAGE_HEAD_SIZE",
    "OP_ATTACHMENT",
    "OP_ATTACHMENT_INDEX",
    "OP_CHANNEL",
    "OP_CHUNK",
    "OP_CHUNK_INDEX",
    "OP_DATA_END",
    "OP_FOOTER",
    "OP_HEADER",
    "OP_MESSAGE",
    "OP_MESSAGE_INDEX",
    "OP_METADATA",
    "OP_METADATA_INDEX",
    "OP_SCHEMA",
    "OP_STATISTICS",
    "OP_SUMMARY_OFFSET",
    "RECORD",
    "STATISTICS",
    "iter_records",
    "record_name",
]

MCAP_MAGIC = b"\x89MCAP0\r\n"
"""The first and last bytes of an MCAP file."""

OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_ATTACHMENT, OP_ATTACHMENT_INDEX = 0x07, 0x08, 0x09, 0x0A
OP_STATISTICS, OP_METADATA, OP_METADATA_INDEX, OP_SUMMARY_OFFSET, OP_DATA_END = 0x0B, 0x0C, 0x0D, 0x0E, 0x0F

_RECORD_NAMES = {
    OP_HEADER: "header", OP_FOOTER: "footer", OP_SCHEMA: "schema", OP_CHANNEL: "channel", OP_MESSAGE: "message",
    OP_CHUNK: "chunk", OP_MESSAGE_INDEX: "message index", OP_CHUNK_INDEX: "chunk index", OP_ATTACHMENT: "attachment",
    OP_ATTACHMENT_INDEX: "attachment index", OP_STATISTICS: "statistics", OP_METADATA: "metadata",
    OP_METADATA_INDEX: "metadata index", OP_SUMMARY_OFFSET: "summary offset", OP_DATA_END: "data end",
}

RECORD = struct.Struct("<BQ")
"""Every record's prefix: opcode, length of the body that follows."""
MESSAGE = struct.Struct("<HIQ")
"""A Message record's channel id, sequence and log time (the publish time follows, then the data)."""
MESSAGE_HEAD_SIZE = 2 + 4 + 8 + 8
"""Bytes of a Message record's body before its data: channel id, sequence, log time, publish time."""
CHUNK_HEAD = struct.Struct("<QQQII")
"""A Chunk record's message start and end time, uncompressed size and CRC, and compression name length."""
FOOTER = struct.Struct("<BQQQI")
"""The Footer record, prefix included: opcode, length, summary start, summary offset start, summary CRC."""
STATISTICS = struct.Struct("<QHIIIIQQ")
"""A Statistics record's message count, schema … chunk counts, message start and end time."""

COMPRESSIONS = ("", "zstd", "lz4")
"""The chunk compressions the MCAP spec names (``""``: none)."""


def record_name(opcode: int) -> str:
    """``OP_CHUNK`` → ``"chunk"``; an unknown opcode as ``opcode 0x10``."""
    return _RECORD_NAMES.get(opcode, f"opcode 0x{opcode:02x}")


def iter_records(view: memoryview, *, strict: bool = True) -> Iterator[tuple[int, int, int]]:
    """(opcode, position of the body, length of the body) of each record in ``view``: a chunk's
    decompressed records, a summary section, or a whole data section read into memory.

    This is the one walk over MCAP records that the summary, ``tfrec info`` and the fallback
    readers share. tfrec's one reader (:mod:`tfrec.formats.mcap.source`) inlines the same
    loop in its hot path (it takes a message per iteration without a generator), and is tested to
    take exactly the records this yields.

    Args:
        view: the records.
        strict: raise on a record that runs past the end of ``view``; else stop before it.

    Raises:
        ValueError: (``strict``) a record header or body runs past the end.
    """
    pos, end, head = 0, len(view), RECORD.size
    unpack = RECORD.unpack_from
    while pos < end:
        if pos + head > end:
            if strict:
                raise ValueError("a record header runs past the end")
            return
        opcode, length = unpack(view, pos)
        pos += head
        if pos + length > end:
            if strict:
                raise ValueError("a record runs past the end")
            return
        yield opcode, pos, length
        pos += length
