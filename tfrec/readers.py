"""Reading recordings back into arrays: MCAP, rosbag2 folders, ROS 1 bags and tfrec's ``.rrd``.

:func:`read_recording` gives one :class:`Recording` whatever the format: the robot description,
the topic table, the joint states as one (N, J) array and every TF frame pair as a time series.
``diff`` compares two of them and ``replay`` plays one back.

How each format is read:

- ``.mcap`` (ROS 2 profile, CDR): :mod:`tfrec.mcap_read`, tfrec's own sequential reader; a
  file cut short is read up to the cut (complete records of a partial chunk included), a damaged
  chunk is skipped (its CRC fails) and reading goes on; :attr:`Recording.read_error` says what was lost.
- rosbag2 folders (mcap or sqlite3 storage) and ROS 1 ``.bag`` files: ``rosbags``' ``AnyReader``
  (a rosbag2 folder of one uncompressed MCAP: :mod:`tfrec.mcap_read`). What rosbags refuses is
  read as far as possible, with :attr:`Recording.read_error` saying where reading stopped: a ROS 1
  bag cut short, without an index or with a damaged chunk record by record
  (:mod:`tfrec.rosbag1_read`); a sqlite3 ``.db3`` cut short through SQLite, from a copy whose
  header's page count is lowered to the pages the file still has, its ``messages`` table in row
  order up to the first missing page.
- ``.rrd``: :mod:`tfrec.rrd_read`, through Rerun's own reader. Rerun stores transforms as float32.

JointState and TFMessage messages with a fixed layout (the same names in every message) are
decoded in bulk with numpy (:mod:`tfrec.ros_decode`); anything else through rosbags'
deserializers, message by message.
"""

from __future__ import annotations

import os
import sqlite3
import struct
import tempfile
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

from .bag_metadata import BagMetadata, one_line, qos_durability, read_bag_metadata
from .errors import RecordingError
from .mcap_read import MCAP_MAGIC, read_mcap
from .recorded import (
    DECODED_TOPICS,
    JOINT_STATES,
    ROBOT_DESCRIPTION,
    TF,
    TF_STATIC,
    Collector,
    FrameSeries,
    JointStates,
    Recording,
    TopicInfo,
    deserializer,
)
from .rosbag1_read import ROS1_MAGIC, read_rosbag1_records, ros1_compression
from .rrd_read import RRD_MAGIC, read_rrd

__all__ = [
    "JOINT_STATES",
    "ROBOT_DESCRIPTION",
    "TF",
    "TF_STATIC",
    "FrameSeries",
    "JointStates",
    "Recording",
    "TopicInfo",
    "read_recording",
    "recording_format",
]

_BATCH = 32768
"""Messages of a topic decoded at once."""


def recording_format(path: str | os.PathLike[str]) -> str:
    """The format of a recording: ``mcap``, ``rosbag2``, ``rosbag1`` or ``rrd``, from its first bytes.

    Raises:
        RecordingError: a missing path, or something that is none of those.
    """
    where = os.fspath(path)
    file = Path(path)
    if file.is_dir():
        if (file / "metadata.yaml").is_file():
            return "rosbag2"
        raise RecordingError(f"{where}: a folder without metadata.yaml (not a rosbag2 bag)")
    if not file.exists():
        raise RecordingError(f"{where}: no such file or folder")
    try:
        with open(file, "rb") as stream:
            head = stream.read(16)
    except OSError as err:
        raise RecordingError(f"{where}: cannot read: {err.strerror or err}") from None
    if head.startswith(MCAP_MAGIC):
        return "mcap"
    if head.startswith(ROS1_MAGIC):
        return "rosbag1"
    if head.startswith(RRD_MAGIC):
        return "rrd"
    if head.startswith(b"SQLite format 3\0") and (file.parent / "metadata.yaml").is_file():
        return "rosbag2"
    raise RecordingError(f"{where}: not a recording (neither MCAP, rosbag2, ROS 1 bag nor Rerun .rrd)")


def read_recording(path: str | os.PathLike[str], *, topics: Collection[str] | None = None) -> Recording:
    """Read a recording into arrays.

    Args:
        path: an ``.mcap`` file, a rosbag2 folder (or its ``.db3``), a ROS 1 ``.bag`` or an ``.rrd``.
        topics: decode only these of /robot_description, /tf_static, /joint_states and /tf
            (the topic table always lists every topic); None for all.

    Returns:
        The recording. A damaged MCAP, ROS 1 bag or sqlite3 bag yields what was readable,
        with ``read_error`` set.

    Raises:
        RecordingError: a missing or unreadable input, or one that is not a recording; one
            line naming the file.
    """
    fmt = recording_format(path)
    wanted = DECODED_TOPICS if topics is None else frozenset(topics)
    if fmt == "mcap":
        return read_mcap(Path(path), wanted)
    if fmt == "rrd":
        return read_rrd(Path(path), wanted)
    file = Path(path)
    if fmt == "rosbag1":
        return _read_rosbags(file, fmt, wanted)
    if file.is_file():
        file = file.parent
    meta = read_bag_metadata(file)  # its errors are one line, rosbags' are not
    if meta.storage == "mcap" and not meta.compression and len(meta.files) == 1:
        recording = read_mcap(meta.files[0], wanted)  # tfrec record --bag: much faster than rosbags
        recording.path, recording.format = os.fspath(file), "rosbag2"
        recording.details["storage"] = "mcap"
        return recording
    return _read_rosbags(file, fmt, wanted, meta)


class _Refused(Exception):
    """rosbags cannot read the bag (its index or database is damaged)."""


def _read_rosbags(path: Path, fmt: str, wanted: frozenset[str], meta: BagMetadata | None = None) -> Recording:
    """Read a bag with rosbags; a ROS 1 or sqlite3 bag that it refuses as far as it is readable."""
    where = os.fspath(path)
    try:
        recording = _read_anyreader(path, fmt, wanted)
    except _Refused as err:
        refused = str(err)
        if fmt == "rosbag1":
            return read_rosbag1_records(path, wanted, refused=refused)
        if meta is not None and meta.storage == "sqlite3":
            return _read_sqlite3_rows(path, meta.files, wanted, refused=refused)
        raise RecordingError(f"{where}: cannot read rosbag2 bag: {refused}") from None
    if fmt == "rosbag1":
        recording.details["compression"] = ros1_compression(path)
    elif meta is not None:
        recording.details["storage"] = meta.storage
        if meta.compression:
            recording.details["compression"] = meta.compression
    return recording


def _read_anyreader(path: Path, fmt: str, wanted: frozenset[str]) -> Recording:
    """Read a bag with rosbags' AnyReader.

    Raises:
        _Refused: rosbags cannot read it (its message is one line).
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error
    from rosbags.serde import SerdeError
    from rosbags.typesys import Stores, get_typestore

    where = os.fspath(path)
    ros1 = fmt == "rosbag1"
    recording = Recording(path=where, format=fmt)
    collector = Collector(recording, wanted, ros1=ros1)
    default = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    try:
        with AnyReader([path], default_typestore=default) as reader:
            decoded = []
            durability: dict[str, str | None] = {}
            for connection in reader.connections:
                durability.setdefault(connection.topic, _durability(connection.ext))
                if collector.decodes(connection.topic, connection.msgtype):
                    if not ros1 and getattr(connection.ext, "serialization_format", "cdr") != "cdr":
                        raise RecordingError(f"{where}: topic {connection.topic} is not cdr-serialized")
                    decoded.append(connection)
                    collector.set_deserializer(connection.topic, deserializer(
                        reader.typestore, connection.msgtype, ros1=ros1, where=where, topic=connection.topic))
            stats: dict[str, list[Any]] = {}  # topic → [type, count, first, last]
            pending: dict[str, list[bytes]] = {}
            for connection, log_time, raw in reader.messages():
                topic = connection.topic
                entry = stats.get(topic)
                if entry is None:
                    stats[topic] = [connection.msgtype, 1, log_time, log_time]
                else:
                    entry[1] += 1
                    entry[2] = min(entry[2], log_time)
                    entry[3] = max(entry[3], log_time)
                if connection in decoded:
                    batch = pending.setdefault(topic, [])
                    batch.append(raw)
                    if len(batch) >= _BATCH:
                        collector.add(topic, batch)
                        pending[topic] = []
            for topic, batch in pending.items():
                collector.add(topic, batch)
            for topic, (msgtype, count, first, last) in stats.items():
                collector.count(topic, msgtype, count, first, last, durability.get(topic))
    except (AnyReaderError, Reader1Error, Reader2Error, sqlite3.DatabaseError) as err:
        raise _Refused(one_line(str(err))) from None
    except SerdeError as err:
        raise RecordingError(f"{where}: cannot decode a message: {one_line(str(err))}") from None
    except (EOFError, RuntimeError) as err:  # a chunk that does not decompress (bz2, lz4)
        raise _Refused(f"a damaged chunk ({type(err).__name__}: {one_line(str(err))})") from None
    except OSError as err:  # bz2 says "Invalid data stream" as an OSError without an errno
        if err.errno is not None:
            raise RecordingError(f"{where}: cannot read: {err.strerror or err}") from None
        raise _Refused(f"a damaged chunk ({one_line(str(err))})") from None
    return collector.finish()


def _durability(ext: Any) -> str | None:
    """A rosbags connection's QoS durability (rosbag2), or ``latched`` for a latching ROS 1 topic."""
    profiles = getattr(ext, "offered_qos_profiles", None)
    if profiles:
        durability = getattr(profiles[0], "durability", None)
        return str(durability.name).lower() if durability is not None else None
    return "latched" if getattr(ext, "latching", None) else None


# -- a damaged rosbag2 sqlite3 bag -----------------------------------------------------------------


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
        RecordingError: a file whose topics table cannot be read.
    """
    from rosbags.typesys import Stores, get_typestore

    where = os.fspath(folder)
    recording = Recording(path=where, format="rosbag2", details={"storage": "sqlite3"})
    collector = Collector(recording, wanted, ros1=False)
    store = get_typestore(Stores.ROS2_HUMBLE)
    stats: dict[str, list[Any]] = {}  # topic → [type, count, first, last, durability]
    pending: dict[str, list[tuple[int, bytes]]] = {}
    problems: list[str] = []
    for file in files:
        with tempfile.TemporaryDirectory(prefix="tfrec-") as scratch:
            try:
                db, note = _open_cut_database(file, Path(scratch) / file.name)
            except OSError as err:
                raise RecordingError(f"{where}: cannot read {file.name}: {err.strerror or err}") from None
            try:
                problem = _read_rows(db, collector, store, stats, pending, where=where, refused=refused)
            finally:
                db.close()
        if problem is not None:
            problems.append(f"reading {file.name} stopped after {problem[0]:,} messages: {problem[1]}{note}")
    for name, messages in pending.items():
        messages.sort(key=lambda message: message[0])
        for at in range(0, len(messages), _BATCH):
            collector.add(name, [data for _, data in messages[at : at + _BATCH]])
    for name, (msgtype, count, first, last, durability) in stats.items():
        collector.count(name, msgtype, count, first, last, durability)
    if problems:
        total = sum(entry[1] for entry in stats.values())
        recording.read_error = f"{where}: {'; '.join(problems)}; {total:,} messages read"
    return collector.finish()


def _read_rows(db: sqlite3.Connection, collector: Collector, store: Any, stats: dict[str, list[Any]],
               pending: dict[str, list[tuple[int, bytes]]], *, where: str, refused: str) -> tuple[int, str] | None:
    """Read one database's topics and messages into ``stats`` and ``pending``; returns (messages
    read, SQLite's error) when reading stopped early, else None.

    Raises:
        RecordingError: the topics table cannot be read.
    """
    try:
        cursor = db.execute("SELECT * FROM topics")
        columns = [column[0] for column in cursor.description]
        topics = {row[columns.index("id")]: dict(zip(columns, row)) for row in cursor}
    except (sqlite3.DatabaseError, ValueError):
        raise RecordingError(f"{where}: cannot read rosbag2 bag: {one_line(refused)}") from None
    for topic in topics.values():
        name, msgtype = str(topic["name"]), str(topic["type"])
        if collector.decodes(name, msgtype) and name not in collector.deserializers:
            if topic.get("serialization_format", "cdr") != "cdr":
                raise RecordingError(f"{where}: topic {name} is not cdr-serialized")
            collector.set_deserializer(name, deserializer(store, msgtype, ros1=False, where=where, topic=name))
    read = 0
    try:
        for topic_id, time_ns, data in db.execute("SELECT topic_id, timestamp, data FROM messages"):
            row = topics.get(topic_id)
            if row is None:
                continue
            name = str(row["name"])
            entry = stats.get(name)
            if entry is None:
                durability = qos_durability(str(row.get("offered_qos_profiles") or ""))
                stats[name] = [str(row["type"]), 1, time_ns, time_ns, durability]
            else:
                entry[1] += 1
                entry[2] = min(entry[2], time_ns)
                entry[3] = max(entry[3], time_ns)
            if name in collector.deserializers:
                pending.setdefault(name, []).append((time_ns, bytes(data)))
            read += 1
    except sqlite3.DatabaseError as err:
        return read, str(err)
    return None
