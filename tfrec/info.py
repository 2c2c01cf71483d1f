"""``tfrec info``: what a recording holds — MCAP, rosbag2 folder (mcap or sqlite3), ROS 1 bag, ``.rrd``.

The summary comes from the file's own index wherever it has one — an MCAP's message indexes, a
ROS 1 bag's index records, a sqlite3 database's counts — so a one-hour file is summarized without
reading its messages; only a few are decoded (:func:`tfrec.formats.read_recording` with
``summary``): every /robot_description and /tf_static message, the first /joint_states message
and the first thousand /tf messages of each namespace. A damaged file is summarized as far as it
is readable, with one warning saying what was lost (:attr:`Recording.read_error`, also in the
result's ``read_error``).

The robots are those ``replay`` shows and ``diff`` compares (:func:`tfrec.robots.find_robots`):
one per description, per namespace (``/robot1/robot_description``…).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterable, Mapping
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from tfrec.conventions import CLOCK_GAP_NS, JOINT_STATES, NS_PER_S, TF, namespace_name
from tfrec.errors import TfrecWarning, printable
from tfrec.formats.reader import identify_recording, read_recording
from tfrec.recording import Recording
from tfrec.robots import RecordedRobot, find_robots

__all__ = ["format_summary", "summarize"]

_KINDS = {"mcap": "MCAP", "rosbag1": "ROS 1 bag", "rrd": "Rerun recording (.rrd)"}


def summarize(path: str | os.PathLike[str], *, namespace: str | None = None,
              remap: Iterable[str] | Mapping[str, str] | None = None) -> dict[str, Any]:
    """Summarize a recording: whatever :func:`tfrec.formats.read_recording` reads.

    A damaged file is summarized as far as it is readable, with a warning saying what was lost.

    Args:
        path: the recording.
        namespace: list only the robots of this namespace.
        remap: topic remapping rules, ``FROM:=TO``, as ROS remapping applies them.

    Returns:
        A JSON-ready dict: ``path``, ``format`` (``mcap``, ``rosbag2``, ``rosbag1``, ``rrd``),
        ``storage`` (a rosbag2 folder's storage plugin, else None), ``files``, ``metadata_yaml``
        (a rosbag2 folder: whether it has one; else None), ``profile`` and
        ``library`` (an MCAP's header; None for other formats), ``compression`` (of the chunks),
        ``bag_compression`` (a rosbag2 bag's: ``zstd file``, ``zstd message``; else None),
        ``message_count``, ``start_time_ns``, ``end_time_ns``, ``duration_ns``, ``duration_s``,
        ``start_time`` and ``end_time`` (ISO 8601, UTC; None when empty) — log times —,
        ``topics`` (name, type, count, rate_hz, durability), ``robots`` (key, namespace, name,
        problem, joints, tf_frames), ``robot_name``, ``joints`` and ``tf_frames`` (of every
        robot together), ``stamps`` (None, or the first header stamp of /joint_states and /tf
        when they are on another clock than the log times: ``first_ns``, ``clock``) and
        ``read_error`` (None, or what a damaged file lost), ``recipe`` (how ``tfrec record`` made it: the
        ``tfrec.recipe`` metadata map of :mod:`tfrec.recipe`, or None).

    Raises:
        ReadError: a missing file, one that is not a recording, one with nothing readable,
            or a message that cannot be decoded.
    """
    source = identify_recording(path)
    recording = read_recording(source, namespace=namespace, remap=remap, summary=True)
    if recording.read_error is not None:
        warnings.warn(recording.read_error, TfrecWarning, stacklevel=2)
    robots = find_robots(recording, namespace=None if namespace is None else namespace_name(namespace))
    meta = source.bag
    firsts = [t.first_ns for t in recording.topics.values() if t.first_ns is not None and t.count]
    lasts = [t.last_ns for t in recording.topics.values() if t.last_ns is not None and t.count]
    start = min([*firsts, *([recording.start_ns] if recording.start_ns is not None else [])], default=None)
    end = max([*lasts, *([recording.end_ns] if recording.end_ns is not None else [])], default=None)
    duration = end - start if start is not None and end is not None else 0
    topics = []
    for name, topic in recording.topics.items():
        span = (topic.last_ns or 0) - (topic.first_ns or 0)
        rate = (topic.count - 1) / (span / NS_PER_S) if topic.count > 1 and span > 0 else None
        topics.append({"name": name, "type": topic.type, "count": topic.count,
                       "rate_hz": rate, "durability": topic.durability})
    details = recording.details
    compression = details.get("compression", "")
    listed = [_robot(robot) for robot in robots]
    return {
        "path": str(source.path),
        "format": source.format,
        "storage": meta.storage if meta is not None else None,
        "files": [file.name for file in source.files],
        "metadata_yaml": None if meta is None else meta.topic_counts is not None,
        "profile": details.get("profile") or None,
        "library": details.get("library") or None,
        "compression": ", ".join(sorted(c or "none" for c in compression.split(", "))) if compression else "no",
        "bag_compression": details.get("bag_compression"),
        "message_count": sum(topic.count for topic in recording.topics.values()),
        "start_time_ns": start,
        "end_time_ns": end,
        "duration_ns": duration,
        "duration_s": duration / NS_PER_S,
        "start_time": _iso(start) if start is not None else None,
        "end_time": _iso(end) if end is not None else None,
        "topics": topics,
        "robots": listed,
        "robot_name": next((robot["name"] for robot in listed if robot["name"] is not None), None),
        "joints": next((robot["joints"] for robot in listed if robot["joints"] is not None), None),
        "tf_frames": [frame for robot in listed for frame in robot["tf_frames"]],
        "stamps": _stamps(recording),
        "read_error": recording.read_error,
        "recipe": _recipe(source.files if source.format in ("mcap", "rosbag2") else ()),
    }


def _recipe(files: Iterable[Path]) -> dict[str, str] | None:
    """How ``tfrec record`` made the recording: its ``tfrec.recipe`` metadata (:mod:`tfrec.recipe`), or None."""
    for file in files:
        if os.fspath(file).endswith(".mcap"):
            from tfrec.formats.mcap.summary import metadata_records

            try:
                found = metadata_records(file).get("tfrec.recipe")
            except OSError:
                continue
            if found is not None:
                return found
    return None


def _robot(robot: RecordedRobot) -> dict[str, Any]:
    frames = {pair: True for pair in robot.tf_static}
    for pair in robot.tf:
        frames.setdefault(pair, False)
    return {
        "key": robot.key,
        "namespace": robot.namespace,
        "name": robot.name,
        "problem": robot.problem,
        "joints": None if robot.joint_states is None else list(robot.joint_states.names),
        "tf_frames": [{"parent": parent, "child": child, "static": static} for (parent, child), static in frames.items()],
    }


def _stamps(rec: Recording) -> dict[str, Any] | None:
    """The first header stamp of /joint_states and /tf, when it is on another clock than their log times."""
    stamps: list[int] = []
    logged: list[int] = []
    for namespace in rec.namespace_names():
        topics = rec.robot_topics(namespace)
        series = [s.time_ns for s in topics.tf.values() if len(s)]
        if topics.joint_states is not None and len(topics.joint_states):
            series.append(topics.joint_states.time_ns)
        stamps += [int(s.min()) for s in series]
        for kind in (JOINT_STATES, TF):
            info = rec.topics.get(namespace + kind)
            if info is not None and info.first_ns is not None:
                logged.append(info.first_ns)
    if rec.time_base != "header" or not stamps or not logged or abs(min(stamps) - min(logged)) <= CLOCK_GAP_NS:
        return None
    if max(stamps) == 0:
        return {"first_ns": 0, "clock": "stamped 0"}
    return {"first_ns": min(stamps), "clock": "another clock than the log times (sim time?)"}


# -- text ------------------------------------------------------------------------------------------


def _iso(time_ns: int) -> str:
    sec, frac = divmod(time_ns, NS_PER_S)
    return datetime.fromtimestamp(sec, tz=timezone.utc).strftime("%Y-%m-%dT%H:%M:%S") + f".{frac:09d}Z"


def _format_kind(summary: dict[str, Any]) -> str:
    fmt, storage = summary["format"], summary["storage"]
    compression = summary["compression"].replace("none", "uncompressed")
    kind = _KINDS.get(fmt) or f"rosbag2 folder ({'MCAP' if storage == 'mcap' else storage} storage"
    if fmt == "rosbag2":
        if summary["bag_compression"]:
            kind += f", {summary['bag_compression']} compression"
        kind += ")" if summary["metadata_yaml"] else ", no metadata.yaml)"
    if fmt == "mcap" or storage == "mcap":
        kind += (f", profile {summary['profile'] or '(none)'}, {compression} chunks, "
                 f"written by {summary['library'] or '(unknown)'}")
    elif fmt == "rosbag1":
        kind += f", {compression} chunks"
    return kind


def _robot_lines(robot: dict[str, Any], indent: str) -> list[str]:
    lines = []
    if robot["joints"] is not None:
        named = ", ".join(robot["joints"]) or "none (its /joint_states messages name no joint)"
        lines.append(f"{indent}Joints ({len(robot['joints'])}): {named}")
    frames = robot["tf_frames"]
    if frames:
        lines.append(f"{indent}TF frames ({len(frames)} parent → child):")
        lines += [f"{indent}  {f['parent']} → {f['child']}{'  (static)' if f['static'] else ''}" for f in frames]
    elif robot["name"] is not None:
        lines.append(f"{indent}TF frames:   none")
    return lines


def _robot_name(robot: dict[str, Any]) -> str:
    name = robot["name"] or ("(frames of no robot)" if robot["key"].endswith("other_frames") else "(no description)")
    if robot["problem"] is not None:
        name += f" (its description is not usable: {robot['problem']})"
    return name


def format_summary(summary: dict[str, Any]) -> str:
    """The readable form of :func:`summarize`'s result, like ``ros2 bag info``. What the recording names (topics,
    types, frames, joints, files) is shown escaped where it holds a character that is not printable
    (:func:`tfrec.errors.printable`), the topics' columns aligned on what is shown."""
    lines = [f"File:        {summary['path']}", f"Format:      {_format_kind(summary)}"]
    if summary["format"] == "rosbag2":
        lines.append(f"Files:       {', '.join(summary['files'])}")
    robots = summary["robots"]
    if len(robots) == 1 and robots[0]["key"] == "" and (robots[0]["name"] or robots[0]["problem"]):
        lines.append(f"Robot:       {_robot_name(robots[0])}")
    lines.append(f"Duration:    {summary['duration_ns'] / NS_PER_S:.9f} s")
    if summary["start_time_ns"] is not None:
        lines.append(f"Start:       {summary['start_time']} ({summary['start_time_ns']} ns)")
        lines.append(f"End:         {summary['end_time']} ({summary['end_time_ns']} ns)")
    stamps = summary["stamps"]
    if stamps is not None and stamps["clock"] == "stamped 0":
        lines.append("Stamps:      /joint_states and /tf are stamped 0: no time of their own (replay them with "
                     "--use-log-time)")
    elif stamps is not None:
        lines.append(f"Stamps:      header stamps of /joint_states and /tf from {stamps['first_ns'] / NS_PER_S:.3f} s: "
                     f"{stamps['clock']}; replay, diff and --check use the header stamps (--use-log-time: the log times)")
    recipe = summary.get("recipe")
    if recipe is not None:
        lines.append(f"Made with:   {recipe.get('command', '?')}   (tfrec {recipe.get('tfrec_version') or '?'}; "
                     f"remake: tfrec record --like {summary['path']})")
        lines.append(f"             description sha256 {recipe.get('description_sha256') or '?'}, expanded URDF "
                     f"sha256 {recipe.get('urdf_sha256') or '?'}")
    lines.append(f"Messages:    {summary['message_count']}")
    topics = summary["topics"]
    lines.append(f"Topics ({len(topics)}):")
    rows = [
        (printable(t["name"]), printable(t["type"]), f"{t['count']} msg{'s' if t['count'] != 1 else ''}",
         f"{t['rate_hz']:.3f} Hz" if t["rate_hz"] is not None else "", printable(t["durability"] or ""))
        for t in topics
    ]
    widths = [max((len(row[i]) for row in rows), default=0) for i in range(5)]
    for row in rows:
        cells = [row[0].ljust(widths[0]), row[1].ljust(widths[1]), row[2].rjust(widths[2]),
                 row[3].rjust(widths[3]), row[4]]
        lines.append(("  " + "  ".join(cells)).rstrip())
    if len(robots) == 1 and robots[0]["key"] == "":
        lines += _robot_lines(robots[0], "")
    elif robots:
        lines.append(f"Robots ({len(robots)}):")
        for robot in robots:
            lines.append(f"  {robot['key']}: {_robot_name(robot)}")
            lines += _robot_lines(robot, "    ")
    return "\n".join(printable(line) for line in lines)
