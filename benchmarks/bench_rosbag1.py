"""ROS 1 bag writing speed and memory: tfrec's vectorized writer against rosbags' ``rosbag1.Writer``.

1. Write rate. One hour at 100 Hz of a 10-joint chain (360,000 samples: 360,000 /joint_states +
   360,000 /tf messages of 10 transforms, plus /robot_description and /tf_static) is written:
   - tfrec: ``Ros1BagSink.write_chunk`` on the FK chunks (fixed-layout ROS 1 serialization built
     with numpy, batched message records), for each compression;
   - baseline: rosbags' ``rosbag1.Writer.write`` of ``typestore.serialize_ros1`` of rosbags message
     objects, on a subset of the samples, extrapolated to the hour. The message objects are built
     before the clock starts, so the baseline is timed at its most favourable.
   FK itself is outside both timings; the full streaming path (trajectory → FK chunks → sink) is
   reported on its own line.
2. Peak memory (``ru_maxrss``, in a fresh subprocess) of the full streaming path for that hour.

Run from the repository root:

    .venv/bin/python benchmarks/bench_rosbag1.py
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from _common import best_of, machine
from bench_mcap import chain

from tfrec.conventions import DEFAULT_START_TIME_NS, NS_PER_S
from tfrec.formats.ros.types import TF_MESSAGE_DEFINITION
from tfrec.formats.rosbag1 import Ros1BagSink
from tfrec.formats.rosbag1.writer import _WORKERS
from tfrec.kinematics.fk import DynamicChunk, iter_dynamic_chunks, static_transforms
from tfrec.model import Robot
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.types import JointTrajectory

RATE_HZ = 100.0
TARGET_S = 10.0
TARGET_RSS_MB = 500.0


def write_tfrec(path: Path, robot: Robot, chunks: list[DynamicChunk], compression: str) -> None:
    """The sink alone, on FK chunks computed beforehand."""
    sink = Ros1BagSink(path, compression=compression)
    sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=DEFAULT_START_TIME_NS)
    for chunk in chunks:
        sink.write_chunk(stamp_ns=chunk.time_ns + DEFAULT_START_TIME_NS, joint_names=chunk.names,
                         positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()


def full_path(path: Path, robot: Robot, trajectory: JointTrajectory, compression: str = "none") -> float:
    """Seconds of the full streaming path: FK chunks → Ros1BagSink, as ``tfrec record`` would run it."""
    start = time.perf_counter()
    sink = Ros1BagSink(path, compression=compression)
    sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=DEFAULT_START_TIME_NS)
    for chunk in iter_dynamic_chunks(robot, trajectory):
        sink.write_chunk(stamp_ns=chunk.time_ns + DEFAULT_START_TIME_NS, joint_names=chunk.names,
                         positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()
    return time.perf_counter() - start


def _store() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg(TF_MESSAGE_DEFINITION, "tf2_msgs/msg/TFMessage"))
    return store


def baseline_messages(store: Any, chunks: list[DynamicChunk], samples: int) -> list[tuple[str, Any, int]]:
    """(topic, rosbags message object, time) of the first ``samples`` samples."""
    t = store.types
    out: list[tuple[str, Any, int]] = []
    seq = 0
    for chunk in chunks:
        for i in range(len(chunk.time_ns)):
            if len(out) >= 2 * samples:
                return out
            ns = int(chunk.time_ns[i]) + DEFAULT_START_TIME_NS
            stamp = t["builtin_interfaces/msg/Time"](sec=ns // NS_PER_S, nanosec=ns % NS_PER_S)
            out.append(("/joint_states", t["sensor_msgs/msg/JointState"](
                header=t["std_msgs/msg/Header"](seq=seq, stamp=stamp, frame_id=""), name=list(chunk.names),
                position=chunk.positions[i].copy(), velocity=chunk.velocities[i].copy(), effort=np.zeros(0),
            ), ns))
            seq += 1
            tf = chunk.transforms
            out.append(("/tf", t["tf2_msgs/msg/TFMessage"](transforms=[
                t["geometry_msgs/msg/TransformStamped"](
                    header=t["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=parent), child_frame_id=child,
                    transform=t["geometry_msgs/msg/Transform"](
                        translation=t["geometry_msgs/msg/Vector3"](*tf.translation[i, k].tolist()),
                        rotation=t["geometry_msgs/msg/Quaternion"](*tf.rotation[i, k].tolist()),
                    ))
                for k, (parent, child) in enumerate(zip(tf.parents, tf.children))
            ]), ns))
    return out


def write_baseline(path: Path, store: Any, messages: list[tuple[str, Any, int]], compression: str) -> float:
    """Seconds for rosbags' Writer to serialize and write ``messages``."""
    from rosbags.rosbag1 import Writer

    path.unlink(missing_ok=True)
    start = time.perf_counter()
    writer = Writer(path)
    if compression != "none":
        writer.set_compression(Writer.CompressionFormat[compression.upper()])
    with writer:
        connections = {
            topic: writer.add_connection(topic, msgtype, typestore=store)
            for topic, msgtype in (("/joint_states", "sensor_msgs/msg/JointState"), ("/tf", "tf2_msgs/msg/TFMessage"))
        }
        types = {"/joint_states": "sensor_msgs/msg/JointState", "/tf": "tf2_msgs/msg/TFMessage"}
        for topic, msg, ns in messages:
            writer.write(connections[topic], ns, store.serialize_ros1(msg, types[topic]))
    return time.perf_counter() - start


def memory_child(out: Path, samples: int) -> None:
    """The full streaming path. Prints seconds, bag MB, peak RSS after the imports and at the end (MB)."""
    start_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux
    robot = chain(10)
    trajectory = make_trajectory(robot, "random", duration_s=samples / RATE_HZ, rate_hz=RATE_HZ, seed=0)
    elapsed = full_path(out, robot, trajectory)
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(elapsed, out.stat().st_size / 1e6, start_mb, rss_mb)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hours", type=float, default=1.0, help="recording length at 100 Hz (h)")
    parser.add_argument("--baseline-samples", type=int, default=5_000, help="samples for the baseline")
    parser.add_argument("--no-memory", action="store_true", help="skip the memory run")
    parser.add_argument("--memory-child", metavar="OUT", help=argparse.SUPPRESS)
    options = parser.parse_args(argv)
    samples = round(options.hours * 3600 * RATE_HZ)
    if options.memory_child:
        memory_child(Path(options.memory_child), samples)
        return 0

    memory = None
    if not options.no_memory:  # first, before this process grows (fork carries the high-water RSS over)
        with tempfile.TemporaryDirectory() as tmp:
            memory = subprocess.run(
                [sys.executable, __file__, "--memory-child", str(Path(tmp) / "hour.bag"), "--hours", str(options.hours)],
                check=True, capture_output=True, text=True,
            ).stdout.split()

    robot = chain(10)
    trajectory = make_trajectory(robot, "random", duration_s=samples / RATE_HZ, rate_hz=RATE_HZ, seed=0)
    chunks = list(iter_dynamic_chunks(robot, trajectory))
    n = len(trajectory)
    messages = 2 * n + 2
    print(f"robot: inline chain, {len(robot.moving_joints)} moving joints, "
          f"{len(chunks[0].transforms.children)} dynamic transforms per /tf message; "
          f"{options.hours:g} h at {RATE_HZ:g} Hz = {n:,} samples, {messages:,} messages")
    print(machine("rosbags", "lz4"))
    store = _store()
    subset = baseline_messages(store, chunks, options.baseline_samples)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        sizes: dict[str, float] = {}
        for compression in ("none", "lz4", "bz2"):
            out = folder / f"tfrec-{compression}.bag"
            write_tfrec(folder / "warm.bag", robot, chunks[:1], compression)
            repeat = 1 if compression == "bz2" else 3
            seconds = best_of(repeat, partial(write_tfrec, out, robot, chunks, compression))
            base_s = write_baseline(folder / "baseline.bag", store, subset, compression) * n / (len(subset) // 2)
            sizes[compression] = out.stat().st_size / 1e6
            if compression == "bz2":  # bz2 level 9 itself is the bound (rosbag's level): its input rate instead
                verdict = f"bz2 level 9 bound: {sizes['none'] / seconds:.0f} MB/s of records on {_WORKERS} threads"
            else:
                verdict = f"target < {TARGET_S:g} s: {'met' if seconds < TARGET_S else 'NOT met'}"
            print(f"{compression:>4}: tfrec Ros1BagSink {seconds:.2f} s ({'best of 3' if repeat == 3 else 'once'}; "
                  f"{messages / seconds:,.0f} msg/s, {sizes[compression]:.0f} MB); rosbags Writer + "
                  f"serialize_ros1 {base_s:.0f} s (extrapolated from {len(subset):,} messages); "
                  f"ratio {base_s / seconds:.0f}x; {verdict}")
        full_s = full_path(folder / "full.bag", robot, trajectory)
        print(f"full streaming path (FK chunks + Ros1BagSink, none): {full_s:.2f} s = {messages / full_s:,.0f} msg/s")
    if memory is not None:
        write_s, size_mb, start_mb, rss_mb = (float(value) for value in memory)
        print(f"memory: full streaming path in a fresh process, {size_mb:.0f} MB bag in {write_s:.1f} s; peak RSS "
              f"{rss_mb:.0f} MB (after imports {start_mb:.0f} MB); target < {TARGET_RSS_MB:.0f} MB: "
              f"{'met' if rss_mb < TARGET_RSS_MB else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
