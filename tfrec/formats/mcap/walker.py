"""Walking an MCAP file's records: the mechanics of :mod:`tfrec.formats.mcap.reader`.

:class:`McapWalker` walks the records of the data section and, for each chunk, first the Message
Index records that follow it (:mod:`tfrec.formats.mcap.index`): a chunk that holds nothing to
decode is counted from them and not read; a chunk that is read has its messages found with numpy
through them (a chunk without indexes is walked record by record, in a loop with no Python object
per message). A damaged chunk is skipped and noted (:class:`Damage`); the summary section stands in
for the channels it held and tells the file's true start.
"""

from __future__ import annotations

import os
import struct
import zlib
from typing import IO

import numpy as np

from tfrec.errors import ReadError
from tfrec.formats._collect import (
    DECODE_BATCH,
    Collector,
    ReadStopped,
    with_article,
)
from tfrec.formats._compression import MAX_CHUNK_BYTES, decompress, salvage
from tfrec.formats.mcap.index import index_chunk, read_message_indexes
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
from tfrec.formats.ros.decode import RawMessages
from tfrec.formats.ros.types import topic_deserializer
from tfrec.formats.rosbag2.metadata import qos_durability
from tfrec.recording import TopicStats

__all__ = ["Damage", "McapWalker"]

_NO_TIME = 1 << 64
"""A channel's ``first_ns`` and ``last_ns`` before its first message: above any log time (uint64)."""


class _Channel(TopicStats):
    """A channel: its topic, whether its messages are decoded, those not yet handed to the
    collector, and its count (``first_ns``, ``last_ns``: its earliest and latest log time).

    A message's time is taken with one comparison when it is not earlier than the latest so
    far (the usual case) — see :meth:`add_time`, which the chunk loop inlines.
    """

    __slots__ = ("datas", "decoded", "times", "topic")

    def __init__(self, topic: str, msgtype: str, decoded: bool, durability: str | None) -> None:
        super().__init__(msgtype, durability)
        self.topic = topic
        self.decoded = decoded
        self.datas: list[memoryview] = []
        self.times: list[int] = []  # the log times of ``datas``
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

    def add_span(self, count: int, first: int, last: int) -> None:
        """Count ``count`` messages logged from ``first`` to ``last``."""
        self.count += count
        assert self.first_ns is not None and self.last_ns is not None  # _NO_TIME before the first message
        self.first_ns = min(self.first_ns, first)
        self.last_ns = last if self.last_ns == _NO_TIME else max(self.last_ns, last)


class Damage:
    """A skipped (or partly read) chunk in the middle of the file."""

    __slots__ = ("indexed", "problem", "recovered", "start")

    def __init__(self, start: int, problem: str, recovered: int) -> None:
        self.start = start
        self.problem = problem
        self.recovered = recovered
        self.indexed: int | None = None
        """Its messages, as its message index records count them (None: no index)."""


class McapWalker:
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
        self.schemas: dict[int, tuple[str, str, bytes]] = {}  # id → (name, encoding, data)
        self.channels: dict[int, _Channel] = {}
        self.pending = 0
        self.damage: list[Damage] = []
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
            if opcode == OP_CHUNK:
                self._chunk_record(length, record_start)
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

    def _chunk_record(self, length: int, start: int) -> None:
        """The chunk record at byte ``start`` (its body of ``length`` bytes follows) and the
        message indexes after it: counted from them when nothing in it is decoded, else read."""
        body_at = self.offset
        self.stream.seek(length, os.SEEK_CUR)
        indexes = read_message_indexes(self.stream, self.size)
        after = self.stream.tell()
        if indexes and self._counted(indexes):
            self.stream.seek(body_at + min(length, 64))  # only the header: the compression, the start time
            self._chunk_head(self.stream.read(min(length, 64)))
            self.stream.seek(after)
            self.offset = after
            return
        self.stream.seek(body_at)
        self.offset = body_at
        body = self.read(length, "chunk")
        self._chunk(body, start, indexes)
        self.flush()
        self.stream.seek(after)
        self.offset = after

    def _counted(self, indexes: dict[int, np.ndarray]) -> bool:
        """Count a chunk from its message indexes when none of its messages is to be decoded
        (all its channels known, none decoded or each one's wanted messages taken)."""
        channels = self.channels
        for channel_id in indexes:
            channel = channels.get(channel_id)
            if channel is None or (channel.decoded and self.collector.remaining(channel.topic) != 0):
                return False
        for channel_id, pairs in indexes.items():
            if len(pairs):
                times = pairs[:, 0]
                channels[channel_id].add_span(len(pairs), int(times.min()), int(times.max()))
        return True

    def _chunk(self, body: bytes, start: int, indexes: dict[int, np.ndarray]) -> None:
        """A whole chunk record at byte ``start``: its records, or none when its data is damaged."""
        head = self._chunk_head(body)
        if head is None:
            self._damaged(start, "its header is damaged", 0, indexes)
            return
        try:
            if len(head.records) != head.length:
                raise ValueError("its records run past its end")
            records = decompress(head.compression, head.records, head.size, supported=COMPRESSIONS)
            if head.crc and zlib.crc32(records) != head.crc:
                raise ValueError("CRC mismatch")
        except ValueError as err:
            self._damaged(start, str(err), 0, indexes)
            return
        before = self.messages
        problem = self._indexed_records(records, indexes) if indexes else self._chunk_records(records)
        if problem is not None:
            self._damaged(start, problem, self.messages - before, indexes)

    def _indexed_records(self, records: bytes | memoryview, indexes: dict[int, np.ndarray]) -> str | None:
        """Take a chunk's records through its message indexes (see :func:`_chunk_records` for
        what is returned); records the indexes do not describe are walked one by one."""
        found = index_chunk(records, indexes)
        if found is None:
            return self._chunk_records(records)
        view = memoryview(records)
        for begin, end in found.gaps:  # schemas and channels first: the messages may need them
            problem = self._chunk_records(view[begin:end])
            if problem is not None:
                return problem
        channels = self.channels
        for channel_id in np.unique(found.channel).tolist():
            channel = channels.get(channel_id)
            if channel is None:
                return f"a message on unknown channel {channel_id}"
            rows = np.flatnonzero(found.channel == channel_id)
            times = found.log_time[rows]
            channel.add_span(len(rows), int(times.min()), int(times.max()))
            if channel.decoded:  # decoded from the chunk's records, not a Python object per message
                self.collector.add(channel.topic, RawMessages(records, found.start[rows], found.stop[rows]), times)
        return None

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
                        channel.times.append(log_time)
                elif opcode in (OP_SCHEMA, OP_CHANNEL):
                    self._record(view, opcode, pos, length)
                elif opcode < 0x80:  # 0x80 and up: private records
                    return f"{with_article(record_name(opcode))} record inside the chunk"
                pos += length
        except (struct.error, ValueError, UnicodeDecodeError) as err:
            return f"a damaged record ({err})"
        return None

    def _damaged(self, start: int, problem: str, recovered: int, indexes: dict[int, np.ndarray]) -> None:
        damage = Damage(start, problem, recovered)
        if indexes:  # what the damaged chunk held
            damage.indexed = sum(len(pairs) for pairs in indexes.values())
        self.damage.append(damage)
        if len(self.damage) == 1:
            self.summary_channels()

    def _summary_records(self) -> tuple[memoryview, list[tuple[int, int, int]]]:
        """The summary section and its records (opcode, position, length); no records when the
        file has no intact summary (one that holds its CRC)."""
        if not self._summary_read:
            self._summary = read_summary_section(self.stream, self.size, after=self.offset)
            self._summary_read = True
        view = self._summary if self._summary is not None else memoryview(b"")
        return view, summary_records(view)

    def summary_channels(self) -> None:
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
        try:
            statistics = statistics_of(*self._summary_records())
        except (struct.error, ValueError):
            statistics = None
        return int(statistics.start) if statistics is not None and statistics.message_count else self.chunks_start

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
                channel.times.append(log_time)
                self.pending += 1
        elif opcode == OP_SCHEMA:
            schema_id, name, encoding, data = parse_schema(view, pos)
            self.schemas[schema_id] = (name, encoding, data)
        elif opcode == OP_CHANNEL:
            record = parse_channel(view, pos, length)
            if record.id not in self.channels:
                topic = self.collector.resolve(record.topic)
                msgtype, encoding, data = self.schemas.get(record.schema_id, ("", "", b""))
                decoded = self.collector.decodes(topic, msgtype, definition=data.decode("utf-8", "replace"),
                                                 definition_encoding=encoding,
                                                 type_hash=record.metadata.get("topic_type_hash", ""))
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
                self.collector.add(channel.topic, channel.datas, channel.times)
                channel.datas, channel.times = [], []
        self.pending = 0

    def finish(self) -> None:
        for channel in self.channels.values():
            if channel.count:
                self.collector.count(channel.topic, channel)
            else:  # listed, as ros2 bag info lists it
                self.collector.topic(channel.topic, channel.type, channel.durability)

    def indexed_counts(self) -> dict[str, int] | None:
        """Messages per (resolved) topic as the summary's Statistics record counts them; None
        without an intact summary, or one whose statistics count no channels or unknown ones."""
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

