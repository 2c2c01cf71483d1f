"""Reading recordings back into arrays: MCAP, rosbag2 folders, ROS 1 bags and tfrec's ``.rrd``.

:func:`read_recording` gives one :class:`Recording` whatever the format: the robot descriptions,
the topic table, the joint states as one (N, J) array and every TF frame pair as a time series —
for the root namespace and for every other namespace that holds robot topics (``/robot1/tf``).
``diff`` compares two of them and ``replay`` plays one back.

It reads through the one source of each format (:func:`tfrec.formats.open_messages`), asking it for the
connections it decodes — /robot_description, /tf_static, /joint_states and /tf of any namespace, of the layout
ROS gives them — and taking the topic table from the source's counts (from the file's own index where it has
one). A damaged file yields what was readable, with :attr:`Recording.read_error` set by the source. JointState and
TFMessage messages with a fixed layout (the same names in every message) are decoded in bulk with numpy
(:mod:`tfrec.formats.ros.decode`); anything else through rosbags' deserializers, message by message. An ``.rrd``
holds no ROS messages: :mod:`tfrec.formats.rrd.reader` reads it through Rerun's own reader (transforms are float32
there).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Collection, Generator, Iterable, Mapping
from dataclasses import replace

from tfrec.conventions import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC, robot_topic_kind
from tfrec.errors import warn_again
from tfrec.formats._collect import Collector, ReadOptions, set_span
from tfrec.formats.source import RecordingSource, identify_recording, messages_of, recording_format
from tfrec.recording import Recording, TopicInfo

PIECE_MESSAGES = 10_000
"""/joint_states and /tf messages of a piece of a recording read piece by piece (:func:`read_pieces`), about."""

__all__ = [
    "PIECE_MESSAGES",
    "ReadOptions",
    "RecordingSource",
    "identify_recording",
    "read_pieces",
    "read_recording",
    "recording_format",
]


def read_recording(
    path: str | os.PathLike[str] | RecordingSource,
    *,
    topics: Collection[str] | None = None,
    namespace: str | None = None,
    remap: Iterable[str] | Mapping[str, str] | None = None,
    use_log_time: bool = False,
    summary: bool = False,
) -> Recording:
    """Read a recording into arrays.

    Args:
        path: an ``.mcap`` file, a rosbag2 folder (or its ``.db3``), a ROS 1 ``.bag`` or an
            ``.rrd``; or what :func:`identify_recording` found of one.
        topics: decode only these of /robot_description, /tf_static, /joint_states and /tf —
            in every namespace (``/tf`` is robot1's ``/robot1/tf`` too), or one namespace's
            (``/robot1/tf``); the topic table always lists every topic. None for all.
        namespace: decode only the robot topics of this namespace (``/robot1``, ``"/"`` for the
            root) and of the root namespace, whose /tf and /joint_states its robots may share.
        remap: ``FROM:=TO`` rules (or a mapping) that rename topics as ROS remapping does,
            before anything else: ``["/robot1/tf:=/tf"]``.
        use_log_time: take each message's log time for the stamps of /joint_states and /tf
            (:attr:`Recording.time_base` ``log``): for a driver that stamps 0, say.
        summary: decode only what a summary needs: every description and /tf_static message,
            the first /joint_states messages and the first thousand /tf messages of each namespace.

    Returns:
        The recording. A damaged MCAP, ROS 1 bag or sqlite3 bag yields what was readable,
        with ``read_error`` set.

    Raises:
        ReadError: a missing or unreadable input, one that is not a recording, or a bad `remap` rule;
            one line naming the file.
    """
    options = ReadOptions.of(topics=topics, namespace=namespace, remap=remap, use_log_time=use_log_time,
                             summary=summary)
    source = path if isinstance(path, RecordingSource) else identify_recording(path)
    if source.format == "rrd":
        from tfrec.formats.rrd.reader import read_rrd

        return read_rrd(source.path, options)
    recording = Recording(path=source.where, format=source.format)
    collector = Collector(recording, options, ros1=source.format == "rosbag1")
    with messages_of(source, options.resolve) as messages:
        for batch in messages.batches(collector.wants, check_counts=True):
            collector.take(batch, messages)
        collector.count(messages)
    recording.read_error = messages.read_error
    recording.details = dict(messages.details)
    if source.bag is not None:
        recording.details["storage"] = source.bag.storage
        if source.bag.compression:
            recording.details["bag_compression"] = f"{source.bag.compression} {source.bag.compression_mode or 'file'}"
    collector.finish()
    set_span(recording, messages.true_start_ns)
    return recording


def _kinds(topics: Collection[str] | None, kinds: tuple[str, ...]) -> frozenset[str] | None:
    """The topics of ``topics`` (kinds like ``/tf``, or one namespace's ``/robot1/tf``) of these kinds."""
    if topics is None:
        return frozenset(kinds)
    return frozenset(t for t in topics if (found := robot_topic_kind(t)) is not None and found[1] in kinds)


def read_pieces(
    path: str | os.PathLike[str] | RecordingSource,
    *,
    topics: Collection[str] | None = None,
    namespace: str | None = None,
    remap: Iterable[str] | Mapping[str, str] | None = None,
    use_log_time: bool = False,
    messages: int | None = None,
) -> Generator[tuple[Recording, bool], None, None]:
    """Read a recording piece by piece, in bounded memory: what :func:`read_recording` gives, its time series cut
    into consecutive pieces of about ``messages`` /joint_states and /tf messages (default :data:`PIECE_MESSAGES`), in
    the order the file holds them (by log time).

    The latched data (/robot_description, /tf_static) is read first, from the chunks that hold it, and every piece
    has it, with the whole recording's topic table; each piece has the /joint_states and /tf series of its
    messages (each sorted by stamp). Each piece comes with whether it is the last; the last has the recording's
    ``read_error``; warnings are given once. An ``.rrd`` is one piece. Arguments as :func:`read_recording`'s.

    Raises:
        ReadError: as :func:`read_recording`.
    """
    source = path if isinstance(path, RecordingSource) else identify_recording(path)
    if source.format == "rrd":
        yield read_recording(source, topics=topics, namespace=namespace, remap=remap, use_log_time=use_log_time), True
        return
    with warnings.catch_warnings(record=True) as latched_said:
        warnings.simplefilter("always")
        latched = read_recording(source, topics=_kinds(topics, (ROBOT_DESCRIPTION, TF_STATIC)), namespace=namespace,
                                 remap=remap, use_log_time=use_log_time)
    for said in latched_said:  # given again, once: the walk below may say the same of the file (not again)
        warn_again(said)
    options = ReadOptions.of(topics=_kinds(topics, (JOINT_STATES, TF)), namespace=namespace, remap=remap,
                             use_log_time=use_log_time)
    collector = Collector(Recording(path=source.where, format=source.format), options,
                          ros1=source.format == "rosbag1")
    if use_log_time:
        collector.recording.time_base = "log"
    with messages_of(source, options.resolve) as found:
        walk = iter(found.batches(collector.wants))
        while True:
            with warnings.catch_warnings():  # what reading the latched data said is not said again
                warnings.filterwarnings("ignore", message=_said(latched.read_error))
                for said in latched_said:
                    warnings.filterwarnings("ignore", message=_said(str(said.message)) + "$", category=said.category)
                batch = next(walk, None)
            if batch is None:
                break
            collector.take(batch, found)
            if collector.pending >= (PIECE_MESSAGES if messages is None else messages):
                yield _with_latched(collector.piece(), latched), False
    collector.count(found)
    last = _with_latched(collector.piece(), latched)
    last.read_error = found.read_error or latched.read_error
    _walked_counts(last, {topic: stats.info() for topic, stats in collector.topics.items()}, found.true_start_ns)
    collector.warn_stamps()
    yield last, True


def _walked_counts(last: Recording, walked: dict[str, TopicInfo], true_start: int | None) -> None:
    """The last piece's topic table and span as reading the whole recording gives them: the counts of the time
    series from their own walk (a damaged file loses what that walk could not read; the latched data's walk read
    only the chunks holding latched data, and took the rest from the index)."""
    topics = dict(last.topics)
    for topic, info in walked.items():
        kind = robot_topic_kind(topic)
        if kind is not None and kind[1] in (JOINT_STATES, TF):
            topics[topic] = info
    last.topics = topics
    set_span(last, true_start)


def _said(read_error: str | None) -> str:
    """A warnings filter's message pattern for a damage already reported (none: matches nothing)."""
    import re

    return re.escape(read_error) if read_error else "(?!)"


def _with_latched(piece: Recording, latched: Recording) -> Recording:
    """A piece of a recording's series, with the recording's topic table and latched data."""
    piece.topics, piece.start_ns, piece.end_ns = latched.topics, latched.start_ns, latched.end_ns
    piece.details = latched.details
    piece.robot_description, piece.robot_descriptions = latched.robot_description, latched.robot_descriptions
    piece.tf_static = latched.tf_static
    for name, robot in latched.namespaces.items():
        own = piece.namespaces.get(name)
        piece.namespaces[name] = robot if own is None else replace(own, descriptions=robot.descriptions,
                                                                   tf_static=robot.tf_static)
    return piece
