"""From raw messages to a :class:`~tfrec.recording.Recording`: what every reader feeds.

The readers (:mod:`tfrec.formats.mcap.reader`, :mod:`tfrec.formats.rosbag1.reader`,
:mod:`tfrec.formats.rrd.reader`, and rosbags in :mod:`tfrec.formats._rosbags`) feed raw messages
to a :class:`Collector`, which decodes them in bulk (:mod:`tfrec.formats.ros.decode`) and builds
the :class:`~tfrec.recording.Recording`; the readers of damaged files say what was lost in one
line (:func:`read_error_line`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, RECORDED_TOPICS, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.formats.ros.decode import JointStateAccumulator, TFAccumulator, transforms_of
from tfrec.recording import FrameSeries, JointStates, Recording, TopicStats

__all__ = [
    "DECODED_TOPICS",
    "DECODE_BATCH",
    "Collector",
    "ReadStopped",
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
