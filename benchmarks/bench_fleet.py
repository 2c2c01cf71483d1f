"""Fleet check speed: many recordings checked on a process pool of 1 and 2 workers, and on Ray.

The recordings: ``tfrec record robots/marm.xacro --traj random --rate 100 --duration 600
--seed K --no-rrd`` for a few seeds (``--distinct``), and hard links to them up to ``--count``
files (identical content is fine for throughput; the files are read from the page cache after
the first pass, so storage is not measured — see docs/scaling.md for it). They are made once in
``--folder`` and reused by later runs.

Timed, in one run:

1. Phases of one recording, in this process (best of 3): reading and decoding
   (``read_recording``), preparing the replay (``load_replay``, which reads too), re-simulation
   and comparison (``check_replay``), within it the forward kinematics of every recorded moving
   joint (``dynamic_transforms`` as ``check_replay`` calls it, one joint at a time), and the
   health checks (``series_findings``).
2. ``check_recording`` on every file: a pool of 1 worker, a pool of 2, and Ray (a local cluster
   of 2 CPUs, started before the clock starts, and its workers warmed by 4 recordings — a Ray
   worker imports tfrec in its first task, a pool worker is forked with it imported; both timed on
   their own as Ray's start-up). For each: the
   wall time, the steady-state time per recording (from the first result to the last, so that
   starting the workers is left out), the per-recording cost inside the workers (``elapsed_s``
   and ``read_s`` of the summary rows), and each worker's peak RSS (``VmHWM``).
3. Per-task overhead: 2,000 tasks that do nothing, on the pool of 2 and on Ray.
4. Driver-side costs: fingerprinting every file (``--resume``) and writing report rows (Parquet).
5. With ``--hour``: one recording of 60 min at 100 Hz, its phases as in 1, and ``check_recording``
   on it in a fresh process (wall and CPU time, peak RSS) — the unit of docs/scaling.md.

Targets: speed-up of 2 workers over 1 >= 1.7x; Ray's steady-state time per recording within
15 % of the pool's. The machine may be shared: each run says how busy its workers were (the
engine's idle time) and how much of that they ran on a CPU (the rest is waiting for a core taken
by other processes), and the speed-up on two free cores that those give. Run from the repository root (a few minutes with the defaults on 2 cores):

    PYTHONPATH=. .venv/bin/python benchmarks/bench_fleet.py [--count 200] [--minutes 10]
"""

from __future__ import annotations

import argparse
import logging
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

from _common import best_of, machine

from tfrec.fleet import Row, Task, check_tasks, fingerprint, run
from tfrec.fleet.health import series_findings

REPO = Path(__file__).resolve().parents[1]
TARGET_SPEEDUP = 1.7
TARGET_RAY_OVERHEAD = 0.15


def noop(key: str) -> list[Row]:
    """A task that does nothing, for the per-task overhead."""
    return [Row(file=key)]


def make_recordings(folder: Path, *, count: int, minutes: float, distinct: int) -> list[Path]:
    """``count`` recordings in ``folder`` (made once): ``distinct`` generated, the rest hard links."""
    folder.mkdir(parents=True, exist_ok=True)
    sources = []
    for seed in range(min(distinct, count)):
        path = folder / f"source_{seed:02d}_{minutes:g}min.mcap"
        if not path.exists():
            subprocess.run([sys.executable, "-m", "tfrec", "record", str(REPO / "robots" / "marm.xacro"),
                            "--traj", "random", "--seed", str(seed), "--rate", "100", "--duration",
                            str(minutes * 60), "--no-rrd", "-o", str(path)], check=True, capture_output=True)
        sources.append(path)
    out = []
    for k in range(count):
        link = folder / f"rec_{k:04d}_{minutes:g}min.mcap"
        if not link.exists():
            os.link(sources[k % len(sources)], link)
        out.append(link)
    return out


def phases(path: Path) -> dict[str, float]:
    """Seconds of each phase of checking one recording, in this process (best of 3)."""
    from tfrec.formats.reader import read_recording
    from tfrec.kinematics.fk import dynamic_transforms
    from tfrec.replay.check import check_replay
    from tfrec.replay.load import joint_positions, load_replay
    from tfrec.resample import align

    replay = load_replay(path)
    robot, js = replay.robot, replay.joint_states
    assert robot is not None and js is not None

    def fk() -> None:  # what check_replay's frames cost in forward kinematics, one joint at a time
        names, positions = joint_positions(robot, js)
        for (parent, child), series in replay.tf.items():
            joint = next((j for j in robot.moving_joints if replay.frame_prefix + j.child == child), None)
            if joint is None:
                continue
            alignment = align(series.time_ns, js.time_ns)
            q = alignment.linear(positions[:, names.index(joint.name)])
            dynamic_transforms(robot, [joint.name], q[:, None], frame_prefix=replay.frame_prefix)

    tf_ns = {pair: s.time_ns for pair, s in replay.tf.items()}
    return {
        "read_recording": best_of(3, lambda: read_recording(path)),
        "load_replay": best_of(3, lambda: load_replay(path)),
        "check_replay": best_of(3, lambda: check_replay(replay)),
        "fk": best_of(3, fk),
        "health": best_of(3, lambda: series_findings(js.time_ns, tf_ns, replay.origin_ns)),
        "samples": float(len(js)),
    }


class Timing:
    """The results of one engine run: rows and when each task's rows arrived."""

    def __init__(self) -> None:
        self.rows: list[Row] = []
        self.arrivals: list[float] = []

    def __call__(self, rows: list[Row], _: object) -> None:
        self.arrivals.append(time.perf_counter())
        self.rows.append(rows[0])


def run_engine(tasks: list[Task], **options: object) -> tuple[float, Timing]:
    timing = Timing()
    start = time.perf_counter()
    run(tasks, on_result=timing, **options)  # type: ignore[arg-type]
    return time.perf_counter() - start, timing


def steady(timing: Timing) -> float:
    """Seconds per task from the first result to the last (workers' start-up left out)."""
    arrivals = timing.arrivals
    return (arrivals[-1] - arrivals[0]) / max(1, len(arrivals) - 1)


def describe(label: str, wall: float, timing: Timing, workers: int) -> dict[str, float]:
    heads = timing.rows
    verdicts = {v: sum(1 for r in heads if r.verdict == v) for v in ("pass", "fail", "error")}
    elapsed = [r.elapsed_s for r in heads if r.elapsed_s is not None]
    cpu = [r.cpu_s for r in heads if r.cpu_s is not None]
    read = [r.read_s for r in heads if r.read_s is not None]
    peaks: dict[str, int] = {}
    for row in heads:
        if row.peak_rss_bytes is not None:
            peaks[row.worker] = max(peaks.get(row.worker, 0), row.peak_rss_bytes)
    per = steady(timing)
    busy = sum(elapsed) / (workers * wall)  # the engine's idle time: start-up, gaps between tasks
    on_cpu = sum(cpu) / sum(elapsed)  # the rest: waiting for a core (other processes) or the disk
    print(f"{label}: {len(heads)} recordings in {wall:.1f} s ({wall / len(heads) * 1000:.0f} ms each, start-up "
          f"included); steady state {per * 1000:.0f} ms per recording ({1 / per:.2f}/s); in the worker "
          f"{statistics.mean(elapsed) * 1000:.0f} ms per recording (CPU {statistics.mean(cpu) * 1000:.0f} ms), of which "
          f"reading {statistics.mean(read) * 1000:.0f} ms; workers busy {busy * 100:.1f} % of the time, on a CPU "
          f"{on_cpu * 100:.0f} % of that: cores used {sum(cpu) / wall:.2f} (load average {os.getloadavg()[0]:.2f}); peak RSS per worker {', '.join(f'{p / 1e6:.0f} MB' for p in peaks.values())} "
          f"({len(peaks)} workers); verdicts {verdicts}")
    return {"wall": wall, "steady": per, "elapsed": statistics.mean(elapsed), "cpu": statistics.mean(cpu),
            "read": statistics.mean(read), "busy": busy,
            "peak": max(peaks.values()) / 1e6 if peaks else 0.0}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=200, help="recordings (default 200)")
    parser.add_argument("--minutes", type=float, default=10.0, help="length of each recording (default 10)")
    parser.add_argument("--distinct", type=int, default=4, help="distinct recordings generated (default 4)")
    parser.add_argument("--folder", type=Path, help="where the recordings are made (default: a temporary folder)")
    parser.add_argument("--no-ray", action="store_true", help="skip the Ray runs")
    parser.add_argument("--noop-tasks", type=int, default=2000, help="tasks of the per-task overhead runs")
    parser.add_argument("--hour", action="store_true", help="also time one 60 min recording (section 5)")
    options = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    print(machine("pyarrow", *(() if options.no_ray else ("ray",))))
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    with tempfile.TemporaryDirectory(prefix="tfrec-bench-fleet-") as scratch:
        folder = options.folder or Path(scratch)
        start = time.perf_counter()
        files = make_recordings(folder, count=options.count, minutes=options.minutes, distinct=options.distinct)
        size_mb = files[0].stat().st_size / 1e6
        print(f"recordings: {len(files)} x robots/marm.xacro --traj random, {options.minutes:g} min at 100 Hz, "
              f"{size_mb:.1f} MB each ({options.distinct} distinct, the rest hard links), ready in "
              f"{time.perf_counter() - start:.1f} s")

        p = phases(files[0])
        n = int(p["samples"])
        print(f"phases of one recording ({n:,} joint states, {n:,} /tf messages of 8 transforms), best of 3: "
              f"read_recording {p['read_recording'] * 1000:.0f} ms; load_replay {p['load_replay'] * 1000:.0f} ms; "
              f"check_replay {p['check_replay'] * 1000:.0f} ms, of which FK {p['fk'] * 1000:.0f} ms; "
              f"health checks {p['health'] * 1000:.0f} ms")

        tasks = check_tasks(files)
        wall1, timing1 = run_engine(tasks, jobs=1)
        one = describe("pool, 1 worker", wall1, timing1, 1)
        wall2, timing2 = run_engine(tasks, jobs=2)
        two = describe("pool, 2 workers", wall2, timing2, 2)
        speedup = wall1 / wall2
        # on two free cores: each worker as busy as measured, at the CPU time per recording measured
        free = 2 * two["busy"] / one["busy"] * one["cpu"] / two["cpu"]
        print(f"speed-up of 2 workers: {speedup:.2f}x wall ({one['steady'] / two['steady']:.2f}x steady state); "
              f"target >= {TARGET_SPEEDUP}x: {'met' if speedup >= TARGET_SPEEDUP else 'NOT met'}; on two free cores "
              f"(workers busy as measured, CPU time per recording as measured): {free:.2f}x")

        noops = [Task(f"t{k}", noop, (f"t{k}",)) for k in range(options.noop_tasks)]
        noop_wall, noop_timing = run_engine(noops, jobs=2)
        print(f"per-task overhead, pool of 2: {options.noop_tasks:,} empty tasks in {noop_wall:.2f} s, steady state "
              f"{steady(noop_timing) * 1e3:.2f} ms per task")

        if not options.no_ray:
            import ray

            os.environ.setdefault("RAY_AUTH_MODE", "disabled")
            os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
            started = time.perf_counter()
            ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False,
                     logging_level=logging.ERROR,
                     runtime_env={"env_vars": {"PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}})
            init_s = time.perf_counter() - started
            warm_s, _ = run_engine(tasks[:4], engine="ray")  # each worker's first task imports tfrec
            print(f"Ray start-up: ray.init (local cluster of 2 CPUs) {init_s:.1f} s, then the workers' first "
                  f"4 recordings {warm_s:.1f} s")
            try:
                wall_r, timing_r = run_engine(tasks, engine="ray")
                ray_stats = describe("Ray, 2 CPUs", wall_r, timing_r, 2)
                overhead = ray_stats["steady"] / two["steady"] - 1
                free = two["busy"] / ray_stats["busy"] * ray_stats["cpu"] / two["cpu"] - 1
                print(f"Ray against the pool of 2, steady state: {overhead * 100:+.1f} %; wall (workers' start-up "
                      f"included, not ray.init): {(wall_r / wall2 - 1) * 100:+.1f} %; target <= "
                      f"{TARGET_RAY_OVERHEAD * 100:.0f} %: {'met' if overhead <= TARGET_RAY_OVERHEAD else 'NOT met'}; "
                      f"on two free cores (workers busy and CPU time per recording as measured): {free * 100:+.1f} %")
                noop_wall, noop_timing = run_engine(noops, engine="ray")
                print(f"per-task overhead, Ray 2 CPUs: {options.noop_tasks:,} empty tasks in {noop_wall:.2f} s, "
                      f"steady state {steady(noop_timing) * 1e3:.2f} ms per task")
            finally:
                ray.shutdown()

        started = time.perf_counter()
        for file in files:
            fingerprint(file)
        per_file = (time.perf_counter() - started) / len(files)
        from tfrec.fleet.report import ReportWriter

        rows = [row.to_dict() for row in timing2.rows] * max(1, 20_000 // len(timing2.rows))
        started = time.perf_counter()
        with ReportWriter(Path(scratch) / "bench.parquet") as writer:
            for row in rows:
                writer.write([row])
        per_row = (time.perf_counter() - started) / len(rows)
        print(f"driver: fingerprint {per_file * 1e3:.2f} ms per file; Parquet report {per_row * 1e6:.0f} us per row "
              f"({len(rows):,} rows written one at a time)")
        if options.hour:
            hour(folder)
    return 0


_ONE_CHECK = """
import json, sys, warnings
warnings.simplefilter("ignore")
from tfrec.fleet import check_tasks, execute
row = execute(check_tasks([sys.argv[1]])[0])[0]
print(json.dumps(row.to_dict()))
"""


def hour(folder: Path) -> None:
    """Section 5: one 60 min recording."""
    import json

    (path,) = make_recordings(folder / "hour", count=1, minutes=60, distinct=1)
    p = phases(path)
    print(f"one 60 min recording ({path.stat().st_size / 1e6:.1f} MB, {int(p['samples']):,} joint states), best of 3: "
          f"read_recording {p['read_recording']:.2f} s; load_replay {p['load_replay']:.2f} s; check_replay "
          f"{p['check_replay']:.2f} s, of which FK {p['fk']:.2f} s; health checks {p['health']:.3f} s")
    done = subprocess.run([sys.executable, "-c", _ONE_CHECK, str(path)], check=True, capture_output=True, text=True)
    row = json.loads(done.stdout)
    print(f"check_recording of it in a fresh process: {row['elapsed_s']:.2f} s (CPU {row['cpu_s']:.2f} s), reading "
          f"{row['read_s']:.2f} s; peak RSS {row['peak_rss_bytes'] / 1e6:.0f} MB; verdict {row['verdict']}")


if __name__ == "__main__":
    sys.exit(main())
