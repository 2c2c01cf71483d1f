"""Reading an MCAP file (ROS 2 profile, CDR) into a :class:`~tfrec.recording.Recording`.

tfrec's own sequential reader: it walks the records and the records inside each chunk (zstd,
lz4 or uncompressed) with ``struct``, keeping each message as a memoryview of its chunk, so no
Python object is built per message; the messages are then decoded in bulk. mcap's reader
builds a record object per message and reads ~130k messages/s; this reads ~300k/s.

A damaged file (a recorder killed mid-write, flipped bytes) is read as far as possible, and
:attr:`Recording.read_error` says what was lost:

- a file that ends inside a chunk keeps the complete records of the part that is there: the
  records of every compressed block that is whole are recovered (:func:`tfrec.formats._compression.salvage`);
- a whole chunk whose data does not decompress, or does not match its CRC, is skipped, and
  reading goes on with the next record: a flipped byte mostly decompresses to wrong data
  without any error, so only the CRC tells which messages can be trusted. The summary's
  schemas and channels then stand in for the ones the skipped chunk held.

When messages were lost, :attr:`Recording.start_ns` (and ``end_ns``) still give the recording's
true span, so times count from its real start: the summary's Statistics record when the
summary is intact (its CRC holds), else the message start times in the headers of the chunk
records read — a chunk's header survives damage to its compressed records. The records other
than messages are parsed by :mod:`tfrec.formats.mcap.summary`.
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path
from typing import IO

from tfrec.errors import ReadError
from tfrec.formats._collect import DECODE_BATCH, Collector, ReadStopped, read_error_line, with_article
from tfrec.formats._compression import MAX_CHUNK_BYTES, decompress, salvage
from tfrec.formats.mcap.records import (
    COMPRESSIONS,
    MCAP_MAGIC,
    MESSAGE,
    MESSAGE_HEAD_SIZE,
    OP_CHANNEL,
    OP_CHUNK,
    OP_DATA_END,
    OP_FOOTER,
    OP_HEADER,
    OP_MESSAGE,
    OP_MESSAGE_INDEX,
    OP_SCHEMA,
    OP_STATISTICS,
    RECORD,
    STATISTICS,
    record_name,
)
from tfrec.formats.mcap.summary import (
    ChunkHead,
    chunk_fields,
    parse_channel,
    parse_header,
    parse_schema,
    read_summary_section,
    summary_records,
)
from tfrec.formats.ros.types import topic_deserializer
from tfrec.formats.rosbag2.metadata import qos_durability
from tfrec.recording import Recording, TopicStats

__all__ = ["read_mcap"]


_NO_TIME = 1 << 64
"""A channel's ``first_ns`` and ``last_ns`` before its first message: above any log time (uint64)."""


class _Channel(TopicStats):
    """A channel: its topic, whether its messages are decoded, those not yet handed to the
    collector, and its count (``first_ns``, ``last_ns``: its earliest and latest log time).

    A message's time is taken with one comparison when it is not earlier than the latest so
    far (the usual case) — see :meth:`add_time`, which the chunk loop inlines.
    """

    __slots__ = ("datas", "decoded", "topic")

    def __init__(self, topic: str, msgtype: str, decoded: bool, durability: str | None) -> None:
        super().__init__(msgtype, durability)
        self.topic = topic
        self.decoded = decoded
        self.datas: list[memoryview] = []
        self.first_ns = self.last_ns = _NO_TIME

    def add_time(self, log_time: int) -> None:
        """Count one message logged at ``log_time``, in any order."""
        first, last = self.first_ns, self.last_ns
        assert first is not None and last is not None  # _NO_TIME before the first message
        if log_time >= last:  # never true for the first message
            self.last_ns = log_time
        elif log_time < first:  # the first message, or one earlier than all so far
            self.first_ns = log_time
            if last == _NO_TIME:
                self.last_ns = log_time
        self.count += 1


class _Damage:
    """A skipped (or partly read) chunk in the middle of the file."""

    __slots__ = ("indexed", "problem", "recovered", "start")

    def __init__(self, start: int, problem: str, recovered: int) -> None:
        self.start = start
        self.problem = problem
        self.recovered = recovered
        self.indexed: int | None = None
        """Its messages, as its message index records count them (None: no index)."""


class _McapReader:
    """Sequential MCAP reading: records, then the records inside each chunk, with no per-message objects.

    The summary section is not needed (it repeats the data section), so reading stops at the
    DataEnd record. The chunks' CRCs are checked.
    """

    def __init__(self, stream: IO[bytes], collector: Collector, where: str, size: int) -> None:
        self.stream = stream
        self.collector = collector
        self.where = where
        self.size = size
        self.offset = 0
        self.schemas: dict[int, str] = {}
        self.channels: dict[int, _Channel] = {}
        self.pending = 0
        self.damage: list[_Damage] = []
        self._indexing: _Damage | None = None  # the damaged chunk whose message index records follow
        self.profile = self.library = ""
        self.compressions: set[str] = set()
        self.chunks_start: int | None = None  # the earliest message start time of the chunk headers read
        self._summary: memoryview | None = None  # the summary section, once read, if it holds its CRC
        self._summary_read = False

    @property
    def messages(self) -> int:
        return sum(channel.count for channel in self.channels.values())

    def read(self, size: int, what: str) -> bytes:
        data = self.stream.read(size)
        if len(data) < size:
            raise ReadStopped(self.offset, f"the file ends inside {with_article(what)} record")
        self.offset += size
        return data

    def run(self) -> None:
        self.read(len(MCAP_MAGIC), "magic")
        while True:
            head = self.stream.read(RECORD.size)
            if not head:
                raise ReadStopped(self.offset, "the file ends without a footer")
            if len(head) < RECORD.size:
                raise ReadStopped(self.offset, "the file ends inside a record header")
            record_start = self.offset
            self.offset += RECORD.size
            opcode, length = RECORD.unpack(head)
            what = record_name(opcode)
            if opcode in (OP_FOOTER, OP_DATA_END):
                return  # the summary section repeats what the data section had
            if opcode == 0 or 0x10 <= opcode < 0x80:  # reserved: not a record, the framing is lost
                raise ReadStopped(record_start, f"a damaged record (opcode 0x{opcode:02x})")
            if self.offset + length > self.size:
                if opcode == OP_CHUNK:
                    recovered = self._cut_chunk(self.stream.read())
                    reason = f"the file ends inside a chunk record (recovered {recovered:,} messages of it)"
                    raise ReadStopped(self.size, reason)
                raise ReadStopped(self.offset, f"the file ends inside {with_article(what)} record")
            if opcode != OP_MESSAGE_INDEX:
                self._indexing = None
            if opcode == OP_CHUNK:
                self._chunk(self.read(length, what), record_start)
                self.flush()
            elif opcode in (OP_SCHEMA, OP_CHANNEL, OP_MESSAGE):
                try:
                    self._record(memoryview(self.read(length, what)), opcode, 0, length)
                except (struct.error, ValueError, UnicodeDecodeError) as err:
                    raise ReadStopped(record_start, f"a damaged {what} record ({err})") from err
                if self.pending >= DECODE_BATCH:
                    self.flush()
            elif opcode == OP_HEADER:
                self.profile, self.library = parse_header(self.read(length, what))
                if self.profile not in ("ros2", ""):
                    raise ReadError(f"{self.where}: MCAP profile {self.profile!r}, not ros2")
            elif opcode == OP_MESSAGE_INDEX and self._indexing is not None:
                body = self.read(length, what)  # count what the damaged chunk held
                if len(body) >= 6:
                    self._indexing.indexed = (self._indexing.indexed or 0) + struct.unpack_from("<I", body, 2)[0] // 16
            else:
                self.stream.seek(length, os.SEEK_CUR)
                self.offset += length

    def _chunk_head(self, body: bytes) -> ChunkHead | None:
        """A chunk record's header fields (None when damaged), noting its compression and start time."""
        try:
            head = chunk_fields(body)
        except (struct.error, UnicodeDecodeError):
            return None
        if head.plausible():
            self.compressions.add(head.compression or "none")
            if self.chunks_start is None or head.start < self.chunks_start:
                self.chunks_start = head.start
        return head

    def _chunk(self, body: bytes, start: int) -> None:
        """A whole chunk record at byte ``start``: its records, or none when its data is damaged."""
        head = self._chunk_head(body)
        if head is None:
            self._damaged(start, "its header is damaged", 0)
            return
        try:
            if len(head.records) != head.length:
                raise ValueError("its records run past its end")
            records = decompress(head.compression, head.records, head.size, supported=COMPRESSIONS)
            if head.crc and zlib.crc32(records) != head.crc:
                raise ValueError("CRC mismatch")
        except ValueError as err:
            self._damaged(start, str(err), 0)
            return
        before = self.messages
        problem = self._chunk_records(records)
        if problem is not None:
            self._damaged(start, problem, self.messages - before)

    def _cut_chunk(self, body: bytes) -> int:
        """The complete records in a chunk the file ends inside; returns how many messages they hold."""
        head = self._chunk_head(body)
        if head is None:
            return 0
        before = self.messages
        records = salvage(head.compression, head.records, limit=min(head.size, MAX_CHUNK_BYTES), supported=COMPRESSIONS)
        self._chunk_records(records)  # stops at the first incomplete record
        return self.messages - before

    def _chunk_records(self, data: bytes | memoryview) -> str | None:
        """Take the records of a chunk's decompressed data.

        Returns:
            None, or the problem that stopped them (the records before it are taken): a record
            that runs past the end, a message on an unknown channel, a record that has no place
            in a chunk.
        """
        view = memoryview(data)
        pos, end = 0, len(view)
        record, message, channels, head = RECORD.unpack_from, MESSAGE.unpack_from, self.channels, RECORD.size
        try:
            while pos < end:
                opcode, length = record(view, pos)  # struct.error when its header runs past the end
                pos += head
                if pos + length > end:
                    return "a record runs past the end of the chunk"
                if opcode == OP_MESSAGE:  # the hot path, inlined from _record
                    channel_id, _, log_time = message(view, pos)
                    channel = channels.get(channel_id)
                    if channel is None:
                        return f"a message on unknown channel {channel_id}"
                    if log_time >= channel.last_ns:  # channel.add_time(log_time), inlined
                        channel.last_ns = log_time
                    elif log_time < channel.first_ns:
                        channel.first_ns = log_time
                        if channel.last_ns == _NO_TIME:
                            channel.last_ns = log_time
                    channel.count += 1
                    if channel.decoded:
                        channel.datas.append(view[pos + MESSAGE_HEAD_SIZE : pos + length])
                elif opcode in (OP_SCHEMA, OP_CHANNEL):
                    self._record(view, opcode, pos, length)
                elif opcode < 0x80:  # 0x80 and up: private records
                    return f"{with_article(record_name(opcode))} record inside the chunk"
                pos += length
        except (struct.error, ValueError, UnicodeDecodeError) as err:
            return f"a damaged record ({err})"
        return None

    def _damaged(self, start: int, problem: str, recovered: int) -> None:
        self._indexing = _Damage(start, problem, recovered)
        self.damage.append(self._indexing)
        if len(self.damage) == 1:
            self._summary_channels()

    def _summary_records(self) -> tuple[memoryview, list[tuple[int, int, int]]]:
        """The summary section and its records (opcode, position, length); no records when the
        file has no intact summary (one that holds its CRC)."""
        if not self._summary_read:
            self._summary = read_summary_section(self.stream, self.size, after=self.offset)
            self._summary_read = True
        view = self._summary if self._summary is not None else memoryview(b"")
        return view, summary_records(view)

    def _summary_channels(self) -> None:
        """Take the schemas and channels of the summary section: a skipped chunk may have held the
        only other copy of them. Nothing is taken from a summary that fails its CRC."""
        view, records = self._summary_records()
        try:
            for opcode, pos, length in records:
                if opcode in (OP_SCHEMA, OP_CHANNEL):
                    self._record(view, opcode, pos, length)
        except (struct.error, ValueError, UnicodeDecodeError):
            return  # a damaged summary: its channels stay unknown

    def true_start(self) -> int | None:
        """The recording's first log time, had nothing been lost: from the summary's statistics,
        else the earliest message start time of the chunk headers read."""
        view, records = self._summary_records()
        for opcode, pos, length in records:
            if opcode == OP_STATISTICS and length >= STATISTICS.size:
                count, *_, start, _ = STATISTICS.unpack_from(view, pos)
                if count:
                    return int(start)
        return self.chunks_start

    def damage_summary(self) -> str:
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

    def _record(self, view: memoryview, opcode: int, pos: int, length: int) -> None:
        """One record's body at ``view[pos : pos + length]``."""
        if opcode == OP_MESSAGE:
            channel_id, _, log_time = MESSAGE.unpack_from(view, pos)
            channel = self.channels.get(channel_id)
            if channel is None:
                raise ValueError(f"message on unknown channel {channel_id}")
            channel.add_time(log_time)
            if channel.decoded:
                channel.datas.append(view[pos + MESSAGE_HEAD_SIZE : pos + length])
                self.pending += 1
        elif opcode == OP_SCHEMA:
            schema_id, name = parse_schema(view, pos)
            self.schemas[schema_id] = name
        elif opcode == OP_CHANNEL:
            record = parse_channel(view, pos, length)
            if record.id not in self.channels:
                topic, msgtype = record.topic, self.schemas.get(record.schema_id, "")
                decoded = self.collector.decodes(topic, msgtype)
                if decoded and record.encoding != "cdr":
                    raise ReadError(f"{self.where}: topic {topic} is encoded as '{record.encoding}', not cdr")
                if decoded:
                    self.collector.set_deserializer(topic, topic_deserializer(msgtype, where=self.where, topic=topic))
                durability = qos_durability(record.metadata.get("offered_qos_profiles", ""))
                self.channels[record.id] = _Channel(topic, msgtype, decoded, durability)

    def flush(self) -> None:
        """Decode the messages collected so far."""
        for channel in self.channels.values():
            if channel.datas:
                self.collector.add(channel.topic, channel.datas)
                channel.datas = []
        self.pending = 0

    def finish(self) -> None:
        for channel in self.channels.values():
            if channel.count:
                self.collector.count(channel.topic, channel)


def read_mcap(path: Path, wanted: frozenset[str]) -> Recording:
    """Read an MCAP file, decoding the topics in ``wanted``.

    Raises:
        ReadError: the file cannot be opened, or is damaged before its first channel.
    """
    where = os.fspath(path)
    recording = Recording(path=where, format="mcap")
    collector = Collector(recording, wanted, ros1=False)
    try:
        with open(path, "rb") as stream:
            size = os.fstat(stream.fileno()).st_size
            reader = _McapReader(stream, collector, where, size)
            stop: ReadStopped | None = None
            try:
                reader.run()
            except ReadStopped as err:
                stop = err
            if not reader.channels and reader.damage:
                raise ReadError(f"{where}: unreadable MCAP: {reader.damage_summary()}")
            if not reader.channels and stop is not None:
                raise ReadError(f"{where}: unreadable MCAP: {stop.reason} at byte {stop.offset:,}")
            problems = [reader.damage_summary()] if reader.damage else []
            if stop is not None:
                problems.append(stop.problem(size))
            if problems:
                recording.read_error = read_error_line(where, problems, reader.messages)
            reader.flush()
            reader.finish()
            true_start = reader.true_start() if problems else None
            recording.details = {"profile": reader.profile, "library": reader.library,
                                 "compression": ", ".join(sorted(reader.compressions))}
    except OSError as err:
        raise ReadError(f"{where}: cannot read: {err.strerror or err}") from err
    collector.finish()
    if true_start is not None and (recording.start_ns is None or true_start < recording.start_ns):
        recording.start_ns = true_start  # messages before the first one read were lost
        if recording.end_ns is None:
            recording.end_ns = true_start
    return recording
