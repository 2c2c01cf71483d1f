"""A rosbag2 bag's messages in sqlite3 storage, in one walk: tfrec's one reader of ``.db3`` files, with SQL.

:class:`Sqlite3Source` reads each database's ``topics`` table (names, types, offered QoS, type hashes) and, when the
bag has one (Iron and later), its ``message_definitions`` table as
:class:`~tfrec.formats.ros.connection.Connection` s, then its ``messages`` table in one pass in timestamp order, a
batch of rows at a time: every topic counted (messages, first and last timestamp), the data of the connections asked
for taken — SQLite leaves a column it is not asked for — and the others' not read. Every message the database holds
is read, whatever ``metadata.yaml`` says of its QoS (rosbags' reader matches each of ``metadata.yaml``'s topics to a
database row by its QoS text, and yields nothing for a topic whose QoS differs — rosbag2's own talker bag, or a QoS
edited in ``metadata.yaml`` to make a bag play). A bag's MCAP storage is read by
:class:`tfrec.formats.mcap.source.McapSource`.

Nothing a database brings is run: its ``topics`` and ``messages`` must be plain tables (a view or a virtual table is
code run by every read), and a row whose timestamp is not an integer or whose data is not a blob is damaged data,
skipped. A database SQLite
refuses (a recorder killed mid-write) is read from a copy whose page count is lowered to the pages the file holds,
in row order up to the first missing page (:func:`open_cut_database`);
:attr:`~tfrec.formats.ros.connection.MessageSource.read_error` says what was lost.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import struct
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import ReadError, one_line
from tfrec.formats.ros.connection import (
    BATCH_MESSAGES,
    Connection,
    MessageBatch,
    MessageSource,
    distinct,
    full_type,
    raw_messages,
)
from tfrec.formats.ros.definitions import MAX_DEFINITION_CHARS
from tfrec.formats.rosbag2.metadata import qos_durability

__all__ = ["WELL_FORMED", "Sqlite3Source", "connect_read_only", "open_cut_database"]

WELL_FORMED = "typeof(timestamp) = 'integer' AND typeof(data) = 'blob'"
"""The rows read: a timestamp that is not an integer, or data that is not a blob (text, a number, NULL — SQLite
keeps what it is given, in a table made without rosbag2's constraints), is damaged data, skipped (metadata.yaml's
count then differs, with a warning)."""


def connect_read_only(file: Path) -> sqlite3.Connection:
    """A read-only connection: to the database and its write-ahead log where they can be opened,
    else (a read-only folder without the log's shared-memory file) to the database file alone.

    Raises:
        ReadError: ``topics`` or ``messages`` is a view or a virtual table.
    """
    try:
        db = sqlite3.connect(f"{file.resolve().as_uri()}?mode=ro", uri=True)
        db.execute("SELECT 1 FROM sqlite_master LIMIT 1").fetchall()
    except sqlite3.OperationalError:
        db = sqlite3.connect(f"{file.resolve().as_uri()}?immutable=1", uri=True)
    return _plain_tables(db, file)


def _plain_tables(db: sqlite3.Connection, file: Path) -> sqlite3.Connection:
    """``db``, once its ``topics`` and ``messages`` are plain tables: a view or a virtual table is
    code run by every read (a recursive view never ends, and SQLite does not return to Python to
    see a signal while it runs).

    Raises:
        ReadError: ``topics`` or ``messages`` is a view or a virtual table.
    """
    try:
        kinds = {str(name).lower(): (str(kind), str(sql or "")) for name, kind, sql in db.execute(
            "SELECT name, type, sql FROM sqlite_master WHERE lower(name) IN ('topics', 'messages')")}
    except sqlite3.DatabaseError:
        return db  # unreadable: what reads it says so (or salvages it)
    for name, (kind, sql) in sorted(kinds.items()):
        if kind != "table" or sql.lstrip().upper().startswith("CREATE VIRTUAL"):
            db.close()
            what = "a view" if kind == "view" else "a virtual table" if kind == "table" else f"a {kind}"
            raise ReadError(f"{file}: its '{name}' is {what}, not a table: not a rosbag2 database (tfrec runs no "
                            "SQL a bag brings)")
    return db


def open_cut_database(file: Path, copy: Path) -> tuple[sqlite3.Connection, str]:
    """A damaged ``.db3``, copied to ``copy`` with the page count in its header lowered to the
    pages the file holds (else SQLite refuses the whole file as malformed), opened; and what was
    wrong with it."""
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
    return _plain_tables(sqlite3.connect(copy), file), note


def _topics(db: sqlite3.Connection) -> dict[int, dict[str, Any]]:
    cursor = db.execute("SELECT * FROM topics")
    columns = [column[0] for column in cursor.description]
    return {row[columns.index("id")]: dict(zip(columns, row)) for row in cursor}


def _definitions(db: sqlite3.Connection, types: set[str]) -> dict[str, tuple[str, str]]:
    """The ``message_definitions`` rows (rosbag2 Iron and later) of ``types``: type (as ROS 2 names it) →
    (encoding, text); a definition past :data:`~tfrec.formats.ros.definitions.MAX_DEFINITION_CHARS` is left out.
    Nothing when the table is missing, or is a view or a virtual table (SQL a bag brings is not run)."""
    try:
        kind = db.execute("SELECT type, sql FROM sqlite_master WHERE lower(name) = 'message_definitions'").fetchone()
        if not types or kind is None or kind[0] != "table" or str(kind[1] or "").lstrip().upper().startswith(
                "CREATE VIRTUAL"):
            return {}
        marks = ", ".join("?" * len(types))
        rows = db.execute("SELECT topic_type, encoding, encoded_message_definition FROM message_definitions "
                          f"WHERE topic_type IN ({marks}) AND length(encoded_message_definition) <= ?",
                          (*sorted(types), MAX_DEFINITION_CHARS)).fetchall()
    except sqlite3.DatabaseError:
        return {}
    return {full_type(str(msgtype)): (str(encoding), str(text)) for msgtype, encoding, text in rows
            if isinstance(encoding, str) and isinstance(text, str) and text}


def _fetched(cursor: sqlite3.Cursor, *, careful: bool) -> Iterator[list[Any]]:
    """A query's rows, :data:`~tfrec.formats.ros.connection.BATCH_MESSAGES` at a time; ``careful``: row by row, so
    that the rows before one SQLite cannot read are given before its error."""
    if not careful:
        while rows := cursor.fetchmany(BATCH_MESSAGES):
            yield rows
        return
    rows = []
    try:
        for row in cursor:
            rows.append(row)
            if len(rows) >= BATCH_MESSAGES:
                yield rows
                rows = []
    except sqlite3.DatabaseError:
        if rows:
            yield rows
        raise
    if rows:
        yield rows


_Columns = tuple[NDArray[np.int64], NDArray[np.int64], tuple[Any, ...]]
"""Rows as columns: topic ids, timestamps, data (None where not read)."""


def _columns(rows: list[Any]) -> _Columns:
    topic_ids, times, datas = zip(*rows)  # transposed in C
    return np.array(topic_ids, dtype=np.int64), np.array(times, dtype=np.int64), datas


class _Ties:
    """The rows read so far that share the last timestamp, per topic id: where reading in timestamp order goes on."""

    def __init__(self) -> None:
        self.time_ns = -1
        self.counts: dict[int, int] = {}

    def follow(self, topics: NDArray[np.int64], stamps: NDArray[np.int64]) -> None:
        """Take the next rows read (in timestamp order)."""
        if not len(stamps):
            return
        last = int(stamps[-1])
        if last != self.time_ns:
            self.time_ns, self.counts = last, {}
        tied = topics[stamps == last]
        for topic_id, count in zip(*np.unique(tied, return_counts=True)):
            self.counts[int(topic_id)] = self.counts.get(int(topic_id), 0) + int(count)


class Sqlite3Source(MessageSource):
    """The messages of a rosbag2 bag's sqlite3 databases, file by file, each in timestamp order.

    Args:
        files: the ``.db3`` files, in order.
        where: the bag, for messages.
        resolve: a recorded topic name → the name it is played under.
        decompress: decompresses each message (a bag compressed message by message).
    """

    def __init__(self, files: Sequence[Path], *, where: str, resolve: Callable[[str], str],
                 decompress: Callable[[bytes], bytes] | None = None) -> None:
        super().__init__(where, "rosbag2")
        self.files = list(files)
        self.resolve = resolve
        self.decompress = decompress
        self._problems: list[str] = []

    def _walk(self) -> Iterator[MessageBatch]:
        for file in self.files:
            yield from self._file(file)
        if self._problems:
            self.lost(self.where, self._problems, self.counted)

    def _file(self, file: Path) -> Iterator[MessageBatch]:
        """One database, in timestamp order; salvaged when SQLite refuses it."""
        read = 0
        try:
            db = connect_read_only(file)
            try:
                # no memory map: its pages of a long bag would stay resident (a 4 h bag is 1.7 GB); read through
                # SQLite's page cache, memory does not grow with the bag
                db.execute("PRAGMA mmap_size = 0")
                ids = self._connections(db)
                for batch, rows in self._rows(db, ids, ordered=True):
                    read += rows
                    if batch is not None:
                        yield batch
            finally:
                db.close()
        except sqlite3.DatabaseError as err:
            if read:  # the rows after it are lost
                self._problems.append(f"reading {file.name} stopped after {read:,} messages: {one_line(str(err))}")
                return
            yield from self._salvage(file, f"{file.name}: {one_line(str(err))}")

    def _connections(self, db: sqlite3.Connection) -> dict[int, int]:
        """The topics table as connections: topic id → connection id."""
        rows = _topics(db)
        types = {str(row["type"]) for row in rows.values()}
        definitions = _definitions(db, types | {full_type(msgtype) for msgtype in types})
        ids: dict[int, int] = {}
        for topic_id, row in rows.items():
            msgtype = full_type(str(row["type"]))
            encoding, text = definitions.get(msgtype, ("", ""))
            qos = str(row.get("offered_qos_profiles") or "")
            durability = qos_durability(qos)
            ids[int(topic_id)] = self.connection_id(Connection(
                topic=self.resolve(str(row["name"])), msgtype=msgtype,
                encoding=str(row.get("serialization_format") or "cdr"), definition=text, definition_encoding=encoding,
                latched=durability == "transient_local", qos=qos,
                type_hash=str(row.get("type_description_hash") or ""),
            ), durability, shown_type=str(row["type"]))
        return ids

    def _rows(self, db: sqlite3.Connection, ids: dict[int, int], *,
              ordered: bool) -> Iterator[tuple[MessageBatch | None, int]]:
        """The messages table, in timestamp order (``ordered``) or in row order (a damaged database: the rows one
        by one, so that those before a row SQLite cannot read are kept), a batch of rows at a time: every row
        counted, the wanted ones' data taken. Once some connections are done (a summary has the first messages it
        wants), the rest is counted with SQL and only the rows still wanted are read.

        Yields:
            The batch of the wanted messages (None when there are none) and how many rows were counted.

        Raises:
            sqlite3.DatabaseError: SQLite stopped (the rows before are yielded first).
        """
        until = "" if self.until_ns is None else f" AND timestamp <= {int(self.until_ns)}"
        needed = [topic_id for topic_id, conn in ids.items() if self.wanted(conn)]
        cursor = db.execute(f"SELECT topic_id, timestamp, CASE WHEN topic_id IN ({', '.join(map(str, needed))}) "
                            f"THEN data END FROM messages WHERE {WELL_FORMED}{until}"
                            f"{' ORDER BY timestamp, rowid' if ordered else ''}")
        known = np.array(sorted(ids), dtype=np.int64)
        ties = _Ties()
        for rows in _fetched(cursor, careful=not ordered):
            columns = _columns(rows)
            ties.follow(columns[0], columns[1])
            known_rows = np.isin(columns[0], known)
            if not known_rows.all():  # rows of no topic: not counted
                index = np.flatnonzero(known_rows)
                columns = columns[0][index], columns[1][index], tuple(columns[2][i] for i in index.tolist())
            if len(columns[0]):
                yield self._batch(columns, ids, count=True), len(columns[0])
            if ordered and any(not self.wanted(ids[topic_id]) for topic_id in needed):
                break
        else:
            return
        cursor.close()
        left = self._count_rest(db, ids, f"{until} AND timestamp >= {ties.time_ns}", ties.counts)
        yield None, sum(left.values())
        needed = [topic_id for topic_id, conn in ids.items() if self.wanted(conn) and left.get(topic_id, 0) > 0]
        if needed:
            cursor = db.execute(f"SELECT topic_id, timestamp, data FROM messages WHERE {WELL_FORMED}{until} AND "
                                f"timestamp >= {ties.time_ns} AND topic_id IN ({', '.join(map(str, needed))}) "
                                "ORDER BY timestamp, rowid")
            skip = sum(ties.counts.get(topic_id, 0) for topic_id in needed)  # those read already
            for rows in _fetched(cursor, careful=False):
                rows, skip = rows[skip:], max(0, skip - len(rows))
                if rows:
                    yield self._batch(_columns(rows), ids, count=False), 0

    def _count_rest(self, db: sqlite3.Connection, ids: dict[int, int], where: str,
                    read: dict[int, int]) -> dict[int, int]:
        """Count the rows left with SQL: those ``where`` says, but the ``read`` ones (topic id → rows) counted
        already; returns how many of each topic id (a topic with none left needs no more reading). The pages are
        read, not mapped: counting needs no row's data, and mapped pages of the whole file would count as the
        process's memory (a one-hour bag's 436 MB)."""
        db.execute("PRAGMA mmap_size = 0")  # takes effect as no statement is running
        left: dict[int, int] = {}
        for topic_id, count, first, last in db.execute(
                f"SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages WHERE {WELL_FORMED}{where} "
                "GROUP BY topic_id"):
            if topic_id in ids:
                stats = self.stats[ids[topic_id]]
                left[topic_id] = rest = int(count) - read.get(topic_id, 0)
                stats.count += rest
                stats.add_times(int(first), int(last))
        return left

    def _batch(self, columns: _Columns, lut: dict[int, int], *, count: bool) -> MessageBatch | None:
        """Rows (topic ids, timestamps, data or None) counted (``count``), and those with data as a batch."""
        topics, stamps, datas = columns
        present = distinct(topics)
        conns = np.empty(len(topics), dtype=np.int64)
        for topic_id in present:
            chosen = topics == topic_id
            conns[chosen] = conn = lut[topic_id]
            if count:
                taken = stamps[chosen]
                stats = self.stats[conn]
                stats.count += len(taken)
                stats.add_times(int(taken.min()), int(taken.max()))
        wanted = np.array([self.wanted(conn) for conn in range(len(self.connections))], dtype=bool)[conns]
        if wanted.all():
            data = list(datas)
            index = np.arange(len(datas))
        else:  # the others' data was not read (or is no longer wanted)
            index = np.flatnonzero(wanted)
            if not len(index):
                return None
            data = [datas[i] for i in index.tolist()]
        if self.decompress is not None:
            data = [self.decompress(bytes(message)) for message in data]
        self.messages += len(index)
        return MessageBatch.of(conns[index], stamps[index], None, raw_messages(data))

    def _salvage(self, file: Path, refused: str) -> Iterator[MessageBatch]:
        """A database SQLite refuses, read in row order from a copy, as far as SQLite goes.

        Raises:
            ReadError: the copy cannot be made, or its topics table cannot be read.
        """
        with tempfile.TemporaryDirectory(prefix="tfrec-") as scratch:
            try:
                db, note = open_cut_database(file, Path(scratch) / file.name)
            except OSError as err:
                raise ReadError(f"{self.where}: cannot read {file.name}: {err.strerror or err}") from err
            read = 0
            try:
                try:
                    ids = self._connections(db)
                except (sqlite3.DatabaseError, ValueError):
                    raise ReadError(f"{self.where}: cannot read rosbag2 bag: {one_line(refused)}") from None
                for batch, rows in self._rows(db, ids, ordered=False):
                    read += rows
                    if batch is not None:
                        yield batch
            except sqlite3.DatabaseError as err:
                self._problems.append(f"reading {file.name} stopped after {read:,} messages: {one_line(str(err))}{note}")
            finally:
                db.close()
