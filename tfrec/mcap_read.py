"""Reading an MCAP file (ROS 2 profile, CDR) into a :class:`~tfrec.recorded.Recording`.

tfrec's own sequential reader: it walks the records and the records inside each chunk (zstd,
lz4 or uncompressed) with ``struct``, keeping each message as a memoryview of its chunk, so no
Python object is built per message; the messages are then decoded in bulk. mcap's reader
builds a record object per message and reads ~130k messages/s; this reads ~300k/s.

A file that ends early or has a damaged chunk (a recorder killed mid-write) is read up to the
damage: :attr:`Recording.read_error` says where reading stopped.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path
from typing import IO, Any

from .errors import RecordingError
from .recorded import Collector, Recording, deserializer

__all__ = ["read_mcap", "MCAP_MAGIC"]

MCAP_MAGIC = b"\x89MCAP0\r\n"
_BATCH = 32768
"""Messages of a topic decoded at once outside chunks."""

_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK, _OP_DATA_END = 1, 2, 3, 4, 5, 6, 15
_RECORD_NAMES = {1: "header", 2: "footer", 3: "schema", 4: "channel", 5: "message", 6: "chunk", 7: "message index",
                 8: "chunk index", 9: "attachment", 10: "attachment index", 11: "statistics", 12: "metadata",
                 13: "metadata index", 14: "summary offset", 15: "data end"}
_RECORD = struct.Struct("<BQ")
_MESSAGE = struct.Struct("<HIQ")  # channel id, sequence, log time (publish time follows)
_MESSAGE_HEAD = 2 + 4 + 8 + 8


class _Truncated(Exception):
    """Reading stopped: the file ends (or is damaged) at ``offset``."""

    def __init__(self, offset: int, reason: str) -> None:
        super().__init__(reason)
        self.offset = offset
        self.reason = reason


class _Channel:
    __slots__ = ("topic", "type", "decoded", "count", "first", "last", "datas")

    def __init__(self, topic: str, msgtype: str, decoded: bool) -> None:
        self.topic = topic
        self.type = msgtype
        self.decoded = decoded
        self.count = 0
        self.first = 0
        self.last = 0
        self.datas: list[memoryview] = []


def _ros2_store() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


class _McapReader:
    """Sequential MCAP reading: records, then the records inside each chunk, with no per-message objects.

    The summary section is not needed (it repeats the data section), so reading stops at the
    DataEnd record; the CRCs are not checked.
    """

    def __init__(self, stream: IO[bytes], collector: Collector, where: str) -> None:
        self.stream = stream
        self.collector = collector
        self.where = where
        self.offset = 0
        self.schemas: dict[int, str] = {}
        self.channels: dict[int, _Channel] = {}
        self.pending = 0

    @property
    def messages(self) -> int:
        return sum(channel.count for channel in self.channels.values())

    def read(self, size: int, what: str) -> bytes:
        data = self.stream.read(size)
        if len(data) < size:
            raise _Truncated(self.offset, f"the file ends inside a{'n' if what[0] in 'aeiou' else ''} {what} record")
        self.offset += size
        return data

    def run(self) -> None:
        self.read(len(MCAP_MAGIC), "magic")
        while True:
            head = self.stream.read(9)
            if not head:
                raise _Truncated(self.offset, "the file ends without a footer")
            if len(head) < 9:
                raise _Truncated(self.offset, "the file ends inside a record header")
            record_start = self.offset
            self.offset += 9
            opcode, length = _RECORD.unpack(head)
            what = _RECORD_NAMES.get(opcode, f"opcode 0x{opcode:02x}")
            if opcode in (_OP_FOOTER, _OP_DATA_END):
                return  # the summary section repeats what the data section had
            if opcode in (_OP_CHUNK, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE):
                body = self.read(length, what)
                try:
                    if opcode == _OP_CHUNK:
                        self._chunk(body)
                    else:
                        self._record(memoryview(body), opcode, 0, length)
                except (struct.error, ValueError, UnicodeDecodeError) as err:
                    raise _Truncated(record_start, f"a damaged {what} record ({err})") from None
                if opcode == _OP_CHUNK or self.pending >= _BATCH:
                    self.flush()
            elif opcode == _OP_HEADER:
                profile = self._profile(self.read(length, what))
                if profile not in ("ros2", ""):
                    raise RecordingError(f"{self.where}: MCAP profile '{profile}', not ros2")
            else:
                self.stream.seek(length, os.SEEK_CUR)
                self.offset += length

    @staticmethod
    def _profile(body: bytes) -> str:
        (size,) = struct.unpack_from("<I", body, 0)
        return body[4 : 4 + size].decode("utf-8", "replace")

    def _chunk(self, body: bytes) -> None:
        _, _, uncompressed_size, _, name_len = struct.unpack_from("<QQQII", body, 0)
        pos = 8 + 8 + 8 + 4 + 4
        compression = body[pos : pos + name_len].decode()
        pos += name_len
        (size,) = struct.unpack_from("<Q", body, pos)
        pos += 8
        data = body[pos : pos + size]
        if len(data) != size:
            raise ValueError("chunk data shorter than its length")
        if compression == "zstd":
            import zstandard

            try:
                data = zstandard.ZstdDecompressor().decompress(data, max_output_size=uncompressed_size)
            except zstandard.ZstdError as err:
                raise ValueError(f"zstd: {err}") from None
        elif compression == "lz4":
            import lz4.frame

            try:
                data = lz4.frame.decompress(data)
            except RuntimeError as err:  # lz4 reports corrupt frames as RuntimeError
                raise ValueError(f"lz4: {err}") from None
        elif compression:
            raise ValueError(f"unsupported chunk compression '{compression}'")
        if len(data) != uncompressed_size:
            raise ValueError("chunk data does not decompress to its size")
        view = memoryview(data)
        pos, end = 0, len(data)
        record, message, channels = _RECORD.unpack_from, _MESSAGE.unpack_from, self.channels
        while pos < end:
            opcode, length = record(data, pos)
            pos += 9
            if pos + length > end:
                raise ValueError("record runs past the end of its chunk")
            if opcode == _OP_MESSAGE:  # the hot path, inlined from _record
                channel_id, _, log_time = message(data, pos)
                channel = channels.get(channel_id)
                if channel is None:
                    raise ValueError(f"message on unknown channel {channel_id}")
                if channel.count == 0:
                    channel.first = log_time
                channel.count += 1
                channel.last = log_time
                if channel.decoded:
                    channel.datas.append(view[pos + _MESSAGE_HEAD : pos + length])
            else:
                self._record(view, opcode, pos, length)
            pos += length

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
                msgtype = self.schemas.get(schema_id, "")
                decoded = self.collector.decodes(topic, msgtype)
                if decoded and encoding != "cdr":
                    raise RecordingError(f"{self.where}: topic {topic} is encoded as '{encoding}', not cdr")
                if decoded:
                    self.collector.set_deserializer(
                        topic, deserializer(_ros2_store(), msgtype, ros1=False, where=self.where, topic=topic)
                    )
                self.channels[channel_id] = _Channel(topic, msgtype, decoded)

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
                self.collector.count(channel.topic, channel.type, channel.count, channel.first, channel.last)


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
            reader = _McapReader(stream, collector, where)
            try:
                reader.run()
            except _Truncated as stop:
                if not reader.channels:
                    raise RecordingError(f"{where}: unreadable MCAP: {stop.reason} at byte {stop.offset:,}") from None
                recording.read_error = (
                    f"{where}: reading stopped at byte {stop.offset:,} of {path.stat().st_size:,}: {stop.reason}; "
                    f"{reader.messages:,} messages read"
                )
            reader.flush()
            reader.finish()
    except OSError as err:
        raise RecordingError(f"{where}: cannot read: {err.strerror or err}") from None
    return collector.finish()
