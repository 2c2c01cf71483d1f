"""Reading rosbag2 folders and ROS 1 bags with rosbags' ``AnyReader``; what it refuses, as far as readable.

A ROS 1 bag that rosbags refuses is read record by record (:mod:`tfrec.formats.rosbag1.reader`);
a sqlite3 ``.db3`` cut short through SQLite, from a copy whose header's page count is lowered to
the pages the file still has, its ``messages`` table in row order up to the first missing page.
"""

from __future__ import annotations

import contextlib
import functools
import io
import os
import sqlite3
import struct
import tempfile
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any, BinaryIO

from tfrec.errors import ReadError, one_line
from tfrec.formats._collect import DECODE_BATCH, Collector, read_error_line
from tfrec.formats._compression import MAX_CHUNK_BYTES, decompress, inflate_at_most
from tfrec.formats.ros.types import topic_deserializer, typestore
from tfrec.formats.rosbag1.reader import read_rosbag1_records, ros1_compression
from tfrec.formats.rosbag2.metadata import BagMetadata, qos_durability
from tfrec.recording import Recording

__all__ = [
    "read_rosbags",
]

class _Refused(Exception):
    """rosbags cannot read the bag (its index or database is damaged)."""


def read_rosbags(path: Path, fmt: str, wanted: frozenset[str], meta: BagMetadata | None = None) -> Recording:
    """Read a bag with rosbags; a ROS 1 or sqlite3 bag that it refuses as far as it is readable."""
    where = os.fspath(path)
    try:
        with _bounded_decompression():
            recording = _read_anyreader(path, fmt, wanted)
    except _Refused as err:
        refused = str(err)
        if fmt == "rosbag1":
            return read_rosbag1_records(path, wanted, refused=refused)
        if meta is not None and meta.storage == "sqlite3":
            return _read_sqlite3_rows(path, meta.files, wanted, refused=refused)
        raise ReadError(f"{where}: cannot read rosbag2 bag: {refused}") from err
    if fmt == "rosbag1":
        recording.details["compression"] = ros1_compression(path)
    elif meta is not None:
        recording.details["storage"] = meta.storage
        if meta.compression:
            recording.details["compression"] = meta.compression
    return recording


_DAMAGED_DATA: tuple[type[Exception], ...] = (AssertionError, IndexError, KeyError, ValueError, struct.error)
"""What rosbags raises, besides its own errors, on damaged data that it does not check: its
assertions about the data (a message's time against its index entry), a connection or chunk
missing from its tables, a buffer shorter than its length field, an offset or text that is not
one. Caught only around rosbags' own calls (opening the bag, taking the next message), so that
tfrec's bugs keep their traceback."""


def _read_anyreader(path: Path, fmt: str, wanted: frozenset[str]) -> Recording:
    """Read a bag with rosbags' AnyReader.

    Raises:
        _Refused: rosbags cannot read it, or stopped at damaged data (its message is one line).
        ReadError: the file cannot be read (an OSError with an errno), or its message
            types cannot be decoded.
    """
    from rosbags.highlevel import AnyReader
    from rosbags.serde import SerdeError

    where = os.fspath(path)
    ros1 = fmt == "rosbag1"
    recording = Recording(path=where, format=fmt)
    collector = Collector(recording, wanted, ros1=ros1)
    try:
        reader = AnyReader([path], default_typestore=typestore(ros1=ros1))
        reader.open()
    except _rosbags_errors() as err:
        raise _refusal(where, err) from err
    try:
        decoded = []
        durability: dict[str, str | None] = {}
        for connection in reader.connections:
            durability.setdefault(connection.topic, _durability(connection.ext))
            if collector.decodes(connection.topic, connection.msgtype):
                if not ros1 and getattr(connection.ext, "serialization_format", "cdr") != "cdr":
                    raise ReadError(f"{where}: topic {connection.topic} is not cdr-serialized")
                decoded.append(connection)
                collector.set_deserializer(connection.topic, topic_deserializer(
                    connection.msgtype, where=where, topic=connection.topic, ros1=ros1, store=reader.typestore))
        pending: dict[str, list[bytes]] = {}
        for connection, log_time, raw in _messages(reader, where):
            topic = connection.topic
            collector.topic(topic, connection.msgtype, durability[topic]).add(log_time)
            if connection in decoded:
                batch = pending.setdefault(topic, [])
                batch.append(raw)
                if len(batch) >= DECODE_BATCH:
                    collector.add(topic, batch)
                    pending[topic] = []
        for topic, batch in pending.items():
            collector.add(topic, batch)
    except SerdeError as err:
        raise ReadError(f"{where}: cannot decode a message: {one_line(str(err))}") from err
    finally:
        reader.close()
    return collector.finish()


@contextlib.contextmanager
def _bounded_decompression() -> Iterator[None]:
    """rosbags inflates whatever a bag holds, whatever its size: a 5 kB bz2 chunk of a ROS 1 bag to 4 GiB of
    zeros, a zstd chunk of a rosbag2 MCAP past what it declares, a zstd message or file of a compressed rosbag2
    bag. While it reads, its decompressors are tfrec's bounded ones (:mod:`tfrec.formats._compression`): a chunk
    never past what it declares or :data:`MAX_CHUNK_BYTES`, a message or ROS 1 chunk (no size declared to
    rosbags) never past :data:`MAX_CHUNK_BYTES`, a compressed file never past :data:`MAX_FILE_RATIO` times its
    size. What inflates past is a ValueError: damaged data."""
    import rosbags.rosbag1.reader as ros1_reader
    import rosbags.rosbag2.reader as ros2_reader
    import rosbags.rosbag2.storage_mcap as mcap_storage

    with _PATCH_LOCK:
        saved = dict(ros1_reader.decompressors), dict(mcap_storage.DECOMPRESSORS), vars(ros2_reader)["zstd"]
        ros1_reader.decompressors.update({kind: functools.partial(_at_most, kind) for kind in ("bz2", "lz4")})
        mcap_storage.DECOMPRESSORS.update({kind: functools.partial(_as_declared, kind) for kind in ("lz4", "zstd")})
        vars(ros2_reader)["zstd"] = _BoundedZstd  # its per-message and per-file decompression
        try:
            yield
        finally:
            ros1_reader.decompressors.clear()
            ros1_reader.decompressors.update(saved[0])
            mcap_storage.DECOMPRESSORS.clear()
            mcap_storage.DECOMPRESSORS.update(saved[1])
            vars(ros2_reader)["zstd"] = saved[2]


_PATCH_LOCK = threading.RLock()
"""One bag at a time in rosbags' patched decompressors (their tables are module-level)."""

MAX_FILE_RATIO = 1000
"""A file of a rosbag2 bag compressed per file may inflate to at most this many times its size, or 64 MiB
(zstd makes 4 GiB of zeros out of 131 kB, a ratio of 32,000; recorded messages compress less than 100-fold).
rosbags inflates such a file into a temporary folder before reading it: this bounds the disk it fills."""


def _at_most(kind: str, data: bytes) -> bytes:
    return bytes(inflate_at_most(kind, data, MAX_CHUNK_BYTES))


def _as_declared(kind: str, data: bytes, size: int) -> bytes:
    return bytes(decompress(kind, data, size, limit=MAX_CHUNK_BYTES))


class _BoundedZstd:
    """What rosbags' rosbag2 reader uses of its ``zstd`` module, bounded."""

    @staticmethod
    def decompress(data: bytes) -> bytes:
        return bytes(inflate_at_most("zstd", data, MAX_CHUNK_BYTES))

    @staticmethod
    def open(stream: BinaryIO, mode: str = "rb") -> _BoundedReader:
        import zstandard

        size = os.fstat(stream.fileno()).st_size
        return _BoundedReader(zstandard.ZstdDecompressor().stream_reader(stream), max(64 << 20, MAX_FILE_RATIO * size))


class _BoundedReader(io.RawIOBase):
    """A zstd stream that raises ValueError past ``limit`` bytes of output."""

    def __init__(self, reader: Any, limit: int) -> None:
        super().__init__()
        self._reader, self._limit, self._count = reader, limit, 0

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        import zstandard

        try:
            data = self._reader.read(len(buffer))
        except zstandard.ZstdError as err:
            raise ValueError(f"zstd: {err}") from err
        self._count += len(data)
        if self._count > self._limit:
            raise ValueError(f"a compressed file inflates to more than {self._limit:,} bytes "
                             f"(at most {MAX_FILE_RATIO} times its size)")
        buffer[:len(data)] = data
        return len(data)


def _messages(reader: Any, where: str) -> Iterator[tuple[Any, int, bytes]]:
    """``reader.messages()``, with what rosbags raises on damaged data turned into :class:`_Refused`."""
    messages = reader.messages()
    while True:
        try:
            message = next(messages)
        except StopIteration:
            return
        except _rosbags_errors() as err:
            raise _refusal(where, err) from err
        yield message


def _rosbags_errors() -> tuple[type[Exception], ...]:
    """What rosbags raises when it cannot read a bag: see :func:`_refusal`."""
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error

    return (AnyReaderError, Reader1Error, Reader2Error, sqlite3.DatabaseError, EOFError, RuntimeError, OSError,
            MemoryError, *_DAMAGED_DATA)


def _refusal(where: str, err: Exception) -> Exception:
    """What an error of :func:`_rosbags_errors` means: :class:`_Refused` (the bag is damaged, or
    rosbags refuses it), or a :class:`ReadError` when the file cannot be read at all."""
    text = one_line(str(err))
    if isinstance(err, OSError) and (err.errno is not None or isinstance(err, FileNotFoundError)):
        return ReadError(f"{where}: cannot read: {err.strerror or text}")
    if isinstance(err, OSError):  # bz2 says "Invalid data stream" as an OSError without an errno
        return _Refused(f"a damaged chunk ({text})")
    if isinstance(err, (EOFError, RuntimeError)):  # a chunk that does not decompress (bz2, lz4)
        return _Refused(f"a damaged chunk ({type(err).__name__}: {text})")
    if isinstance(err, MemoryError):  # rosbags reads as many bytes as a length field says, before looking
        return _Refused("damaged data (a length field asks for more memory than there is)")
    if isinstance(err, _DAMAGED_DATA):
        return _Refused(f"damaged data ({type(err).__name__}{': ' + text if text else ''})")
    return _Refused(text)


def _durability(ext: Any) -> str | None:
    """A rosbags connection's QoS durability (rosbag2), or ``latched`` for a latching ROS 1 topic."""
    profiles = getattr(ext, "offered_qos_profiles", None)
    if profiles:
        durability = getattr(profiles[0], "durability", None)
        return str(durability.name).lower() if durability is not None else None
    return "latched" if getattr(ext, "latching", None) else None


def _open_cut_database(file: Path, copy: Path) -> tuple[sqlite3.Connection, str]:
    """A damaged ``.db3``, copied to ``copy`` with the page count in its header lowered to the
    pages the file holds (else SQLite refuses the whole file as malformed), opened; and what was
    wrong with it."""
    import shutil

    shutil.copyfile(file, copy)
    note = ""
    with open(copy, "r+b") as stream:
        head = stream.read(100)
        size = os.fstat(stream.fileno()).st_size
        if len(head) == 100 and head.startswith(b"SQLite format 3\0"):
            (page_size,) = struct.unpack_from(">H", head, 16)
            page_size = 65536 if page_size == 1 else page_size
            (pages,) = struct.unpack_from(">I", head, 28)
            have = size // page_size if page_size else 0
            if 0 < have < pages:
                stream.seek(28)
                stream.write(struct.pack(">I", have))
                note = f" (the file holds {size:,} of the {pages * page_size:,} bytes its header gives)"
    return sqlite3.connect(copy), note


def _read_sqlite3_rows(folder: Path, files: Sequence[Path], wanted: frozenset[str], *, refused: str) -> Recording:
    """Read the messages of a rosbag2 sqlite3 bag that SQLite still gives, in row order.

    Args:
        folder: the bag folder.
        files: its ``.db3`` files, from metadata.yaml.
        wanted: the topics to decode.
        refused: why rosbags refused the bag, for the error when nothing is readable either.

    Raises:
        ReadError: a file whose topics table cannot be read.
    """
    where = os.fspath(folder)
    recording = Recording(path=where, format="rosbag2", details={"storage": "sqlite3"})
    collector = Collector(recording, wanted, ros1=False)
    pending: dict[str, list[tuple[int, bytes]]] = {}
    problems: list[str] = []
    for file in files:
        with tempfile.TemporaryDirectory(prefix="tfrec-") as scratch:
            try:
                db, note = _open_cut_database(file, Path(scratch) / file.name)
            except OSError as err:
                raise ReadError(f"{where}: cannot read {file.name}: {err.strerror or err}") from err
            try:
                problem = _read_rows(db, collector, pending, where=where, refused=refused)
            finally:
                db.close()
        if problem is not None:
            problems.append(f"reading {file.name} stopped after {problem[0]:,} messages: {problem[1]}{note}")
    for name, messages in pending.items():
        collector.add_in_time_order(name, messages)
    if problems:
        total = sum(stats.count for stats in collector.topics.values())
        recording.read_error = read_error_line(where, problems, total)
    return collector.finish()


def _read_rows(db: sqlite3.Connection, collector: Collector, pending: dict[str, list[tuple[int, bytes]]], *,
               where: str, refused: str) -> tuple[int, str] | None:
    """Read one database's topics and messages: counted in ``collector``, the decoded topics'
    (log time, message) into ``pending``; returns (messages read, SQLite's error) when reading
    stopped early, else None.

    Raises:
        ReadError: the topics table cannot be read.
    """
    try:
        cursor = db.execute("SELECT * FROM topics")
        columns = [column[0] for column in cursor.description]
        topics = {row[columns.index("id")]: dict(zip(columns, row)) for row in cursor}
    except (sqlite3.DatabaseError, ValueError):
        raise ReadError(f"{where}: cannot read rosbag2 bag: {one_line(refused)}")
    for topic in topics.values():
        name, msgtype = str(topic["name"]), str(topic["type"])
        if collector.decodes(name, msgtype) and name not in collector.deserializers:
            if topic.get("serialization_format", "cdr") != "cdr":
                raise ReadError(f"{where}: topic {name} is not cdr-serialized")
            collector.set_deserializer(name, topic_deserializer(msgtype, where=where, topic=name))
    read = 0
    try:
        for topic_id, time_ns, data in db.execute("SELECT topic_id, timestamp, data FROM messages"):
            row = topics.get(topic_id)
            if row is None:
                continue
            name = str(row["name"])
            stats = collector.topics.get(name)
            if stats is None:
                durability = qos_durability(str(row.get("offered_qos_profiles") or ""))
                stats = collector.topic(name, str(row["type"]), durability)
            stats.add(time_ns)
            if name in collector.deserializers:
                pending.setdefault(name, []).append((time_ns, bytes(data)))
            read += 1
    except sqlite3.DatabaseError as err:
        return read, str(err)
    return None
