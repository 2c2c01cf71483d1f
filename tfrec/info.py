"""``tfrec info``: what a recording holds — MCAP, rosbag2 folder (mcap or sqlite3), ROS 1 bag, ``.rrd``.

An intact MCAP (and a rosbag2 folder of them) is summarized from its summary section
(Statistics, chunk and message indexes, read by :mod:`tfrec.formats.mcap.summary`), so a one-hour file
is summarized without decompressing it; only a few messages are decoded: the first
/joint_states and /robot_description messages, every /tf_static message and the first
:data:`TF_MESSAGES_DECODED` /tf messages.

Everything else is read whole with :func:`tfrec.formats.read_recording`: an MCAP without a
valid summary (a recorder killed mid-write, a damaged file), sqlite3 bags, ROS 1 bags and
``.rrd`` files. A damaged file is summarized as far as it is readable, with one warning saying
what was lost (:attr:`Recording.read_error`, also in the result's ``read_error``).
"""

from __future__ import annotations

import io
import os
import struct
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import IO, Any

from tfrec.conventions import JOINT_STATES, NS_PER_S, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.errors import ReadError
from tfrec.formats.mcap.records import MCAP_MAGIC
from tfrec.formats.mcap.summary import McapSummary, channel_spans, iter_messages, read_header, read_summary
from tfrec.formats.reader import identify_recording, read_recording
from tfrec.formats.ros.types import UndecodableMessage, deserializer
from tfrec.formats.rosbag2.metadata import BagMetadata, qos_durability
from tfrec.recording import Recording, TopicStats

__all__ = ["TF_MESSAGES_DECODED", "format_summary", "summarize"]

TF_MESSAGES_DECODED = 1000
"""/tf messages decoded for the frame list: every broadcaster of a running system appears in the
first ones, and decoding all of a long recording would take seconds."""

_KINDS = {"mcap": "MCAP", "rosbag1": "ROS 1 bag", "rrd": "Rerun recording (.rrd)"}


class _DecodeError(ValueError):
    """A message that its schema's type cannot decode."""


@dataclass
class _Scan:
    """What one or more MCAP files hold (merged across the files of a bag)."""

    profile: str = ""
    library: str = ""
    compressions: set[str] = field(default_factory=set)
    topics: dict[str, TopicStats] = field(default_factory=dict)
    robot_name: str | None = None
    joints: list[str] | None = None
    frames: dict[tuple[str, str], bool] = field(default_factory=dict)  # (parent, child) → static
    start_ns: int | None = None  # the recording's span when messages were lost; else from the topics
    end_ns: int | None = None
    read_error: str | None = None


def summarize(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Summarize a recording: whatever :func:`tfrec.formats.read_recording` reads.

    A damaged file is summarized as far as it is readable, with a warning saying what was lost.

    Returns:
        A JSON-ready dict: ``path``, ``format`` (``mcap``, ``rosbag2``, ``rosbag1``, ``rrd``),
        ``storage`` (a rosbag2 folder's storage plugin, else None), ``files``, ``profile``,
        ``library``, ``compression``, ``message_count``, ``start_time_ns``, ``end_time_ns``,
        ``duration_ns``, ``duration_s``, ``start_time`` and ``end_time`` (ISO 8601, UTC; None
        when empty), ``topics`` (name, type, count, rate_hz, durability), ``robot_name``,
        ``joints``, ``tf_frames`` (parent, child, static) and ``read_error`` (None, or what a
        damaged file lost).

    Raises:
        ReadError: a missing file, one that is not a recording, one with nothing readable,
            or a message that cannot be decoded.
    """
    source = identify_recording(path)
    meta, files = source.bag, list(source.files)
    if source.format == "mcap" or (meta is not None and meta.storage == "mcap" and not meta.compression):
        scan = _Scan()
        if all(_scan_file(file, scan) for file in files):
            return _as_dict(source.path, source.format, meta, files, scan)
    recording = read_recording(source)
    if recording.read_error is not None:
        warnings.warn(recording.read_error, stacklevel=2)
    return _as_dict(source.path, source.format, meta, files, _scan_recording(recording))


def format_summary(summary: dict[str, Any]) -> str:
    """The readable form of :func:`summarize`'s result, like ``ros2 bag info``."""
    lines = [f"File:        {summary['path']}"]
    fmt, storage = summary["format"], summary["storage"]
    compression = summary["compression"].replace("none", "uncompressed")
    kind = _KINDS.get(fmt) or f"rosbag2 folder ({'MCAP' if storage == 'mcap' else storage} storage)"
    if fmt == "mcap" or storage == "mcap":
        kind += (f", profile {summary['profile'] or '(none)'}, {compression} chunks, "
                 f"written by {summary['library'] or '(unknown)'}")
    elif fmt == "rosbag1":
        kind += f", {compression} chunks"
    elif compression != "no":
        kind += f", {compression} compression"
    lines.append(f"Format:      {kind}")
    if fmt == "rosbag2":
        lines.append(f"Files:       {', '.join(summary['files'])}")
    if summary["robot_name"] is not None:
        lines.append(f"Robot:       {summary['robot_name']}")
    lines.append(f"Duration:    {summary['duration_ns'] / NS_PER_S:.9f} s")
    if summary["start_time_ns"] is not None:
        lines.append(f"Start:       {summary['start_time']} ({summary['start_time_ns']} ns)")
        lines.append(f"End:         {summary['end_time']} ({summary['end_time_ns']} ns)")
    lines.append(f"Messages:    {summary['message_count']}")
    topics = summary["topics"]
    lines.append(f"Topics ({len(topics)}):")
    rows = [
        (t["name"], t["type"], f"{t['count']} msg{'s' if t['count'] != 1 else ''}",
         f"{t['rate_hz']:.3f} Hz" if t["rate_hz"] is not None else "", t["durability"] or "")
        for t in topics
    ]
    widths = [max((len(row[i]) for row in rows), default=0) for i in range(5)]
    for row in rows:
        cells = [row[0].ljust(widths[0]), row[1].ljust(widths[1]), row[2].rjust(widths[2]),
                 row[3].rjust(widths[3]), row[4]]
        lines.append(("  " + "  ".join(cells)).rstrip())
    if summary["joints"] is not None:
        lines.append(f"Joints ({len(summary['joints'])}): {', '.join(summary['joints'])}")
    frames = summary["tf_frames"]
    lines.append(f"TF frames ({len(frames)} parent → child):")
    for frame in frames:
        lines.append(f"  {frame['parent']} → {frame['child']}{'  (static)' if frame['static'] else ''}")
    return "\n".join(lines)


# -- one MCAP file -----------------------------------------------------------------------------


def _scan_file(path: Path, scan: _Scan) -> bool:
    """Summarize an MCAP file from its summary section; False when it has no intact one (it is
    then read whole)."""
    try:
        with open(path, "rb") as stream:
            if stream.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                return False
            return _scan_stream(stream, os.fstat(stream.fileno()).st_size, scan)
    except OSError as err:
        raise ReadError(f"{path}: cannot read: {err.strerror or err}") from err
    except _DecodeError as err:
        raise ReadError(f"{path}: {err}") from err
    except (struct.error, ValueError, KeyError, IndexError, EOFError):
        return False  # damaged: read_recording reads what it can and says what was lost


def _scan_stream(stream: IO[bytes], size: int, scan: _Scan) -> bool:
    profile, library = read_header(stream, size)
    summary = read_summary(stream, size)
    if summary is None or summary.statistics is None:
        return False
    scan.profile = scan.profile or profile
    scan.library = scan.library or library
    scan.compressions.update(index.compression for index in summary.chunk_indexes)
    for channel_id, channel in sorted(summary.channels.items()):
        topic = scan.topics.get(channel.topic)
        if topic is None:
            durability = qos_durability(channel.metadata.get("offered_qos_profiles", ""))
            topic = scan.topics[channel.topic] = TopicStats(summary.schemas.get(channel.schema_id, ""), durability)
        topic.count += summary.statistics.channel_counts.get(channel_id, 0)
    for indexed, first, last in channel_spans(stream, size, summary):  # first and last log time per channel
        spanned = summary.channels.values() if indexed is None else [summary.channels[indexed]]
        for channel in spanned:  # a chunk without message indexes: its span stands for every channel
            scan.topics[channel.topic].add_times(first, last)
    _decode_some(stream, size, summary, scan)
    return True


def _decode_some(stream: IO[bytes], size: int, summary: McapSummary, scan: _Scan) -> None:
    """Decode the few messages the summary needs (see the module docstring)."""
    def has(topic: str, msgtype: str) -> bool:
        return topic in scan.topics and scan.topics[topic].type == msgtype

    def first(topic: str, msgtype: str, limit: int | None) -> Iterator[Any]:
        deserialize = deserializer(msgtype)
        for count, (_, _, data) in enumerate(iter_messages(stream, size, summary, (topic,))):
            if limit is not None and count >= limit:
                return
            try:
                yield deserialize(data)
            except UndecodableMessage as err:
                raise _DecodeError(f"cannot decode a {topic} message as {msgtype} ({err})") from err

    if scan.robot_name is None and has(ROBOT_DESCRIPTION, "std_msgs/msg/String"):
        for msg in first(ROBOT_DESCRIPTION, "std_msgs/msg/String", 1):
            scan.robot_name = _robot_name(msg.data)
    if scan.joints is None and has(JOINT_STATES, "sensor_msgs/msg/JointState"):
        for msg in first(JOINT_STATES, "sensor_msgs/msg/JointState", 1):
            scan.joints = list(msg.name)
    for name, static, limit in ((TF_STATIC, True, None), (TF, False, TF_MESSAGES_DECODED)):
        if not has(name, "tf2_msgs/msg/TFMessage"):
            continue
        for msg in first(name, "tf2_msgs/msg/TFMessage", limit):
            for transform in msg.transforms:
                key = (transform.header.frame_id, transform.child_frame_id)
                scan.frames[key] = scan.frames.get(key, False) or static


def _robot_name(urdf: str) -> str | None:
    import xml.etree.ElementTree as ET

    try:
        for _, element in ET.iterparse(io.BytesIO(urdf.encode("utf-8")), events=("start",)):
            return element.get("name") if element.tag == "robot" else None
    except ET.ParseError:
        return None
    return None


# -- a recording read whole --------------------------------------------------------------------


def _scan_recording(rec: Recording) -> _Scan:
    scan = _Scan(profile=rec.details.get("profile", ""), library=rec.details.get("library", ""))
    scan.compressions = {name for name in rec.details.get("compression", "").split(", ") if name}
    for name, info in rec.topics.items():
        topic = scan.topics[name] = TopicStats(info.type, info.durability)
        topic.count = info.count
        if info.first_ns is not None and info.last_ns is not None:
            topic.add_times(info.first_ns, info.last_ns)
    if rec.robot_description is not None:
        scan.robot_name = _robot_name(rec.robot_description)
    if rec.joint_states is not None:
        scan.joints = list(rec.joint_states.names)
    scan.frames = {pair: True for pair in rec.tf_static}
    for pair in rec.tf:
        scan.frames.setdefault(pair, False)
    scan.start_ns, scan.end_ns, scan.read_error = rec.start_ns, rec.end_ns, rec.read_error
    return scan


# -- result ------------------------------------------------------------------------------------


def _iso(time_ns: int) -> str:
    sec, frac = divmod(time_ns, NS_PER_S)
    return datetime.fromtimestamp(sec, tz=timezone.utc).strftime("%Y-%m-%dT%H:%M:%S") + f".{frac:09d}Z"


def _as_dict(path: Path, fmt: str, meta: BagMetadata | None, files: list[Path], scan: _Scan) -> dict[str, Any]:
    firsts = [t.first_ns for t in scan.topics.values() if t.first_ns is not None and t.count]
    lasts = [t.last_ns for t in scan.topics.values() if t.last_ns is not None and t.count]
    if scan.start_ns is not None:
        firsts.append(scan.start_ns)
    if scan.end_ns is not None:
        lasts.append(scan.end_ns)
    start = min(firsts) if firsts else None
    end = max(lasts) if lasts else None
    duration = end - start if start is not None and end is not None else 0
    topics = []
    for name, topic in scan.topics.items():
        span = (topic.last_ns or 0) - (topic.first_ns or 0)
        rate = (topic.count - 1) / (span / NS_PER_S) if topic.count > 1 and span > 0 else None
        topics.append({"name": name, "type": topic.type, "count": topic.count,
                       "rate_hz": rate, "durability": topic.durability})
    compression = ", ".join(sorted(c or "none" for c in scan.compressions)) or "no"
    return {
        "path": str(path),
        "format": fmt,
        "storage": meta.storage if meta is not None else None,
        "files": [file.name for file in files],
        "profile": scan.profile,
        "library": scan.library,
        "compression": compression,
        "message_count": sum(topic.count for topic in scan.topics.values()),
        "start_time_ns": start,
        "end_time_ns": end,
        "duration_ns": duration,
        "duration_s": duration / NS_PER_S,
        "start_time": _iso(start) if start is not None else None,
        "end_time": _iso(end) if end is not None else None,
        "topics": topics,
        "robot_name": scan.robot_name,
        "joints": scan.joints,
        "tf_frames": [{"parent": parent, "child": child, "static": static}
                      for (parent, child), static in scan.frames.items()],
        "read_error": scan.read_error,
    }
