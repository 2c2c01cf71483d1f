"""Peak memory (RSS) and speed of ``replay --check``, ``check`` and ``diff`` on long recordings.

Recordings of a 7-joint arm (robots/marm.xacro, 100 Hz, ``--traj sine``) are made once per duration and
format and cached in a folder (``--cache``, default a folder in the temp dir): MCAP and ROS 1 bag by
``tfrec record``, rosbag2 sqlite3 by rosbags' writer from the MCAP's messages. Each command then runs in a
child process of its own; its peak resident memory is what the kernel reports for it (``os.wait4``'s
``ru_maxrss``), its time the wall clock around it and the CPU time it used (user + system, from the same
rusage: the figure to compare on a machine shared with other jobs). ``check`` is measured as one worker of ``tfrec check``
runs it (:func:`tfrec.fleet.tasks.check_recording` in a child process): the pool's workers are children of
its forkserver, whose peak memory the command's own process does not see. ``check`` throughput on MCAP is the file's messages over
that time, beside rosbags' ``AnyReader`` deserializing every message of the same file in the same run.
``--baseline DIR`` runs the same commands a second time with the ``tfrec`` package found in DIR (a copy of
the code before a change: ``git archive <commit> tfrec | tar -x -C DIR``). Both trees' bytecode is compiled
first, as installing a package does: a run with ``PYTHONDONTWRITEBYTECODE`` set would otherwise compile
every module it imports, each time.

    python benchmarks/bench_memory.py --durations 60 3600 14400
"""

from __future__ import annotations

import argparse
import compileall
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import machine

ROOT = Path(__file__).resolve().parent.parent
ROBOT = ROOT / "robots" / "marm.xacro"
FORMATS = ("mcap", "rosbag1", "sqlite3")


def _run(argv: list[str], *, pythonpath: str | None = None) -> tuple[float, float, float, int]:
    """(peak RSS in MB, wall seconds, CPU seconds (user + system), exit code) of one child process."""
    env = dict(os.environ)
    env["PYTHONPATH"] = pythonpath or str(ROOT)  # run from another folder: `-m` puts the working folder first
    start = time.perf_counter()
    child = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             cwd=tempfile.gettempdir())
    assert child.stderr is not None
    err = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    elapsed = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode not in (0, 1):
        sys.stderr.write(err.decode(errors="replace"))
    return usage.ru_maxrss / 1024, elapsed, usage.ru_utime + usage.ru_stime, child.returncode


def _sqlite3_copy(mcap: Path, out: Path) -> None:
    """A rosbag2 sqlite3 bag of every message of an MCAP file, written by rosbags."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import Writer

    with AnyReader([mcap]) as reader, Writer(out, version=8) as writer:
        made = {}
        for conn in reader.connections:
            made[conn.id] = writer.add_connection(conn.topic, conn.msgtype, typestore=reader.typestore,
                                                  offered_qos_profiles=conn.ext.offered_qos_profiles)
        for conn, stamp, raw in reader.messages():
            writer.write(made[conn.id], stamp, raw)


def recordings(cache: Path, duration_s: int) -> dict[str, Path]:
    """The recordings of one duration, made when not cached yet."""
    cache.mkdir(parents=True, exist_ok=True)
    found = {"mcap": cache / f"marm-{duration_s}s.mcap", "rosbag1": cache / f"marm-{duration_s}s.bag",
             "sqlite3": cache / f"marm-{duration_s}s-sqlite3"}
    for fmt in ("mcap", "rosbag1"):
        if not found[fmt].exists():
            started = time.perf_counter()
            subprocess.run([sys.executable, "-m", "tfrec", "record", str(ROBOT), "--duration", str(duration_s),
                            "--rate", "100", "--no-rrd", "-o", str(found[fmt])], check=True, stdout=subprocess.DEVNULL)
            print(f"made {found[fmt].name} in {time.perf_counter() - started:.1f} s", file=sys.stderr)
    if not found["sqlite3"].exists():
        started = time.perf_counter()
        partial = cache / f"partial-{duration_s}s-sqlite3"
        shutil.rmtree(partial, ignore_errors=True)
        _sqlite3_copy(found["mcap"], partial)
        partial.rename(found["sqlite3"])
        print(f"made {found['sqlite3'].name} in {time.perf_counter() - started:.1f} s", file=sys.stderr)
    return found


def _copy_for_diff(path: Path) -> Path:
    """B of a diff: a second copy of A (the same content, another file)."""
    twin = path.with_name("twin-" + path.name)
    if not twin.exists():
        if path.is_dir():
            shutil.copytree(path, twin)
        else:
            shutil.copyfile(path, twin)
    return twin


_CHECK = ("import sys; from tfrec.fleet.tasks import check_recording; "
          "rows = check_recording(sys.argv[1]); sys.exit(rows[0].verdict != 'pass')")


def commands(path: Path) -> dict[str, list[str]]:
    tfrec = [sys.executable, "-m", "tfrec"]
    return {
        "replay --check": [*tfrec, "replay", str(path), "--check"],
        # what one worker of `tfrec check` does (the pool's workers are the forkserver's children, not ours)
        "check": [sys.executable, "-c", _CHECK, str(path)],
        "diff": [*tfrec, "diff", str(path), str(_copy_for_diff(path))],
    }


def _messages(mcap: Path) -> int:
    from mcap.reader import make_reader

    with open(mcap, "rb") as stream:
        stats = make_reader(stream).get_summary().statistics  # type: ignore[union-attr]
    return int(stats.message_count)


def _anyreader_rate(mcap: Path) -> float:
    """rosbags' AnyReader deserializing every message of the file, messages per second of CPU time."""
    from rosbags.highlevel import AnyReader

    started = time.process_time()
    count = 0
    with AnyReader([mcap]) as reader:
        for conn, _, raw in reader.messages():
            reader.deserialize(raw, conn.msgtype)
            count += 1
    return count / (time.process_time() - started)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--durations", type=int, nargs="+", default=[60, 3600], help="seconds of each recording")
    parser.add_argument("--formats", nargs="+", default=list(FORMATS), choices=FORMATS)
    parser.add_argument("--commands", nargs="+", default=["replay --check", "check", "diff"])
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "tfrec-bench-memory")
    parser.add_argument("--baseline", help="a folder holding the tfrec package to compare with")
    parser.add_argument("--no-anyreader", action="store_true", help="skip the rosbags AnyReader comparison")
    args = parser.parse_args(argv)
    print(machine("mcap", "rosbags"))
    trees = [("this", None)] + ([("baseline", args.baseline)] if args.baseline else [])
    for _, folder in trees:  # as an installed package has them (pip compiles them): not the work of every run
        compileall.compile_dir(Path(folder or ROOT) / "tfrec", quiet=1)
    print("tree      duration  format   command          peak RSS (MB)  wall (s)  CPU (s)  exit")
    for duration_s in args.durations:
        made = recordings(args.cache, duration_s)
        for fmt in args.formats:
            for name, argv_ in commands(made[fmt]).items():
                if name not in args.commands:
                    continue
                for tree, pythonpath in trees:
                    rss, wall, cpu, code = _run(argv_, pythonpath=pythonpath)
                    print(f"{tree:9s} {duration_s:7d}s  {fmt:8s} {name:16s} {rss:13.0f}  {wall:8.2f}  {cpu:7.2f}  "
                          f"{code}", flush=True)
                    if fmt == "mcap" and name == "check":
                        messages = _messages(made["mcap"])
                        print(f"{tree:9s} check throughput on MCAP: {messages / wall:,.0f} msg/s of wall time, "
                              f"{messages / cpu:,.0f} msg/s of CPU time (start-up included)", flush=True)
        if not args.no_anyreader:
            print(f"rosbags AnyReader on {made['mcap'].name}: {_anyreader_rate(made['mcap']):,.0f} msg/s of CPU time",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
