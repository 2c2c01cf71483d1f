"""MCAP writing speed and memory: tfrec's vectorized sink against mcap_ros2's Writer.

1. Write rate. The same /joint_states + /tf data of a 10-joint chain (10 moving joints, 10 dynamic
   transforms per /tf message) is written twice, to a file with zstd chunks:
   - tfrec: ``McapSink.write_chunk`` on the FK chunks (fixed-layout CDR built with numpy);
   - baseline: ``mcap_ros2.writer.Writer.write_message`` fed one dict per message. The dicts are
     built before the clock starts, so the baseline is timed at its most favourable.
   FK itself is outside both timings; the full streaming path (trajectory → FK chunks → sink) is
   reported on its own line.
2. Peak memory (``ru_maxrss``, in a fresh subprocess) of a one-hour 100 Hz recording of
   robots/marm.xacro through the full streaming path, as ``tfrec record`` runs it.

Run from the repository root:

    .venv/bin/python benchmarks/bench_mcap.py
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

from _common import best_of, machine

from tfrec.conventions import DEFAULT_START_TIME_NS, NS_PER_S
from tfrec.description import load_description, parse_urdf
from tfrec.formats.mcap.sink import McapSink
from tfrec.formats.mcap.writer import message_definition
from tfrec.kinematics.fk import DynamicChunk, iter_dynamic_chunks, static_transforms
from tfrec.model import Robot
from tfrec.recorder import plan_outputs, record
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.types import JointTrajectory

REPO = Path(__file__).resolve().parents[1]
TARGET_RATIO = 10.0
TARGET_RATE = 150_000.0
TARGET_RSS_MB = 500.0


def chain(joints: int = 10) -> Robot:
    """A serial chain of revolute joints with a fixed tool frame."""
    parts = ['<robot name="chain10">', '<link name="link0"/>']
    for i in range(1, joints + 1):
        axis = ("0 0 1", "0 1 0", "1 0 0")[i % 3]
        parts.append(
            f'<link name="link{i}"/><joint name="joint{i}" type="revolute"><parent link="link{i - 1}"/>'
            f'<child link="link{i}"/><origin xyz="0 0 0.1" rpy="0 0 0.3"/><axis xyz="{axis}"/>'
            f'<limit lower="-2.5" upper="2.5" effort="10" velocity="2"/></joint>'
        )
    parts.append(f'<link name="tool0"/><joint name="tool_joint" type="fixed"><parent link="link{joints}"/>'
                 '<child link="tool0"/><origin xyz="0 0 0.05"/></joint></robot>')
    return parse_urdf("".join(parts))


def write_tfrec(path: Path, robot: Robot, chunks: list[DynamicChunk], compression: str) -> None:
    """The sink alone, on FK chunks computed beforehand."""
    with open(path, "wb") as stream:
        sink = McapSink(stream, compression=compression)
        sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=DEFAULT_START_TIME_NS)
        for chunk in chunks:
            sink.write_chunk(stamp_ns=chunk.time_ns + DEFAULT_START_TIME_NS, joint_names=chunk.names,
                             positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
        sink.finish()


def full_path(path: Path, robot: Robot, trajectory: JointTrajectory) -> float:
    """Seconds of the full streaming path (FK chunks → McapSink, zstd): ``tfrec record -o path --no-rrd``."""
    start = time.perf_counter()
    record(robot, trajectory, plan_outputs(stem=path.stem, out=path, no_rrd=True, force=True))
    return time.perf_counter() - start


def baseline_messages(chunks: list[DynamicChunk], samples: int) -> list[tuple[str, dict[str, Any], int]]:
    out: list[tuple[str, dict[str, Any], int]] = []
    for chunk in chunks:
        for i in range(len(chunk.time_ns)):
            if len(out) >= 2 * samples:
                return out
            t = int(chunk.time_ns[i]) + DEFAULT_START_TIME_NS
            stamp = {"sec": t // NS_PER_S, "nanosec": t % NS_PER_S}
            out.append(("/joint_states", {
                "header": {"stamp": stamp, "frame_id": ""}, "name": list(chunk.names),
                "position": chunk.positions[i].tolist(), "velocity": chunk.velocities[i].tolist(), "effort": [],
            }, t))
            tf = chunk.transforms
            out.append(("/tf", {"transforms": [
                {"header": {"stamp": stamp, "frame_id": parent}, "child_frame_id": child, "transform": {
                    "translation": dict(zip("xyz", tf.translation[i, k].tolist())),
                    "rotation": dict(zip("xyzw", tf.rotation[i, k].tolist()))}}
                for k, (parent, child) in enumerate(zip(tf.parents, tf.children))
            ]}, t))
    return out


def write_baseline(path: Path, messages: list[tuple[str, dict[str, Any], int]]) -> float:
    from mcap_ros2.writer import Writer

    start = time.perf_counter()
    with open(path, "wb") as stream:
        writer = Writer(stream)  # zstd chunks
        schemas = {
            topic: writer.register_msgdef(msgtype, message_definition(msgtype)[0])
            for topic, msgtype in (("/joint_states", "sensor_msgs/msg/JointState"), ("/tf", "tf2_msgs/msg/TFMessage"))
        }
        for topic, msg, t in messages:
            writer.write_message(topic, schemas[topic], msg, log_time=t, publish_time=t)
        writer.finish()  # type: ignore[no-untyped-call]
    return time.perf_counter() - start


def memory_child(out: Path, duration_s: float, rate_hz: float) -> None:
    """The full streaming path, as ``tfrec record`` runs it. Prints samples, recording seconds,
    process seconds, MCAP MB, peak RSS after the imports (MB) and peak RSS at the end (MB)."""
    start_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux
    start = time.perf_counter()
    robot = load_description(REPO / "robots" / "marm.xacro")
    trajectory = make_trajectory(robot, "random", duration_s=duration_s, rate_hz=rate_hz, seed=1)
    elapsed = full_path(out, robot, trajectory)
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux
    print(len(trajectory), elapsed, time.perf_counter() - start, out.stat().st_size / 1e6, start_mb, rss_mb)


def measure_memory(hours: float) -> list[str]:
    """Run :func:`memory_child` in a fresh interpreter. Done before this process allocates much:
    Linux carries the parent's high-water RSS over fork + exec into the child's ``ru_maxrss``."""
    with tempfile.TemporaryDirectory() as tmp:
        result = subprocess.run(
            [sys.executable, __file__, "--memory-child", str(Path(tmp) / "hour.mcap"), "--memory-hours", str(hours)],
            check=True, capture_output=True, text=True,
        )
    return result.stdout.split()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, default=200_000, help="samples for tfrec (2 messages each)")
    parser.add_argument("--baseline-samples", type=int, default=10_000, help="samples for the baseline")
    parser.add_argument("--memory-hours", type=float, default=1.0, help="length of the memory run (h)")
    parser.add_argument("--no-memory", action="store_true", help="skip the memory run")
    parser.add_argument("--memory-child", metavar="OUT", help=argparse.SUPPRESS)
    options = parser.parse_args(argv)
    if options.memory_child:
        memory_child(Path(options.memory_child), options.memory_hours * 3600.0, 100.0)
        return 0

    memory = None if options.no_memory else measure_memory(options.memory_hours)
    robot = chain(10)
    rate_hz = 1000.0
    trajectory = make_trajectory(robot, "random", duration_s=options.samples / rate_hz, rate_hz=rate_hz, seed=0)
    chunks = list(iter_dynamic_chunks(robot, trajectory))
    n = len(trajectory)
    print(f"robot: inline chain, {len(robot.moving_joints)} moving joints, "
          f"{len(chunks[0].transforms.children)} dynamic transforms per /tf message")
    print(machine("mcap", "mcap-ros2-support"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rates = {}
        for compression in ("zstd", "lz4", "none"):
            out = folder / f"tfrec-{compression}.mcap"
            write_tfrec(folder / "warm.mcap", robot, chunks[:1], compression)
            seconds = best_of(3, partial(write_tfrec, out, robot, chunks, compression))
            rates[compression] = 2 * n / seconds
            size = out.stat().st_size / 1e6
            print(f"tfrec McapSink ({compression}): {2 * n:,} messages in {seconds:.2f} s (best of 3) = "
                  f"{rates[compression]:,.0f} msg/s, {size:.1f} MB")
        messages = baseline_messages(chunks, options.baseline_samples)
        base_s = write_baseline(folder / "baseline.mcap", messages)
        base_rate = len(messages) / base_s
        print(f"baseline mcap_ros2 Writer (zstd, dicts prebuilt): {len(messages):,} messages in {base_s:.2f} s = "
              f"{base_rate:,.0f} msg/s")
        full_s = full_path(folder / "full.mcap", robot, trajectory)
        print(f"full streaming path (FK chunks + McapSink, zstd): {2 * n / full_s:,.0f} msg/s")
        ratio = rates["zstd"] / base_rate
        print(f"ratio (zstd): {ratio:.1f}x; target >= {TARGET_RATIO:.0f}x: {'met' if ratio >= TARGET_RATIO else 'NOT met'}; "
              f"rate target >= {TARGET_RATE:,.0f} msg/s: {'met' if rates['zstd'] >= TARGET_RATE else 'NOT met'}")
    if memory is not None:
        samples, write_s, total_s, size_mb, start_mb, rss_mb = memory
        print(f"memory: robots/marm.xacro, {options.memory_hours:g} h at 100 Hz = {int(samples):,} samples "
              f"({2 * int(samples) + 2:,} messages), {float(size_mb):.0f} MB MCAP; recording {float(write_s):.1f} s "
              f"(process {float(total_s):.1f} s); peak RSS {float(rss_mb):.0f} MB (after imports "
              f"{float(start_mb):.0f} MB); target < {TARGET_RSS_MB:.0f} MB: "
              f"{'met' if float(rss_mb) < TARGET_RSS_MB else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
