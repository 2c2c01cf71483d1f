"""Bags the way real systems record them, written with rosbags' writers (an independent encoder):
namespaced robots, robots sharing /tf with prefixed frames, relative topic names, ROS 1 frame ids
with a leading slash, sim time, a driver that stamps 0 — from a tfrec recording's data."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tests.recording_helpers import _Messages, _typestore
from tfrec.recording import Recording

Message = tuple[str, str, int, Any]
"""(topic, type, log time, message)."""


@dataclass(frozen=True)
class Robot:
    """How one robot of a recording is published.

    Attributes:
        rec: its data (a tfrec recording read back).
        namespace: put in front of its topics (``/robot1``).
        frame_prefix: put in front of its frame ids (robot_state_publisher's ``frame_prefix``).
        description: its /robot_description text (default: the recording's).
        header: the header stamp of a sample logged at a time (default: the same time).
        relative: record its topics without the leading slash (``joint_states``).
        topics: the topics of it to record, by base name.
    """

    rec: Recording
    namespace: str = ""
    frame_prefix: str = ""
    description: str | None = None
    header: Callable[[int], int] | None = None
    relative: bool = False
    topics: Sequence[str] = ("/robot_description", "/tf_static", "/joint_states", "/tf")


def robot_messages(robot: Robot, *, ros1: bool) -> list[Message]:
    """The messages a robot's publishers send, in log-time order."""
    rec = robot.rec
    messages = _Messages(_typestore(ros1), ros1)
    t = messages.t
    stamp = robot.header or (lambda time_ns: time_ns)
    prefix = robot.frame_prefix

    def topic(base: str) -> str:
        name = robot.namespace + base
        return name.lstrip("/") if robot.relative else name

    out: list[Message] = []
    start = rec.start_ns or 0
    description = robot.description if robot.description is not None else rec.robot_description
    if "/robot_description" in robot.topics and description is not None:
        out.append((topic("/robot_description"), "std_msgs/msg/String", start, t["std_msgs/msg/String"](data=description)))
    if "/tf_static" in robot.topics and rec.tf_static:
        items = [((prefix + p, prefix + c), stamp(start), tr, q) for (p, c), (tr, q) in rec.tf_static.items()]
        out.append((topic("/tf_static"), "tf2_msgs/msg/TFMessage", start, messages.tf(items)))
    if "/joint_states" in robot.topics and rec.joint_states is not None:
        js = rec.joint_states
        for i, time_ns in enumerate(js.time_ns.tolist()):
            out.append((topic("/joint_states"), "sensor_msgs/msg/JointState", time_ns,
                        messages.joint_state(stamp(time_ns), js.names, js.positions[i])))
    if "/tf" in robot.topics and rec.tf:
        pairs = list(rec.tf)
        for i, time_ns in enumerate(rec.tf[pairs[0]].time_ns.tolist()):
            items = [((prefix + p, prefix + c), stamp(time_ns), rec.tf[(p, c)].translation[i],
                      rec.tf[(p, c)].rotation[i]) for p, c in pairs]
            out.append((topic("/tf"), "tf2_msgs/msg/TFMessage", time_ns, messages.tf(items)))
    return out


def write_bag(path: Path, robots: Iterable[Robot], *, kind: str, extra: Sequence[Message] = ()) -> Path:
    """The robots' messages (and ``extra`` ones) as a rosbag2 folder (``mcap``, ``sqlite3``) or a ROS 1
    bag (``ros1``), in log-time order; the description and static TF latched."""
    ros1 = kind == "ros1"
    store = _typestore(ros1)
    messages = sorted([m for robot in robots for m in robot_messages(robot, ros1=ros1)] + list(extra),
                      key=lambda m: m[2])
    latched = ("robot_description", "tf_static")
    if ros1:
        from rosbags.rosbag1 import Writer as Writer1

        with Writer1(path) as writer1:
            connections1: dict[str, Any] = {}
            for topic, msgtype, time_ns, msg in messages:
                if topic not in connections1:
                    connections1[topic] = writer1.add_connection(
                        topic, msgtype, typestore=store, latching=1 if topic.endswith(latched) else None)
                writer1.write(connections1[topic], time_ns, bytes(store.serialize_ros1(msg, msgtype)))
        return path
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        connections: dict[str, Any] = {}
        for topic, msgtype, time_ns, msg in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], time_ns, bytes(store.serialize_cdr(msg, msgtype)))
    return path


def renamed(urdf: str, name: str) -> str:
    """A URDF with another robot name (a second robot of one model, published on one topic)."""
    head, sep, rest = urdf.partition("<robot name=")
    quote = rest[0]
    return head + sep + quote + name + rest[rest.index(quote, 1):]


def zeros(_: int) -> int:
    """The header stamp of a driver that stamps nothing: 0."""
    return 0


def sim_time(start_ns: int, at_s: float = 12.0) -> Callable[[int], int]:
    """Header stamps of a simulation started ``at_s`` seconds before ``start_ns`` (use_sim_time): seconds
    since the simulator started, while log times are the wall clock."""
    offset = start_ns - int(at_s * 1e9)
    return lambda time_ns: time_ns - offset
