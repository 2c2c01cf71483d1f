"""``tfrec info``: what a recording holds, for tfrec's MCAP files, any ROS 2 MCAP and rosbag2 folders.

Counts and times come from the MCAP summary (Statistics, chunk and message indexes), so a
one-hour file is summarized without decompressing it; only a few messages are decoded: the first
/joint_states and /robot_description messages, every /tf_static message and the first
:data:`TF_MESSAGES_DECODED` /tf messages. Files without a summary are read linearly.
"""

from __future__ import annotations

import io
import os
import struct
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from functools import lru_cache
from pathlib import Path
from typing import IO, Any

import numpy as np

from .bag_metadata import read_bag_files
from .errors import RecordingError

__all__ = ["TF_MESSAGES_DECODED", "format_summary", "summarize"]

TF_MESSAGES_DECODED = 1000
"""/tf messages decoded for the frame list: every broadcaster of a running system appears in the
first ones, and decoding all of a long recording would take seconds."""

_MAGIC = b"\x89MCAP0\r\n"
_DURABILITY = {0: "system_default", 1: "transient_local", 2: "volatile", 3: "unknown", 4: "best_available"}


class _DecodeError(ValueError):
    """A message that its schema's type cannot decode."""


@dataclass
class _Topic:
    name: str
    type: str
    count: int = 0
    first_ns: int | None = None
    last_ns: int | None = None
    durability: str | None = None

    def add_times(self, first: int, last: int) -> None:
        self.first_ns = first if self.first_ns is None else min(self.first_ns, first)
        self.last_ns = last if self.last_ns is None else max(self.last_ns, last)


@dataclass
class _Scan:
    """What one or more MCAP files hold (merged across the files of a bag)."""

    profile: str = ""
    library: str = ""
    compressions: set[str] = field(default_factory=set)
    topics: dict[str, _Topic] = field(default_factory=dict)
    robot_name: str | None = None
    joints: list[str] | None = None
    frames: dict[tuple[str, str], bool] = field(default_factory=dict)  # (parent, child) → static


def summarize(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Summarize a recording: an MCAP file or a rosbag2 folder with MCAP storage.

    Returns:
        A JSON-ready dict: ``path``, ``format``, ``files``, ``profile``, ``library``,
        ``compression``, ``message_count``, ``start_time_ns``, ``end_time_ns``, ``duration_ns``,
        ``duration_s``, ``start_time`` and ``end_time`` (ISO 8601, UTC; None when empty),
        ``topics`` (name, type, count, rate_hz, durability), ``robot_name``, ``joints`` and
        ``tf_frames`` (parent, child, static).

    Raises:
        RecordingError: a missing file, a file that is not MCAP, an unreadable MCAP, or a folder
            that is not a rosbag2 bag with MCAP storage.
    """
    path = Path(path)
    if path.is_dir():
        fmt, files = "rosbag2", read_bag_files(path)
    elif path.exists():
        fmt, files = "mcap", [path]
    else:
        raise RecordingError(f"{path}: no such file or folder")
    scan = _Scan()
    for file in files:
        _scan_file(file, scan)
    return _as_dict(path, fmt, files, scan)


def format_summary(summary: dict[str, Any]) -> str:
    """The readable form of :func:`summarize`'s result, like ``ros2 bag info``."""
    lines = [f"File:        {summary['path']}"]
    kind = "rosbag2 folder (MCAP storage)" if summary["format"] == "rosbag2" else "MCAP"
    lines.append(f"Format:      {kind}, profile {summary['profile'] or '(none)'}, "
                 f"{summary['compression']} chunks, written by {summary['library'] or '(unknown)'}")
    if summary["format"] == "rosbag2":
        lines.append(f"Files:       {', '.join(summary['files'])}")
    if summary["robot_name"] is not None:
        lines.append(f"Robot:       {summary['robot_name']}")
    lines.append(f"Duration:    {summary['duration_ns'] / 1e9:.9f} s")
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


def _scan_file(path: Path, scan: _Scan) -> None:
    import zstandard
    from mcap.exceptions import McapError

    try:
        with open(path, "rb") as stream:
            if stream.read(len(_MAGIC)) != _MAGIC:
                raise RecordingError(f"{path}: not an MCAP file")
            stream.seek(0)
            _scan_stream(stream, scan)
    except OSError as err:
        raise RecordingError(f"{path}: cannot read: {err.strerror or err}") from None
    except _DecodeError as err:
        raise RecordingError(f"{path}: {err}") from None
    except (McapError, struct.error, ValueError, KeyError, IndexError, zstandard.ZstdError, RuntimeError) as err:
        raise RecordingError(f"{path}: unreadable MCAP ({type(err).__name__}: {err})") from None


def _scan_stream(stream: IO[bytes], scan: _Scan) -> None:
    from mcap.reader import make_reader

    reader = make_reader(stream)
    header = reader.get_header()
    scan.profile = scan.profile or header.profile
    scan.library = scan.library or header.library
    summary = reader.get_summary()
    if summary is None or summary.statistics is None:
        _scan_linear(reader, scan)
    else:
        stats = summary.statistics
        scan.compressions.update(index.compression for index in summary.chunk_indexes)
        for channel_id, channel in sorted(summary.channels.items()):
            schema = summary.schemas.get(channel.schema_id)
            topic = _topic(scan, channel.topic, schema.name if schema else "", channel.metadata)
            topic.count += stats.channel_message_counts.get(channel_id, 0)
        _channel_times(stream, summary, scan)
    _decode_some(reader, scan)


def _topic(scan: _Scan, name: str, msgtype: str, metadata: dict[str, str]) -> _Topic:
    topic = scan.topics.get(name)
    if topic is None:
        topic = scan.topics[name] = _Topic(name, msgtype, durability=_durability(metadata))
    return topic


def _durability(metadata: dict[str, str]) -> str | None:
    import yaml

    try:
        profiles = yaml.safe_load(metadata.get("offered_qos_profiles", "") or "null")
        value = profiles[0]["durability"]
    except (yaml.YAMLError, TypeError, KeyError, IndexError):
        return None
    return _DURABILITY.get(value, "unknown") if isinstance(value, int) else str(value)


def _channel_times(stream: IO[bytes], summary: Any, scan: _Scan) -> None:
    """First and last log time of every channel, from the message index records."""
    for chunk in summary.chunk_indexes:
        if not chunk.message_index_offsets:  # not indexed: the chunk's range for its channels is unknown
            for channel in summary.channels.values():
                scan.topics[channel.topic].add_times(chunk.message_start_time, chunk.message_end_time)
            continue
        for channel_id, offset in chunk.message_index_offsets.items():
            stream.seek(offset)
            opcode, length = struct.unpack("<BQ", stream.read(9))
            if opcode != 0x07 or channel_id not in summary.channels:
                raise ValueError(f"no message index for channel {channel_id} at offset {offset}")
            body = stream.read(length)
            _, size = struct.unpack_from("<HI", body)
            pairs = np.frombuffer(body, dtype="<u8", count=size // 8, offset=6).reshape(-1, 2)
            if len(pairs):
                scan.topics[summary.channels[channel_id].topic].add_times(int(pairs[:, 0].min()), int(pairs[:, 0].max()))


def _scan_linear(reader: Any, scan: _Scan) -> None:
    """A file without a summary: read every record once."""
    for schema, channel, message in reader.iter_messages(log_time_order=False):
        topic = _topic(scan, channel.topic, schema.name if schema else "", channel.metadata)
        topic.count += 1
        topic.add_times(message.log_time, message.log_time)


def _decode_some(reader: Any, scan: _Scan) -> None:
    """Decode the few messages the summary needs (see the module docstring)."""
    def has(topic: str, msgtype: str) -> bool:
        return topic in scan.topics and scan.topics[topic].type == msgtype

    if scan.robot_name is None and has("/robot_description", "std_msgs/msg/String"):
        for data in _first(reader, "/robot_description", 1):
            scan.robot_name = _robot_name(_decode(data, "std_msgs/msg/String", "/robot_description").data)
    if scan.joints is None and has("/joint_states", "sensor_msgs/msg/JointState"):
        for data in _first(reader, "/joint_states", 1):
            scan.joints = list(_decode(data, "sensor_msgs/msg/JointState", "/joint_states").name)
    for name, static, limit in (("/tf_static", True, None), ("/tf", False, TF_MESSAGES_DECODED)):
        if not has(name, "tf2_msgs/msg/TFMessage"):
            continue
        for data in _first(reader, name, limit):
            for transform in _decode(data, "tf2_msgs/msg/TFMessage", name).transforms:
                key = (transform.header.frame_id, transform.child_frame_id)
                scan.frames[key] = scan.frames.get(key, False) or static


def _first(reader: Any, topic: str, limit: int | None) -> Iterable[bytes]:
    for count, (_, _, message) in enumerate(reader.iter_messages(topics=[topic])):
        if limit is not None and count >= limit:
            return
        yield message.data


@lru_cache(maxsize=1)
def _typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _decode(data: bytes, msgtype: str, topic: str) -> Any:
    from rosbags.serde import SerdeError

    try:
        return _typestore().deserialize_cdr(data, msgtype)
    except (SerdeError, struct.error, IndexError, ValueError, UnicodeDecodeError) as err:
        raise _DecodeError(f"cannot decode a {topic} message as {msgtype} ({type(err).__name__}: {err})") from None


def _robot_name(urdf: str) -> str | None:
    import xml.etree.ElementTree as ET

    try:
        for _, element in ET.iterparse(io.BytesIO(urdf.encode("utf-8")), events=("start",)):
            return element.get("name") if element.tag == "robot" else None
    except ET.ParseError:
        return None
    return None


# -- result ------------------------------------------------------------------------------------


def _iso(time_ns: int) -> str:
    sec, frac = divmod(time_ns, 1_000_000_000)
    return datetime.fromtimestamp(sec, tz=timezone.utc).strftime("%Y-%m-%dT%H:%M:%S") + f".{frac:09d}Z"


def _as_dict(path: Path, fmt: str, files: list[Path], scan: _Scan) -> dict[str, Any]:
    firsts = [t.first_ns for t in scan.topics.values() if t.first_ns is not None and t.count]
    lasts = [t.last_ns for t in scan.topics.values() if t.last_ns is not None and t.count]
    start = min(firsts) if firsts else None
    end = max(lasts) if lasts else None
    duration = end - start if start is not None and end is not None else 0
    topics = []
    for topic in scan.topics.values():
        span = (topic.last_ns or 0) - (topic.first_ns or 0)
        rate = (topic.count - 1) / (span / 1e9) if topic.count > 1 and span > 0 else None
        topics.append({"name": topic.name, "type": topic.type, "count": topic.count,
                       "rate_hz": rate, "durability": topic.durability})
    compression = ", ".join(sorted(c or "none" for c in scan.compressions)) or "no"
    return {
        "path": str(path),
        "format": fmt,
        "files": [file.name for file in files],
        "profile": scan.profile,
        "library": scan.library,
        "compression": compression,
        "message_count": sum(topic.count for topic in scan.topics.values()),
        "start_time_ns": start,
        "end_time_ns": end,
        "duration_ns": duration,
        "duration_s": duration / 1e9,
        "start_time": _iso(start) if start is not None else None,
        "end_time": _iso(end) if end is not None else None,
        "topics": topics,
        "robot_name": scan.robot_name,
        "joints": scan.joints,
        "tf_frames": [{"parent": parent, "child": child, "static": static}
                      for (parent, child), static in scan.frames.items()],
    }
