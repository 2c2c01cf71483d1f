"""``tfrec diff`` speed: two one-hour 100 Hz recordings of robots/marm.xacro.

The recordings are made the way ``tfrec record`` makes them (``tfrec.recorder.record``:
trajectory → FK chunks → McapSink, zstd) and cached in a temporary folder, so a second run
only measures the diff:

- A: ``--traj random --duration 3600 --rate 100 --seed 0``: 360,001 samples, 8 moving joints
  (/joint_states) and 8 dynamic transforms per /tf message, ~100 MB;
- B: the same command again (the regression-test case: identical by meaning);
- C: the same trajectory at 50 Hz, so that B's side is interpolated at A's times (linear and
  slerp) for every sample.

Timed: reading each file (``read_recording``), comparing the two Recordings (``compare``), and
the whole ``compare(path, path)`` as ``tfrec diff`` runs it; peak memory is ``ru_maxrss`` of
this process. Target: the whole diff of A and B under 30 s. Run from the repository root:

    .venv/bin/python benchmarks/bench_diff.py
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
import warnings
from pathlib import Path

from _common import machine, timed

from tfrec.description import load_description
from tfrec.diff.compare import compare
from tfrec.formats.reader import read_recording
from tfrec.recorder import plan_outputs, record
from tfrec.trajectory.generators import make_trajectory

REPO = Path(__file__).resolve().parents[1]
TARGET_S = 30.0


def _make(path: Path, *, duration_s: float, rate_hz: float, seed: int) -> Path:
    if path.is_file():
        return path
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_description(REPO / "robots" / "marm.xacro")
    trajectory = make_trajectory(robot, "random", duration_s=duration_s, rate_hz=rate_hz, seed=seed)
    start = time.perf_counter()
    record(robot, trajectory, plan_outputs(stem=path.stem, out=path, no_rrd=True))
    print(f"  recorded {path.name}: {len(trajectory):,} samples in {time.perf_counter() - start:.1f} s, "
          f"{path.stat().st_size / 1e6:.0f} MB")
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=3600.0, help="seconds per recording (default 3600)")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "tfrec-bench-diff",
                        help="folder for the recordings (default: $TMPDIR/tfrec-bench-diff)")
    options = parser.parse_args(argv)
    options.cache.mkdir(parents=True, exist_ok=True)
    tag = f"{options.duration:g}s"
    print(machine())
    print(f"recordings in {options.cache}:")
    a = _make(options.cache / f"marm-random-{tag}-100hz-a.mcap", duration_s=options.duration, rate_hz=100, seed=0)
    b = _make(options.cache / f"marm-random-{tag}-100hz-b.mcap", duration_s=options.duration, rate_hz=100, seed=0)
    c = _make(options.cache / f"marm-random-{tag}-50hz.mcap", duration_s=options.duration, rate_hz=50, seed=0)

    read_a, rec_a = timed(f"read A ({a.stat().st_size / 1e6:.0f} MB)", lambda: read_recording(a))
    read_b, rec_b = timed("read B", lambda: read_recording(b))
    assert rec_a.joint_states is not None
    samples = len(rec_a.joint_states)
    frames = len(rec_a.tf)
    print(f"  {samples:,} joint states x {len(rec_a.joint_states.names)} joints, "
          f"{samples:,} x {frames} transforms = {samples * frames:,} transforms per file; "
          f"{(read_a + read_b) / 2 / (2 * samples) * 1e6:.1f} µs per message")
    _, report = timed("compare A, B (already read)", lambda: compare(rec_a, rec_b))
    print(f"  verdict: {report.verdict}")
    total, report = timed("whole diff A B (read both + compare)", lambda: compare(a, b))
    print(f"  verdict: {report.verdict}")
    rec_c = read_recording(c)
    _, report = timed("compare A (100 Hz), C (50 Hz, interpolated at A's times)",
                       lambda: compare(rec_a, rec_c, pos_tol=1e-3, rot_tol=1e-2, joint_tol=1e-2))
    print(f"  verdict: {report.verdict}; largest: " + ", ".join(
        f"{k} {v.value:.2g}" for k, v in report.largest.items()))
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory (ru_maxrss): {peak_mb:,.0f} MB")
    print(f"whole diff of two one-hour 100 Hz recordings: {total:.1f} s; target < {TARGET_S:.0f} s: "
          f"{'met' if total < TARGET_S else 'NOT met'}")
    return 0 if total < TARGET_S else 1


if __name__ == "__main__":
    raise SystemExit(main())
