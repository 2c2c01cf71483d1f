"""``tfrec convert`` speed and memory: MCAP → ROS 1 bag and back, against rosbags-convert.

The recording: one hour at 100 Hz of a 10-joint chain, as ``tfrec record`` writes it (360,000
/joint_states + 360,000 /tf messages of 10 transforms, plus /robot_description and /tf_static:
720,002 messages; zstd chunks). Timed, in-process (the fastest of ``--repeat`` runs):

- tfrec: ``tfrec.convert.convert(hour.mcap, hour.bag)`` (CDR → ROS 1, uncompressed chunks, as
  ``rosbag record`` writes them) and ``convert(hour.bag, back.mcap)`` (ROS 1 → CDR, zstd chunks):
  TF and joint states translated in bulk with numpy, streamed chunk by chunk. Target: < 10 s each.
- baseline, in the same run: rosbags-convert (``rosbags.convert.converter.convert``, what the
  ``rosbags-convert`` command runs) of the first ``--baseline-samples`` samples of the same
  recording, each way (MCAP → ROS 1 bag; that bag → a rosbag2 folder with MCAP storage),
  extrapolated to the hour. The ratio is the baseline's over tfrec's.

Then the peak memory (``ru_maxrss``) of ``python -m tfrec convert hour.mcap hour.bag`` in a fresh
process: the conversion streams, so it stays near the interpreter's own footprint.

Run from the repository root:

    .venv/bin/python benchmarks/bench_convert.py
"""

from __future__ import annotations

import argparse
import contextlib
import io
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import machine
from bench_mcap import chain

from tfrec.conventions import DEFAULT_START_TIME_NS
from tfrec.convert import convert
from tfrec.formats.mcap.sink import McapSink
from tfrec.kinematics.fk import iter_dynamic_chunks, static_transforms
from tfrec.model import Robot
from tfrec.trajectory.generators import make_trajectory

RATE_HZ = 100.0
TARGET_S = 10.0


def write_recording(path: Path, robot: Robot, samples: int) -> int:
    """``samples`` samples of a random trajectory as tfrec's MCAP; returns its messages."""
    trajectory = make_trajectory(robot, "random", duration_s=(samples - 1) / RATE_HZ, rate_hz=RATE_HZ, seed=0)
    with open(path, "wb") as stream:
        sink = McapSink(stream)
        sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=DEFAULT_START_TIME_NS)
        for chunk in iter_dynamic_chunks(robot, trajectory):
            sink.write_chunk(stamp_ns=chunk.time_ns + DEFAULT_START_TIME_NS, joint_names=chunk.names,
                             positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
        sink.finish()
        return sink.message_count


def timed_convert(source: Path, target: Path, repeat: int) -> tuple[float, float]:
    """(wall, CPU) seconds of the fastest of ``repeat`` conversions (the target replaced each time); CPU
    time counts every thread (chunk compression runs on two) and does not depend on what else the
    shared machine runs."""
    best = (float("inf"), float("inf"))
    for _ in range(repeat):
        start, cpu = time.perf_counter(), time.process_time()
        convert(source, target, force=True)
        best = min(best, (time.perf_counter() - start, time.process_time() - cpu))
    return best


def rosbags_convert(source: Path, target: Path) -> float:
    """Seconds of rosbags-convert (its API, as its command line calls it); its own prints are hidden."""
    from rosbags.convert.converter import convert as rosbags_convert_api

    start = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        rosbags_convert_api(srcs=[source], dst=target, dst_storage="mcap", dst_version=9, compress=None,
                            compress_mode="file", default_typestore=None, typestore=None, exclude_topics=[],
                            include_topics=[], exclude_msgtypes=[], include_msgtypes=[])
    return time.perf_counter() - start


def peak_memory_mb(source: Path, target: Path) -> tuple[float, float]:
    """(seconds, peak RSS in MB) of ``python -m tfrec convert`` in a fresh process."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "tfrec", "convert", str(source), str(target), "--force"], check=True,
                   capture_output=True)
    elapsed = time.perf_counter() - start
    return elapsed, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # KiB on Linux


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hours", type=float, default=1.0, help="recording length at 100 Hz (h)")
    parser.add_argument("--baseline-samples", type=int, default=20_000, help="samples for rosbags-convert")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each tfrec conversion (the fastest counts)")
    options = parser.parse_args(argv)
    samples = round(options.hours * 3600 * RATE_HZ)
    robot = chain(10)
    print(machine("rosbags", "mcap", "zstandard"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        hour = folder / "hour.mcap"
        messages = write_recording(hour, robot, samples)
        print(f"recording: inline 10-joint chain, {options.hours:g} h at {RATE_HZ:g} Hz = {samples:,} samples, "
              f"{messages:,} messages; MCAP {hour.stat().st_size / 1e6:.0f} MB (zstd)")
        to_bag, to_bag_cpu = timed_convert(hour, folder / "hour.bag", options.repeat)
        back, back_cpu = timed_convert(folder / "hour.bag", folder / "back.mcap", options.repeat)
        bag_mb = (folder / "hour.bag").stat().st_size / 1e6

        subset = folder / "subset.mcap"
        subset_messages = write_recording(subset, robot, options.baseline_samples)
        scale = messages / subset_messages
        base_to_bag = rosbags_convert(subset, folder / "subset.bag") * scale
        base_back = rosbags_convert(folder / "subset.bag", folder / "subset-back") * scale
        for label, seconds, cpu, base in (("MCAP → ROS 1 bag", to_bag, to_bag_cpu, base_to_bag),
                                          ("ROS 1 bag → MCAP", back, back_cpu, base_back)):
            verdict = f"target < {TARGET_S:g} s: {'met' if seconds < TARGET_S else 'NOT met'}"
            print(f"{label}: tfrec {seconds:.2f} s ({cpu:.2f} s CPU; {messages / seconds:,.0f} msg/s, best of "
                  f"{options.repeat}); "
                  f"rosbags-convert {base:.0f} s (extrapolated from {subset_messages:,} messages, "
                  f"{subset_messages / (base / scale):,.0f} msg/s); ratio {base / seconds:.0f}x; {verdict}")
        print(f"sizes: ROS 1 bag {bag_mb:.0f} MB (uncompressed), MCAP back {(folder / 'back.mcap').stat().st_size / 1e6:.0f} MB")
        seconds, rss = peak_memory_mb(hour, folder / "fresh.bag")
        print(f"memory: python -m tfrec convert hour.mcap hour.bag in a fresh process: {seconds:.1f} s, "
              f"peak RSS {rss:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
