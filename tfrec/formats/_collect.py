"""From raw messages to a :class:`~tfrec.recording.Recording`: what every reader feeds.

The readers (:mod:`tfrec.formats.mcap.reader`, :mod:`tfrec.formats.rosbag1`,
:mod:`tfrec.formats.rosbag2.sqlite3`, :mod:`tfrec.formats.rrd.reader`) feed raw messages to a
:class:`Collector`, which decodes them in bulk (:mod:`tfrec.formats.ros.decode`) and builds the
:class:`~tfrec.recording.Recording`: every namespace's robot topics (``/robot1/tf`` is robot1's
/tf), with topic names resolved as a player publishes them (:meth:`ReadOptions.resolve`: relative
names are global, ``remap`` rules apply) and frame ids as tf2 sees them (no leading slash). The
readers of damaged files say what was lost in one line (:func:`read_error_line`); counts that
disagree with a file's own index warn, with both numbers (:func:`count_differences`).
"""

from __future__ import annotations

import warnings
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
from tfrec.errors import ReadError, TfrecWarning
from tfrec.formats.ros.decode import JointStateAccumulator, TFAccumulator, transforms_of
from tfrec.formats.ros.definitions import foreign_layout
from tfrec.formats.ros.joint_names import repeated_joints
from tfrec.recording import FrameSeries, JointStates, Recording, RobotTopics, TopicStats, robot_name

__all__ = [
    "DECODED_TOPICS",
    "DECODE_BATCH",
    "SUMMARY_LIMITS",
    "Collector",
    "ReadOptions",
    "ReadStopped",
    "count_differences",
    "decodes_type",
    "parse_remap",
    "read_error_line",
    "with_article",
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
        if kind == JOINT_STATES:
            self.accumulator = JointStateAccumulator(deserialize, ros1=ros1)
        elif kind == TF:
            self.accumulator = TFAccumulator(deserialize, ros1=ros1)
        self.latched: list[tuple[int, int, bytes]] = []  # (log time, arrival, message) of /tf_static, descriptions


class Collector:
    """Receives raw messages per topic and builds the :class:`Recording`.

    A reader resolves each topic name (:meth:`resolve`), asks whether it is decoded
    (:meth:`decodes`), gives its deserializer (:meth:`set_deserializer`), counts its messages
    (:meth:`topic`, :meth:`count`) and hands the decoded topics' messages to :meth:`add`
    (decompressed by ``decompress`` first, for a rosbag2 bag compressed message by message).
    """

    def __init__(self, recording: Recording, options: ReadOptions, *, ros1: bool,
                 decompress: Callable[[bytes], bytes] | None = None) -> None:
        self.recording = recording
        self.options = options
        self.ros1 = ros1
        self.decompress = decompress
        self.topics: dict[str, TopicStats] = {}
        self.decoded: dict[str, _Decoded] = {}
        self._arrivals = 0
        self._foreign: set[str] = set()
        if options.use_log_time:
            recording.time_base = "log"

    # -- topics ---------------------------------------------------------------------------

    def resolve(self, topic: str) -> str:
        """A recorded topic's name as it is played (see :meth:`ReadOptions.resolve`)."""
        return self.options.resolve(topic)

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
            warnings.warn(f"{self.recording.path}: {topic} ({msgtype}): {reason}; its messages are not read as "
                          f"{what} (foreign data: listed, and copied as they are by convert)", TfrecWarning, stacklevel=3)
        return False

    def set_deserializer(self, topic: str, deserialize: Callable[[bytes], Any]) -> None:
        """Decode the messages of ``topic`` (resolved, :meth:`decodes`) with ``deserialize`` as a
        fallback of the bulk decoder; the first deserializer given for a topic is kept."""
        if topic not in self.decoded:
            found = robot_topic_kind(topic)
            assert found is not None, topic
            self.decoded[topic] = _Decoded(found[0], found[1], deserialize, self.ros1)

    def remaining(self, topic: str) -> int | None:
        """How many more messages of a decoded topic are wanted: None for all, 0 for none."""
        limit = self.options.limit(topic)
        decoded = self.decoded.get(topic)
        return None if limit is None else max(0, limit - (decoded.taken if decoded is not None else 0))

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
            entry = self.topics[topic] = TopicStats(stats.type, stats.durability)
        entry.merge(stats)

    # -- messages -------------------------------------------------------------------------

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
        if self.decompress is not None:  # a rosbag2 bag compressed message by message
            datas = [self.decompress(bytes(data)) for data in datas]
        decoded.taken += len(datas)
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

    def add_in_time_order(self, topic: str, messages: list[tuple[int, bytes]]) -> None:
        """Decode (log time, raw message) pairs of a decoded topic, sorted by log time (stably)."""
        messages.sort(key=lambda message: message[0])
        for at in range(0, len(messages), DECODE_BATCH):
            batch = messages[at : at + DECODE_BATCH]
            self.add(topic, [data for _, data in batch], [time_ns for time_ns, _ in batch])

    # -- the result -----------------------------------------------------------------------

    def finish(self) -> Recording:
        rec = self.recording
        rec.topics = {topic: stats.info() for topic, stats in self.topics.items()}  # in the file's order
        firsts = [info.first_ns for info in rec.topics.values() if info.first_ns is not None]
        lasts = [info.last_ns for info in rec.topics.values() if info.last_ns is not None]
        rec.start_ns = min(firsts) if firsts else None
        rec.end_ns = max(lasts) if lasts else None
        parts: dict[str, dict[str, Any]] = {}
        for topic, decoded in self.decoded.items():
            part = parts.setdefault(decoded.namespace, {})
            if decoded.kind == ROBOT_DESCRIPTION:
                part["descriptions"] = _descriptions(decoded)
            elif decoded.kind == TF_STATIC:
                part["tf_static"] = _static(decoded)
            elif decoded.kind == JOINT_STATES and decoded.accumulator is not None and decoded.accumulator.messages:
                assert isinstance(decoded.accumulator, JointStateAccumulator)
                time, names, positions = decoded.accumulator.result()
                repeated = decoded.accumulator.repeated
                part["joint_states"] = JointStates(time, names, positions, tuple(repeated))
                self._warn_zero_stamps(topic, time)
                if repeated:
                    warnings.warn(repeated_joints(self.recording.path, topic, repeated, decoded.taken,
                                                  first=self.options.summary), TfrecWarning, stacklevel=4)
            elif decoded.kind == TF and decoded.accumulator is not None:
                assert isinstance(decoded.accumulator, TFAccumulator)
                part["tf"] = tf = _frames(decoded.accumulator)
                self._warn_zero_stamps(topic, np.concatenate([s.time_ns for s in tf.values()] or [np.zeros(0, np.int64)]))
        for namespace, part in parts.items():
            topics = RobotTopics(tuple(part.get("descriptions", ())), part.get("joint_states"),
                                 part.get("tf", {}), part.get("tf_static", {}))
            if namespace:
                rec.namespaces[namespace] = topics
                continue
            rec.robot_description = topics.robot_description
            rec.robot_descriptions = topics.descriptions if len(topics.descriptions) > 1 else ()
            rec.joint_states, rec.tf, rec.tf_static = topics.joint_states, topics.tf, topics.tf_static
        return rec

    def _warn_zero_stamps(self, topic: str, time_ns: NDArray[np.int64]) -> None:
        if self.options.use_log_time or not len(time_ns):
            return
        zero = int(np.count_nonzero(time_ns == 0))
        if zero <= 1:  # one sample at t=0 is a clock that starts at 0
            return
        if topic.endswith(JOINT_STATES):
            what = ("messages are stamped 0 (a driver that does not stamp them: robot_state_publisher publishes "
                    "nothing for them)")
        else:
            what = "transforms are stamped 0 (tf2's \"latest\": they have no time of their own)"
        warnings.warn(f"{self.recording.path}: {zero:,} of {len(time_ns):,} {topic} {what}; their times are "
                      "meaningless: `use_log_time` replays by log time", TfrecWarning, stacklevel=4)


def _descriptions(decoded: _Decoded) -> list[str]:
    """The last description of each robot name, in order of first appearance (by log time)."""
    by_name: dict[str | None, str] = {}
    for _, _, raw in sorted(decoded.latched, key=lambda item: (item[0], item[1])):
        text = str(decoded.deserialize(raw).data)
        name = robot_name(text)
        by_name[name] = text
    return list(by_name.values())


def _strip(frame: str) -> str:
    """A frame id as tf2 sees it: without its leading slash (ROS 1's ``/base_link``)."""
    return frame.lstrip("/")


def _static(decoded: _Decoded) -> dict[Pair, tuple[Array, Array]]:
    """The last transform of each pair of /tf_static messages, in log-time order."""
    out: dict[Pair, tuple[Array, Array]] = {}
    for _, _, raw in sorted(decoded.latched, key=lambda item: (item[0], item[1])):
        for (parent, child), _, fields in transforms_of(decoded.deserialize(raw)):
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
