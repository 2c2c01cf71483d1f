"""From a source's messages to a :class:`~tfrec.recording.Recording`: what :func:`tfrec.formats.read_recording`
decodes, and how.

A :class:`Collector` is the connection filter of a source's walk (:meth:`Collector.wants`: the robot topics of
every namespace, ``/robot1/tf`` being robot1's /tf, of the layout ROS gives them; a type tfrec reads of another
layout is foreign data, with a warning) and takes its batches: it decodes them in bulk (:mod:`tfrec.formats.ros.decode`)
and builds the :class:`~tfrec.recording.Recording`, with topic names resolved as a player publishes them
(:meth:`ReadOptions.resolve`: relative names are global, ``remap`` rules apply) and frame ids as tf2 sees them (no
leading slash). The ``.rrd`` reader takes its options (:class:`ReadOptions`).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import (
    JOINT_STATES,
    RECORDED_TOPICS,
    ROBOT_DESCRIPTION,
    TF,
    TF_STATIC,
    global_topic,
    namespace_name,
    robot_topic_kind,
)
from tfrec.errors import ReadError
from tfrec.formats.ros.connection import Connection, MessageBatch, MessageSource, distinct, warn_reading
from tfrec.formats.ros.decode import JointStateAccumulator, RawMessages, TFAccumulator, read_string, read_transforms
from tfrec.formats.ros.definitions import foreign_layout
from tfrec.formats.ros.joint_names import repeated_joints
from tfrec.formats.ros.types import topic_deserializer
from tfrec.recording import FrameSeries, JointStates, RecordedRobot, Recording, TopicStats, robot_name

__all__ = [
    "DECODED_TOPICS",
    "DECODE_BATCH",
    "SUMMARY_LIMITS",
    "Collector",
    "ReadOptions",
    "decodes_type",
    "parse_remap",
]

Array = NDArray[np.float64]
Pair = tuple[str, str]


DECODED_TOPICS = frozenset(RECORDED_TOPICS)
"""The kinds of topics whose messages are decoded (in every namespace); every other topic is only counted."""


DECODE_BATCH = 32768
"""Messages of a topic a reader hands to :meth:`Collector.add` at once, at most."""

SUMMARY_LIMITS: Mapping[str, int | None] = {ROBOT_DESCRIPTION: None, TF_STATIC: None, JOINT_STATES: 10, TF: 1000}
"""Messages of each kind decoded for a summary (``tfrec info``), per topic; None: all. Every broadcaster
of a running system appears in the first /tf messages, and a robot's joints in its first /joint_states
(ten: enough to tell stamps that are all 0)."""


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
    """Whether a message of this type on this topic (any namespace's /tf, /joint_states…) is
    decoded (else only counted): a /tf_static topic of another type, for one, gives no
    :attr:`Recording.tf_static`."""
    found = robot_topic_kind(topic)
    return found is not None and _short_type(msgtype) in _KINDS[found[1]]


def parse_remap(rule: str) -> tuple[str, str]:
    """A remapping rule ``FROM:=TO`` (``/robot1/tf:=/tf``) as two global topic names.

    Raises:
        ReadError: a rule that is not ``FROM:=TO`` with two topic names.
    """
    source, sep, target = rule.partition(":=")
    if not sep or global_topic(source) == "/" or global_topic(target) == "/":
        raise ReadError(f"`remap` '{rule}' is not a remapping rule FROM:=TO (e.g. /robot1/tf:=/tf)")
    return global_topic(source), global_topic(target)


@dataclass(frozen=True, slots=True)
class ReadOptions:
    """What a reader decodes, and how topic names and times are taken.

    Attributes:
        topics: decode only these kinds (``/tf``: the /tf of every namespace) or topics
            (``/robot1/tf``); None for all of /robot_description, /tf_static, /joint_states, /tf.
        namespace: decode only this namespace's robot topics (``/robot1``; ``""`` the root's)
            and the root's, which robots of a namespace may share; None for all.
        remap: (from, to) rules applied to every topic name, as ROS remapping does: the first
            rule whose ``from`` is the (global) name renames it.
        use_log_time: take each message's log time for its header stamps (a driver that
            stamps 0, a recording whose stamps are unusable).
        summary: decode only what a summary needs (:data:`SUMMARY_LIMITS`).
    """

    topics: frozenset[str] | None = None
    namespace: str | None = None
    remap: tuple[tuple[str, str], ...] = ()
    use_log_time: bool = False
    summary: bool = False

    @classmethod
    def of(cls, *, topics: Collection[str] | None = None, namespace: str | None = None,
           remap: Iterable[str] | Mapping[str, str] | None = None, use_log_time: bool = False,
           summary: bool = False) -> ReadOptions:
        """The options from what a user gives: topic names, a namespace in any spelling, and
        ``FROM:=TO`` rules (or a mapping).

        Raises:
            ReadError: a remapping rule that is not ``FROM:=TO``.
        """
        if isinstance(remap, Mapping):
            rules = tuple((global_topic(a), global_topic(b)) for a, b in remap.items())
        else:
            rules = tuple(parse_remap(rule) for rule in remap or ())
        return cls(None if topics is None else frozenset(global_topic(t) for t in topics),
                   None if namespace is None else namespace_name(namespace), rules, use_log_time, summary)

    def resolve(self, topic: str) -> str:
        """A recorded topic name as it is played: global (``joint_states`` → ``/joint_states``), then remapped."""
        name = global_topic(topic)
        for source, target in self.remap:
            if name == source:
                return target
        return name

    def decodes(self, topic: str, msgtype: str) -> bool:
        """Whether the messages of a (resolved) topic of this type are decoded."""
        found = robot_topic_kind(topic)
        if found is None or not decodes_type(topic, msgtype):
            return False
        namespace, kind = found
        if self.namespace is not None and namespace not in (self.namespace, ""):
            return False
        return self.topics is None or kind in self.topics or topic in self.topics

    def limit(self, topic: str) -> int | None:
        """How many messages of a decoded topic are decoded: None for all."""
        found = robot_topic_kind(topic)
        return SUMMARY_LIMITS[found[1]] if self.summary and found is not None else None


class _Decoded:
    """A decoded topic: its kind, namespace, deserializer and what was taken of it."""

    __slots__ = ("accumulator", "deserialize", "kind", "latched", "namespace", "taken")

    def __init__(self, namespace: str, kind: str, deserialize: Callable[[bytes], Any], ros1: bool) -> None:
        self.namespace = namespace
        self.kind = kind
        self.deserialize = deserialize
        self.taken = 0
        self.accumulator: JointStateAccumulator | TFAccumulator | None = None
        self.latched: list[tuple[int, int, bytes]] = []  # (log time, arrival, message) of /tf_static, descriptions
        self.restart(ros1)

    def restart(self, ros1: bool) -> None:
        """Forget what was taken (a piece of the recording is done), keeping the count."""
        self.accumulator = None
        if self.kind == JOINT_STATES:
            self.accumulator = JointStateAccumulator(self.deserialize, ros1=ros1)
        elif self.kind == TF:
            self.accumulator = TFAccumulator(self.deserialize, ros1=ros1)
        self.latched = []


class Collector:
    """Builds a :class:`Recording` from a :class:`~tfrec.formats.ros.connection.MessageSource`'s walk.

    :meth:`wants` is the walk's connection filter (the topics decoded: the robot topics of the layout tfrec reads),
    :meth:`take` decodes each batch in bulk per topic (and tells the source when a summary has all it wants of a
    topic), :meth:`count` takes the source's counts, and :meth:`finish` gives the recording.
    """

    def __init__(self, recording: Recording, options: ReadOptions, *, ros1: bool) -> None:
        self.recording = recording
        self.options = options
        self.ros1 = ros1
        self.topics: dict[str, TopicStats] = {}
        self.decoded: dict[str, _Decoded] = {}
        self._arrivals = 0
        self._foreign: set[str] = set()
        self.pending = 0  # messages taken since the last piece (:meth:`piece`)
        self._zero_stamps: dict[str, list[int]] = {}  # topic → [stamps that are 0, stamps], over every piece
        self._repeated: dict[str, dict[str, int]] = {}  # topic → joint → messages naming it more than once
        if options.use_log_time:
            recording.time_base = "log"

    # -- topics ---------------------------------------------------------------------------

    def wants(self, connection: Connection) -> bool:
        """Whether a connection's messages are decoded (else only counted); a decoded topic gets its deserializer
        (rosbags', the fallback of the bulk decoder: the first publisher's type is kept).

        Raises:
            ReadError: a decoded topic that is not in the recording's serialization (CDR, or ROS 1's).
        """
        topic = connection.topic
        if not self.decodes(topic, connection.msgtype, definition=connection.definition,
                            definition_encoding=connection.definition_encoding, type_hash=connection.type_hash):
            return False
        expected = "ros1" if self.ros1 else "cdr"
        if connection.encoding != expected:
            raise ReadError(f"{self.recording.path}: topic {topic} is encoded as '{connection.encoding}', not "
                            f"{expected}")
        if topic not in self.decoded:
            found = robot_topic_kind(topic)
            assert found is not None, topic
            deserialize = topic_deserializer(connection.msgtype, where=self.recording.path, topic=topic,
                                             ros1=self.ros1)
            self.decoded[topic] = _Decoded(found[0], found[1], deserialize, self.ros1)
        return True

    def decodes(self, topic: str, msgtype: str, *, definition: str = "", definition_encoding: str = "",
                type_hash: str = "") -> bool:
        """Whether messages of this (resolved) topic, of a publisher with this type, definition and type hash
        (md5sum in ROS 1), are decoded (else only counted). A type tfrec reads whose definition is not the
        layout ROS gives it is foreign data (:func:`~tfrec.formats.ros.definitions.foreign_layout`): not
        decoded, with one warning per topic."""
        if not self.options.decodes(topic, msgtype):
            return False
        reason = foreign_layout(msgtype, ros1=self.ros1, definition=definition, definition_encoding=definition_encoding,
                                type_hash=type_hash)
        if reason is None:
            return True
        if topic not in self._foreign:
            self._foreign.add(topic)
            kind = robot_topic_kind(topic)
            what = {JOINT_STATES: "joint states", ROBOT_DESCRIPTION: "a robot description"}.get(
                kind[1] if kind else "", "TF")
            warn_reading(f"{self.recording.path}: {topic} ({msgtype}): {reason}; its messages are not read as "
                          f"{what} (foreign data: listed, and copied as they are by convert)")
        return False

    def remaining(self, topic: str) -> int | None:
        """How many more messages of a decoded topic are wanted: None for all, 0 for none."""
        limit = self.options.limit(topic)
        decoded = self.decoded.get(topic)
        return None if limit is None else max(0, limit - (decoded.taken if decoded is not None else 0))

    def count(self, source: MessageSource) -> None:
        """Take every connection's count from the source (after its walk): topics in the order the file lists
        them, the type and durability those of a topic's first connection."""
        for conn, stats in source.stats.items():
            topic = source.connections[conn].topic
            entry = self.topics.get(topic)
            if entry is None:
                entry = self.topics[topic] = TopicStats(stats.type, stats.durability)
            entry.merge(stats)

    # -- messages -------------------------------------------------------------------------

    def take(self, batch: MessageBatch, source: MessageSource) -> None:
        """Decode a batch's messages, topic by topic; a topic of which a summary has all it wants is done (the
        source leaves the chunks that hold nothing else unread)."""
        present = distinct(batch.conn)
        by_topic: dict[str, list[int]] = {}
        for conn in present:
            by_topic.setdefault(source.connections[conn].topic, []).append(conn)
        for topic, conns in by_topic.items():
            if len(by_topic) == 1:
                self.add(topic, batch.data, batch.log_time)
            else:
                index = np.flatnonzero(batch.conn == conns[0] if len(conns) == 1 else np.isin(batch.conn, conns))
                self.add(topic, RawMessages(batch.data.buffer, batch.data.starts[index], batch.data.stops[index]),
                         batch.log_time[index])
            if self.remaining(topic) == 0:
                for conn, connection in source.connections.items():
                    if connection.topic == topic:
                        source.done(conn)

    def add(self, topic: str, datas: Sequence[bytes | memoryview],
            log_times: Sequence[int] | NDArray[np.int64] | None = None) -> None:
        """Decode raw messages of a decoded topic, with their log times (needed for
        /tf_static, /robot_description and ``use_log_time``; else in any order)."""
        decoded = self.decoded[topic]
        remaining = self.remaining(topic)
        if remaining is not None and len(datas) > remaining:
            datas = datas[:remaining]
            log_times = None if log_times is None else log_times[:remaining]
        if not datas:
            return
        decoded.taken += len(datas)
        self.pending += len(datas)
        if decoded.accumulator is not None:
            times = None
            if self.options.use_log_time:
                assert log_times is not None, "a reader gives log times with use_log_time"
                times = np.asarray(log_times, dtype=np.int64)
            decoded.accumulator.add(datas, times)
            return
        times_list = [int(t) for t in log_times] if log_times is not None else [0] * len(datas)
        for time_ns, data in zip(times_list, datas):
            decoded.latched.append((int(time_ns), self._arrivals, bytes(data)))
            self._arrivals += 1

    # -- the result -----------------------------------------------------------------------

    def finish(self) -> Recording:
        """The recording: the topic table (after :meth:`count`), latched data and every series taken."""
        rec = self.recording
        rec.topics = {topic: stats.info() for topic, stats in self.topics.items()}  # in the file's order
        set_span(rec)
        self._fill(rec)
        self.warn_stamps()
        return rec

    def piece(self) -> Recording:
        """The series of the messages taken since the last piece, as a recording of their own (no topic table;
        latched data only as far as it was taken since): the accumulators start again, so that a recording is
        read piece by piece in bounded memory. The warnings about stamps and repeated joint names wait for
        :meth:`warn_stamps`, which counts every piece."""
        rec = Recording(path=self.recording.path, format=self.recording.format, time_base=self.recording.time_base)
        self._fill(rec)
        for decoded in self.decoded.values():
            decoded.restart(self.ros1)
        self.pending = 0
        return rec

    def _fill(self, rec: Recording) -> None:
        """Put what was taken into ``rec``, robot by robot, tallying the stamps that are 0 and the repeats."""
        parts: dict[str, dict[str, Any]] = {}
        for topic, decoded in self.decoded.items():
            part = parts.setdefault(decoded.namespace, {})
            if decoded.kind == ROBOT_DESCRIPTION:
                part["descriptions"] = _descriptions(decoded, ros1=self.ros1)
            elif decoded.kind == TF_STATIC:
                part["tf_static"] = _static(decoded, ros1=self.ros1)
            elif decoded.kind == JOINT_STATES and decoded.accumulator is not None and decoded.accumulator.messages:
                assert isinstance(decoded.accumulator, JointStateAccumulator)
                time, names, positions = decoded.accumulator.result()
                repeated = decoded.accumulator.repeated
                part["joint_states"] = JointStates(time, names, positions, tuple(repeated))
                self._tally_stamps(topic, time)
                tally = self._repeated.setdefault(topic, {})
                for name, count in repeated.items():
                    tally[name] = tally.get(name, 0) + count
            elif decoded.kind == TF and decoded.accumulator is not None:
                assert isinstance(decoded.accumulator, TFAccumulator)
                part["tf"] = tf = _frames(decoded.accumulator)
                self._tally_stamps(topic, np.concatenate([s.time_ns for s in tf.values()] or [np.zeros(0, np.int64)]))
        for namespace, part in parts.items():
            topics = RecordedRobot(namespace, tuple(part.get("descriptions", ())), part.get("joint_states"),
                                   part.get("tf", {}), part.get("tf_static", {}))
            if namespace:
                rec.namespaces[namespace] = topics
                continue
            rec.robot_description = topics.robot_description
            rec.robot_descriptions = topics.descriptions if len(topics.descriptions) > 1 else ()
            rec.joint_states, rec.tf, rec.tf_static = topics.joint_states, topics.tf, topics.tf_static

    def _tally_stamps(self, topic: str, time_ns: NDArray[np.int64]) -> None:
        tally = self._zero_stamps.setdefault(topic, [0, 0])
        tally[0] += int(np.count_nonzero(time_ns == 0))
        tally[1] += len(time_ns)

    def warn_stamps(self) -> None:
        """Warn, once per topic, of stamps that are 0 and of joints named twice in a message, over everything
        taken (every piece); the tallies start again."""
        for topic, (zero, total) in self._zero_stamps.items():
            self._warn_zero_stamps(topic, zero, total)
            repeated = self._repeated.get(topic)
            if repeated:
                warn_reading(repeated_joints(self.recording.path, topic, repeated, self.decoded[topic].taken,
                                              first=self.options.summary))
        self._repeated.clear()
        self._zero_stamps.clear()

    def _warn_zero_stamps(self, topic: str, zero: int, total: int) -> None:
        if self.options.use_log_time or not total:
            return
        if zero <= 1:  # one sample at t=0 is a clock that starts at 0
            return
        if topic.endswith(JOINT_STATES):
            what = ("messages are stamped 0 (a driver that does not stamp them: robot_state_publisher publishes "
                    "nothing for them)")
        else:
            what = "transforms are stamped 0 (tf2's \"latest\": they have no time of their own)"
        warn_reading(f"{self.recording.path}: {zero:,} of {total:,} {topic} {what}; their times are "
                      "meaningless: `use_log_time` replays by log time")


def _descriptions(decoded: _Decoded, *, ros1: bool) -> list[str]:
    """The last description of each robot name, in order of first appearance (by log time)."""
    by_name: dict[str | None, str] = {}
    for _, _, raw in sorted(decoded.latched, key=lambda item: (item[0], item[1])):
        text = read_string(raw, ros1=ros1, deserialize=decoded.deserialize)
        name = robot_name(text)
        by_name[name] = text
    return list(by_name.values())


def _strip(frame: str) -> str:
    """A frame id as tf2 sees it: without its leading slash (ROS 1's ``/base_link``)."""
    return frame.lstrip("/")


def _static(decoded: _Decoded, *, ros1: bool) -> dict[Pair, tuple[Array, Array]]:
    """The last transform of each pair of /tf_static messages, in log-time order."""
    out: dict[Pair, tuple[Array, Array]] = {}
    for _, _, raw in sorted(decoded.latched, key=lambda item: (item[0], item[1])):
        for (parent, child), _, fields in read_transforms(raw, ros1=ros1, deserialize=decoded.deserialize):
            out[(_strip(parent), _strip(child))] = (np.array(fields[:3]), np.array(fields[3:]))
    return out


def _frames(accumulator: TFAccumulator) -> dict[Pair, FrameSeries]:
    """The /tf series per pair; pairs whose frame ids differ only by a leading slash are merged."""
    out: dict[Pair, FrameSeries] = {}
    for (parent, child), (time, values) in accumulator.result().items():
        pair = (_strip(parent), _strip(child))
        if pair in out:  # "/base" and "base": one frame to tf2
            old = out[pair]
            time = np.concatenate([old.time_ns, time])
            values = np.concatenate([np.hstack([old.translation, old.rotation]), values])
            order = np.argsort(time, kind="stable")
            time, values = time[order], values[order]
        out[pair] = FrameSeries(time, np.ascontiguousarray(values[:, :3]), np.ascontiguousarray(values[:, 3:]))
    return out


def set_span(rec: Recording, true_start: int | None = None) -> None:
    """A recording's start and end from its topic table (first and last log times of any topic); a ``true_start``
    before them (the file's own start: messages before the first one read were lost) starts it."""
    firsts = [info.first_ns for info in rec.topics.values() if info.first_ns is not None]
    lasts = [info.last_ns for info in rec.topics.values() if info.last_ns is not None]
    rec.start_ns = min(firsts) if firsts else None
    rec.end_ns = max(lasts) if lasts else None
    if true_start is not None and (rec.start_ns is None or true_start < rec.start_ns):
        rec.start_ns = true_start
        if rec.end_ns is None:
            rec.end_ns = true_start
