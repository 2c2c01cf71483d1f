"""Reading a rosbag2 bag's sqlite3 databases (``.db3``) directly, with SQL.

Every message the database holds is read: the ``topics`` table names the topics, and the
``messages`` table is read in one pass — every topic counted (messages, first and last
timestamp), the data of the decoded topics' messages taken, the others' not read. A summary
(``tfrec info``) counts with ``COUNT``, ``MIN`` and ``MAX`` per ``topic_id`` and reads only the
first messages of the decoded topics, by ``topic_id`` in timestamp order. (rosbags' reader matches each of ``metadata.yaml``'s topics to a database row
by its QoS text, and yields nothing for a topic whose QoS differs — rosbag2's own talker bag, or
a QoS edited in ``metadata.yaml`` to make a bag play.)

A ``.db3`` cut short (a recorder killed mid-write) is refused by SQLite as malformed; it is read
as far as possible from a copy whose header's page count is lowered to the pages the file still
has, its ``messages`` table in row order up to the first missing page, and
:attr:`~tfrec.recording.Recording.read_error` says what was lost.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import struct
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tfrec.errors import ReadError, one_line
from tfrec.formats._collect import DECODE_BATCH, Collector, read_error_line
from tfrec.formats.ros.definitions import INTERPRETED, MAX_DEFINITION_CHARS
from tfrec.formats.ros.types import topic_deserializer
from tfrec.formats.rosbag2.metadata import qos_durability
from tfrec.recording import TopicStats

__all__ = ["INTEGER_TIME", "Damaged", "connect_read_only", "open_cut_database", "read_sqlite3_into",
           "salvage_sqlite3_into"]

INTEGER_TIME = "typeof(timestamp) = 'integer'"
"""The rows read: a timestamp that is not an integer (text, a float, NULL — SQLite keeps what it is
given) is damaged data, skipped (metadata.yaml's count then differs, with a warning)."""


class Damaged(Exception):
    """SQLite cannot read a database (or stopped inside it): read it with :func:`salvage_sqlite3_into`."""


def connect_read_only(file: Path) -> sqlite3.Connection:
    """A read-only connection: to the database and its write-ahead log where they can be opened,
    else (a read-only folder without the log's shared-memory file) to the database file alone."""
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


def _topics(db: sqlite3.Connection) -> dict[int, dict[str, Any]]:
    cursor = db.execute("SELECT * FROM topics")
    columns = [column[0] for column in cursor.description]
    return {row[columns.index("id")]: dict(zip(columns, row)) for row in cursor}


def _definitions(db: sqlite3.Connection, types: set[str]) -> dict[str, tuple[str, str]]:
    """The ``message_definitions`` rows (rosbag2 Iron and later) of ``types``: type → (encoding, text).
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
    return {str(msgtype): (str(encoding), str(text)) for msgtype, encoding, text in rows
            if isinstance(encoding, str) and isinstance(text, str)}


def _register(db: sqlite3.Connection, topics: dict[int, dict[str, Any]], collector: Collector, where: str) -> dict[int, str]:
    """Each topic row's resolved name; the decoded ones (whose types have the layout tfrec reads, by the
    database's ``message_definitions`` and type hashes) get their deserializer.

    Raises:
        ReadError: a decoded topic that is not CDR.
    """
    names: dict[int, str] = {}
    definitions = _definitions(db, {str(row["type"]) for row in topics.values()} & set(INTERPRETED))
    for topic_id, row in topics.items():
        name, msgtype = collector.resolve(str(row["name"])), str(row["type"])
        names[topic_id] = name
        encoding, text = definitions.get(msgtype, ("", ""))
        if collector.decodes(name, msgtype, definition=text, definition_encoding=encoding,
                             type_hash=str(row.get("type_description_hash") or "")):
            if row.get("serialization_format", "cdr") != "cdr":
                raise ReadError(f"{where}: topic {name} is not cdr-serialized")
            collector.set_deserializer(name, topic_deserializer(msgtype, where=where, topic=name))
    return names


def _stats(row: dict[str, Any]) -> TopicStats:
    return TopicStats(str(row["type"]), qos_durability(str(row.get("offered_qos_profiles") or "")))


def read_sqlite3_into(files: Sequence[Path], collector: Collector, *, where: str) -> None:
    """Read a bag's ``.db3`` files into ``collector``: counts per topic, decoded topics' messages.

    Args:
        files: the databases, in order.
        collector: where the messages go.
        where: the bag, for messages.

    Raises:
        Damaged: SQLite refuses a database or stops inside one (the collector is then
            half-filled: start again with :func:`salvage_sqlite3_into`).
        ReadError: a decoded topic that is not CDR.
    """
    for file in files:
        try:
            db = connect_read_only(file)
        except sqlite3.Error as err:
            raise Damaged(f"{file.name}: {err}") from err
        try:
            db.execute("PRAGMA mmap_size = 1073741824")  # pages mapped, not copied (no effect where unsupported)
            topics = _topics(db)
            names = _register(db, topics, collector, where)
            stats = {topic_id: _stats(row) for topic_id, row in topics.items()}
            decoded = [topic_id for topic_id, name in names.items() if name in collector.decoded]
            if decoded and not collector.options.summary:
                _scan(db, decoded, names, stats, collector)
            else:
                _count(db, stats)
            for topic_id in topics:
                collector.count(names[topic_id], stats[topic_id])
            if collector.options.summary:
                for topic_id in decoded:
                    if stats[topic_id].count:
                        _decode(db, topic_id, names[topic_id], collector)
        except (sqlite3.DatabaseError, ValueError) as err:
            raise Damaged(f"{file.name}: {one_line(str(err))}") from err
        finally:
            db.close()


def _count(db: sqlite3.Connection, stats: dict[int, TopicStats]) -> None:
    """Count every topic's messages, first and last timestamps, without reading their data."""
    for topic_id, count, first, last in db.execute("SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) "
                                                   f"FROM messages WHERE {INTEGER_TIME} GROUP BY topic_id"):
        if topic_id in stats:
            stats[topic_id].count += int(count)
            stats[topic_id].add_times(int(first), int(last))


def _scan(db: sqlite3.Connection, decoded: list[int], names: dict[int, str], stats: dict[int, TopicStats],
          collector: Collector) -> None:
    """One pass over the messages table: every topic counted, the decoded topics' messages handed to the
    collector a batch at a time (the others' data is not read: SQLite leaves a column it is not asked for)."""
    wanted = ", ".join(str(int(topic_id)) for topic_id in decoded)
    cursor = db.execute(f"SELECT topic_id, timestamp, CASE WHEN topic_id IN ({wanted}) THEN data END "
                        f"FROM messages WHERE {INTEGER_TIME}")
    while True:
        rows = cursor.fetchmany(DECODE_BATCH)
        if not rows:
            return
        id_column, time_column, datas = zip(*rows)  # columns, transposed in C
        ids, times = np.array(id_column, dtype=np.int64), np.array(time_column, dtype=np.int64)
        for topic_id in np.unique(ids).tolist():
            if topic_id not in stats:
                continue
            index = np.flatnonzero(ids == topic_id)
            chosen = times[index]
            stats[topic_id].count += len(index)
            stats[topic_id].add_times(int(chosen.min()), int(chosen.max()))
            if topic_id in decoded:
                collector.add(names[topic_id], [datas[i] for i in index.tolist()], chosen)


def _decode(db: sqlite3.Connection, topic_id: int, name: str, collector: Collector) -> None:
    """Hand a decoded topic's first messages to the collector, in timestamp order (a summary's)."""
    remaining = collector.remaining(name)
    if remaining == 0:
        return
    query = f"SELECT timestamp, data FROM messages WHERE topic_id = ? AND {INTEGER_TIME} ORDER BY timestamp"
    cursor = db.execute(query + ("" if remaining is None else f" LIMIT {int(remaining)}"), (topic_id,))
    while True:
        rows = cursor.fetchmany(DECODE_BATCH)
        if not rows:
            return
        collector.add(name, [row[1] for row in rows], [row[0] for row in rows])


# -- a damaged database ---------------------------------------------------------------------------


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


def salvage_sqlite3_into(files: Sequence[Path], collector: Collector, *, where: str, refused: str) -> None:
    """Read the messages of a bag's databases that SQLite still gives, in row order.

    Args:
        files: the ``.db3`` files.
        collector: a fresh collector.
        where: the bag, for messages.
        refused: why the databases could not be read whole, for the error when nothing is readable either.

    Raises:
        ReadError: a file whose topics table cannot be read.
    """
    pending: dict[str, list[tuple[int, bytes]]] = {}
    problems: list[str] = []
    for file in files:
        with tempfile.TemporaryDirectory(prefix="tfrec-") as scratch:
            try:
                db, note = open_cut_database(file, Path(scratch) / file.name)
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
        collector.recording.read_error = read_error_line(where, problems, total)


def _read_rows(db: sqlite3.Connection, collector: Collector, pending: dict[str, list[tuple[int, bytes]]], *,
               where: str, refused: str) -> tuple[int, str] | None:
    """Read one database's topics and messages: counted in ``collector``, the decoded topics'
    (log time, message) into ``pending``; returns (messages read, SQLite's error) when reading
    stopped early, else None.

    Raises:
        ReadError: the topics table cannot be read.
    """
    try:
        topics = _topics(db)
    except (sqlite3.DatabaseError, ValueError):
        raise ReadError(f"{where}: cannot read rosbag2 bag: {one_line(refused)}")
    names = _register(db, topics, collector, where)
    for topic_id, row in topics.items():
        collector.topic(names[topic_id], str(row["type"]), _stats(row).durability)
    read = 0
    try:
        for topic_id, time_ns, data in db.execute(f"SELECT topic_id, timestamp, data FROM messages WHERE {INTEGER_TIME}"):
            if topic_id not in topics:
                continue
            name = names[topic_id]
            collector.topics[name].add(time_ns)
            if name in collector.decoded:
                pending.setdefault(name, []).append((time_ns, bytes(data)))
            read += 1
    except sqlite3.DatabaseError as err:
        return read, str(err)
    return None
