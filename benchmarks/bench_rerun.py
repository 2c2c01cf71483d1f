"""Rerun writing speed: tfrec's columnar sink against per-frame ``rr.log`` of the same data.

The recording: robots/marm.xacro (8 moving joints, 8 dynamic transforms) along a ``random``
trajectory at 100 Hz for 10 minutes (60,001 samples). FK is computed before the clocks start.

- **tfrec**: ``RerunSink`` as ``tfrec record`` drives it — ``begin`` (geometry, frames, fixed joints),
  ``write_chunk`` per FK chunk of 8192 samples (``rr.send_columns``: one chunk per entity), ``finish``
  (blueprint, flush, close). Best of 3.
- **per-frame baseline**: for every sample ``set_time`` on the ``ros_time`` timeline, then one
  ``rr.log`` per joint for its ``Transform3D`` (translation, quaternion, parent and child frame), its
  position and its velocity (``Scalars``), to a file, flushed at the end. It is timed on the first
  ``--baseline-samples`` samples and extrapolated linearly to the whole recording; its static
  geometry is not logged at all, which favours it.

Run from the repository root:

    .venv/bin/python benchmarks/bench_rerun.py
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import machine

from tfrec.description import load_description
from tfrec.formats.rrd.paths import TIMELINE, joint_entity, tf_entity, velocity_entity
from tfrec.kinematics.fk import DynamicChunk, iter_dynamic_chunks, static_transforms
from tfrec.model import Robot
from tfrec.recorder import DEFAULT_START_TIME_NS
from tfrec.trajectory.generators import make_trajectory
from tfrec.viewer.sink import RerunSink

REPO = Path(__file__).resolve().parents[1]
TARGET_RATIO = 100.0


def write_columnar(path: Path, robot: Robot, chunks: list[DynamicChunk]) -> float:
    """Seconds for the whole ``.rrd``: begin, every chunk, finish."""
    start = time.perf_counter()
    sink = RerunSink(path, robot=robot, recording_id="bench")
    sink.begin(static=static_transforms(robot), start_time_ns=DEFAULT_START_TIME_NS, robot_description=robot.urdf)
    for chunk in chunks:
        sink.write_chunk(stamp_ns=chunk.time_ns + DEFAULT_START_TIME_NS, joint_names=chunk.names,
                         positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()
    return time.perf_counter() - start


def write_per_frame(path: Path, chunks: list[DynamicChunk], samples: int) -> tuple[int, float]:
    """(samples logged, seconds) for per-frame ``rr.log`` of the first ``samples`` samples."""
    import rerun as rr

    start = time.perf_counter()
    rec = rr.RecordingStream("tfrec", recording_id="bench-per-frame")
    rec.save(path)
    done = 0
    for chunk in chunks:
        tf = chunk.transforms
        entities = [(tf_entity(name), joint_entity(name), velocity_entity(name)) for name in chunk.names]
        for i in range(len(chunk.time_ns)):
            if done == samples:
                break
            rec.set_time(TIMELINE, timestamp=np.datetime64(int(chunk.time_ns[i]) + DEFAULT_START_TIME_NS, "ns"))
            for k, (parent, child) in enumerate(zip(tf.parents, tf.children)):
                rec.log(entities[k][0], rr.Transform3D(translation=tf.translation[i, k], quaternion=tf.rotation[i, k],
                                                       parent_frame=parent, child_frame=child))
            for j, (tf_path, position_path, velocity_path) in enumerate(entities):
                rec.log(position_path, rr.Scalars(chunk.positions[i, j]))
                rec.log(velocity_path, rr.Scalars(chunk.velocities[i, j]))
            done += 1
    rec.flush()
    rec.disconnect()
    return done, time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, default=10.0, help="length of the trajectory")
    parser.add_argument("--rate-hz", type=float, default=100.0, help="sample rate")
    parser.add_argument("--baseline-samples", type=int, default=3000, help="samples logged per frame (extrapolated)")
    options = parser.parse_args(argv)

    robot = load_description(REPO / "robots" / "marm.xacro")
    trajectory = make_trajectory(robot, "random", duration_s=options.minutes * 60.0, rate_hz=options.rate_hz, seed=0)
    chunks = list(iter_dynamic_chunks(robot, trajectory))
    n, joints = len(trajectory), len(chunks[0].names)
    print(f"robot: robots/marm.xacro, {joints} moving joints, {len(chunks[0].transforms.children)} dynamic transforms; "
          f"{options.minutes:g} min at {options.rate_hz:g} Hz = {n:,} samples")
    print(machine("rerun-sdk"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_columnar(folder / "warm.rrd", robot, chunks[:1])
        columnar_s = min(write_columnar(folder / f"columnar{i}.rrd", robot, chunks) for i in range(3))
        size_mb = (folder / "columnar0.rrd").stat().st_size / 1e6
        print(f"tfrec RerunSink (send_columns): {n:,} samples in {columnar_s:.3f} s (best of 3) = "
              f"{n / columnar_s:,.0f} samples/s, {size_mb:.1f} MB")
        logged, frame_s = write_per_frame(folder / "per_frame.rrd", chunks, options.baseline_samples)
        extrapolated_s = frame_s * n / logged
        print(f"per-frame rr.log: {logged:,} samples ({3 * joints * logged:,} log calls) in {frame_s:.2f} s = "
              f"{logged / frame_s:,.0f} samples/s; extrapolated to {n:,} samples: {extrapolated_s:.0f} s")
    ratio = extrapolated_s / columnar_s
    print(f"ratio: {ratio:,.0f}x; target >= {TARGET_RATIO:.0f}x: {'met' if ratio >= TARGET_RATIO else 'NOT met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
