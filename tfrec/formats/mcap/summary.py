"""MCAP records besides messages — header, schemas, channels, chunk headers — and the summary section.

Used by the one reader (:mod:`tfrec.formats.mcap.source`): the records of the data section
that are not messages, and the summary section, which tells a damaged file's schemas, channels and
true start, and an intact file's message counts (its Statistics record), against which the
messages read are checked.

A summary section is only trusted when its CRC holds (:func:`read_summary_section`). The parsers
raise ``struct.error``, ``ValueError`` (``UnicodeDecodeError`` included) or ``KeyError`` on
damaged records.
"""

from __future__ import annotations

import os
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, NamedTuple

from tfrec.formats.mcap.records import (
    CHUNK_HEAD,
    COMPRESSIONS,
    FOOTER,
    MCAP_MAGIC,
    OP_ATTACHMENT_INDEX,
    OP_CHANNEL,
    OP_CHUNK_INDEX,
    OP_FOOTER,
    OP_METADATA,
    OP_METADATA_INDEX,
    OP_SCHEMA,
    OP_STATISTICS,
    RECORD,
    STATISTICS,
    iter_records,
)
from tfrec.formats.ros.connection import Extra

__all__ = [
    "METADATA_LIMIT",
    "ChannelRecord",
    "ChunkHead",
    "ChunkIndex",
    "McapSummary",
    "Statistics",
    "chunk_fields",
    "id_map",
    "listed_extras",
    "metadata_records",
    "parse_channel",
    "parse_header",
    "parse_schema",
    "read_summary",
    "read_summary_section",
    "statistics_of",
    "summary_records",
]

_MAP_ENTRY = struct.Struct("<HQ")  # the uint16 → uint64 maps of Statistics and ChunkIndex
_CHUNK_INDEX = struct.Struct("<QQQQ")  # message start and end time, chunk start offset and length


# -- records ------------------------------------------------------------------------------------


class ChunkHead(NamedTuple):
    """A chunk record's fields; ``records`` may be shorter than ``length`` in a cut file."""

    start: int
    end: int
    compression: str
    size: int
    crc: int
    records: memoryview
    length: int

    def plausible(self) -> bool:
        """Whether the header looks undamaged, so that its message times can be believed."""
        return self.compression in COMPRESSIONS and 0 < self.start <= self.end


def chunk_fields(body: bytes) -> ChunkHead:
    """A chunk record's header fields and its compressed records.

    Raises:
        struct.error, UnicodeDecodeError: a damaged chunk header.
    """
    start, end, size, crc, name_len = CHUNK_HEAD.unpack_from(body, 0)
    pos = CHUNK_HEAD.size
    compression = body[pos : pos + name_len].decode()
    pos += name_len
    (length,) = struct.unpack_from("<Q", body, pos)
    pos += 8
    return ChunkHead(start, end, compression, size, crc, memoryview(body)[pos : pos + length], length)


def parse_header(body: bytes) -> tuple[str, str]:
    """The Header record's profile and library, as far as they are readable (``""`` where not)."""
    profile = library = ""
    try:
        (size,) = struct.unpack_from("<I", body, 0)
        profile = body[4 : 4 + size].decode("utf-8", "replace")
        (library_size,) = struct.unpack_from("<I", body, 4 + size)
        library = body[8 + size : 8 + size + library_size].decode("utf-8", "replace")
    except struct.error:
        pass
    return profile, library


def parse_schema(view: memoryview, pos: int) -> tuple[int, str, str, bytes]:
    """A Schema record's id, name, encoding and data (the body starts at ``view[pos]``).

    Raises:
        struct.error, UnicodeDecodeError: a damaged record.
    """
    schema_id, size = struct.unpack_from("<HI", view, pos)
    at = pos + 6
    name = bytes(view[at : at + size]).decode()
    at += size
    (size,) = struct.unpack_from("<I", view, at)
    encoding = bytes(view[at + 4 : at + 4 + size]).decode()
    at += 4 + size
    (size,) = struct.unpack_from("<I", view, at)
    data = bytes(view[at + 4 : at + 4 + size])
    if len(data) != size:
        raise struct.error("the schema's data runs past the record")
    return schema_id, name, encoding, data


class ChannelRecord(NamedTuple):
    id: int
    schema_id: int
    topic: str
    encoding: str
    metadata: dict[str, str]
    """Empty when missing or damaged."""


def parse_channel(view: memoryview, pos: int, length: int) -> ChannelRecord:
    """A Channel record (the body is ``view[pos : pos + length]``)."""
    channel_id, schema_id, topic_len = struct.unpack_from("<HHI", view, pos)
    at = pos + 8
    topic = bytes(view[at : at + topic_len]).decode()
    at += topic_len
    (enc_len,) = struct.unpack_from("<I", view, at)
    encoding = bytes(view[at + 4 : at + 4 + enc_len]).decode()
    return ChannelRecord(channel_id, schema_id, topic, encoding, _metadata(view, at + 4 + enc_len, pos + length))


def _metadata(view: memoryview, pos: int, end: int) -> dict[str, str]:
    """A channel record's metadata map (from ``pos``); empty when it is missing or damaged."""
    out: dict[str, str] = {}
    try:
        (size,) = struct.unpack_from("<I", view, pos)
        pos += 4
        stop = min(pos + size, end)
        while pos < stop:
            (key_len,) = struct.unpack_from("<I", view, pos)
            key = bytes(view[pos + 4 : pos + 4 + key_len]).decode()
            pos += 4 + key_len
            (value_len,) = struct.unpack_from("<I", view, pos)
            out[key] = bytes(view[pos + 4 : pos + 4 + value_len]).decode()
            pos += 4 + value_len
    except (struct.error, UnicodeDecodeError):
        return {}
    return out


def id_map(view: memoryview, pos: int) -> tuple[dict[int, int], int]:
    """A uint16 → uint64 map at ``pos``, and the position after it."""
    (size,) = struct.unpack_from("<I", view, pos)
    pos += 4
    if size % _MAP_ENTRY.size:
        raise ValueError(f"a map of {size} bytes")
    out = dict(_MAP_ENTRY.iter_unpack(view[pos : pos + size]))
    return out, pos + size


def _record_at(stream: IO[bytes], size: int, offset: int, opcode: int, what: str) -> bytes:
    """The body of the record at byte ``offset``, which must be of ``opcode``.

    Raises:
        ValueError: another record, or one that runs past the end of the file.
    """
    if not 0 <= offset <= size - RECORD.size:
        raise ValueError(f"no {what} at offset {offset}")
    stream.seek(offset)
    found, length = RECORD.unpack(stream.read(RECORD.size))
    if found != opcode or offset + RECORD.size + length > size:
        raise ValueError(f"no {what} at offset {offset}")
    return stream.read(length)


# -- the summary section ------------------------------------------------------------------------


def read_summary_section(stream: IO[bytes], size: int, *, after: int) -> memoryview | None:
    """The summary section of a file of ``size`` bytes, the footer left out; None when there is
    none, when the footer is damaged or lies before byte ``after``, or when the section does not
    hold its CRC. The stream's position is kept."""
    footer_start = size - len(MCAP_MAGIC) - FOOTER.size
    if footer_start < after:
        return None
    here = stream.tell()
    try:
        stream.seek(footer_start)
        footer = stream.read(FOOTER.size + len(MCAP_MAGIC))
        opcode, length, summary_start, _, crc = FOOTER.unpack_from(footer)
        if (footer[FOOTER.size :] != MCAP_MAGIC or opcode != OP_FOOTER or length != FOOTER.size - RECORD.size
                or not after <= summary_start <= footer_start):
            return None
        stream.seek(summary_start)
        section = stream.read(footer_start + FOOTER.size - 4 - summary_start)  # the CRC covers the footer too
        if crc and zlib.crc32(section) != crc:
            return None
        return memoryview(section)[: footer_start - summary_start]
    except struct.error:
        return None
    finally:
        stream.seek(here)


def summary_records(view: memoryview) -> list[tuple[int, int, int]]:
    """The records of a summary section: (opcode, position of the body, length), up to the
    first that runs past its end."""
    return list(iter_records(view, strict=False))


def listed_extras(stream: IO[bytes], size: int, path: Path) -> list[Extra]:
    """The attachments and metadata records an MCAP file's summary indexes, its ``rosbag2`` metadata
    record left out; none without a summary."""
    view = read_summary_section(stream, size, after=len(MCAP_MAGIC))
    if view is None:
        return []
    found: list[Extra] = []
    for opcode, pos, _ in summary_records(view):
        try:
            if opcode == OP_ATTACHMENT_INDEX:
                offset, length, log_time, create_time, data_size = struct.unpack_from("<QQQQQ", view, pos)
                name, at = _text(view, pos + 40)
                media_type, _ = _text(view, at)
                found.append(Extra("attachment", name, path, offset, length, log_time, create_time, media_type,
                                   data_size))
            elif opcode == OP_METADATA_INDEX:
                offset, length = struct.unpack_from("<QQ", view, pos)
                name, _ = _text(view, pos + 16)
                if name != "rosbag2":
                    found.append(Extra("metadata", name, path, offset, length))
        except struct.error:
            break
    return found


METADATA_LIMIT = 1 << 20
"""Bytes of a metadata record :func:`metadata_records` reads at most (tfrec's recipe takes about one KiB)."""


def metadata_records(path: Path) -> dict[str, dict[str, str]]:
    """The metadata records an MCAP file's summary indexes (its ``rosbag2`` one left out): name → map;
    none without a summary, a damaged record or one over :data:`METADATA_LIMIT` bytes left out."""
    found: dict[str, dict[str, str]] = {}
    with open(path, "rb") as stream:
        size = os.fstat(stream.fileno()).st_size
        for extra in listed_extras(stream, size, path):
            if extra.kind != "metadata" or extra.length > METADATA_LIMIT:
                continue
            try:
                body = memoryview(_record_at(stream, size, extra.offset, OP_METADATA, "metadata record"))
                _, at = _text(body, 0)
            except (ValueError, struct.error):
                continue
            found.setdefault(extra.name, _metadata(body, at, len(body)))
    return found


def _text(view: memoryview, at: int) -> tuple[str, int]:
    (length,) = struct.unpack_from("<I", view, at)
    return bytes(view[at + 4 : at + 4 + length]).decode("utf-8", "replace"), at + 4 + length


class Statistics(NamedTuple):
    message_count: int
    start: int
    """Log time of the first message."""
    end: int
    channel_counts: dict[int, int]
    """Channel id → messages."""


class ChunkIndex(NamedTuple):
    start: int
    """Log time of the chunk's first message."""
    end: int
    offset: int
    """Byte of the chunk record."""
    message_indexes: dict[int, int]
    """Channel id → byte of the channel's message index record for the chunk; empty: not indexed."""
    compression: str


@dataclass
class McapSummary:
    """What an MCAP file's summary section says."""

    schemas: dict[int, str] = field(default_factory=dict)
    """Schema id → name (the message type)."""
    channels: dict[int, ChannelRecord] = field(default_factory=dict)
    statistics: Statistics | None = None
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)


def statistics_of(view: memoryview, records: list[tuple[int, int, int]]) -> Statistics | None:
    """A summary section's Statistics record (see :func:`summary_records`), or None.

    Raises:
        struct.error, ValueError: a damaged record.
    """
    for opcode, pos, length in records:
        if opcode == OP_STATISTICS and length >= STATISTICS.size:
            count, *_, start, end = STATISTICS.unpack_from(view, pos)
            counts, _ = id_map(view, pos + STATISTICS.size)
            return Statistics(count, start, end, counts)
    return None


def read_summary(stream: IO[bytes], size: int) -> McapSummary | None:
    """The summary section of an MCAP file (see :func:`read_summary_section`), or None.

    Raises:
        struct.error, ValueError: a damaged record in a summary that holds its CRC (or has none).
    """
    view = read_summary_section(stream, size, after=len(MCAP_MAGIC))
    if view is None:
        return None
    summary = McapSummary()
    for opcode, pos, length in summary_records(view):
        if opcode == OP_SCHEMA:
            schema_id, name, _, _ = parse_schema(view, pos)
            summary.schemas[schema_id] = name
        elif opcode == OP_CHANNEL:
            channel = parse_channel(view, pos, length)
            summary.channels[channel.id] = channel
        elif opcode == OP_STATISTICS:
            count, *_, start, end = STATISTICS.unpack_from(view, pos)
            counts, _ = id_map(view, pos + STATISTICS.size)
            summary.statistics = Statistics(count, start, end, counts)
        elif opcode == OP_CHUNK_INDEX:
            start, end, offset, _ = _CHUNK_INDEX.unpack_from(view, pos)
            indexes, at = id_map(view, pos + _CHUNK_INDEX.size)
            (name_len,) = struct.unpack_from("<I", view, at + 8)  # after the message index length
            compression = bytes(view[at + 12 : at + 12 + name_len]).decode()
            summary.chunk_indexes.append(ChunkIndex(start, end, offset, indexes, compression))
    return summary
