"""A recording's messages, raw: who published them (:class:`Connection`), batches of them (:class:`MessageBatch`),
and what every format's one reader is (:class:`MessageSource`).

A :class:`Connection` is a topic's publisher as a recording stores it — a ROS 1 bag's connection
record, an MCAP channel with its schema, a rosbag2 topic row — with everything a writer needs to
write its messages elsewhere: the type, the serialization (``cdr`` or ``ros1``), the message
definition the file carries, latching (ROS 1) or offered QoS (ROS 2), the type hash or md5sum. A
:class:`MessageSource` (:func:`tfrec.formats.open_messages`) walks the file(s) once and yields the messages of the
connections asked for in :class:`MessageBatch` es — one chunk of the file at a time, in log-time order within the
batch — as views of the chunk's decompressed bytes, never one Python object per message; it counts the others, and
notes what a damaged file lost (:class:`ReadStopped`, :meth:`MessageSource.lost`) in one line.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import TfrecWarning
from tfrec.formats.ros.decode import RawMessages
from tfrec.recording import TopicStats

__all__ = [
    "BATCH_MESSAGES",
    "Connection",
    "Extra",
    "MessageBatch",
    "MessageSource",
    "ReadStopped",
    "Wanted",
    "count_differences",
    "distinct",
    "full_type",
    "raw_messages",
    "warn_reading",
    "with_article",
]

BATCH_MESSAGES = 4096
"""Messages a source gathers into one batch, at most, where the file does not cut them into chunks (messages outside
chunks, rows of a database)."""


@dataclass(frozen=True, slots=True)
class Connection:
    """A topic's publisher, as a recording holds it (or as an output writes it).

    Attributes:
        topic: the name as it is played: global, remapped (``joint_states`` → ``/joint_states``).
        msgtype: ``pkg/msg/Type``.
        encoding: ``cdr`` (ROS 2) or ``ros1``.
        definition: the message definition the file gives for the type, ``""`` when none.
        definition_encoding: ``ros2msg``, ``ros2idl`` or ``ros1msg``; ``""`` without a definition.
        latched: published transient_local (ROS 2) or latching (ROS 1): a late subscriber gets
            the last message (/tf_static, /robot_description, a map).
        qos: ROS 2's offered QoS profiles, the YAML text rosbag2 stores; ``""`` when unknown.
        type_hash: ROS 2's type hash (``RIHS01_…``) or ROS 1's md5sum; ``""`` when unknown.
        callerid: ROS 1's publishing node; ``""`` when none.
    """

    topic: str
    msgtype: str
    encoding: str
    definition: str = ""
    definition_encoding: str = ""
    latched: bool = False
    qos: str = ""
    type_hash: str = ""
    callerid: str = ""

    @property
    def ros1(self) -> bool:
        """Serialized as ROS 1 (rather than CDR)."""
        return self.encoding == "ros1"


@dataclass(frozen=True, slots=True)
class Extra:
    """An MCAP attachment or metadata record of an input, copied as it is by ``tfrec convert``: where its
    bytes are, and what an output's summary indexes of it.

    Attributes:
        kind: ``attachment`` or ``metadata``.
        name: its name (a calibration file's name, a metadata map's name).
        path: the file that holds it.
        offset: where the record begins in ``path`` (its opcode).
        length: the whole record's bytes, opcode and length field included.
        log_time, create_time, media_type, data_size: an attachment's, for its index.
    """

    kind: str
    name: str
    path: Path
    offset: int
    length: int
    log_time: int = 0
    create_time: int = 0
    media_type: str = ""
    data_size: int = 0

    @property
    def shown(self) -> str:
        """``attachment 'calibration.yaml'``."""
        return f"{self.kind} {self.name!r}" if self.kind == "attachment" else f"metadata record {self.name!r}"


@dataclass(frozen=True, slots=True)
class MessageBatch:
    """Messages of several connections, in log-time order (ties in the file's order).

    Attributes:
        conn: int64 (n,) the connection id of each message (:attr:`MessageSource.connections`).
        log_time: int64 (n,) log (receive) times, ns since the epoch.
        publish_time: int64 (n,) publish times (an MCAP's), or None where the format has none.
        data: the serialized messages.
    """

    conn: NDArray[np.int64]
    log_time: NDArray[np.int64]
    publish_time: NDArray[np.int64] | None
    data: RawMessages

    def __len__(self) -> int:
        return len(self.conn)

    def take(self, index: NDArray[np.intp]) -> MessageBatch:
        """The messages ``index`` (in that order)."""
        return MessageBatch(self.conn[index], self.log_time[index],
                            None if self.publish_time is None else self.publish_time[index],
                            RawMessages(self.data.buffer, self.data.starts[index], self.data.stops[index]))

    @classmethod
    def of(cls, conn: NDArray[np.int64], log_time: NDArray[np.int64], publish_time: NDArray[np.int64] | None,
           data: RawMessages) -> MessageBatch:
        """A batch of messages in any order, sorted by log time (stably)."""
        if len(log_time) > 1 and bool(np.any(np.diff(log_time) < 0)):
            order = np.argsort(log_time, kind="stable")
            return cls(conn, log_time, publish_time, data).take(order)
        return cls(conn, log_time, publish_time, data)


def full_type(name: str) -> str:
    """A type name as ROS 2 spells it: ``pkg/Type`` → ``pkg/msg/Type``; ``pkg/msg/Type``,
    ``pkg/srv/Type_Event`` and ``""`` stay."""
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 and all(parts) else name


def distinct(values: NDArray[np.integer]) -> list[int]:
    """The distinct values of an integer array (a batch's connection ids), in ascending order: what
    ``np.unique(values).tolist()`` gives, without the ``numpy.ma`` that ``np.unique`` loads (numpy 2.3 and later:
    ~7 ms, a twentieth of ``tfrec info`` of a small file)."""
    ordered = np.sort(values)
    return ordered[np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])].tolist() if len(ordered) else []


def raw_messages(datas: list[bytes]) -> RawMessages:
    """Messages given one by one, as one buffer (one copy)."""
    sizes = np.fromiter(map(len, datas), dtype=np.int64, count=len(datas))
    stops = np.cumsum(sizes)
    return RawMessages(b"".join(datas), stops - sizes, stops)


def count_differences(read: Mapping[str, int], indexed: Mapping[str, int], *, index: str) -> str | None:
    """``message counts differ from <index>: /tf: 10 read, 12 in <index>``, for the topics whose
    count read differs from what a file's own index says; None when none does."""
    differ = [(topic, read.get(topic, 0), count) for topic, count in indexed.items() if read.get(topic, 0) != count]
    if not differ:
        return None
    shown = "; ".join(f"{topic}: {got:,} read, {count:,} in {index}" for topic, got, count in differ[:3])
    more = f"; and {len(differ) - 3} more topics" if len(differ) > 3 else ""
    return f"message counts differ from {index}: {shown}{more}"


class ReadStopped(Exception):
    """Raised inside a reader: reading stopped at byte ``offset`` of a damaged file, for ``reason``."""

    def __init__(self, offset: int, reason: str) -> None:
        super().__init__(reason)
        self.offset = offset
        self.reason = reason

    def problem(self, size: int) -> str:
        """``reading stopped at byte 1,234 of 5,678: <reason>``, for a file of ``size`` bytes."""
        return f"reading stopped at byte {self.offset:,} of {size:,}: {self.reason}"


def with_article(what: str) -> str:
    """``"chunk record"`` → ``"a chunk record"``, ``"index"`` → ``"an index"``."""
    return f"a{'n' if what[0] in 'aeiou' else ''} {what}"


def warn_reading(message: str) -> None:
    """Warn of something odd in a recording being read, attributed to the first caller outside :mod:`tfrec.formats`
    (the command that reads it), so that the same oddity of two inputs (``diff A A``) is shown for each."""
    frame = sys._getframe(1)
    level = 2
    while frame.f_back is not None and str(frame.f_globals.get("__name__", "")).startswith("tfrec.formats"):
        frame = frame.f_back
        level += 1
    warnings.warn(message, TfrecWarning, stacklevel=level)


Wanted = Callable[[Connection], bool]
"""Which connections' messages a walk yields: asked once for each connection, when the walk meets it."""


class MessageSource:
    """A recording's messages, read in one walk of its files: the shape of rosbags' ``AnyReader.messages`` and
    mcap's reader (:func:`tfrec.formats.open_messages` opens one).

    :meth:`batches` walks the file(s) once, in the file's order, and yields :class:`MessageBatch` es — a chunk at
    a time, in log-time order within each — of the connections asked for; the other connections' messages are
    counted (from the file's index where it has one, without reading them). Whatever a damaged file lost is noted,
    not raised: :attr:`read_error` says it in one line once the walk is over.

    Attributes:
        where: the recording, for messages.
        format: ``mcap``, ``rosbag2`` or ``rosbag1``.
        connections: connection id → :class:`Connection`, filled as the walk finds them (a connection is known
            before the first batch that holds one of its messages). Publishers that are the same in every
            respect share one id.
        messages: messages yielded so far.
        extras: the attachments and metadata records met (an MCAP's), in the file's order, when asked for.
        details: what ``tfrec info`` shows of the container: ``profile``, ``library``, ``compression``…
        true_start_ns: the first log time of a damaged recording as far as the file still tells (an MCAP's
            summary statistics or chunk headers, a ROS 1 bag's chunk info records), when messages before the
            first one read were lost; else None.
    """

    def __init__(self, where: str, fmt: str) -> None:
        self.where = where
        self.format = fmt
        self.connections: dict[int, Connection] = {}
        self.messages = 0
        self.extras: list[Extra] = []
        self.details: dict[str, str] = {}
        self.true_start_ns: int | None = None
        self._stats: dict[int, TopicStats] = {}
        self._ids: dict[Connection, int] = {}
        self._wanted: list[bool] = []
        self._done: set[int] = set()
        self._select: Wanted | None = None
        self._lost: list[str] = []
        self.until_ns: int | None = None
        self.publish_time = False
        self.want_extras = False
        self.check_counts = False
        self.expected_counts: Mapping[str, int] | None = None
        """Messages per topic (as played) that a rosbag2 bag's ``metadata.yaml`` lists, checked against those
        counted (``check_counts``); None: nothing to check against."""

    # -- the walk -------------------------------------------------------------------------------

    def batches(self, connections: Wanted | None = None, *, until_ns: int | None = None, publish_time: bool = False,
                extras: bool = False, check_counts: bool = False) -> Iterator[MessageBatch]:
        """The messages, a chunk of the file at a time (one walk: call it once).

        Args:
            connections: which connections' messages to yield (None: all); the others are only counted.
            until_ns: messages logged after it are not wanted: a chunk that holds none before it may be left
                unread (its messages are then not counted).
            publish_time: give each batch its publish times (an MCAP's; None where the format has none).
            extras: note the attachments and metadata records (:attr:`extras`), and warn of a damaged one.
            check_counts: warn when the messages counted differ from what the file's own index says (an MCAP's
                summary statistics, a ROS 1 bag's chunk info records, a rosbag2 bag's ``metadata.yaml``).

        Raises:
            ReadError: the file cannot be read at all (what a damaged one lost is :attr:`read_error`).
        """
        self._select = connections
        self.until_ns = until_ns
        self.publish_time = publish_time
        self.want_extras = extras
        self.check_counts = check_counts
        return self._checked(self._walk())

    def _checked(self, walk: Iterator[MessageBatch]) -> Iterator[MessageBatch]:
        """The walk, then (``check_counts``) the counts against ``metadata.yaml``'s, for an intact recording."""
        yield from walk
        if not self.check_counts or self.expected_counts is None or self.read_error is not None:
            return
        read: dict[str, int] = {}
        for conn, stats in self._stats.items():
            topic = self.connections[conn].topic
            read[topic] = read.get(topic, 0) + stats.count
        expected = dict(self.expected_counts)
        for topic, count in read.items():
            if count:
                expected.setdefault(topic, 0)  # a topic metadata.yaml does not list
        differ = count_differences(read, expected, index="metadata.yaml")
        if differ is not None:
            warn_reading(f"{self.where}: {differ}")

    def _walk(self) -> Iterator[MessageBatch]:
        raise NotImplementedError

    def done(self, conn: int) -> None:
        """No more messages of connection ``conn`` are wanted: a chunk that holds nothing else wanted is counted
        from the index, not read (a summary's first messages)."""
        self._done.add(conn)

    def wanted(self, conn: int) -> bool:
        """Whether the walk yields the messages of connection ``conn`` (and they are still wanted)."""
        return self._wanted[conn] and conn not in self._done

    # -- connections and counts -----------------------------------------------------------------

    def connection_id(self, connection: Connection, durability: str | None = None, *, shown_type: str | None = None) -> int:
        """The id of a connection, a new one (asked whether it is wanted) for a publisher not seen before.

        Args:
            durability: what :class:`~tfrec.recording.TopicInfo` says of its durability.
            shown_type: its type as the file names it, for the topic table (default: ``connection.msgtype``).
        """
        found = self._ids.get(connection)
        if found is None:
            found = self._ids[connection] = len(self._ids)
            self.connections[found] = connection
            self._stats[found] = TopicStats(connection.msgtype if shown_type is None else shown_type, durability)
            self._wanted.append(self._select is None or bool(self._select(connection)))
        return found

    @property
    def stats(self) -> dict[int, TopicStats]:
        """Every connection's messages as the walk counted them (from the index for chunks it did not read)."""
        return self._stats

    @property
    def counted(self) -> int:
        """Messages counted so far, of every connection."""
        return sum(stats.count for stats in self._stats.values())

    # -- damage ---------------------------------------------------------------------------------

    def lost(self, name: str, problems: list[str], messages: int) -> None:
        """Note what a damaged file (``name``: the recording, or one file of a rosbag2 bag) lost."""
        self._lost.append(f"{name}: {'; '.join(problems)}; {messages:,} messages read")

    @property
    def read_error(self) -> str | None:
        """What was lost of a damaged recording, in one line (after :meth:`batches`), or None."""
        return "; ".join(self._lost) if self._lost else None
