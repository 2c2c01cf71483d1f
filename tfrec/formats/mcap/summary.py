"""MCAP records besides messages — header, schemas, channels, chunk headers — and the summary section.

Shared by the sequential reader (:mod:`tfrec.formats.mcap.reader`) and ``tfrec info``
(:mod:`tfrec.info`), which summarizes an intact file from its summary section: the
Statistics record (message counts), the chunk indexes (compressions) and the message index
records they point to (first and last log time of each channel), reading only the few
messages it decodes (:func:`iter_messages`) — a one-hour file is summarized without
decompressing it.

A summary section is only trusted when its CRC holds (:func:`read_summary_section`); the
chunks read through the chunk indexes are not checked against their CRCs. The parsers raise
``struct.error``, ``ValueError`` (``UnicodeDecodeError`` included) or ``KeyError`` on damaged records.
"""

from __future__ import annotations

import heapq
import os
import struct
import zlib
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from typing import IO, NamedTuple

import numpy as np

from tfrec.formats._compression import decompress
from tfrec.formats.mcap.records import (
    CHUNK_HEAD,
    COMPRESSIONS,
    FOOTER,
    MCAP_MAGIC,
    MESSAGE,
    MESSAGE_HEAD_SIZE,
    OP_CHANNEL,
    OP_CHUNK,
    OP_CHUNK_INDEX,
    OP_DATA_END,
    OP_FOOTER,
    OP_HEADER,
    OP_MESSAGE,
    OP_MESSAGE_INDEX,
    OP_SCHEMA,
    OP_STATISTICS,
    RECORD,
    STATISTICS,
    iter_records,
)

__all__ = [
    "ChannelRecord",
    "ChunkHead",
    "ChunkIndex",
    "McapSummary",
    "Statistics",
    "channel_spans",
    "chunk_fields",
    "iter_messages",
    "parse_channel",
    "parse_header",
    "parse_schema",
    "read_header",
    "read_summary",
    "read_summary_section",
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


def parse_schema(view: memoryview, pos: int) -> tuple[int, str]:
    """A Schema record's id and name (the body starts at ``view[pos]``)."""
    schema_id, name_len = struct.unpack_from("<HI", view, pos)
    return schema_id, bytes(view[pos + 6 : pos + 6 + name_len]).decode()


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


def _id_map(view: memoryview, pos: int) -> tuple[dict[int, int], int]:
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


def read_header(stream: IO[bytes], size: int) -> tuple[str, str]:
    """The profile and library of the Header record that follows the magic.

    Raises:
        ValueError: the file does not start with the magic and a Header record.
    """
    stream.seek(0)
    if stream.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
        raise ValueError("no MCAP magic")
    return parse_header(_record_at(stream, size, len(MCAP_MAGIC), OP_HEADER, "header"))


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
            schema_id, name = parse_schema(view, pos)
            summary.schemas[schema_id] = name
        elif opcode == OP_CHANNEL:
            channel = parse_channel(view, pos, length)
            summary.channels[channel.id] = channel
        elif opcode == OP_STATISTICS:
            count, *_, start, end = STATISTICS.unpack_from(view, pos)
            counts, _ = _id_map(view, pos + STATISTICS.size)
            summary.statistics = Statistics(count, start, end, counts)
        elif opcode == OP_CHUNK_INDEX:
            start, end, offset, _ = _CHUNK_INDEX.unpack_from(view, pos)
            indexes, at = _id_map(view, pos + _CHUNK_INDEX.size)
            (name_len,) = struct.unpack_from("<I", view, at + 8)  # after the message index length
            compression = bytes(view[at + 12 : at + 12 + name_len]).decode()
            summary.chunk_indexes.append(ChunkIndex(start, end, offset, indexes, compression))
    return summary


def channel_spans(stream: IO[bytes], size: int, summary: McapSummary) -> Iterator[tuple[int | None, int, int]]:
    """(channel id, first log time, last log time) of each channel in each chunk, from the
    message index records; channel None for a chunk without them (its span stands for each channel).

    Raises:
        ValueError: a chunk index points to no message index record of a known channel.
    """
    for chunk in summary.chunk_indexes:
        if not chunk.message_indexes:
            yield None, chunk.start, chunk.end
            continue
        for channel_id, offset in chunk.message_indexes.items():
            if channel_id not in summary.channels:
                raise ValueError(f"no message index for channel {channel_id} at offset {offset}")
            body = _record_at(stream, size, offset, OP_MESSAGE_INDEX, f"message index for channel {channel_id}")
            _, length = struct.unpack_from("<HI", body)
            pairs = np.frombuffer(body, dtype="<u8", count=length // 8, offset=6).reshape(-1, 2)
            if len(pairs):
                yield channel_id, int(pairs[:, 0].min()), int(pairs[:, 0].max())


# -- messages through the summary ---------------------------------------------------------------


def iter_messages(
    stream: IO[bytes], size: int, summary: McapSummary, topics: Collection[str]
) -> Iterator[tuple[int, int, bytes]]:
    """(channel id, log time, data) of the messages on ``topics``, in log time order (ties in
    file order), as mcap's reader gives them: the chunks are read through the chunk indexes,
    each when its first log time comes up, so taking the first few messages reads few chunks.
    A file without chunk indexes is read from the start.

    Raises:
        struct.error, ValueError, KeyError: a damaged chunk, or a message on a channel the
            summary does not list.
    """
    if not summary.chunk_indexes:
        yield from sorted(_sequential_messages(stream, size, topics), key=lambda message: message[1])
        return
    channels = summary.channels
    wanted = {channel_id for channel_id, channel in channels.items() if channel.topic in topics}
    queue: list[tuple[int, int, int, int, ChunkIndex | tuple[int, int, bytes]]] = []
    for chunk in summary.chunk_indexes:
        if not chunk.message_indexes or any(channels[channel_id].topic in topics for channel_id in chunk.message_indexes):
            queue.append((chunk.start, chunk.offset, -1, len(queue), chunk))
    heapq.heapify(queue)
    pushed = len(queue)
    while queue:
        *_, item = heapq.heappop(queue)
        if not isinstance(item, ChunkIndex):
            yield item
            continue
        head = chunk_fields(_record_at(stream, size, item.offset, OP_CHUNK, "chunk"))
        if len(head.records) != head.length:
            raise ValueError("a chunk's records run past its end")
        records = decompress(head.compression, head.records, head.size, supported=COMPRESSIONS)
        for index, (channel_id, log_time, data) in enumerate(_chunk_messages(memoryview(records))):
            if channel_id not in channels:
                raise ValueError(f"a message on unknown channel {channel_id}")
            if channel_id in wanted:
                heapq.heappush(queue, (log_time, item.offset, index, pushed, (channel_id, log_time, bytes(data))))
                pushed += 1


def _chunk_messages(view: memoryview) -> Iterator[tuple[int, int, memoryview]]:
    """(channel id, log time, data) of the Message records of a chunk's records."""
    for opcode, pos, length in iter_records(view):
        if opcode == OP_MESSAGE:
            channel_id, _, log_time = MESSAGE.unpack_from(view, pos)
            yield channel_id, log_time, view[pos + MESSAGE_HEAD_SIZE : pos + length]


def _sequential_messages(stream: IO[bytes], size: int, topics: Collection[str]) -> Iterator[tuple[int, int, bytes]]:
    """(channel id, log time, data) of the messages on ``topics``, in file order, from the data section."""
    schemas: set[int] = set()
    channels: dict[int, str] = {}

    def take(opcode: int, view: memoryview, pos: int, length: int) -> Iterator[tuple[int, int, bytes]]:
        if opcode == OP_SCHEMA:
            schemas.add(parse_schema(view, pos)[0])
        elif opcode == OP_CHANNEL:
            channel = parse_channel(view, pos, length)
            if channel.schema_id and channel.schema_id not in schemas:
                raise ValueError(f"no schema record with id {channel.schema_id}")
            channels[channel.id] = channel.topic
        elif opcode == OP_MESSAGE:
            channel_id, _, log_time = MESSAGE.unpack_from(view, pos)
            if channels[channel_id] in topics:
                yield channel_id, log_time, bytes(view[pos + MESSAGE_HEAD_SIZE : pos + length])

    stream.seek(len(MCAP_MAGIC))
    offset = len(MCAP_MAGIC)
    while offset + RECORD.size <= size:
        opcode, length = RECORD.unpack(stream.read(RECORD.size))
        if opcode in (OP_DATA_END, OP_FOOTER):
            return
        if offset + RECORD.size + length > size:
            raise ValueError("a record runs past the end of the file")
        if opcode in (OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK):
            view = memoryview(stream.read(length))
            if opcode != OP_CHUNK:
                yield from take(opcode, view, 0, length)
            else:
                head = chunk_fields(bytes(view))
                records = memoryview(decompress(head.compression, head.records, head.size, supported=COMPRESSIONS))
                for inner, pos, inner_length in iter_records(records):
                    yield from take(inner, records, pos, inner_length)
        else:
            stream.seek(length, os.SEEK_CUR)
        offset += RECORD.size + length
    raise ValueError("the file ends without a footer")
