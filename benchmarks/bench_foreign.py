"""Reading bags written by other tools: ``tfrec info`` and ``tfrec replay --check`` on a one-hour 100 Hz recording.

The recording is ``tfrec record robots/marm.xacro --traj random --duration 3600 --rate 100 --seed 0``
(360,001 /joint_states and 360,001 /tf messages of 8 transforms, plus /robot_description and
/tf_static: 720,004 messages), re-written with rosbags' writers — the messages' own bytes taken
from tfrec's MCAP (CDR), converted to ROS 1 serialization with rosbags' ``cdr_to_ros1`` — as:

- a ROS 1 bag (``rosbags.rosbag1.Writer``, its default chunks, uncompressed; and lz4);
- a rosbag2 folder with sqlite3 storage (``rosbags.rosbag2.Writer``);
- a rosbag2 folder with MCAP storage (``rosbags.rosbag2.Writer``: 1 MiB uncompressed chunks).

They are made once and kept in a temporary folder (``--cache``). Timed, each as the command runs
(a fresh ``python -m tfrec`` process, start-up included; the fastest of three runs, wall clock and CPU
time) and in-process (reading and checking):

- ``tfrec info FILE``: from the file's index, without reading the messages;
- ``tfrec replay FILE --check``: every /joint_states and /tf message read, decoded and
  re-simulated; the rate is the file's messages over the command's wall time. Target: ≥ 200,000
  messages/s;
- baseline, in the same run: rosbags' ``AnyReader`` iterating the same file's /joint_states and
  /tf messages with ``deserialize`` (what reading them with rosbags costs, before any check), on
  its first 50,000 messages, given as a rate. The ratio is tfrec's whole ``--check`` over that.

Run from the repository root:

    .venv/bin/python benchmarks/bench_foreign.py
"""

from __future__ import annotations

import argparse
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from _common import machine

REPO = Path(__file__).resolve().parents[1]
TARGET_MSGS_PER_S = 200_000
BASELINE_MESSAGES = 50_000


def _record(path: Path, duration_s: float) -> Path:
    if path.is_file():
        return path
    from tfrec.description import load_description
    from tfrec.recorder import plan_outputs, record
    from tfrec.trajectory.generators import make_trajectory

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_description(REPO / "robots" / "marm.xacro")
    trajectory = make_trajectory(robot, "random", duration_s=duration_s, rate_hz=100.0, seed=0)
    record(robot, trajectory, plan_outputs(stem=path.stem, out=path, no_rrd=True))
    return path


def _messages(source: Path) -> Iterator[tuple[str, str, int, bytes]]:
    """(topic, type, log time, CDR bytes) of tfrec's MCAP, in log-time order, read with mcap's reader."""
    from mcap.reader import make_reader

    with open(source, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
            assert schema is not None
            yield channel.topic, schema.name, message.log_time, message.data


def _write_foreign(source: Path, cache: Path) -> dict[str, Path]:
    """The recording re-written by rosbags' writers (made once, kept in ``cache``)."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    out = {"ROS 1 bag": cache / "hour-rosbags.bag", "ROS 1 bag, lz4": cache / "hour-rosbags-lz4.bag",
           "rosbag2 sqlite3": cache / "hour-rosbags-sqlite3", "rosbag2 MCAP": cache / "hour-rosbags-mcap"}
    if all(path.exists() for path in out.values()):
        return out
    ros2, ros1 = get_typestore(Stores.ROS2_HUMBLE), get_typestore(Stores.ROS1_NOETIC)
    ros1.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms\n", "tf2_msgs/msg/TFMessage"))
    start = time.perf_counter()
    for label, path in out.items():
        if path.exists():
            continue
        scratch = path.with_name(path.name + ".tmp")
        shutil.rmtree(scratch, ignore_errors=True)
        scratch.unlink(missing_ok=True)
        connections: dict[str, Any] = {}
        if label.startswith("ROS 1"):
            writer1 = Writer1(scratch)
            if label.endswith("lz4"):
                writer1.set_compression(Writer1.CompressionFormat.LZ4)
            with writer1:
                for topic, msgtype, time_ns, data in _messages(source):
                    if topic not in connections:
                        latching = 1 if topic in ("/robot_description", "/tf_static") else None
                        connections[topic] = writer1.add_connection(topic, msgtype, typestore=ros1, latching=latching)
                    writer1.write(connections[topic], time_ns, ros2.cdr_to_ros1(data, msgtype))
        else:
            plugin = StoragePlugin.SQLITE3 if "sqlite3" in label else StoragePlugin.MCAP
            with Writer(scratch, version=9, storage_plugin=plugin) as writer:
                for topic, msgtype, time_ns, data in _messages(source):
                    if topic not in connections:
                        connections[topic] = writer.add_connection(topic, msgtype, typestore=ros2)
                    writer.write(connections[topic], time_ns, data)
            if plugin == StoragePlugin.MCAP:  # rosbags names the file after the folder
                (scratch / f"{scratch.name}.mcap").rename(scratch / f"{path.name}.mcap")
                meta = scratch / "metadata.yaml"
                meta.write_text(meta.read_text().replace(f"{scratch.name}.mcap", f"{path.name}.mcap"))
            else:
                (scratch / f"{scratch.name}.db3").rename(scratch / f"{path.name}.db3")
                meta = scratch / "metadata.yaml"
                meta.write_text(meta.read_text().replace(f"{scratch.name}.db3", f"{path.name}.db3"))
        scratch.rename(path)
        print(f"  wrote {label}: {path.name} ({time.perf_counter() - start:.0f} s so far)")
    return out


def _size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.iterdir()) if path.is_dir() else path.stat().st_size


def _command(*args: str, repeat: int = 3) -> tuple[float, float]:
    """Seconds of ``python -m tfrec ARGS`` in a fresh process (start-up included), the fastest of ``repeat``
    runs: (wall clock, CPU time of the process). The CPU time does not depend on what else the machine runs."""
    best = (float("inf"), float("inf"))
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        result = subprocess.run([sys.executable, "-m", "tfrec", *args], capture_output=True, text=True, cwd=REPO,
                                check=False)
        elapsed = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if result.returncode != 0:
            raise SystemExit(f"tfrec {' '.join(args)} exited {result.returncode}: {result.stderr.strip()}")
        cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
        best = (min(best[0], elapsed), min(best[1], cpu))
    return best


def _baseline(path: Path) -> float:
    """rosbags' AnyReader: /joint_states and /tf messages deserialized per second, over the first ones."""
    from rosbags.highlevel import AnyReader

    count = 0
    start = time.perf_counter()
    with AnyReader([path]) as reader:
        connections = [c for c in reader.connections if c.topic in ("/joint_states", "/tf")]
        for connection, _, raw in reader.messages(connections=connections):
            reader.deserialize(raw, connection.msgtype)
            count += 1
            if count >= BASELINE_MESSAGES:
                break
    return count / (time.perf_counter() - start)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=3600.0, help="seconds of the recording (default 3600)")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "tfrec-bench-foreign",
                        help="folder for the recordings (default: $TMPDIR/tfrec-bench-foreign)")
    options = parser.parse_args(argv)
    cache = options.cache / f"{options.duration:g}s"
    cache.mkdir(parents=True, exist_ok=True)
    print(machine("rosbags", "mcap"))
    print(f"recordings in {cache}:")
    source = _record(cache / "hour-tfrec.mcap", options.duration)
    files = {"tfrec MCAP (reference)": source, **_write_foreign(source, cache)}

    from tfrec.formats.reader import read_recording
    from tfrec.replay import check_replay, load_replay

    failed = False
    rows = []
    for label, path in files.items():
        messages = sum(info.count for info in read_recording(path, summary=True).topics.values())
        info_s, _ = _command("info", str(path))
        check_s, check_cpu = _command("replay", str(path), "--check")
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            report = check_replay(load_replay(path, need_robot=True))
        inside_s = time.perf_counter() - start
        baseline = _baseline(path)
        rate = messages / check_s
        met = rate >= TARGET_MSGS_PER_S
        failed |= not met and label != "tfrec MCAP (reference)"
        rows.append((label, path, info_s, check_s, check_cpu, rate, baseline))
        print(f"{label}: {path.name}, {_size(path) / 1e6:.0f} MB, {messages:,} messages")
        print(f"  tfrec info: {info_s:.2f} s (command, best of 3)")
        print(f"  tfrec replay --check: {check_s:.2f} s (command, best of 3; {check_cpu:.2f} s CPU) = {rate:,.0f} msg/s "
              f"({messages / check_cpu:,.0f} per CPU second); {inside_s:.2f} s in-process; "
              f"{'PASS' if report.passed else 'FAIL'}")
        print(f"  baseline rosbags AnyReader + deserialize: {baseline:,.0f} msg/s; ratio {rate / baseline:.0f}x; "
              f"target >= {TARGET_MSGS_PER_S:,} msg/s: {'met' if met else 'NOT met'}")
    print()
    print("| file | size | info (s) | replay --check (s) | msg/s | msg per CPU s | rosbags AnyReader msg/s | ratio |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for label, path, info_s, check_s, check_cpu, rate, baseline in rows:
        messages = rate * check_s
        print(f"| {label} | {_size(path) / 1e6:.0f} MB | {info_s:.2f} | {check_s:.2f} | {rate:,.0f} | "
              f"{messages / check_cpu:,.0f} | {baseline:,.0f} | {rate / baseline:.0f}× |")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
