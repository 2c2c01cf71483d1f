"""Recordings for the readers, diff and golden tests: tfrec's own MCAPs, and the same data
re-written with rosbags' writers as rosbag2 folders and ROS 1 bags (an independent encoder)."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tfrec.description import load_description
from tfrec.formats.mcap.sink import McapSink
from tfrec.formats.mcap.writer import DEFAULT_START_TIME_NS
from tfrec.kinematics.fk import Transforms, iter_dynamic_chunks, static_transforms
from tfrec.model import Robot
from tfrec.recording import Recording
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.types import JointTrajectory

from .conftest import ROBOTS

Perturb = Callable[[np.ndarray, Transforms], Transforms]


def load_robot(name: str) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # mbot's legacy xacro calls
        return load_description(ROBOTS / f"{name}.xacro")


def write_mcap(
    path: Path,
    robot: Robot,
    trajectory: JointTrajectory,
    *,
    start_time_ns: int = DEFAULT_START_TIME_NS,
    perturb: Perturb | None = None,
    description: str | None = None,
    compression: str = "zstd",
    chunk_samples: int = 4096,
    chunk_bytes: int | None = None,
) -> Path:
    """An MCAP written by tfrec's sink, optionally with transforms changed by ``perturb(time_ns, transforms)``."""
    with open(path, "wb") as stream:
        sink = (McapSink(stream, compression=compression) if chunk_bytes is None
                else McapSink(stream, compression=compression, chunk_bytes=chunk_bytes))
        sink.begin(robot_description=robot.urdf if description is None else description,
                   static=static_transforms(robot), start_time_ns=start_time_ns)
        for chunk in iter_dynamic_chunks(robot, trajectory, chunk_samples=chunk_samples):
            stamps = chunk.time_ns + start_time_ns
            transforms = chunk.transforms if perturb is None else perturb(stamps, chunk.transforms)
            sink.write_chunk(stamp_ns=stamps, joint_names=chunk.names, positions=chunk.positions,
                             velocities=chunk.velocities, transforms=transforms)
        sink.finish()
    return path


def marm_trajectory(robot: Robot, *, duration_s: float = 2.0, rate_hz: float = 50.0) -> JointTrajectory:
    return make_trajectory(robot, "sine", duration_s=duration_s, rate_hz=rate_hz)


_TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"


def _typestore(ros1: bool) -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:
        store.register(get_types_from_msg(_TF_MSG, "tf2_msgs/msg/TFMessage"))
    return store


class _Messages:
    """ROS messages of a :class:`Recording`, built with rosbags' message classes."""

    def __init__(self, store: Any, ros1: bool) -> None:
        self.store = store
        self.ros1 = ros1
        self.t = store.types
        self.seq = 0

    def header(self, time_ns: int, frame: str) -> Any:
        stamp = self.t["builtin_interfaces/msg/Time"](sec=int(time_ns // 1_000_000_000),
                                                       nanosec=int(time_ns % 1_000_000_000))
        self.seq += 1
        if self.ros1:
            return self.t["std_msgs/msg/Header"](seq=self.seq, stamp=stamp, frame_id=frame)
        return self.t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def tf(self, items: list[tuple[tuple[str, str], int, np.ndarray, np.ndarray]]) -> Any:
        t = self.t
        transforms = [
            t["geometry_msgs/msg/TransformStamped"](
                header=self.header(time_ns, parent), child_frame_id=child,
                transform=t["geometry_msgs/msg/Transform"](
                    translation=t["geometry_msgs/msg/Vector3"](x=float(tr[0]), y=float(tr[1]), z=float(tr[2])),
                    rotation=t["geometry_msgs/msg/Quaternion"](x=float(q[0]), y=float(q[1]), z=float(q[2]),
                                                               w=float(q[3])),
                ),
            )
            for (parent, child), time_ns, tr, q in items
        ]
        return t["tf2_msgs/msg/TFMessage"](transforms=transforms)

    def joint_state(self, time_ns: int, names: tuple[str, ...], positions: np.ndarray) -> Any:
        empty = np.zeros(0, dtype=np.float64)
        return self.t["sensor_msgs/msg/JointState"](
            header=self.header(time_ns, ""), name=list(names), position=np.asarray(positions, dtype=np.float64),
            velocity=empty, effort=empty,
        )


def recording_messages(rec: Recording, messages: _Messages) -> list[tuple[str, str, int, Any]]:
    """(topic, type, log time, message) of a recording, in time order."""
    out: list[tuple[str, str, int, Any]] = []
    start = rec.start_ns or 0
    if rec.robot_description is not None:
        out.append(("/robot_description", "std_msgs/msg/String", start,
                    messages.t["std_msgs/msg/String"](data=rec.robot_description)))
    if rec.tf_static:
        items = [(pair, start, tr, q) for pair, (tr, q) in rec.tf_static.items()]
        out.append(("/tf_static", "tf2_msgs/msg/TFMessage", start, messages.tf(items)))
    if rec.joint_states is not None:
        js = rec.joint_states
        for i, time_ns in enumerate(js.time_ns):
            out.append(("/joint_states", "sensor_msgs/msg/JointState", int(time_ns),
                        messages.joint_state(int(time_ns), js.names, js.positions[i])))
    if rec.tf:
        pairs = list(rec.tf)
        times = rec.tf[pairs[0]].time_ns
        for i, time_ns in enumerate(times):
            items = [(pair, int(time_ns), rec.tf[pair].translation[i], rec.tf[pair].rotation[i]) for pair in pairs]
            out.append(("/tf", "tf2_msgs/msg/TFMessage", int(time_ns), messages.tf(items)))
    out.sort(key=lambda item: item[2])
    return out


def write_rosbag2(rec: Recording, path: Path, *, storage: str = "sqlite3") -> Path:
    """The recording as a rosbag2 folder written by rosbags (sqlite3 or mcap storage)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = _typestore(ros1=False)
    plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        connections: dict[str, Any] = {}
        for topic, msgtype, time_ns, msg in recording_messages(rec, _Messages(store, ros1=False)):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], time_ns, bytes(store.serialize_cdr(msg, msgtype)))
    return path


def write_rosbag1(rec: Recording, path: Path, *, chunk_threshold: int | None = None) -> Path:
    """The recording as a ROS 1 bag written by rosbags (a chunk ends past ``chunk_threshold`` bytes: rosbags' 1 MiB
    when None)."""
    from rosbags.rosbag1 import Writer

    store = _typestore(ros1=True)
    with Writer(path) as writer:
        if chunk_threshold is not None:
            writer.chunk_threshold = chunk_threshold
        connections: dict[str, Any] = {}
        for topic, msgtype, time_ns, msg in recording_messages(rec, _Messages(store, ros1=True)):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], time_ns, bytes(store.serialize_ros1(msg, msgtype)))
    return path


def cdr_messages(rec: Recording, *, ros1: bool = False) -> dict[str, list[bytes]]:
    """Serialized messages per topic (for the decoder unit tests)."""
    store = _typestore(ros1)
    out: dict[str, list[bytes]] = {}
    for topic, msgtype, _, msg in recording_messages(rec, _Messages(store, ros1)):
        data = store.serialize_ros1(msg, msgtype) if ros1 else store.serialize_cdr(msg, msgtype)
        out.setdefault(topic, []).append(bytes(data))
    return out


def deserializer(msgtype: str, *, ros1: bool = False) -> Callable[[bytes], Any]:
    store = _typestore(ros1)
    if ros1:
        return lambda raw: store.deserialize_ros1(raw, msgtype)
    return lambda raw: store.deserialize_cdr(raw, msgtype)
