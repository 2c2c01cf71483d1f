"""Reading an MCAP file (ROS 2 profile, CDR) into a :class:`~tfrec.recorded.Recording`.

tfrec's own sequential reader: it walks the records and the records inside each chunk (zstd,
lz4 or uncompressed) with ``struct``, keeping each message as a memoryview of its chunk, so no
Python object is built per message; the messages are then decoded in bulk. mcap's reader
builds a record object per message and reads ~130k messages/s; this reads ~300k/s.

A damaged file (a recorder killed mid-write, flipped bytes) is read as far as possible, and
:attr:`Recording.read_error` says what was lost:

- a file that ends inside a chunk keeps the complete records of the part that is there: zstd
  and lz4 decompress block by block (128 KiB and 64 KiB of records), so the records of every
  block that is whole are recovered;
- a whole chunk whose data does not decompress, or does not match its CRC, is skipped, and
  reading goes on with the next record: a flipped byte mostly decompresses to wrong data
  without any error, so only the CRC tells which messages can be trusted. The summary's
  schemas and channels then stand in for the ones the skipped chunk held.

When messages were lost, :attr:`Recording.start_ns` (and ``end_ns``) still give the recording's
true span, so times count from its real start: the summary's Statistics record when the
summary is intact (its CRC holds), else the message start times in the headers of the chunk
records read — a chunk's header survives damage to its compressed records.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any, NamedTuple

from .bag_metadata import qos_durability
from .errors import RecordingError
from .recorded import Collector, ReadStopped, Recording, deserializer, with_article

__all__ = ["MCAP_MAGIC", "read_mcap"]

MCAP_MAGIC = b"\x89MCAP0\r\n"
_BATCH = 32768
"""Messages of a topic decoded at once outside chunks."""
_PIECE = 4096
"""Compressed bytes fed at a time when salvaging a cut chunk, so the blocks before a corrupt tail come out."""

_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 1, 2, 3, 4, 5, 6
_OP_MESSAGE_INDEX, _OP_STATISTICS, _OP_DATA_END = 7, 11, 15
_RECORD_NAMES = {1: "header", 2: "footer", 3: "schema", 4: "channel", 5: "message", 6: "chunk", 7: "message index",
                 8: "chunk index", 9: "attachment", 10: "attachment index", 11: "statistics", 12: "metadata",
                 13: "metadata index", 14: "summary offset", 15: "data end"}
_RECORD = struct.Struct("<BQ")
_MESSAGE = struct.Struct("<HIQ")  # channel id, sequence, log time (publish time follows)
_MESSAGE_HEAD = 2 + 4 + 8 + 8
_CHUNK_HEAD = struct.Struct("<QQQII")  # start time, end time, uncompressed size and CRC, compression length
_FOOTER = struct.Struct("<BQQQI")  # opcode, length, summary start, summary offset start, summary CRC
_STATISTICS = struct.Struct("<QHIIIIQQ")  # message count, schema … chunk counts, message start and end time
_COMPRESSIONS = ("", "zstd", "lz4")


class _Channel:
    __slots__ = ("count", "datas", "decoded", "durability", "first", "last", "topic", "type")

    def __init__(self, topic: str, msgtype: str, decoded: bool, durability: str | None) -> None:
        self.topic = topic
        self.type = msgtype
        self.decoded = decoded
        self.durability = durability
        self.count = 0
        self.first = 0
        self.last = 0
        self.datas: list[memoryview] = []


class _Damage:
    """A skipped (or partly read) chunk in the middle of the file."""

    __slots__ = ("indexed", "problem", "recovered", "start")

    def __init__(self, start: int, problem: str, recovered: int) -> None:
        self.start = start
        self.problem = problem
        self.recovered = recovered
        self.indexed: int | None = None
        """Its messages, as its message index records count them (None: no index)."""


class _ChunkHead(NamedTuple):
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
        return self.compression in _COMPRESSIONS and 0 < self.start <= self.end


def _chunk_fields(body: bytes) -> _ChunkHead:
    """A chunk record's header fields and its compressed records.

    Raises:
        struct.error, UnicodeDecodeError: a damaged chunk header.
    """
    start, end, size, crc, name_len = _CHUNK_HEAD.unpack_from(body, 0)
    pos = _CHUNK_HEAD.size
    compression = body[pos : pos + name_len].decode()
    pos += name_len
    (length,) = struct.unpack_from("<Q", body, pos)
    pos += 8
    return _ChunkHead(start, end, compression, size, crc, memoryview(body)[pos : pos + length], length)


def _decompress(compression: str, data: memoryview, size: int) -> bytes | memoryview:
    """A whole chunk's records, decompressed.

    Raises:
        ValueError: the data does not decompress, or the compression is unknown.
    """
    if compression == "zstd":
        import zstandard

        try:
            return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
        except zstandard.ZstdError as err:
            raise ValueError(f"zstd: {err}") from None
    if compression == "lz4":
        import lz4.frame

        try:
            return lz4.frame.decompress(data)  # type: ignore[no-any-return]
        except RuntimeError as err:  # lz4 reports corrupt frames as RuntimeError
            raise ValueError(f"lz4: {err}") from None
    if compression:
        raise ValueError(f"unsupported chunk compression '{compression}'")
    return data


def _salvage(compression: str, data: memoryview) -> bytes | memoryview:
    """What decompresses of a cut chunk's records: every whole compressed block, up to the end
    of the data or to the first corrupt block."""
    if not compression:
        return data
    decompress: Callable[[memoryview], bytes]
    error: type[Exception]
    if compression == "zstd":
        import zstandard

        decompress, error = zstandard.ZstdDecompressor().decompressobj().decompress, zstandard.ZstdError
    elif compression == "lz4":
        import lz4.frame

        decompress, error = lz4.frame.LZ4FrameDecompressor().decompress, RuntimeError
    else:
        return b""
    out: list[bytes] = []
    for at in range(0, len(data), _PIECE):  # pieces, so the blocks before a corrupt one come out
        try:
            out.append(decompress(data[at : at + _PIECE]))
        except error:
            break
    return b"".join(out)


def _ros2_store() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


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
            head = self.stream.read(9)
            if not head:
                raise ReadStopped(self.offset, "the file ends without a footer")
            if len(head) < 9:
                raise ReadStopped(self.offset, "the file ends inside a record header")
            record_start = self.offset
            self.offset += 9
            opcode, length = _RECORD.unpack(head)
            what = _RECORD_NAMES.get(opcode, f"opcode 0x{opcode:02x}")
            if opcode in (_OP_FOOTER, _OP_DATA_END):
                return  # the summary section repeats what the data section had
            if opcode == 0 or 0x10 <= opcode < 0x80:  # reserved: not a record, the framing is lost
                raise ReadStopped(record_start, f"a damaged record (opcode 0x{opcode:02x})")
            if self.offset + length > self.size:
                if opcode == _OP_CHUNK:
                    recovered = self._cut_chunk(self.stream.read())
                    reason = f"the file ends inside a chunk record (recovered {recovered:,} messages of it)"
                    raise ReadStopped(self.size, reason)
                raise ReadStopped(self.offset, f"the file ends inside {with_article(what)} record")
            if opcode != _OP_MESSAGE_INDEX:
                self._indexing = None
            if opcode == _OP_CHUNK:
                self._chunk(self.read(length, what), record_start)
                self.flush()
            elif opcode in (_OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE):
                try:
                    self._record(memoryview(self.read(length, what)), opcode, 0, length)
                except (struct.error, ValueError, UnicodeDecodeError) as err:
                    raise ReadStopped(record_start, f"a damaged {what} record ({err})") from None
                if self.pending >= _BATCH:
                    self.flush()
            elif opcode == _OP_HEADER:
                self._header(self.read(length, what))
                if self.profile not in ("ros2", ""):
                    raise RecordingError(f"{self.where}: MCAP profile '{self.profile}', not ros2")
            elif opcode == _OP_MESSAGE_INDEX and self._indexing is not None:
                body = self.read(length, what)  # count what the damaged chunk held
                if len(body) >= 6:
                    self._indexing.indexed = (self._indexing.indexed or 0) + struct.unpack_from("<I", body, 2)[0] // 16
            else:
                self.stream.seek(length, os.SEEK_CUR)
                self.offset += length

    def _header(self, body: bytes) -> None:
        """The Header record: profile and library."""
        try:
            (size,) = struct.unpack_from("<I", body, 0)
            self.profile = body[4 : 4 + size].decode("utf-8", "replace")
            (library_size,) = struct.unpack_from("<I", body, 4 + size)
            self.library = body[8 + size : 8 + size + library_size].decode("utf-8", "replace")
        except struct.error:
            pass  # a damaged header: the profile is checked as far as it could be read

    def _chunk_head(self, body: bytes) -> _ChunkHead | None:
        """A chunk record's header fields (None when damaged), noting its compression and start time."""
        try:
            head = _chunk_fields(body)
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
            records = _decompress(head.compression, head.records, head.size)
            if len(records) != head.size:
                raise ValueError(f"its records decompress to {len(records):,} bytes, not {head.size:,}")
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
        records = _salvage(head.compression, head.records)[: head.size]
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
        record, message, channels = _RECORD.unpack_from, _MESSAGE.unpack_from, self.channels
        try:
            while pos < end:
                opcode, length = record(view, pos)  # struct.error when its header runs past the end
                pos += 9
                if pos + length > end:
                    return "a record runs past the end of the chunk"
                if opcode == _OP_MESSAGE:  # the hot path, inlined from _record
                    channel_id, _, log_time = message(view, pos)
                    channel = channels.get(channel_id)
                    if channel is None:
                        return f"a message on unknown channel {channel_id}"
                    if channel.count == 0:
                        channel.first = log_time
                    channel.count += 1
                    channel.last = log_time
                    if channel.decoded:
                        channel.datas.append(view[pos + _MESSAGE_HEAD : pos + length])
                elif opcode in (_OP_SCHEMA, _OP_CHANNEL):
                    self._record(view, opcode, pos, length)
                elif opcode < 0x80:  # 0x80 and up: private records
                    return f"{with_article(_RECORD_NAMES.get(opcode, f'opcode 0x{opcode:02x}'))} record inside the chunk"
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
            self._summary, self._summary_read = self._read_summary(), True
        view = self._summary if self._summary is not None else memoryview(b"")
        records, pos, end = [], 0, len(view)
        while pos + 9 <= end:
            opcode, length = _RECORD.unpack_from(view, pos)
            pos += 9
            if pos + length > end:
                break
            records.append((opcode, pos, length))
            pos += length
        return view, records

    def _read_summary(self) -> memoryview | None:
        footer_start = self.size - len(MCAP_MAGIC) - _FOOTER.size
        if footer_start < self.offset:
            return None
        here = self.stream.tell()
        try:
            self.stream.seek(footer_start)
            footer = self.stream.read(_FOOTER.size + len(MCAP_MAGIC))
            opcode, length, summary_start, _, crc = _FOOTER.unpack_from(footer)
            if (footer[_FOOTER.size :] != MCAP_MAGIC or opcode != _OP_FOOTER or length != _FOOTER.size - 9
                    or not self.offset <= summary_start <= footer_start):
                return None
            self.stream.seek(summary_start)
            section = self.stream.read(footer_start + _FOOTER.size - 4 - summary_start)  # the CRC covers the footer too
            if crc and zlib.crc32(section) != crc:
                return None
            return memoryview(section)[: footer_start - summary_start]
        except struct.error:
            return None
        finally:
            self.stream.seek(here)

    def _summary_channels(self) -> None:
        """Take the schemas and channels of the summary section: a skipped chunk may have held the
        only other copy of them. Nothing is taken from a summary that fails its CRC."""
        view, records = self._summary_records()
        try:
            for opcode, pos, length in records:
                if opcode in (_OP_SCHEMA, _OP_CHANNEL):
                    self._record(view, opcode, pos, length)
        except (struct.error, ValueError, UnicodeDecodeError):
            return  # a damaged summary: its channels stay unknown

    def true_start(self) -> int | None:
        """The recording's first log time, had nothing been lost: from the summary's statistics,
        else the earliest message start time of the chunk headers read."""
        view, records = self._summary_records()
        for opcode, pos, length in records:
            if opcode == _OP_STATISTICS and length >= _STATISTICS.size:
                count, *_, start, _ = _STATISTICS.unpack_from(view, pos)
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
        if opcode == _OP_MESSAGE:
            channel_id, _, log_time = _MESSAGE.unpack_from(view, pos)
            channel = self.channels.get(channel_id)
            if channel is None:
                raise ValueError(f"message on unknown channel {channel_id}")
            if channel.count == 0:
                channel.first = log_time
            channel.count += 1
            channel.last = log_time
            if channel.decoded:
                channel.datas.append(view[pos + _MESSAGE_HEAD : pos + length])
                self.pending += 1
        elif opcode == _OP_SCHEMA:
            schema_id, name_len = struct.unpack_from("<HI", view, pos)
            self.schemas[schema_id] = bytes(view[pos + 6 : pos + 6 + name_len]).decode()
        elif opcode == _OP_CHANNEL:
            channel_id, schema_id, topic_len = struct.unpack_from("<HHI", view, pos)
            at = pos + 8
            topic = bytes(view[at : at + topic_len]).decode()
            at += topic_len
            (enc_len,) = struct.unpack_from("<I", view, at)
            encoding = bytes(view[at + 4 : at + 4 + enc_len]).decode()
            if channel_id not in self.channels:
                metadata = self._metadata(view, at + 4 + enc_len, pos + length)
                msgtype = self.schemas.get(schema_id, "")
                decoded = self.collector.decodes(topic, msgtype)
                if decoded and encoding != "cdr":
                    raise RecordingError(f"{self.where}: topic {topic} is encoded as '{encoding}', not cdr")
                if decoded:
                    self.collector.set_deserializer(
                        topic, deserializer(_ros2_store(), msgtype, ros1=False, where=self.where, topic=topic)
                    )
                durability = qos_durability(metadata.get("offered_qos_profiles", ""))
                self.channels[channel_id] = _Channel(topic, msgtype, decoded, durability)

    @staticmethod
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
                self.collector.count(channel.topic, channel.type, channel.count, channel.first, channel.last,
                                     channel.durability)


def read_mcap(path: Path, wanted: frozenset[str]) -> Recording:
    """Read an MCAP file, decoding the topics in ``wanted``.

    Raises:
        RecordingError: the file cannot be opened, or is damaged before its first channel.
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
                raise RecordingError(f"{where}: unreadable MCAP: {reader.damage_summary()}")
            if not reader.channels and stop is not None:
                raise RecordingError(f"{where}: unreadable MCAP: {stop.reason} at byte {stop.offset:,}")
            problems = [reader.damage_summary()] if reader.damage else []
            if stop is not None:
                problems.append(f"reading stopped at byte {stop.offset:,} of {size:,}: {stop.reason}")
            if problems:
                recording.read_error = f"{where}: {'; '.join(problems)}; {reader.messages:,} messages read"
            reader.flush()
            reader.finish()
            true_start = reader.true_start() if problems else None
            recording.details = {"profile": reader.profile, "library": reader.library,
                                 "compression": ", ".join(sorted(reader.compressions))}
    except OSError as err:
        raise RecordingError(f"{where}: cannot read: {err.strerror or err}") from None
    collector.finish()
    if true_start is not None and (recording.start_ns is None or true_start < recording.start_ns):
        recording.start_ns = true_start  # messages before the first one read were lost
        if recording.end_ns is None:
            recording.end_ns = true_start
    return recording
