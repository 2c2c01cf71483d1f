"""The least a ``.rrd`` of a recording can cost with Rerun's own API: ``bench_limits.py --only record`` runs it in a
fresh process beside ``tfrec record``, so that its CPU time (Rerun's threads included) is compared with
``record --no-rrd``'s.

It imports Rerun and writes the transforms of 8 joints at 100 Hz for HOURS — translation and quaternion as
float32, the one ``ros_time`` timeline, no frame names, no joint positions or velocities, no geometry, no
blueprint — through ``rr.Transform3D.columns`` and ``send_columns``, 8,192 samples a chunk, to a file in a
temporary folder; with ``--joints`` the 8 positions and 8 velocities too, as two entities of 8 scalars a row
(the leanest layout of them). The values are random: Rerun's writer does not look at them. It prints the CPU
time (user + system, every thread) from the import of Rerun to the file's end, without making the data.

    .venv/bin/python benchmarks/rrd_floor.py 1 [--joints]
"""

from __future__ import annotations

import argparse
import resource
import tempfile
from pathlib import Path

import numpy as np

JOINTS = 8
RATE_HZ = 100
CHUNK = 8192


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("hours", type=float)
    parser.add_argument("--joints", action="store_true", help="the joints' positions and velocities too")
    args = parser.parse_args(argv)
    n = int(args.hours * 3600 * RATE_HZ) + 1
    rng = np.random.default_rng(0)
    stamps = (1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * (1_000_000_000 // RATE_HZ))
    translation = rng.normal(size=(n, JOINTS, 3)).astype(np.float32)
    rotation = rng.normal(size=(n, JOINTS, 4)).astype(np.float32)
    positions, velocities = rng.normal(size=(n, JOINTS)), rng.normal(size=(n, JOINTS))

    started = _cpu()
    import rerun as rr  # the import is part of the cost

    with tempfile.TemporaryDirectory() as tmp:
        stream = rr.RecordingStream("rrd-floor", recording_id="rrd-floor")
        stream.save(Path(tmp) / "floor.rrd")
        for start in range(0, n, CHUNK):
            piece = slice(start, start + CHUNK)
            index = [rr.TimeColumn("ros_time", timestamp=stamps[piece].astype("datetime64[ns]"))]
            for k in range(JOINTS):
                stream.send_columns(f"tf/{k}", indexes=index, columns=rr.Transform3D.columns(
                    translation=translation[piece, k], quaternion=rotation[piece, k]))
            if args.joints:
                rows = len(stamps[piece])
                for name, values in (("position", positions), ("velocity", velocities)):
                    stream.send_columns(f"joints/{name}", indexes=index,
                                        columns=rr.Scalars.columns(scalars=values[piece].ravel()).partition([JOINTS] * rows))
        stream.flush()
        stream.disconnect()
        size = (Path(tmp) / "floor.rrd").stat().st_size
    print(f"{_cpu() - started:.3f} s CPU, {size / 1e6:.0f} MB")
    return 0


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


if __name__ == "__main__":
    raise SystemExit(main())
