"""Raw messages of any recording, as ``tfrec convert`` copies them: who published them, and batches of them.

A :class:`Connection` is a topic's publisher as a recording stores it — a ROS 1 bag's connection
record, an MCAP channel with its schema, a rosbag2 topic row — with everything a writer needs to
write its messages elsewhere: the type, the serialization (``cdr`` or ``ros1``), the message
definition the file carries, latching (ROS 1) or offered QoS (ROS 2), the type hash or md5sum. A
:class:`MessageSource` (:func:`tfrec.formats.messages.open_messages`) yields its messages in
:class:`MessageBatch` es — one chunk of the file at a time, in log-time order within the batch —
as views of the chunk's decompressed bytes, never one Python object per message.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from tfrec.formats.ros.decode import RawMessages

__all__ = ["Connection", "Extra", "MessageBatch", "MessageSource", "full_type", "raw_messages"]


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


def raw_messages(datas: list[bytes]) -> RawMessages:
    """Messages given one by one, as one buffer (one copy)."""
    sizes = np.fromiter(map(len, datas), dtype=np.int64, count=len(datas))
    stops = np.cumsum(sizes)
    return RawMessages(b"".join(datas), stops - sizes, stops)


@dataclass
class MessageSource:
    """A recording's raw messages, read batch by batch (:meth:`batches`).

    Attributes:
        where: the recording, for messages.
        format: ``mcap``, ``rosbag2`` or ``rosbag1``.
        connections: connection id → :class:`Connection`, filled as reading finds them (a
            connection is known before the first batch that holds one of its messages).
            Publishers that are the same in every respect share one id.
        problems: what was lost of a damaged file, one phrase each.
        messages: messages read so far.
        until_ns: a hint: messages logged after it are not wanted, so a chunk that holds none
            before it may be left unread (its messages are not counted); None: every message.
        extras: the attachments and metadata records met (an MCAP's), in the file's order.
    """

    where: str
    format: str
    until_ns: int | None = None
    connections: dict[int, Connection] = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)
    messages: int = 0
    extras: list[Extra] = field(default_factory=list)
    _ids: dict[Connection, int] = field(default_factory=dict, repr=False)

    def connection_id(self, connection: Connection) -> int:
        """The id of a connection, a new one for a publisher not seen before."""
        found = self._ids.get(connection)
        if found is None:
            found = self._ids[connection] = len(self._ids)
            self.connections[found] = connection
        return found

    def batches(self) -> Iterator[MessageBatch]:
        """The messages, a chunk of the file at a time.

        Raises:
            ReadError: the file cannot be read at all (a damaged file stops with :attr:`read_error` set).
        """
        raise NotImplementedError

    @property
    def read_error(self) -> str | None:
        """What was lost of a damaged file, in one line (after :meth:`batches`), or None."""
        if not self.problems:
            return None
        return f"{self.where}: {'; '.join(self.problems)}; {self.messages:,} messages read"
