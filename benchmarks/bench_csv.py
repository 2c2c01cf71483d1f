"""CSV trajectory reading: tfrec's bounded, checked reader against pandas' C parser and numpy.loadtxt.

A CSV of one million rows (``time`` + robots/marm.xacro's 7 actuated joints, 100 Hz, random values
within the limits, ~120 MB) is read:

- tfrec: ``read_csv_trajectory`` (size bound, header and joint checks, numpy parsing block by block,
  time and limit checks, velocities by ``numpy.gradient``) — the whole of what ``--traj FILE.csv`` reads;
- baselines, in the same run: ``pandas.read_csv`` (C engine, float64) and ``numpy.loadtxt`` of the same
  file, parsing only (no checks, no velocities);
- the cell-by-cell path (what a file that is not plain numbers takes, e.g. quoted cells) on 100,000 rows;
- peak memory (``ru_maxrss``) of a fresh process reading the million rows.

Run from the repository root:

    .venv/bin/python benchmarks/bench_csv.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from _common import best_of, machine

from tfrec import load_description
from tfrec.trajectory.csv_file import read_csv_trajectory

ROWS = 1_000_000
SLOW_ROWS = 100_000
ROBOT = "robots/marm.xacro"


def write_csv(path: Path, rows: int, *, quoted: bool = False) -> list[str]:
    robot = load_description(ROBOT)
    joints = [joint for joint in robot.actuated_joints]
    rng = np.random.default_rng(0)
    columns = [np.arange(rows) / 100.0]
    for joint in joints:
        lower, upper = (joint.limit.lower, joint.limit.upper) if joint.limit is not None else (-3.0, 3.0)
        columns.append(rng.uniform(lower, upper, rows))
    names = ["time", *(joint.name for joint in joints)]
    table = np.column_stack(columns)
    with path.open("w") as out:
        out.write(",".join(f'"{n}"' if quoted else n for n in names) + "\n")
        if quoted:
            for row in table:
                out.write(",".join(f'"{float(v)!r}"' for v in row) + "\n")
        else:
            np.savetxt(out, table, delimiter=",", fmt="%.9g")
    return names


def peak_rss_mb(path: Path) -> float:
    """The growth of a fresh process's peak resident memory (VmHWM, which exec resets, unlike
    ru_maxrss) while it reads ``path``."""
    code = ("from tfrec import load_description; from tfrec.trajectory.csv_file import read_csv_trajectory\n"
            "def hwm(): return next(int(l.split()[1]) for l in open('/proc/self/status') if l.startswith('VmHWM'))\n"
            f"r = load_description({ROBOT!r}); base = hwm()\n"
            f"t = read_csv_trajectory({str(path)!r}, r); print(base, hwm())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    return (int(out[1]) - int(out[0])) / 1024


def main() -> None:
    import pandas as pd

    print(machine("pandas"))
    robot = load_description(ROBOT)
    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp) / "million.csv"
        write_csv(big, ROWS)
        size_mb = big.stat().st_size / 1e6
        print(f"file: {ROWS:,} rows x {len(robot.actuated_joints) + 1} columns, {size_mb:.0f} MB")
        trajectory = read_csv_trajectory(big, robot)
        frame = pd.read_csv(big, dtype=np.float64)
        assert np.array_equal(trajectory.positions, frame.to_numpy()[:, 1:]), "tfrec and pandas disagree"
        assert np.array_equal(trajectory.time_ns, np.rint(frame["time"].to_numpy() * 1e9).astype(np.int64))
        tfrec_s = best_of(3, lambda: read_csv_trajectory(big, robot))
        pandas_s = best_of(3, lambda: pd.read_csv(big, dtype=np.float64))
        loadtxt_s = best_of(1, lambda: np.loadtxt(big, delimiter=",", skiprows=1))
        print(f"tfrec read_csv_trajectory: {tfrec_s:.2f} s ({ROWS / tfrec_s:,.0f} rows/s, with every check and velocities)")
        print(f"pandas.read_csv (C engine): {pandas_s:.2f} s; tfrec / pandas = {tfrec_s / pandas_s:.2f}x")
        print(f"numpy.loadtxt: {loadtxt_s:.2f} s; tfrec / loadtxt = {tfrec_s / loadtxt_s:.2f}x")
        print(f"peak memory of a fresh process reading it: +{peak_rss_mb(big):.0f} MB "
              f"(the file is {size_mb:.0f} MB; the arrays {trajectory.positions.nbytes * 2 / 1e6:.0f} MB)")
        slow = Path(tmp) / "quoted.csv"
        write_csv(slow, SLOW_ROWS, quoted=True)
        slow_s = best_of(1, lambda: read_csv_trajectory(slow, robot))
        print(f"cell by cell (quoted cells), {SLOW_ROWS:,} rows: {slow_s:.2f} s ({SLOW_ROWS / slow_s:,.0f} rows/s)")


if __name__ == "__main__":
    main()
