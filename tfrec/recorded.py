"""What a recording holds, format aside: the :class:`Recording` the readers build.

The readers (:mod:`tfrec.mcap_read`, :mod:`tfrec.rosbag1_read`, :mod:`tfrec.rrd_read`, and
rosbags in :mod:`tfrec.readers`) feed raw messages to a :class:`Collector`, which decodes them in
bulk (:mod:`tfrec.ros_decode`) and builds the :class:`Recording`; the readers of damaged files
say what was lost in one line (:func:`read_error_line`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .conventions import JOINT_STATES, RECORDED_TOPICS, ROBOT_DESCRIPTION, TF, TF_STATIC
from .ros_decode import JointStateAccumulator, TFAccumulator, transforms_of

__all__ = [
    "DECODED_TOPICS",
    "DECODE_BATCH",
    "JOINT_STATES",
    "ROBOT_DESCRIPTION",
    "TF",
    "TF_STATIC",
    "Collector",
    "FrameSeries",
    "JointStates",
    "ReadStopped",
    "Recording",
    "TopicInfo",
    "TopicStats",
    "decodes_type",
    "read_error_line",
    "with_article",
]

Array = NDArray[np.float64]

DECODED_TOPICS = frozenset(RECORDED_TOPICS)
"""The topics whose messages are decoded; every other topic is only counted."""

DECODE_BATCH = 32768
"""Messages of a topic a reader hands to :meth:`Collector.add` at once, at most."""


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


def read_error_line(where: str, problems: Sequence[str], messages: int) -> str:
    """:attr:`Recording.read_error`: the file, what went wrong (``problems``), and how many messages were read."""
    return f"{where}: {'; '.join(problems)}; {messages:,} messages read"


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """One topic of a recording.

    Attributes:
        type: the message type as the recording names it (``tf2_msgs/msg/TFMessage``).
        count: messages on the topic.
        first_ns, last_ns: log times (receive times) of the first and last message, ns since
            the epoch; None for data without a time (static data in an ``.rrd``).
        durability: the offered QoS durability (``transient_local``, ``volatile``…) where the
            format records it (MCAP channels, rosbag2 topics); ``latched`` for a latching
            topic of a ROS 1 bag; else None.
    """

    type: str
    count: int
    first_ns: int | None
    last_ns: int | None
    durability: str | None = None


class TopicStats:
    """A reader's running count of one topic's (or one channel's) messages; becomes a :class:`TopicInfo`.

    Attributes: as :class:`TopicInfo`'s; ``first_ns`` and ``last_ns`` are None until a message
    with a time is counted.
    """

    __slots__ = ("count", "durability", "first_ns", "last_ns", "type")

    def __init__(self, msgtype: str, durability: str | None = None) -> None:
        self.type = msgtype
        self.durability = durability
        self.count = 0
        self.first_ns: int | None = None
        self.last_ns: int | None = None

    def add(self, time_ns: int) -> None:
        """Count one message logged at ``time_ns``."""
        if self.first_ns is None or time_ns < self.first_ns:
            self.first_ns = time_ns
        if self.last_ns is None or time_ns > self.last_ns:
            self.last_ns = time_ns
        self.count += 1

    def add_times(self, first_ns: int | None, last_ns: int | None) -> None:
        """Widen the time span to include [``first_ns``, ``last_ns``] (None: no time)."""
        if first_ns is not None and (self.first_ns is None or first_ns < self.first_ns):
            self.first_ns = first_ns
        if last_ns is not None and (self.last_ns is None or last_ns > self.last_ns):
            self.last_ns = last_ns

    def merge(self, other: TopicStats) -> None:
        """Add the messages ``other`` counted (another channel or file of the same topic)."""
        self.count += other.count
        self.add_times(other.first_ns, other.last_ns)
        self.durability = self.durability or other.durability

    def info(self) -> TopicInfo:
        return TopicInfo(self.type, self.count, self.first_ns, self.last_ns, self.durability)


@dataclass(frozen=True, slots=True)
class JointStates:
    """Every /joint_states message as one array.

    Attributes:
        time_ns: int64 (N,) header stamps, non-decreasing.
        names: the union of the joint names of all messages, in order of first appearance.
        positions: float64 (N, J); NaN where a message has no position for a joint.
    """

    time_ns: NDArray[np.int64]
    names: tuple[str, ...]
    positions: Array

    def __len__(self) -> int:
        return len(self.time_ns)


@dataclass(frozen=True, slots=True)
class FrameSeries:
    """The transforms of one (parent, child) pair on /tf, in time order.

    Attributes:
        time_ns: int64 (M,) stamps of the transforms.
        translation: float64 (M, 3), metres.
        rotation: float64 (M, 4), quaternions (x, y, z, w) as recorded.
    """

    time_ns: NDArray[np.int64]
    translation: Array
    rotation: Array

    def __len__(self) -> int:
        return len(self.time_ns)


@dataclass
class Recording:
    """What a recording holds, format aside.

    Attributes:
        path: the file or folder read.
        format: ``"mcap"``, ``"rosbag2"``, ``"rosbag1"`` or ``"rrd"``.
        robot_description: the URDF text of the last /robot_description message, or None.
        topics: topic name → :class:`TopicInfo`. An ``.rrd`` has no topics: its entities are
            listed under the topics they stand for.
        joint_states: /joint_states, or None when the recording has none.
        tf: (parent, child) → :class:`FrameSeries` of the transforms on /tf.
        tf_static: (parent, child) → (translation (3,), rotation (4,)) of the last /tf_static
            transform of that pair.
        start_ns, end_ns: log times of the first and last message (ns since the epoch), or
            None for an empty recording. When a damaged file lost messages, the recording's
            true start (and end) as far as the file still tells — an MCAP's summary
            statistics or chunk headers — so times count from the real start, not from the
            first message that could be read.
        read_error: None, or one line saying what a damaged file lost (where reading stopped,
            or which chunks were skipped); the rest of the recording holds what was readable.
        float32: True when the format stores transforms as float32 (``.rrd``).
        details: what ``tfrec info`` shows about the container, where known: ``profile``,
            ``library`` (MCAP header), ``compression`` (chunk or file compression, ``none``),
            ``storage`` (rosbag2 storage plugin).
    """

    path: str
    format: str
    robot_description: str | None = None
    topics: dict[str, TopicInfo] = field(default_factory=dict)
    joint_states: JointStates | None = None
    tf: dict[tuple[str, str], FrameSeries] = field(default_factory=dict)
    tf_static: dict[tuple[str, str], tuple[Array, Array]] = field(default_factory=dict)
    start_ns: int | None = None
    end_ns: int | None = None
    read_error: str | None = None
    float32: bool = False
    details: dict[str, str] = field(default_factory=dict)

    @property
    def duration_ns(self) -> int:
        return 0 if self.start_ns is None or self.end_ns is None else self.end_ns - self.start_ns


# -- decoding -------------------------------------------------------------------------------------


def _short_type(msgtype: str) -> str:
    """``tf2_msgs/msg/TFMessage`` and ``tf2_msgs/TFMessage`` → ``tf2_msgs/TFMessage``."""
    return msgtype.replace("/msg/", "/")


_KINDS = {
    JOINT_STATES: ("sensor_msgs/JointState",),
    TF: ("tf2_msgs/TFMessage", "tf/tfMessage"),
    TF_STATIC: ("tf2_msgs/TFMessage", "tf/tfMessage"),
    ROBOT_DESCRIPTION: ("std_msgs/String",),
}


def decodes_type(topic: str, msgtype: str) -> bool:
    """Whether a message of this type on this topic is decoded (else only counted): a
    /tf_static topic of another type, for one, gives no :attr:`Recording.tf_static`."""
    return _short_type(msgtype) in _KINDS.get(topic, ())


class Collector:
    """Receives raw messages per topic and builds the :class:`Recording`."""

    def __init__(self, recording: Recording, wanted: frozenset[str], *, ros1: bool) -> None:
        self.recording = recording
        self.wanted = wanted
        self.ros1 = ros1
        self.topics: dict[str, TopicStats] = {}
        self.joint_states: JointStateAccumulator | None = None
        self.tf: TFAccumulator | None = None
        self.static: list[bytes] = []
        self.description: bytes | None = None
        self.deserializers: dict[str, Callable[[bytes], Any]] = {}

    def decodes(self, topic: str, msgtype: str) -> bool:
        """Whether messages of this topic are decoded (else only counted)."""
        return topic in self.wanted and decodes_type(topic, msgtype)

    def set_deserializer(self, topic: str, deserialize: Callable[[bytes], Any]) -> None:
        self.deserializers[topic] = deserialize
        if topic == JOINT_STATES and self.joint_states is None:
            self.joint_states = JointStateAccumulator(deserialize, ros1=self.ros1)
        elif topic == TF and self.tf is None:
            self.tf = TFAccumulator(deserialize, ros1=self.ros1)

    def topic(self, topic: str, msgtype: str, durability: str | None = None) -> TopicStats:
        """The count of a topic's messages, for a reader that counts them one by one; the type
        and durability are those of the topic's first channel."""
        stats = self.topics.get(topic)
        if stats is None:
            stats = self.topics[topic] = TopicStats(msgtype, durability)
        return stats

    def count(self, topic: str, stats: TopicStats) -> None:
        """Add the messages a reader counted on one channel (or connection) of ``topic``."""
        entry = self.topics.get(topic)
        if entry is None:
            entry = self.topics[topic] = TopicStats(stats.type)
        entry.merge(stats)

    def add(self, topic: str, datas: list[Any]) -> None:
        """Decode raw messages of a decoded topic, in order."""
        if topic == JOINT_STATES:
            assert self.joint_states is not None
            self.joint_states.add(datas)
        elif topic == TF:
            assert self.tf is not None
            self.tf.add(datas)
        elif topic == TF_STATIC:
            self.static.extend(bytes(d) for d in datas)
        elif topic == ROBOT_DESCRIPTION and datas:
            self.description = bytes(datas[-1])

    def add_in_time_order(self, topic: str, messages: list[tuple[int, bytes]]) -> None:
        """Decode (log time, raw message) pairs of a decoded topic, sorted by log time (stably)."""
        messages.sort(key=lambda message: message[0])
        for at in range(0, len(messages), DECODE_BATCH):
            self.add(topic, [data for _, data in messages[at : at + DECODE_BATCH]])

    def finish(self) -> Recording:
        rec = self.recording
        rec.topics = {topic: self.topics[topic].info() for topic in sorted(self.topics)}
        firsts = [info.first_ns for info in rec.topics.values() if info.first_ns is not None]
        lasts = [info.last_ns for info in rec.topics.values() if info.last_ns is not None]
        rec.start_ns = min(firsts) if firsts else None
        rec.end_ns = max(lasts) if lasts else None
        if self.description is not None:
            rec.robot_description = str(self.deserializers[ROBOT_DESCRIPTION](self.description).data)
        for raw in self.static:
            for pair, _, fields in transforms_of(self.deserializers[TF_STATIC](raw)):
                rec.tf_static[pair] = (np.array(fields[:3]), np.array(fields[3:]))
        if self.joint_states is not None and self.joint_states.messages:
            time, names, positions = self.joint_states.result()
            rec.joint_states = JointStates(time, names, positions)
        if self.tf is not None:
            for pair, (time, values) in self.tf.result().items():
                translation, rotation = np.ascontiguousarray(values[:, :3]), np.ascontiguousarray(values[:, 3:])
                rec.tf[pair] = FrameSeries(time, translation, rotation)
        return rec
