"""A ROS 1 bag's raw messages, chunk by chunk, for copying them (``tfrec convert``).

:class:`Ros1Messages` walks the bag (format 2.0) once, in the file's order. The connections come
from the index at the end of the file when there is one (so every chunk's connections are known
before it is read), else from the connection records met on the way; each chunk, decompressed
(none, bz2 or lz4), becomes one :class:`~tfrec.formats.ros.connection.MessageBatch`: its messages
found through the index data records that follow it with numpy
(:func:`~tfrec.formats.rosbag1.index.message_spans`), or record by record.

A damaged bag is read as far as it goes: a chunk that does not decompress is skipped, a bag cut
short (no index) gives the complete records of its last chunk, and
:attr:`~tfrec.formats.ros.connection.MessageSource.problems` says what was lost.
"""

from __future__ import annotations

import os
import struct
import warnings
from collections.abc import Callable, Generator, Iterator
from dataclasses import replace
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import ReadError, TfrecWarning
from tfrec.formats._compression import MAX_CHUNK_BYTES, decompress, salvage
from tfrec.formats.ros.connection import MessageBatch, MessageSource
from tfrec.formats.ros.decode import RawMessages
from tfrec.formats.ros.encode import ns_from_stamps
from tfrec.formats.rosbag1.index import message_spans
from tfrec.formats.rosbag1.reader import (
    COMPRESSIONS,
    OP_CHUNK,
    OP_CONNECTION,
    OP_INDEX,
    OP_MESSAGE,
    ROS1_MAGIC,
    RecordDamaged,
    bag_header,
    connection_of,
    header_fields,
    index_connections,
    read_record,
    time_field,
    uint32_field,
)

__all__ = ["Ros1Messages"]

_ENTRY = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("offset", "<u4")])


class Ros1Messages(MessageSource):
    """The raw messages of a ROS 1 bag.

    Args:
        path: the bag.
        where: the recording, for messages.
        resolve: a recorded topic name → the name it is played under.
    """

    def __init__(self, path: Path, *, where: str, resolve: Callable[[str], str]) -> None:
        super().__init__(where, "rosbag1")
        self.path = path
        self.resolve = resolve
        self._conns: dict[int, int] = {}  # the bag's connection id → connection id
        self._index_reached = False  # the walk reached the index section (its chunk info records)

    def batches(self) -> Iterator[MessageBatch]:
        try:
            stream = open(self.path, "rb")  # noqa: SIM115 - closed below
        except OSError as err:
            raise ReadError(f"{self.where}: cannot read: {err.strerror or err}") from err
        with stream:
            size = os.fstat(stream.fileno()).st_size
            if stream.read(len(ROS1_MAGIC)) != ROS1_MAGIC:
                raise ReadError(f"{self.where}: not a ROS 1 bag (format 2.0)")
            header = bag_header(stream, size)
            if header is None:
                raise ReadError(f"{self.where}: cannot read ROS 1 bag: a damaged bag header record, and no record "
                                "where the records after it begin")
            if header.problem:
                warnings.warn(f"{self.where}: {header.problem}; read past it", TfrecWarning, stacklevel=2)
            body_start = header.body_start
            end = self._index(stream, header.fields, body_start, size)
            stream.seek(body_start)
            reached = yield from self._walk(stream, body_start, end, size)
            if end is None and reached and not self._index_reached:
                self._stop(size, size, "the file ends without an index")

    def _index(self, stream: IO[bytes], fields: dict[str, bytes], body_start: int, size: int) -> int | None:
        """Take the connection records of the bag's index; returns where the chunks end (the
        index's position), or None for a bag without an index (a recorder stopped before writing it)."""
        index_pos, connections = index_connections(stream, fields, body_start, size)
        for conn_fields, data in connections:
            self._connection(conn_fields, data)
        return index_pos

    def _walk(self, stream: IO[bytes], pos: int, end: int | None, size: int) -> Generator[MessageBatch, None, bool]:
        """The records from ``pos`` up to ``end`` (the index; None: the end of the file); returns
        whether it got there (else a problem says where it stopped)."""
        while pos < (size if end is None else end):
            try:
                fields, data_pos, data_len = read_record(stream, size, cut_ok=True)
                op = fields.get("op", b"\0")[0]
            except (RecordDamaged, IndexError) as err:
                self._stop(pos, size, str(err) or "a damaged record header")
                return False
            if data_pos + data_len > size:
                if op == OP_CHUNK:
                    batch = self._chunk(fields, stream.read(), {}, pos, cut=True)
                    recovered = 0 if batch is None else len(batch)
                    if batch is not None:
                        yield batch
                    self._stop(size, size, f"the file ends inside a chunk record (recovered {recovered:,} messages of it)")
                else:
                    self._stop(pos, size, "the file ends inside a record")
                return False
            data = stream.read(data_len)
            if op == OP_CHUNK:
                entries = self._index_data(stream, size)
                batch = self._chunk(fields, data, entries, pos, cut=False)
                if batch is not None:
                    yield batch
            elif op == OP_CONNECTION:
                try:
                    self._connection(fields, data)
                except ValueError as err:
                    self._stop(pos, size, f"a damaged connection record ({err})")
                    return False
            elif op == OP_MESSAGE:  # not where format 2.0 puts them
                self.problems.append(f"a message record outside any chunk at byte {pos:,} was skipped")
            elif op != OP_INDEX:
                self._index_reached = True
                break  # the index section (chunk info records): every chunk was read
            pos = stream.tell()
        return True

    def _stop(self, offset: int, size: int, reason: str) -> None:
        self.problems.append(f"reading stopped at byte {offset:,} of {size:,}: {reason}")

    def _connection(self, fields: dict[str, bytes], data: bytes | memoryview) -> None:
        conn = uint32_field(fields, "conn")
        if conn in self._conns:
            return
        found = connection_of(fields, header_fields(data))
        self._conns[conn] = self.connection_id(replace(found, topic=self.resolve(found.topic)))

    def _index_data(self, stream: IO[bytes], size: int) -> dict[int, NDArray[np.void]]:
        """The index data records after a chunk (the stream is left after them)."""
        entries: dict[int, NDArray[np.void]] = {}
        while True:
            at = stream.tell()
            try:
                fields, _, data_len = read_record(stream, size)
                if fields.get("op") != bytes([OP_INDEX]):
                    stream.seek(at)
                    return entries
                conn = uint32_field(fields, "conn")
                data = stream.read(data_len)
                if uint32_field(fields, "ver") != 1 or len(data) % _ENTRY.itemsize:
                    return {}
                entries[conn] = np.frombuffer(data, dtype=_ENTRY)
            except (RecordDamaged, ValueError):
                stream.seek(at)
                return {}

    # -- chunks -------------------------------------------------------------------------------

    def _chunk(self, fields: dict[str, bytes], data: bytes, entries: dict[int, NDArray[np.void]], start: int, *,
               cut: bool) -> MessageBatch | None:
        if self.until_ns is not None and entries and not cut and _first_ns(entries) > self.until_ns:
            return None  # its index says every message in it is past what is wanted
        try:
            compression = fields["compression"].decode("ascii")
            size = uint32_field(fields, "size")
            if cut:
                records = salvage(compression, data, limit=min(size, MAX_CHUNK_BYTES), supported=COMPRESSIONS)
            else:
                records = decompress(compression, data, size, supported=COMPRESSIONS)
        except (KeyError, UnicodeDecodeError, ValueError) as err:
            if not cut:
                self.problems.append(f"a damaged chunk record at byte {start:,} ({err}) was skipped")
            return None
        if entries and not cut and all(conn in self._conns for conn in entries):
            batch = self._indexed(records, entries)
            if batch is not None:
                return batch
        batch, problem = self._records(memoryview(records))
        if problem is not None and not cut:
            self.problems.append(f"a damaged chunk record at byte {start:,} ({problem}): the records before it were read")
        return batch

    def _indexed(self, records: bytes | memoryview, entries: dict[int, NDArray[np.void]]) -> MessageBatch | None:
        """A chunk's messages through its index data records; None when they do not describe it."""
        buffer = np.frombuffer(records, dtype=np.uint8)
        parts = []
        for conn, found in entries.items():
            spans = message_spans(buffer, np.sort(found["offset"].astype(np.int64)), conn)
            if spans is None:
                return None
            parts.append((np.full(len(spans[0]), self._conns[conn], np.int64), *spans))
        if not parts:
            return None
        conns, times, starts, stops = (np.concatenate([part[k] for part in parts]) for k in range(4))
        self.messages += len(conns)
        return MessageBatch.of(conns, times, None, RawMessages(buffer, starts, stops))

    def _records(self, view: memoryview) -> tuple[MessageBatch | None, str | None]:
        """A chunk's records one by one: connections taken, messages returned; and the problem
        that stopped the walk (the records before it are taken)."""
        pos, end = 0, len(view)
        conns: list[int] = []
        times: list[int] = []
        starts: list[int] = []
        stops: list[int] = []
        problem = None
        while pos < end:
            try:
                (header_len,) = struct.unpack_from("<I", view, pos)
                (data_len,) = struct.unpack_from("<I", view, pos + 4 + header_len)
                body = pos + 8 + header_len
                if body + data_len > end:
                    raise ValueError("a record runs past the end of the chunk")
                fields = header_fields(view[pos + 4 : pos + 4 + header_len])
                op = fields.get("op", b"\0")[0]
                if op == OP_MESSAGE:
                    conn = self._conns.get(uint32_field(fields, "conn"))
                    if conn is None:
                        raise ValueError(f"a message on unknown connection {uint32_field(fields, 'conn')}")
                    conns.append(conn)
                    times.append(time_field(fields, "time"))
                    starts.append(body)
                    stops.append(body + data_len)
                elif op == OP_CONNECTION:
                    self._connection(fields, view[body : body + data_len])
                else:
                    raise ValueError(f"a record with op {op} inside the chunk")
            except (struct.error, ValueError) as err:
                problem = str(err)
                break
            pos = body + data_len
        if not conns:
            return None, problem
        self.messages += len(conns)
        return MessageBatch.of(np.array(conns, np.int64), np.array(times, np.int64), None,
                               RawMessages(np.frombuffer(view, dtype=np.uint8), np.array(starts, np.int64),
                                           np.array(stops, np.int64))), problem


def _first_ns(entries: dict[int, NDArray[np.void]]) -> int:
    """The earliest time of a chunk's index data entries (ns)."""
    times = [ns_from_stamps(e["sec"].astype(np.int64), e["nsec"].astype(np.int64)).min() for e in entries.values() if len(e)]
    return int(min(times)) if times else -1
