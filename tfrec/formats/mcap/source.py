"""An MCAP file's messages, in one walk: tfrec's one reader of MCAP (ROS 2 profile, CDR).

:class:`McapSource` walks the records of the data section once, in the file's order (the summary section
repeats it, so the walk stops at the DataEnd record). Schemas and channels become
:class:`~tfrec.formats.ros.connection.Connection` s (schema text, offered QoS, type hash). For each chunk the
Message Index records that follow it are read first (:mod:`tfrec.formats.mcap.index`): a chunk that holds no
message of a connection asked for is counted from them and not read; a chunk that is read (zstd, lz4 or
uncompressed) has its messages found with numpy through them — no Python object per message — and becomes one
:class:`~tfrec.formats.ros.connection.MessageBatch` of the connections asked for (a chunk without indexes is walked
record by record). Attachments and metadata records are noted where they lie, when asked for, not read.

A damaged file (a recorder killed mid-write, flipped bytes) is read as far as possible, and
:attr:`~tfrec.formats.ros.connection.MessageSource.read_error` says what was lost:

- a file that ends inside a chunk keeps the complete records of the part that is there: the records of every
  compressed block that is whole are recovered (:func:`tfrec.formats._compression.salvage`);
- a whole chunk whose data does not decompress, or does not match its CRC, is skipped, and the walk goes on with
  the next record: a flipped byte mostly decompresses to wrong data without any error, so only the CRC tells which
  messages can be trusted. The summary's schemas and channels then stand in for the ones the skipped chunk held;
- the recording's true start stays known (:attr:`~tfrec.formats.ros.connection.MessageSource.true_start_ns`): the
  summary's Statistics record when the summary is intact (its CRC holds), else the message start times in the
  headers of the chunk records read — a chunk's header survives damage to its compressed records.

When the file's summary is intact, the messages counted can be checked against its Statistics record: a channel
whose count differs warns with both numbers.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import ReadError
from tfrec.formats._compression import MAX_CHUNK_BYTES, decompress, salvage
from tfrec.formats.mcap.index import ChunkMessages, index_chunk, read_message_indexes
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
    ChunkHead,
    chunk_fields,
    parse_channel,
    parse_header,
    parse_schema,
    read_summary_section,
    statistics_of,
    summary_records,
)
from tfrec.formats.ros.connection import (
    BATCH_MESSAGES,
    Connection,
    Extra,
    MessageBatch,
    MessageSource,
    ReadStopped,
    count_differences,
    distinct,
    full_type,
    raw_messages,
    warn_reading,
    with_article,
)
from tfrec.formats.ros.decode import RawMessages
from tfrec.formats.rosbag2.metadata import qos_durability

__all__ = ["McapSource"]

_NO_TIME = 1 << 64
"""A channel's ``first_ns`` and ``last_ns`` before its first message: above any log time (uint64)."""
_MESSAGE = struct.Struct("<HIQQ")
"""A Message record's channel id, sequence, log time and publish time."""
_EXTRA_HEAD = 4 * 65536 + 32
"""Bytes read of an attachment or metadata record to find its name (and media type): names longer than 64 KiB
do not fit, and such a record is damaged."""

_Found = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], NDArray[np.int64] | None]
"""Messages found in a chunk's records, in the records' order: channel ids, log times, data starts and stops, and
publish times (None when not asked for)."""


class _Channel:
    """A channel of one file: its connection, whether its messages are yielded, and its count (``first_ns``,
    ``last_ns``: its earliest and latest log time)."""

    __slots__ = ("conn", "count", "first_ns", "last_ns", "topic")

    def __init__(self, conn: int, topic: str) -> None:
        self.conn = conn
        self.topic = topic
        self.count = 0
        self.first_ns = self.last_ns = _NO_TIME

    def add_span(self, count: int, first: int, last: int) -> None:
        """Count ``count`` messages logged from ``first`` to ``last``."""
        self.count += count
        self.first_ns = min(self.first_ns, first)
        self.last_ns = last if self.last_ns == _NO_TIME else max(self.last_ns, last)


class _Damage:
    """A skipped (or partly read) chunk in the middle of the file."""

    __slots__ = ("indexed", "problem", "recovered", "start")

    def __init__(self, start: int, problem: str, recovered: int, indexed: int | None) -> None:
        self.start = start
        self.problem = problem
        self.recovered = recovered
        self.indexed = indexed
        """Its messages, as its message index records count them (None: no index)."""


def _string(data: bytes, at: int) -> tuple[str, int]:
    """An MCAP string (uint32 length, UTF-8) at ``data[at]``, and where it ends.

    Raises:
        ValueError: one that runs past ``data``, or is no UTF-8 (UnicodeDecodeError).
    """
    (size,) = struct.unpack_from("<I", data, at)
    if at + 4 + size > len(data):
        raise ValueError("a name runs past the record")
    return data[at + 4 : at + 4 + size].decode("utf-8"), at + 4 + size


class McapSource(MessageSource):
    """The messages of one MCAP file, or of a rosbag2 bag's MCAP files in order.

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
        self._compressions: set[str] = set()

    def _walk(self) -> Iterator[MessageBatch]:
        for path in self.files:
            name = os.fspath(path)
            try:
                with open(path, "rb") as stream:
                    walk = _FileWalk(self, stream, name)
                    yield from walk.batches()
                    walk.finish()
            except OSError as err:
                raise ReadError(f"{name}: cannot read: {err.strerror or err}") from err

    def note_file(self, profile: str, library: str, compressions: set[str]) -> None:
        """What one file's header and chunks say: ``details`` merged over the files."""
        self.details["profile"] = self.details.get("profile") or profile
        self.details["library"] = self.details.get("library") or library
        self._compressions |= compressions
        self.details["compression"] = ", ".join(sorted(self._compressions))

    def batch(self, conns: NDArray[np.int64], found: _Found, buffer: NDArray[np.uint8]) -> MessageBatch | None:
        """The messages of the connections asked for among ``found`` (of connections ``conns``)."""
        _, log_time, starts, stops, publish = found
        keep = np.array([self.wanted(conn) for conn in range(len(self.connections))], dtype=bool)[conns]
        if not keep.any():
            return None
        if not keep.all():
            index = np.flatnonzero(keep)
            conns, log_time, starts, stops = conns[index], log_time[index], starts[index], stops[index]
            publish = None if publish is None else publish[index]
        data: RawMessages = RawMessages(buffer, starts, stops)
        if self.decompress is not None:
            data = raw_messages([self.decompress(bytes(message)) for message in data])
        self.messages += len(conns)
        return MessageBatch.of(conns, log_time, publish, data)


class _FileWalk:
    """The walk over one file's records, then the records inside each chunk."""

    def __init__(self, source: McapSource, stream: IO[bytes], name: str) -> None:
        self.source = source
        self.stream = stream
        self.name = name
        self.size = os.fstat(stream.fileno()).st_size
        self.offset = 0
        self.schemas: dict[int, tuple[str, str, bytes]] = {}  # id → (name, encoding, data)
        self.channels: dict[int, _Channel] = {}
        self.lut = np.full(65536, -1, dtype=np.int64)  # channel id → connection id
        self.singles: list[tuple[int, int, int, bytes]] = []  # messages outside chunks: channel, log, publish, data
        self.damage: list[_Damage] = []
        self.stop: ReadStopped | None = None
        self.profile = self.library = ""
        self.compressions: set[str] = set()
        self.chunks_start: int | None = None  # the earliest message start time of the chunk headers read
        self._summary: memoryview | None = None  # the summary section, once read, if it holds its CRC
        self._summary_read = False

    @property
    def counted(self) -> int:
        return sum(channel.count for channel in self.channels.values())

    # -- the records of the data section ----------------------------------------------------------

    def batches(self) -> Iterator[MessageBatch]:
        try:
            yield from self._records()
        except ReadStopped as err:
            self.stop = err
        yield from self._flush()

    def _read(self, size: int, what: str) -> bytes:
        data = self.stream.read(size)
        if len(data) < size:
            raise ReadStopped(self.offset, f"the file ends inside {with_article(what)} record")
        self.offset += size
        return data

    def _records(self) -> Iterator[MessageBatch]:
        """Every record up to the summary section (or the end of what is readable).

        Raises:
            ReadStopped: a record the file ends inside, or a damaged one that loses the framing.
        """
        self._read(len(MCAP_MAGIC), "magic")
        while True:
            head = self.stream.read(RECORD.size)
            if not head:
                raise ReadStopped(self.offset, "the file ends without a footer")
            if len(head) < RECORD.size:
                raise ReadStopped(self.offset, "the file ends inside a record header")
            start = self.offset
            self.offset += RECORD.size
            opcode, length = RECORD.unpack(head)
            if opcode in (OP_FOOTER, OP_DATA_END):
                return  # the summary section repeats what the data section had
            if opcode == 0 or 0x10 <= opcode < 0x80:  # reserved: not a record, the framing is lost
                raise ReadStopped(start, f"a damaged record (opcode 0x{opcode:02x})")
            if self.offset + length > self.size:
                yield from self._cut(opcode, start)
            if opcode == OP_CHUNK:
                yield from self._flush()
                batch = self._chunk_record(length, start)
                if batch is not None:
                    yield batch
            elif opcode in (OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_HEADER):
                self._small_record(opcode, length, start)
                if len(self.singles) >= BATCH_MESSAGES:
                    yield from self._flush()
            elif opcode in (OP_ATTACHMENT, OP_METADATA) and self.source.want_extras:
                self._extra(opcode, start, length)
            else:
                self.stream.seek(length, os.SEEK_CUR)
                self.offset += length

    def _cut(self, opcode: int, start: int) -> Iterator[MessageBatch]:
        """The record at ``start`` runs past the end of the file: what is there of a chunk, then the stop.

        Raises:
            ReadStopped: always.
        """
        if opcode == OP_CHUNK:
            yield from self._flush()
            before = self.counted
            batch = self._cut_chunk(self.stream.read())
            if batch is not None:
                yield batch
            raise ReadStopped(self.size, f"the file ends inside a chunk record (recovered {self.counted - before:,} "
                                         "messages of it)")
        raise ReadStopped(self.offset, f"the file ends inside {with_article(record_name(opcode))} record")

    def _small_record(self, opcode: int, length: int, start: int) -> None:
        """A schema, channel, message or header record outside chunks.

        Raises:
            ReadStopped: a damaged record; ReadError: a profile other than ros2.
        """
        what = record_name(opcode)
        body = self._read(length, what)
        if opcode == OP_HEADER:
            self.profile, self.library = parse_header(body)
            if self.profile not in ("ros2", ""):
                raise ReadError(f"{self.name}: MCAP profile {self.profile!r}, not ros2")
            return
        try:
            if opcode == OP_MESSAGE:
                channel_id, _, log_time, publish_time = _MESSAGE.unpack_from(body, 0)
                if channel_id not in self.channels:
                    raise ValueError(f"message on unknown channel {channel_id}")
                self.singles.append((channel_id, log_time, publish_time, body[MESSAGE_HEAD_SIZE:]))
            else:
                self._record(memoryview(body), opcode, 0, length)
        except (struct.error, ValueError, UnicodeDecodeError) as err:
            raise ReadStopped(start, f"a damaged {what} record ({err})") from err

    def _extra(self, opcode: int, start: int, length: int) -> None:
        """An attachment or metadata record: its name (and an attachment's index fields), read without its data;
        tfrec's own ``rosbag2`` metadata record is written anew, not copied. A damaged one is left out with a
        warning: its length frames it, and the walk goes on after it."""
        body_at = self.offset
        try:
            head = self.stream.read(min(length, _EXTRA_HEAD))
            extra = _extra_of(head, opcode, Path(self.name), start, length)
        except (struct.error, ValueError) as err:
            warn_reading(f"{self.name}: a damaged {record_name(opcode)} record at byte {start:,} ({err}): left out")
            extra = None
        if extra is not None:
            self.source.extras.append(extra)
        self.offset = body_at + length
        self.stream.seek(self.offset)

    def _record(self, view: memoryview, opcode: int, pos: int, length: int) -> None:
        """A schema or channel record's body at ``view[pos : pos + length]``."""
        if opcode == OP_SCHEMA:
            schema_id, name, encoding, data = parse_schema(view, pos)
            self.schemas[schema_id] = (name, encoding, data)
        elif opcode == OP_CHANNEL:
            record = parse_channel(view, pos, length)
            if record.id in self.channels:
                return
            msgtype, encoding, data = self.schemas.get(record.schema_id, ("", "", b""))
            qos = record.metadata.get("offered_qos_profiles", "")
            durability = qos_durability(qos)
            topic = self.source.resolve(record.topic)
            connection = Connection(
                topic=topic, msgtype=full_type(msgtype), encoding=record.encoding,
                definition=data.decode("utf-8", "replace"), definition_encoding=encoding if data else "",
                latched=durability == "transient_local", qos=qos,
                type_hash=record.metadata.get("topic_type_hash", ""),
            )
            conn = self.source.connection_id(connection, durability, shown_type=msgtype)
            self.channels[record.id] = _Channel(conn, topic)
            self.lut[record.id] = conn

    def _flush(self) -> Iterator[MessageBatch]:
        """The messages outside chunks collected so far, as a batch."""
        if not self.singles:
            return
        singles, self.singles = self.singles, []
        ids = np.array([single[0] for single in singles], np.int64)
        times = np.array([single[1] for single in singles], np.uint64).astype(np.int64)
        publish = np.array([single[2] for single in singles], np.uint64).astype(np.int64)
        data = raw_messages([single[3] for single in singles])
        batch = self._take((ids, times, data.starts, data.stops, publish if self.source.publish_time else None),
                           data.buffer)
        if batch is not None:
            yield batch

    # -- chunks -----------------------------------------------------------------------------------

    def _chunk_head(self, body: bytes | memoryview) -> ChunkHead | None:
        """A chunk record's header fields (None when damaged), noting its compression and start time."""
        try:
            head = chunk_fields(bytes(body) if isinstance(body, memoryview) else body)
        except (struct.error, UnicodeDecodeError):
            return None
        if head.plausible():
            self.compressions.add(head.compression or "none")
            if self.chunks_start is None or head.start < self.chunks_start:
                self.chunks_start = head.start
        return head

    def _chunk_record(self, length: int, start: int) -> MessageBatch | None:
        """The chunk record at byte ``start`` (its body of ``length`` bytes follows) and the message indexes after
        it: counted from them when nothing in it is wanted, else read."""
        body_at = self.offset
        self.stream.seek(length, os.SEEK_CUR)
        indexes = read_message_indexes(self.stream, self.size)
        after = self.stream.tell()
        batch = None
        if not self._skipped(indexes, body_at, length):
            self.stream.seek(body_at)
            self.offset = body_at
            batch = self._chunk(self._read(length, "chunk"), start, indexes)
        self.stream.seek(after)
        self.offset = after
        return batch

    def _skipped(self, indexes: dict[int, NDArray[np.uint64]], body_at: int, length: int) -> bool:
        """Whether a chunk is left unread: all of it after ``until_ns``, or nothing in it wanted (then counted from
        its message indexes). Its header is read either way: its compression, its start time."""
        until = self.source.until_ns
        if not (until is not None or (indexes and self._all_known_and_unwanted(indexes))):
            return False
        self.stream.seek(body_at)
        head = self._chunk_head(self.stream.read(min(length, 64)))
        if until is not None and head is not None and head.plausible() and head.start > until:
            return True  # every message in it is past what is wanted (not counted)
        if not (indexes and self._all_known_and_unwanted(indexes)):
            return False
        for channel_id, pairs in indexes.items():
            if len(pairs):
                times = pairs[:, 0]
                self.channels[channel_id].add_span(len(pairs), int(times.min()), int(times.max()))
        return True

    def _all_known_and_unwanted(self, indexes: dict[int, NDArray[np.uint64]]) -> bool:
        for channel_id in indexes:
            channel = self.channels.get(channel_id)
            if channel is None or self.source.wanted(channel.conn):
                return False
        return True

    def _chunk(self, body: bytes, start: int, indexes: dict[int, NDArray[np.uint64]]) -> MessageBatch | None:
        """A whole chunk record at byte ``start``: its messages, or none when its data is damaged."""
        head = self._chunk_head(body)
        if head is None:
            self._damaged(start, "its header is damaged", 0, indexes)
            return None
        try:
            if len(head.records) != head.length:
                raise ValueError("its records run past its end")
            records = decompress(head.compression, head.records, head.size, supported=COMPRESSIONS)
            if head.crc and zlib.crc32(records) != head.crc:
                raise ValueError("CRC mismatch")
        except ValueError as err:
            self._damaged(start, str(err), 0, indexes)
            return None
        found, problem = self._indexed(records, indexes) if indexes else self._walk_records(records)
        before = self.counted
        batch = None if found is None else self._take(found, np.frombuffer(records, dtype=np.uint8))
        if problem is not None:
            self._damaged(start, problem, self.counted - before, indexes)
        return batch

    def _indexed(self, records: bytes | memoryview,
                 indexes: dict[int, NDArray[np.uint64]]) -> tuple[_Found | None, str | None]:
        """A chunk's messages through its message indexes (see :meth:`_walk_records` for what is returned); a
        chunk the indexes do not describe, or whose gaps hold messages they miss, is walked record by record."""
        found = index_chunk(records, indexes)
        if found is None:
            return self._walk_records(records)
        view = memoryview(records)
        for begin, end in found.gaps:  # schemas and channels first: the messages may need them
            extra, problem = self._walk_records(view[begin:end])
            if extra is not None:  # messages the indexes miss: the whole chunk, in order
                return self._walk_records(records)
            if problem is not None:
                return None, problem
        ids = found.channel.astype(np.int64)
        unknown = sorted(channel_id for channel_id in indexes if channel_id not in self.channels)
        problem = None
        if unknown:  # the messages of the channels before it are taken
            problem = f"a message on unknown channel {unknown[0]}"
            keep = np.flatnonzero(ids < unknown[0])
            found = ChunkMessages(found.channel[keep], found.log_time[keep], found.start[keep], found.stop[keep],
                                  found.gaps)
            ids = ids[keep]
        publish = None
        if self.source.publish_time and len(ids):
            buffer = np.frombuffer(records, dtype=np.uint8)
            publish = np.ascontiguousarray(
                buffer[(found.start - 8)[:, np.newaxis] + np.arange(8)]).view("<u8").ravel().astype(np.int64)
        return (ids, found.log_time, found.start, found.stop, publish), problem

    def _cut_chunk(self, body: bytes) -> MessageBatch | None:
        """The complete records in a chunk the file ends inside."""
        head = self._chunk_head(body)
        if head is None:
            return None
        records = salvage(head.compression, head.records, limit=min(head.size, MAX_CHUNK_BYTES), supported=COMPRESSIONS)
        found, _ = self._walk_records(records)  # stops at the first incomplete record
        return None if found is None else self._take(found, np.frombuffer(records, dtype=np.uint8))

    def _walk_records(self, data: bytes | memoryview) -> tuple[_Found | None, str | None]:
        """The records of a chunk's decompressed data one by one: schemas and channels taken, messages returned
        (None when there are none); and the problem that stopped the walk (the records before it are taken): a
        record that runs past the end, a message on an unknown channel, a record that has no place in a chunk."""
        view = memoryview(data)
        pos, end = 0, len(view)
        record, message, channels, head = RECORD.unpack_from, _MESSAGE.unpack_from, self.channels, RECORD.size
        ids: list[int] = []
        times: list[int] = []
        publish: list[int] = []
        starts: list[int] = []
        stops: list[int] = []
        problem = None
        try:
            while pos < end:
                opcode, length = record(view, pos)  # struct.error when its header runs past the end
                pos += head
                if pos + length > end:
                    problem = "a record runs past the end of the chunk"
                    break
                if opcode == OP_MESSAGE:  # the hot path
                    channel_id, _, log_time, publish_time = message(view, pos)
                    if channel_id not in channels:
                        problem = f"a message on unknown channel {channel_id}"
                        break
                    ids.append(channel_id)
                    times.append(log_time)
                    publish.append(publish_time)
                    starts.append(pos + MESSAGE_HEAD_SIZE)
                    stops.append(pos + length)
                elif opcode in (OP_SCHEMA, OP_CHANNEL):
                    self._record(view, opcode, pos, length)
                elif opcode < 0x80:  # 0x80 and up: private records
                    problem = f"{with_article(record_name(opcode))} record inside the chunk"
                    break
                pos += length
        except (struct.error, ValueError, UnicodeDecodeError) as err:
            problem = f"a damaged record ({err})"
        if not ids:
            return None, problem
        return (np.array(ids, np.int64), np.array(times, np.uint64).astype(np.int64), np.array(starts, np.int64),
                np.array(stops, np.int64),
                np.array(publish, np.uint64).astype(np.int64) if self.source.publish_time else None), problem

    def _take(self, found: _Found, buffer: NDArray[np.uint8]) -> MessageBatch | None:
        """Count the messages found, and give those of the connections asked for as a batch."""
        ids, log_time = found[0], found[1]
        present = distinct(ids)
        if len(present) == 1:
            self.channels[present[0]].add_span(len(ids), int(log_time.min()), int(log_time.max()))
        else:
            for channel_id in present:
                times = log_time[ids == channel_id]
                self.channels[channel_id].add_span(len(times), int(times.min()), int(times.max()))
        return self.source.batch(self.lut[ids], found, buffer)

    def _damaged(self, start: int, problem: str, recovered: int, indexes: dict[int, NDArray[np.uint64]]) -> None:
        self.damage.append(_Damage(start, problem, recovered,
                                   sum(len(pairs) for pairs in indexes.values()) if indexes else None))
        if len(self.damage) == 1:
            self.summary_channels()

    # -- the summary section ----------------------------------------------------------------------

    def _summary_records(self) -> tuple[memoryview, list[tuple[int, int, int]]]:
        """The summary section and its records (opcode, position, length); no records when the file has no intact
        summary (one that holds its CRC)."""
        if not self._summary_read:
            self._summary = read_summary_section(self.stream, self.size, after=min(self.offset, self.size))
            self._summary_read = True
        view = self._summary if self._summary is not None else memoryview(b"")
        return view, summary_records(view)

    def summary_channels(self) -> None:
        """Take the schemas and channels of the summary section: a skipped chunk may have held the only other copy
        of them. Nothing is taken from a summary that fails its CRC."""
        view, records = self._summary_records()
        try:
            for opcode, pos, length in records:
                if opcode in (OP_SCHEMA, OP_CHANNEL):
                    self._record(view, opcode, pos, length)
        except (struct.error, ValueError, UnicodeDecodeError):
            return  # a damaged summary: its channels stay unknown

    def _true_start(self) -> int | None:
        """The recording's first log time, had nothing been lost: from the summary's statistics, else the earliest
        message start time of the chunk headers read."""
        try:
            statistics = statistics_of(*self._summary_records())
        except (struct.error, ValueError):
            statistics = None
        return int(statistics.start) if statistics is not None and statistics.message_count else self.chunks_start

    def _indexed_counts(self) -> dict[str, int] | None:
        """Messages per (resolved) topic as the summary's Statistics record counts them; None without an intact
        summary, or one whose statistics count no channels or unknown ones."""
        try:
            statistics = statistics_of(*self._summary_records())
        except (struct.error, ValueError):
            return None
        if statistics is None or not statistics.channel_counts or set(statistics.channel_counts) - set(self.channels):
            return None
        out: dict[str, int] = {}
        for channel_id, channel in self.channels.items():
            out[channel.topic] = out.get(channel.topic, 0) + statistics.channel_counts.get(channel_id, 0)
        return out

    def _damage_summary(self) -> str:
        """The damaged chunks in one phrase: where the first is, why, and what was recovered."""
        first = self.damage[0]
        recovered = sum(damage.recovered for damage in self.damage)
        indexed = [damage.indexed for damage in self.damage if damage.indexed is not None]
        if len(self.damage) == 1:
            head, its = f"a damaged chunk record at byte {first.start:,} ({first.problem})", ("its", "it")
        else:
            head = f"{len(self.damage)} damaged chunk records, the first at byte {first.start:,} ({first.problem})"
            its = ("their", "them")
        if len(indexed) == len(self.damage):
            return f"{head}: recovered {recovered:,} of {its[0]} {sum(indexed):,} messages"
        return f"{head}: recovered {recovered:,} messages of {its[1]}"

    # -- the end of the file ----------------------------------------------------------------------

    def finish(self) -> None:
        """What the walk of this file found: its counts, details, and what it lost.

        Raises:
            ReadError: a file damaged before its first channel.
        """
        stop, source = self.stop, self.source
        if not self.channels and self.damage:
            raise ReadError(f"{self.name}: unreadable MCAP: {self._damage_summary()}")
        if not self.channels and stop is not None:
            raise ReadError(f"{self.name}: unreadable MCAP: {stop.reason} at byte {stop.offset:,}")
        problems = [self._damage_summary()] if self.damage else []
        if stop is not None:
            problems.append(stop.problem(self.size))
        if not problems:
            self.summary_channels()  # channels without messages may be only there
        for channel in self.channels.values():
            if channel.count:
                source.stats[channel.conn].add_times(channel.first_ns, channel.last_ns)
                source.stats[channel.conn].count += channel.count
        source.note_file(self.profile, self.library, self.compressions)
        if problems:
            true_start = self._true_start()
            if true_start is not None and (source.true_start_ns is None or true_start < source.true_start_ns):
                source.true_start_ns = true_start
            source.lost(self.name, problems, self.counted)
        elif source.check_counts:
            self._check_counts()

    def _check_counts(self) -> None:
        indexed = self._indexed_counts()
        if indexed is None:
            return
        read: dict[str, int] = {}
        for channel in self.channels.values():
            read[channel.topic] = read.get(channel.topic, 0) + channel.count
        differ = count_differences(read, indexed, index="its summary statistics")
        if differ is not None:
            warn_reading(f"{self.name}: {differ}")


def _extra_of(head: bytes, opcode: int, path: Path, start: int, length: int) -> Extra | None:
    """An attachment or metadata record as an :class:`Extra` (None: tfrec's own ``rosbag2`` metadata).

    Raises:
        ValueError: a record too short for its fields, or a name that is no UTF-8.
    """
    if opcode == OP_METADATA:
        name = _string(head, 0)[0]
        return None if name == "rosbag2" else Extra("metadata", name, path, start, RECORD.size + length)
    log_time, create_time = struct.unpack_from("<QQ", head, 0)
    name, at = _string(head, 16)
    media_type, at = _string(head, at)
    (data_size,) = struct.unpack_from("<Q", head, at)
    if at + 8 + data_size + 4 != length:
        raise ValueError("its data length does not fit the record")
    return Extra("attachment", name, path, start, RECORD.size + length, log_time, create_time, media_type, data_size)
