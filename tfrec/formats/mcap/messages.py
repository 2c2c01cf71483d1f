"""An MCAP file's raw messages, chunk by chunk, for copying them (``tfrec convert``).

:class:`McapMessages` walks the data section once, in the file's order: schemas and channels
become :class:`~tfrec.formats.ros.connection.Connection` s (schema text, offered QoS, type hash),
and each chunk, decompressed, becomes one :class:`~tfrec.formats.ros.connection.MessageBatch`:
its messages found through the chunk's message indexes with numpy (:func:`~tfrec.formats.mcap.index.index_chunk`),
or record by record when it has none. Nothing is decoded. Attachments and metadata records are noted where they
lie (:class:`~tfrec.formats.ros.connection.Extra`), not read: an MCAP output copies them.

A damaged file is read as far as it goes, as :mod:`tfrec.formats.mcap.reader` reads it: a chunk
that does not decompress or fails its CRC is skipped (the summary's channels stand in for any it
held), and a file cut short gives the complete records of its last chunk;
:attr:`~tfrec.formats.ros.connection.MessageSource.problems` says what was lost.
"""

from __future__ import annotations

import os
import struct
import warnings
import zlib
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import ReadError, TfrecWarning
from tfrec.formats._compression import MAX_CHUNK_BYTES, decompress, salvage
from tfrec.formats.mcap.index import index_chunk, read_message_indexes
from tfrec.formats.mcap.records import (
    COMPRESSIONS,
    MCAP_MAGIC,
    MESSAGE_HEAD_SIZE,
    OP_ATTACHMENT,
    OP_CHANNEL,
    OP_CHUNK,
    OP_DATA_END,
    OP_FOOTER,
    OP_HEADER,
    OP_MESSAGE,
    OP_METADATA,
    OP_SCHEMA,
    RECORD,
    record_name,
)
from tfrec.formats.mcap.summary import (
    ChannelRecord,
    chunk_fields,
    parse_channel,
    parse_header,
    parse_schema,
    read_summary_section,
    summary_records,
)
from tfrec.formats.ros.connection import Connection, Extra, MessageBatch, MessageSource, full_type, raw_messages
from tfrec.formats.ros.decode import RawMessages
from tfrec.formats.rosbag2.metadata import qos_durability

__all__ = ["McapMessages"]

_BATCH = 32768
"""Messages outside chunks (an unchunked file) handed over at once, at most."""
_MESSAGE = struct.Struct("<HIQQ")
"""A Message record's channel id, sequence, log time and publish time."""

_EXTRA_HEAD = 4 * 65536 + 32
"""Bytes read of an attachment or metadata record to find its name (and media type): names longer than 64 KiB
do not fit, and such a record is damaged."""


def _string(data: bytes, at: int) -> tuple[str, int]:
    """An MCAP string (uint32 length, UTF-8) at ``data[at]``, and where it ends.

    Raises:
        ValueError: one that runs past ``data``, or is no UTF-8 (UnicodeDecodeError).
    """
    (size,) = struct.unpack_from("<I", data, at)
    if at + 4 + size > len(data):
        raise ValueError("a name runs past the record")
    return data[at + 4 : at + 4 + size].decode("utf-8"), at + 4 + size


_Found = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], RawMessages]
"""Messages found in a chunk: channel ids, log times, publish times, data."""


class _File:
    """One file's schemas, and its channels as connection ids (``lut[channel id]``, -1 when unknown)."""

    def __init__(self) -> None:
        self.schemas: dict[int, tuple[str, str, bytes]] = {}
        self.lut = np.full(65536, -1, dtype=np.int64)


class McapMessages(MessageSource):
    """The raw messages of one MCAP file, or of a rosbag2 bag's MCAP files in order.

    Args:
        files: the files.
        where: the recording, for messages.
        resolve: a recorded topic name → the name it is played under.
        decompress: decompresses each message (a rosbag2 bag compressed message by message).
        fmt: ``mcap``, or ``rosbag2`` for a bag's files.
    """

    def __init__(self, files: Sequence[Path], *, where: str, resolve: Callable[[str], str],
                 decompress: Callable[[bytes], bytes] | None = None, fmt: str = "mcap") -> None:
        super().__init__(where, fmt)
        self.files = list(files)
        self.resolve = resolve
        self.decompress = decompress
        self._file = _File()
        self._summary_taken = False

    def batches(self) -> Iterator[MessageBatch]:
        for path in self.files:
            self._file = _File()
            self._summary_taken = False
            yield from self._batches(path)

    # -- the walk -------------------------------------------------------------------------------

    def _batches(self, path: Path) -> Iterator[MessageBatch]:
        name = os.fspath(path)
        try:
            stream = open(path, "rb")  # noqa: SIM115 - closed below
        except OSError as err:
            raise ReadError(f"{name}: cannot read: {err.strerror or err}") from err
        with stream:
            size = os.fstat(stream.fileno()).st_size
            if stream.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                raise ReadError(f"{name}: not an MCAP file")
            singles: list[tuple[int, int, int, bytes]] = []  # messages outside chunks: channel, log, publish, data
            offset = len(MCAP_MAGIC)
            while True:
                head = stream.read(RECORD.size)
                if len(head) < RECORD.size:
                    self._stop(name, offset, size, "the file ends without a footer" if not head
                               else "the file ends inside a record header")
                    break
                opcode, length = RECORD.unpack(head)
                start, offset = offset, offset + RECORD.size
                if opcode in (OP_FOOTER, OP_DATA_END):
                    break
                if opcode == 0 or 0x10 <= opcode < 0x80:
                    self._stop(name, start, size, f"a damaged record (opcode 0x{opcode:02x})")
                    break
                if offset + length > size:
                    if opcode == OP_CHUNK:
                        yield from self._flush(singles, path, stream)
                        batch, recovered = self._cut_chunk(stream.read(), path, stream)
                        if batch is not None:
                            yield batch
                        self._stop(name, size, size, f"the file ends inside a chunk record (recovered "
                                                     f"{recovered:,} messages of it)")
                    else:
                        self._stop(name, start, size, f"the file ends inside a{'n' if record_name(opcode)[0] in 'aeiou' else ''} "
                                                      f"{record_name(opcode)} record")
                    break
                if opcode == OP_CHUNK:
                    yield from self._flush(singles, path, stream)
                    body = stream.read(length)
                    indexes = read_message_indexes(stream, size)
                    offset = stream.tell()
                    batch = self._chunk(body, indexes, start, path, stream)
                    if batch is not None:
                        yield batch
                    continue
                if opcode in (OP_ATTACHMENT, OP_METADATA):  # kept where they are: copied by the writer
                    try:
                        self._extra(stream, path, opcode, start, length)
                    except (struct.error, ValueError) as err:  # its length is known: the walk goes on after it
                        warnings.warn(f"{name}: a damaged {record_name(opcode)} record at byte {start:,} ({err}): "
                                      "left out", TfrecWarning, stacklevel=2)
                    offset += length
                    stream.seek(offset)
                    continue
                body = stream.read(length)
                offset += length
                try:
                    if opcode == OP_MESSAGE:
                        channel, _, log_time, publish_time = _MESSAGE.unpack_from(body, 0)
                        singles.append((channel, log_time, publish_time, body[MESSAGE_HEAD_SIZE:]))
                        if len(singles) >= _BATCH:
                            yield from self._flush(singles, path, stream)
                    elif opcode == OP_HEADER:
                        profile, _ = parse_header(body)
                        if profile not in ("ros2", ""):
                            raise ReadError(f"{name}: MCAP profile {profile!r}, not ros2")
                    else:
                        self._record(memoryview(body), opcode, 0, length)
                except (struct.error, ValueError, UnicodeDecodeError) as err:
                    if isinstance(err, ReadError):
                        raise
                    self._stop(name, start, size, f"a damaged {record_name(opcode)} record ({err})")
                    break
            yield from self._flush(singles, path, stream)
            self._summary_channels(stream)  # channels without messages may be only there

    def _extra(self, stream: IO[bytes], path: Path, opcode: int, start: int, length: int) -> None:
        """An attachment or metadata record: its name (and an attachment's index fields), read without its
        data; tfrec's own ``rosbag2`` metadata record is written anew, not copied.

        Raises:
            ValueError: a record too short for its fields, or a name that is no UTF-8.
        """
        head = stream.read(min(length, _EXTRA_HEAD))
        if opcode == OP_METADATA:
            name = _string(head, 0)[0]
            if name != "rosbag2":
                self.extras.append(Extra("metadata", name, path, start, RECORD.size + length))
            return
        log_time, create_time = struct.unpack_from("<QQ", head, 0)
        name, at = _string(head, 16)
        media_type, at = _string(head, at)
        (data_size,) = struct.unpack_from("<Q", head, at)
        if at + 8 + data_size + 4 != length:
            raise ValueError("its data length does not fit the record")
        self.extras.append(Extra("attachment", name, path, start, RECORD.size + length, log_time, create_time,
                                 media_type, data_size))

    def _stop(self, name: str, offset: int, size: int, reason: str) -> None:
        where = "" if name == self.where else f"{Path(name).name}: "
        self.problems.append(f"{where}reading stopped at byte {offset:,} of {size:,}: {reason}")

    def _record(self, view: memoryview, opcode: int, pos: int, length: int) -> None:
        """A schema or channel record's body at ``view[pos : pos + length]`` (others are ignored)."""
        if opcode == OP_SCHEMA:
            schema_id, name, encoding, data = parse_schema(view, pos)
            self._file.schemas[schema_id] = (name, encoding, data)
        elif opcode == OP_CHANNEL:
            self._channel(parse_channel(view, pos, length))

    def _channel(self, record: ChannelRecord) -> None:
        if self._file.lut[record.id] >= 0:
            return
        msgtype, encoding, data = self._file.schemas.get(record.schema_id, ("", "", b""))
        qos = record.metadata.get("offered_qos_profiles", "")
        connection = Connection(
            topic=self.resolve(record.topic), msgtype=full_type(msgtype), encoding=record.encoding,
            definition=data.decode("utf-8", "replace"), definition_encoding=encoding if data else "",
            latched=qos_durability(qos) == "transient_local", qos=qos,
            type_hash=record.metadata.get("topic_type_hash", ""),
        )
        self._file.lut[record.id] = self.connection_id(connection)

    def _summary_channels(self, stream: IO[bytes]) -> None:
        """Take the schemas and channels of the summary section (once per file): a skipped chunk
        may have held the only other copy of them."""
        if self._summary_taken:
            return
        self._summary_taken = True
        here = stream.tell()
        size = os.fstat(stream.fileno()).st_size
        view = read_summary_section(stream, size, after=len(MCAP_MAGIC))
        stream.seek(here)
        if view is None:
            return
        try:
            for opcode, pos, length in summary_records(view):
                if opcode in (OP_SCHEMA, OP_CHANNEL):
                    self._record(view, opcode, pos, length)
        except (struct.error, ValueError, UnicodeDecodeError):
            return

    # -- chunks -------------------------------------------------------------------------------

    def _chunk(self, body: bytes, indexes: dict[int, NDArray[np.uint64]], start: int, path: Path,
               stream: IO[bytes]) -> MessageBatch | None:
        """One chunk record's messages; a damaged chunk is noted and gives none."""
        try:
            head = chunk_fields(body)
            if self.until_ns is not None and head.plausible() and head.start > self.until_ns:
                return None  # every message in it is past what is wanted
            if len(head.records) != head.length:
                raise ValueError("its records run past its end")
            records = decompress(head.compression, head.records, head.size, supported=COMPRESSIONS)
            if head.crc and zlib.crc32(records) != head.crc:
                raise ValueError("CRC mismatch")
        except (struct.error, UnicodeDecodeError, ValueError) as err:
            self._damaged(path, start, f"{err}", stream)
            return None
        found = index_chunk(records, indexes) if indexes else None
        problem = None
        if found is not None:
            view = memoryview(records)
            for begin, end in found.gaps:  # schemas and channels first: the messages need them
                extra, problem = self._walk(view[begin:end])
                if problem is not None or extra is not None:  # messages the indexes miss: walk it all
                    found = None
                    break
        if found is None:
            walked, problem = self._walk(records)
            batch = None if walked is None else self._batch(*walked, stream)
        else:
            buffer = np.frombuffer(records, dtype=np.uint8)
            publish = np.ascontiguousarray(
                buffer[(found.start - 8)[:, np.newaxis] + np.arange(8)]).view("<u8").ravel().astype(np.int64)
            batch = self._batch(found.channel, found.log_time, publish, RawMessages(buffer, found.start, found.stop),
                                stream)
        if problem is not None:
            self._damaged(path, start, problem, stream)
        return batch

    def _cut_chunk(self, body: bytes, path: Path, stream: IO[bytes]) -> tuple[MessageBatch | None, int]:
        """The complete records of a chunk the file ends inside, and how many messages they hold."""
        try:
            head = chunk_fields(body)
        except (struct.error, UnicodeDecodeError):
            return None, 0
        records = salvage(head.compression, head.records, limit=min(head.size, MAX_CHUNK_BYTES), supported=COMPRESSIONS)
        walked, _ = self._walk(records)
        batch = None if walked is None else self._batch(*walked, stream)
        return batch, 0 if batch is None else len(batch)

    def _damaged(self, path: Path, start: int, problem: str, stream: IO[bytes]) -> None:
        where = "" if os.fspath(path) == self.where else f"{path.name}: "
        self.problems.append(f"{where}a damaged chunk record at byte {start:,} ({problem}) was skipped")
        self._summary_channels(stream)

    def _walk(self, data: bytes | memoryview) -> tuple[_Found | None, str | None]:
        """The records of a chunk's decompressed data one by one: schemas and channels taken,
        messages returned (channel, log time, publish time, data); and the problem that stopped
        the walk (the records before it are taken)."""
        view = memoryview(data)
        pos, end = 0, len(view)
        channels: list[int] = []
        times: list[int] = []
        publish: list[int] = []
        starts: list[int] = []
        stops: list[int] = []
        problem = None
        try:
            while pos < end:
                opcode, length = RECORD.unpack_from(view, pos)
                pos += RECORD.size
                if pos + length > end:
                    problem = "a record runs past the end of the chunk"
                    break
                if opcode == OP_MESSAGE:
                    channel, _, log_time, publish_time = _MESSAGE.unpack_from(view, pos)
                    channels.append(channel)
                    times.append(log_time)
                    publish.append(publish_time)
                    starts.append(pos + MESSAGE_HEAD_SIZE)
                    stops.append(pos + length)
                elif opcode in (OP_SCHEMA, OP_CHANNEL):
                    self._record(view, opcode, pos, length)
                elif opcode < 0x80:
                    problem = f"a{'n' if record_name(opcode)[0] in 'aeiou' else ''} {record_name(opcode)} record inside the chunk"
                    break
                pos += length
        except (struct.error, ValueError, UnicodeDecodeError) as err:
            problem = f"a damaged record ({err})"
        if not channels:
            return None, problem
        return (np.array(channels, np.int64), np.array(times, np.uint64).astype(np.int64),
                np.array(publish, np.uint64).astype(np.int64),
                RawMessages(np.frombuffer(view, dtype=np.uint8), np.array(starts, np.int64),
                            np.array(stops, np.int64))), problem

    def _batch(self, channels: NDArray[np.integer], log_time: NDArray[np.int64], publish: NDArray[np.int64],
               data: RawMessages, stream: IO[bytes]) -> MessageBatch | None:
        """Messages by channel id as a batch by connection id; messages of unknown channels are noted and left out."""
        conn = self._file.lut[channels.astype(np.intp)]
        if (conn < 0).any():
            self._summary_channels(stream)
            conn = self._file.lut[channels.astype(np.intp)]
            unknown = conn < 0
            if unknown.any():
                self.problems.append(f"{int(unknown.sum()):,} messages on unknown channels "
                                     f"({', '.join(map(str, np.unique(channels[unknown]).tolist()[:5]))}) were skipped")
                keep = np.flatnonzero(~unknown)
                conn, log_time, publish = conn[keep], log_time[keep], publish[keep]
                data = RawMessages(data.buffer, data.starts[keep], data.stops[keep])
        if not len(conn):
            return None
        if self.decompress is not None:
            data = raw_messages([self.decompress(bytes(message)) for message in data])
        self.messages += len(conn)
        return MessageBatch.of(conn, log_time, publish, data)

    def _flush(self, singles: list[tuple[int, int, int, bytes]], path: Path,
               stream: IO[bytes]) -> Iterator[MessageBatch]:
        """The messages outside chunks collected so far, as a batch."""
        if not singles:
            return
        channels = np.array([single[0] for single in singles], np.int64)
        times = np.array([single[1] for single in singles], np.uint64).astype(np.int64)
        publish = np.array([single[2] for single in singles], np.uint64).astype(np.int64)
        data = raw_messages([single[3] for single in singles])
        singles.clear()
        batch = self._batch(channels, times, publish, data, stream)
        if batch is not None:
            yield batch
