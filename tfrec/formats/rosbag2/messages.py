"""A rosbag2 bag's raw messages in sqlite3 storage, for copying them (``tfrec convert``).

:class:`Sqlite3Messages` reads each ``.db3`` file's ``messages`` table in timestamp order, a batch
of rows at a time; its ``topics`` table (offered QoS, type hash) and, when the bag has one
(Iron and later), its ``message_definitions`` table give the
:class:`~tfrec.formats.ros.connection.Connection` s. A bag's MCAP storage is read by
:class:`tfrec.formats.mcap.messages.McapMessages`.

A database SQLite refuses (a recorder killed mid-write) is read from a copy whose page count is
lowered to the pages the file holds, in row order up to the first missing page
(:func:`~tfrec.formats.rosbag2.sqlite3.open_cut_database`);
:attr:`~tfrec.formats.ros.connection.MessageSource.problems` says what was lost.
"""

from __future__ import annotations

import sqlite3
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tfrec.errors import ReadError, one_line
from tfrec.formats.ros.connection import Connection, MessageBatch, MessageSource, full_type, raw_messages
from tfrec.formats.rosbag2.metadata import qos_durability
from tfrec.formats.rosbag2.sqlite3 import INTEGER_TIME, connect_read_only, open_cut_database

__all__ = ["Sqlite3Messages"]

_BATCH = 32768
"""Rows read at once."""


class Sqlite3Messages(MessageSource):
    """The raw messages of a rosbag2 bag's sqlite3 databases, file by file, each in timestamp order.

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

    def batches(self) -> Iterator[MessageBatch]:
        for file in self.files:
            read = 0
            try:
                db = connect_read_only(file)
                try:
                    ids = self._topics(db)
                    until = "" if self.until_ns is None else f" AND timestamp <= {int(self.until_ns)}"
                    cursor = db.execute(f"SELECT topic_id, timestamp, data FROM messages WHERE {INTEGER_TIME}{until} "
                                        "ORDER BY timestamp, id")
                    for batch in self._rows(cursor, ids):
                        read += len(batch)
                        yield batch
                finally:
                    db.close()
            except sqlite3.DatabaseError as err:
                if read:  # the rows after it are lost
                    self.problems.append(f"reading {file.name} stopped after {read:,} messages: {one_line(str(err))}")
                    continue
                yield from self._salvage(file, str(err))

    def _topics(self, db: sqlite3.Connection) -> dict[int, int]:
        """The topics table as connections: topic id → connection id."""
        cursor = db.execute("SELECT * FROM topics")
        columns = [column[0] for column in cursor.description]
        rows = [dict(zip(columns, row)) for row in cursor]
        definitions: dict[str, tuple[str, str]] = {}
        try:
            for msgtype, encoding, text in db.execute(
                    "SELECT topic_type, encoding, encoded_message_definition FROM message_definitions"):
                if text and encoding in ("ros2msg", "ros2idl"):
                    definitions[full_type(str(msgtype))] = (str(encoding), str(text))
        except sqlite3.OperationalError:
            pass  # a bag of Humble or older: no definitions
        ids: dict[int, int] = {}
        for row in rows:
            msgtype = full_type(str(row["type"]))
            encoding, text = definitions.get(msgtype, definitions.get(str(row["type"]), ("", "")))
            qos = str(row.get("offered_qos_profiles") or "")
            ids[int(row["id"])] = self.connection_id(Connection(
                topic=self.resolve(str(row["name"])), msgtype=msgtype,
                encoding=str(row.get("serialization_format") or "cdr"), definition=text, definition_encoding=encoding,
                latched=qos_durability(qos) == "transient_local", qos=qos,
                type_hash=str(row.get("type_description_hash") or ""),
            ))
        return ids

    def _rows(self, cursor: sqlite3.Cursor, ids: dict[int, int]) -> Iterator[MessageBatch]:
        while True:
            rows: list[Any] = cursor.fetchmany(_BATCH)
            if not rows:
                return
            rows = [row for row in rows if row[0] in ids]
            if not rows:
                continue
            topic_ids, times, datas = zip(*rows)
            conn = np.array([ids[topic_id] for topic_id in topic_ids], np.int64)
            data = [bytes(item) for item in datas]
            if self.decompress is not None:
                data = [self.decompress(item) for item in data]
            self.messages += len(conn)
            yield MessageBatch.of(conn, np.array(times, np.int64), None, raw_messages(data))

    def _salvage(self, file: Path, refused: str) -> Iterator[MessageBatch]:
        """A database SQLite refuses, read in row order from a copy, as far as SQLite goes."""
        with tempfile.TemporaryDirectory(prefix="tfrec-") as scratch:
            try:
                db, note = open_cut_database(file, Path(scratch) / file.name)
            except OSError as err:
                raise ReadError(f"{self.where}: cannot read {file.name}: {err.strerror or err}") from err
            read = 0
            try:
                try:
                    ids = self._topics(db)
                except sqlite3.DatabaseError:
                    raise ReadError(f"{self.where}: cannot read rosbag2 bag: {file.name}: {one_line(refused)}")
                for batch in self._rows(db.execute(f"SELECT topic_id, timestamp, data FROM messages WHERE {INTEGER_TIME}"),
                                        ids):
                    read += len(batch)
                    yield batch
            except sqlite3.DatabaseError as err:
                self.problems.append(f"reading {file.name} stopped after {read:,} messages: "
                                     f"{one_line(str(err))}{note}")
            finally:
                db.close()
