"""Each command near its limit (issue 23): the figures of docs/performance.md's "Commands at their limit".

Sections (``--only`` picks some), each with its baseline measured in the same run:

- ``info``: ``tfrec info`` in a fresh process (start-up included; fastest of ``--repeat``, wall clock, CPU time and
  peak RSS of that process) of 1 s of ``robots/mbot.xacro`` as an MCAP, a ROS 1 bag and a rosbag2 folder (tfrec
  record's), and of a one-hour sqlite3 bag (720,004 messages of ``robots/marm.xacro`` at 100 Hz re-written by rosbags'
  writer; ``--no-hour`` leaves it out), against ``python -c pass`` and ``python -c "import numpy"`` (with OpenBLAS's
  default threads, and one), measured in the same run. Python's bytecode is cached as an installed package has it
  (under ``--cache``; PYTHONDONTWRITEBYTECODE is lifted), and once more for the tiny MCAP compiled from source at
  each run. With ``--baseline-tree DIR`` (an older checkout's ``tfrec/`` package, e.g. ``git archive <commit> tfrec
  | tar -x -C DIR``) the same commands run on that code too, as ``before``. Then the layout checks alone (the first
  TFMessage, JointState and String of the tiny MCAP), written back by tfrec's encoder against rosbags' (before).
- ``pacing``: replay's batch windows (``tfrec.replay.pacing.batches``) over the stamps of one hour at 100 Hz of a
  joint-states series and 8 TF series (3.2 M stamps), against the same windows from ``np.unique`` of the stamps
  (the way before). Best of ``--repeat``.
- ``reorder``: ``convert`` of a ROS 1 bag (tfrec's, of a 10-joint chain at 100 Hz for ``--minutes``) to MCAP, the
  chunks put in time order record by record (now) against byte by byte (before); CPU seconds of the whole
  conversion in-process, best of ``--repeat``, and the outputs compared byte for byte.
- ``zstd``: the chunk bodies ``tfrec record`` compresses (``--minutes`` of marm at 100 Hz), compressed at zstd
  levels 1 and 3 with a block ended every 16, 32, 64 KiB or at zstd's own 128 KiB; CPU seconds (best of
  ``--repeat``), compressed size, and the most a cut chunk loses before the cut (tfrec's salvage of the chunk cut
  every 512 compressed bytes). Baseline: level 3, 16 KiB blocks (before).
- ``record``: ``tfrec record robots/marm.xacro`` for ``--hours`` in fresh processes, with and without the .rrd,
  against ``record --no-rrd`` (and ``import rerun`` alone), also without pandas importable (a tfrec installed
  without its test extra); with ``--baseline-tree DIR`` the two records with a ``.rrd`` also on that code, as
  ``before``. Then the floor: what Rerun's own API costs for the least of the same hour (benchmarks/rrd_floor.py:
  Rerun's import and the 8 transforms, then with the joints too), added to ``record --no-rrd``.

Run from the repository root:

    .venv/bin/python benchmarks/bench_limits.py [--only info pacing reorder zstd record] [--baseline-tree DIR] [--no-hour]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from _common import machine

REPO = Path(__file__).resolve().parents[1]


# -- processes ------------------------------------------------------------------------------------


def run_process(argv: Sequence[str], *, env: dict[str, str] | None = None) -> tuple[float, float, float]:
    """(wall seconds, CPU seconds, peak RSS in MB) of one process, from its own rusage (os.wait4). With a
    ``PYTHONPATH`` in ``env`` (an older tree) it runs there: ``python -m`` puts its working folder first."""
    start = time.perf_counter()
    cwd = env["PYTHONPATH"].split(os.pathsep)[0] if env is not None and "PYTHONPATH" in env else REPO
    child = subprocess.Popen(list(argv), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=cwd, env=env)
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited {child.returncode}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024


def best_process(argv: Sequence[str], repeat: int, env: dict[str, str] | None = None) -> tuple[float, float, float]:
    """The fastest wall and CPU times and the largest peak RSS of ``repeat`` runs."""
    runs = [run_process(argv, env=env) for _ in range(repeat)]
    return min(r[0] for r in runs), min(r[1] for r in runs), max(r[2] for r in runs)


def tree_env(tree: Path | None) -> dict[str, str] | None:
    """The environment that runs an older ``tfrec/`` (in ``tree``) instead of this checkout's."""
    if tree is None:
        return None
    return {**os.environ, "PYTHONPATH": os.fspath(tree)}


# -- info -----------------------------------------------------------------------------------------


def sqlite3_hour(cache: Path) -> Path:
    """One hour of marm at 100 Hz (tfrec record), re-written as a rosbag2 sqlite3 bag by rosbags (kept in ``cache``)."""
    from bench_foreign import _messages, _record
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    out = cache / "hour-sqlite3"
    if out.exists():
        return out
    source = _record(cache / "hour-tfrec.mcap", 3600.0)
    store = get_typestore(Stores.ROS2_HUMBLE)
    scratch = cache / "hour-sqlite3.tmp"
    connections: dict[str, Any] = {}
    with Writer(scratch, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        for topic, msgtype, time_ns, data in _messages(source):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], time_ns, data)
    (scratch / "hour-sqlite3.tmp.db3").rename(scratch / "hour-sqlite3.db3")
    meta = scratch / "metadata.yaml"
    meta.write_text(meta.read_text().replace("hour-sqlite3.tmp.db3", "hour-sqlite3.db3"))
    scratch.rename(out)
    return out


def _tiny(cache: Path) -> dict[str, Path]:
    """1 s of robots/mbot.xacro (tfrec record) as an MCAP, a ROS 1 bag and a rosbag2 folder (kept in ``cache``)."""
    out = {"tiny.mcap": cache / "tiny.mcap", "tiny.bag": cache / "tiny.bag", "tiny-bag2/": cache / "tiny-bag2"}
    for label, path in out.items():
        if not path.exists():
            flags = ["--bag", str(path)] if label.endswith("/") else ["-o", str(path)]
            subprocess.run([sys.executable, "-m", "tfrec", "record", "robots/mbot.xacro", "--traj", "sine", "--duration",
                            "1", "--no-rrd", *flags], check=True, cwd=REPO, capture_output=True)
    return out


def _bytecode_env(cache: Path, tree: Path | None, *, compiled: bool = True) -> dict[str, str]:
    """The environment of a measured process: Python's bytecode cached as an installed package has it (kept under
    ``cache``, so the trees stay clean) — or, with ``compiled`` False, every module compiled from source at each run,
    as with PYTHONDONTWRITEBYTECODE=1 — running ``tree``'s tfrec (None: this checkout's)."""
    env = {name: value for name, value in os.environ.items()
           if name not in ("PYTHONDONTWRITEBYTECODE", "PYTHONPYCACHEPREFIX", "OPENBLAS_NUM_THREADS")}
    if compiled:
        env["PYTHONPYCACHEPREFIX"] = os.fspath(cache / "pycache")
    else:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    if tree is not None:
        env["PYTHONPATH"] = os.fspath(tree)
    return env


_CHECK_LAYOUTS = """
import sys, time
from mcap.reader import make_reader
from tfrec.formats.ros.decode import JointStateAccumulator, TFAccumulator, message_layout, read_string
from tfrec.formats.ros.types import deserializer
import numpy as np
first = {}
with open(sys.argv[2], "rb") as stream:
    for schema, channel, message in make_reader(stream).iter_messages():
        first.setdefault(schema.name, bytes(message.data))
start = time.process_time()
for msgtype, raw in sorted(first.items()):
    if msgtype.endswith("String"):
        if sys.argv[1] == "written":
            text = read_string(raw, ros1=False, deserialize=None)
        else:
            text = deserializer(msgtype)(raw).data
        continue
    kind = "tf" if msgtype.endswith("TFMessage") else "joint_states"
    accumulator = (TFAccumulator if kind == "tf" else JointStateAccumulator)(deserializer(msgtype), ros1=False)
    layout = message_layout(kind, raw, ros1=False)
    rows = np.frombuffer(raw, dtype=np.uint8).reshape(1, -1)
    if sys.argv[1] == "written":
        assert accumulator.written_back(layout, rows)
    else:
        assert accumulator._alike(layout, rows, accumulator.deserialize(raw))
print(time.process_time() - start)
"""
"""The layouts of the first TFMessage and JointState of a file, and its first String, checked by writing them back
(``written``) or with rosbags (``rosbags``, as before: the reading store built and its deserializers generated);
prints the CPU seconds of the checks alone."""


def _layout_checks(cache: Path, tiny: Path, repeat: int) -> None:
    """The checks alone, in fresh processes: the fast path (written back by tfrec's encoder) against rosbags'."""
    env = _bytecode_env(cache, None)
    for way in ("written", "rosbags"):
        subprocess.run([sys.executable, "-c", _CHECK_LAYOUTS, way, str(tiny)], check=True, cwd=REPO, env=env,
                       capture_output=True)  # bytecode written
    seconds = {}
    for way in ("written", "rosbags"):
        runs = [float(subprocess.run([sys.executable, "-c", _CHECK_LAYOUTS, way, str(tiny)], check=True, cwd=REPO,
                                     env=env, capture_output=True, text=True).stdout) for _ in range(repeat)]
        seconds[way] = min(runs)
    print(f"  layout checks of tiny.mcap's first TFMessage, JointState and String (fresh process, best of {repeat}): "
          f"written back {seconds['written'] * 1000:.1f} ms CPU, rosbags {seconds['rosbags'] * 1000:.1f} ms CPU; "
          f"ratio {seconds['rosbags'] / seconds['written']:.0f}x")


def bench_info(cache: Path, repeat: int, tree: Path | None, *, hour: bool = True) -> None:
    python = sys.executable
    tiny = _tiny(cache)
    bare = _bytecode_env(cache, None)
    rows: list[tuple[str, list[str], dict[str, str]]] = [
        ("python -c pass", [python, "-c", "pass"], bare),
        ('python -c "import numpy"', [python, "-c", "import numpy"], bare),
        ('python -c "import numpy" (OPENBLAS_NUM_THREADS=1)', [python, "-c", "import numpy"],
         {**bare, "OPENBLAS_NUM_THREADS": "1"})]
    commands = [(f"tfrec info {label}", path, True) for label, path in tiny.items()]
    commands.append(("tfrec info tiny.mcap, compiled from source at each run", tiny["tiny.mcap"], False))
    if hour:
        commands.append(("tfrec info hour-sqlite3/", sqlite3_hour(cache), True))
    for label, path, compiled in commands:
        if tree is not None:
            rows.append((f"{label} (before)", [python, "-m", "tfrec", "info", str(path)],
                         _bytecode_env(cache, tree, compiled=compiled)))
        rows.append((label, [python, "-m", "tfrec", "info", str(path)], _bytecode_env(cache, None, compiled=compiled)))
    for _, argv, env in rows:  # the bytecode written, files cached
        run_process(argv, env=env)
    figures = {label: best_process(argv, repeat, env) for label, argv, env in rows}
    base = figures["python -c pass"]
    print(f"  fresh processes, best of {repeat}; Python's bytecode cached as installed unless said")
    for label, (wall, cpu, rss) in figures.items():
        print(f"  {label}: {wall * 1000:.0f} ms wall, {cpu * 1000:.0f} ms CPU, peak RSS {rss:.0f} MB; "
              f"{wall / base[0]:.1f}x python -c pass (wall), {cpu / base[1]:.1f}x (CPU)")
    if tree is not None:
        for label, _, _ in commands:
            (wall0, cpu0, rss0), (wall1, cpu1, rss1) = figures[f"{label} (before)"], figures[label]
            print(f"  {label}: now/before {wall1 / wall0:.2f}x wall, {cpu1 / cpu0:.2f}x CPU, {rss1 / rss0:.2f}x RSS")
    _layout_checks(cache, tiny["tiny.mcap"], repeat)


# -- pacing ---------------------------------------------------------------------------------------


def unique_batches(stamps: Sequence[np.ndarray], *, start_ns: int, span_ns: int) -> list[tuple[int, int, int]]:
    """Replay's windows as they were computed before: np.unique of every stamp."""
    every = np.unique(np.concatenate([np.asarray(s, dtype=np.int64) for s in stamps if len(s)]))
    every = every[every >= start_ns]
    window = (every - start_ns) // span_ns
    starts = np.flatnonzero(np.r_[True, window[1:] != window[:-1]])
    return [(start_ns + int(window[i]) * span_ns, start_ns + (int(window[i]) + 1) * span_ns, int(every[i]))
            for i in starts]


def best_cpu(repeat: int, run: Callable[[], object]) -> tuple[float, Any]:
    """CPU seconds of the fastest of ``repeat`` calls, and what the last call returned."""
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.process_time()
        result = run()
        best = min(best, time.process_time() - start)
    return best, result


def bench_pacing(repeat: int) -> None:
    from tfrec.replay.pacing import batches

    start_ns = 1_700_000_000_000_000_000
    samples = 360_001
    rng = np.random.default_rng(0)
    joint = start_ns + np.arange(samples, dtype=np.int64) * 10_000_000
    series = [joint] + [joint + rng.integers(0, 2, size=samples) for _ in range(8)]  # 8 TF series, some ties
    span_ns = 20_000_000
    new, got = best_cpu(repeat, lambda: batches(series, start_ns=start_ns, span_ns=span_ns))
    old, want = best_cpu(repeat, lambda: unique_batches(series, start_ns=start_ns, span_ns=span_ns))
    same = [tuple(b) for b in got] == want
    every = np.concatenate(series)
    sort, _ = best_cpu(repeat, lambda: np.sort(every, kind="stable"))
    unique, _ = best_cpu(repeat, lambda: np.unique(every))
    print(f"  the stamps alone: np.sort(kind='stable') {sort:.3f} s CPU, np.unique {unique:.3f} s CPU; "
          f"ratio {unique / sort:.1f}x")
    print(f"  {sum(len(s) for s in series):,} stamps, {len(want):,} windows: stable sort {new:.3f} s CPU, np.unique "
          f"{old:.3f} s CPU (best of {repeat}); ratio {old / new:.1f}x; same windows: {same}")


# -- reorder --------------------------------------------------------------------------------------


def bench_reorder(minutes: float, repeat: int) -> None:
    sys.path.insert(0, os.fspath(REPO))
    from bench_convert import write_recording
    from bench_mcap import chain

    from tests.convert.test_reorder import byte_gather
    from tfrec.convert import convert
    from tfrec.formats.mcap import writer

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        messages = write_recording(folder / "in.mcap", chain(10), round(minutes * 60 * 100))
        convert(folder / "in.mcap", folder / "in.bag")
        record_slices = writer._in_time_order
        figures = {}
        for label, reorder in (("record by record", record_slices), ("byte by byte (before)", byte_gather)):
            writer._in_time_order = reorder  # type: ignore[assignment]
            target = folder / f"{label.split()[0]}.mcap"
            figures[label], _ = best_cpu(repeat, lambda target=target: convert(folder / "in.bag", target, force=True))
        writer._in_time_order = record_slices
        same = (folder / "record.mcap").read_bytes() == (folder / "byte.mcap").read_bytes()
        now, before = figures["record by record"], figures["byte by byte (before)"]
        print(f"  ROS 1 bag → MCAP, {messages:,} messages ({minutes:g} min of a 10-joint chain at 100 Hz): record by "
              f"record {now:.2f} s CPU, byte by byte {before:.2f} s CPU (best of {repeat}); now/before "
              f"{now / before:.2f}x; byte-identical: {same}")


# -- zstd -----------------------------------------------------------------------------------------


def chunk_bodies(minutes: float) -> list[bytes]:
    """The uncompressed chunk bodies ``tfrec record`` compresses: marm, random trajectory, 100 Hz."""
    import io

    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    from tfrec.description import load_description
    from tfrec.formats.mcap.sink import McapSink
    from tfrec.kinematics.fk import iter_dynamic_chunks, static_transforms
    from tfrec.trajectory.generators import make_trajectory

    robot = load_description(REPO / "robots" / "marm.xacro")
    trajectory = make_trajectory(robot, "random", duration_s=minutes * 60, rate_hz=100.0, seed=0)
    stream = io.BytesIO()
    sink = McapSink(stream, compression="none")
    sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=1_700_000_000 * 10**9)
    for chunk in iter_dynamic_chunks(robot, trajectory):
        sink.write_chunk(stamp_ns=chunk.time_ns + 1_700_000_000 * 10**9, joint_names=chunk.names,
                         positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()
    stream.seek(0)
    return [bytes(r.data) for r in StreamReader(stream, skip_magic=False, emit_chunks=True).records if isinstance(r, Chunk)]


def zstd_blocks(level: int, block: int | None) -> Callable[[bytes], bytes]:
    """A chunk compressor: zstd at ``level``, a block ended every ``block`` bytes (None: zstd's own blocks, at most
    128 KiB each)."""
    import zstandard

    compressor = zstandard.ZstdCompressor(level=level)
    if block is None:
        return compressor.compress

    def compress(data: bytes) -> bytes:
        stream = compressor.compressobj(size=len(data))
        parts = [stream.compress(data[i:i + block]) + stream.flush(zstandard.COMPRESSOBJ_FLUSH_BLOCK)
                 for i in range(0, len(data), block)]
        parts.append(stream.flush())
        return b"".join(parts)

    return compress


def worst_cut_loss(compress: Callable[[bytes], bytes], body: bytes, step: int = 512) -> int:
    """The most uncompressed bytes a cut chunk loses before the cut: the cut moved through the compressed chunk
    ``step`` bytes at a time, what tfrec's salvage reads of it rises block by block; the largest rise is what a
    cut just before the end of that block loses."""
    from tfrec.formats._compression import salvage

    packed = compress(body)
    read = [len(salvage("zstd", packed[:cut], limit=len(body))) for cut in range(0, len(packed), step)]
    assert salvage("zstd", packed[:len(packed) // 2], limit=len(body)) == body[:read[len(packed) // 2 // step]]
    return max(b - a for a, b in zip(read, [*read[1:], len(body)]))


def bench_zstd(minutes: float, repeat: int) -> None:
    bodies = chunk_bodies(minutes)
    total = sum(len(b) for b in bodies)
    print(f"  {len(bodies)} chunks, {total / 1e6:.1f} MB uncompressed ({minutes:g} min of marm at 100 Hz)")
    base = None
    for level in (1, 3):
        for block in (16 << 10, 32 << 10, 64 << 10, None):
            compress = zstd_blocks(level, block)
            cpu, packed = best_cpu(repeat, lambda compress=compress: [compress(b) for b in bodies])
            size = sum(len(p) for p in packed)
            loss = worst_cut_loss(compress, bodies[len(bodies) // 2])
            if base is None:
                base = cpu
            print(f"  level {level}, blocks of {'128 KiB (zstd)' if block is None else f'{block >> 10} KiB'}: "
                  f"{cpu:.3f} s CPU ({total / cpu / 1e6:.0f} MB/s), {size / 1e6:.2f} MB, {cpu / base:.2f}x the "
                  f"CPU of level 1 / 16 KiB; a cut loses at most {loss / 1024:.0f} KiB of the chunk before it")


# -- record ---------------------------------------------------------------------------------------


def without_pandas(cache: Path, tree: Path | None = None) -> dict[str, str]:
    """The environment of a tfrec installed without its test extra: pandas not importable (pyarrow, asked by Rerun
    to convert a numpy array, imports pandas whenever it is installed: +40 MB and ~0.4 s); with ``tree``, running
    the older ``tfrec/`` there."""
    stub = cache / "no-pandas" / "pandas"
    stub.mkdir(parents=True, exist_ok=True)
    (stub / "__init__.py").write_text('raise ImportError("pandas is not installed")\n')
    path = os.fspath(stub.parent) if tree is None else os.pathsep.join([os.fspath(tree), os.fspath(stub.parent)])
    return {**os.environ, "PYTHONPATH": path}


def bench_record(cache: Path, hours: float, repeat: int, baseline_tree: Path | None = None) -> None:
    python = sys.executable
    out = cache / "record.mcap"
    record = [python, "-m", "tfrec", "record", str(REPO / "robots" / "marm.xacro"), "--traj", "random", "--duration",
              f"{hours * 3600:g}", "--rate", "100", "--seed", "0", "-o", str(out), "--force"]
    plain = without_pandas(cache)
    rows = [("python -c pass", [python, "-c", "pass"], None),
            ("python -c 'import rerun'", [python, "-c", "import rerun"], None),
            ("python -c 'import rerun' (no pandas)", [python, "-c", "import rerun"], plain),
            ("record --no-rrd", [*record, "--no-rrd"], None),
            ("record (MCAP + .rrd)", record, None),
            ("record (MCAP + .rrd, no pandas)", record, plain),
            ("record --no-mcap (.rrd only)", [*record, "--no-mcap"], None)]
    if baseline_tree is not None:
        rows += [("record (MCAP + .rrd), before", record, tree_env(baseline_tree)),
                 ("record (MCAP + .rrd, no pandas), before", record, without_pandas(cache, baseline_tree))]
    figures = {label: best_process(argv, repeat, env) for label, argv, env in rows}
    base = figures["record --no-rrd"]
    print(f"  robots/marm.xacro, random, {hours:g} h at 100 Hz (best of {repeat}):")
    for label, (wall, cpu, rss) in figures.items():
        print(f"  {label}: {wall:.2f} s wall, {cpu:.2f} s CPU, peak RSS {rss:.0f} MB; {cpu / base[1]:.2f}x the CPU "
              f"and {rss / base[2]:.2f}x the memory of record --no-rrd")
    for what, flags in (("8 transforms", []), ("8 transforms, 8 positions, 8 velocities", ["--joints"])):
        floor = min(_rrd_floor(hours, flags) for _ in range(repeat))
        print(f"  the least a .rrd costs through Rerun's own API (benchmarks/rrd_floor.py: import Rerun, then {what} "
              f"a sample, one timeline, no names): {floor:.2f} s CPU; record --no-rrd plus it: "
              f"{(base[1] + floor) / base[1]:.2f}x the CPU of record --no-rrd")


def _rrd_floor(hours: float, flags: list[str]) -> float:
    """CPU seconds benchmarks/rrd_floor.py reports (from Rerun's import to the file's end)."""
    done = subprocess.run([sys.executable, str(Path(__file__).with_name("rrd_floor.py")), f"{hours:g}", *flags],
                          check=True, capture_output=True, text=True)
    return float(done.stdout.split()[0])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", nargs="+", default=["info", "pacing", "reorder", "zstd", "record"],
                        choices=["info", "pacing", "reorder", "zstd", "record"])
    parser.add_argument("--hours", type=float, default=1.0, help="length of the recording (record)")
    parser.add_argument("--repeat", type=int, default=5, help="runs of each (the fastest counts)")
    parser.add_argument("--minutes", type=float, default=10.0, help="length of the converted bag (reorder)")
    parser.add_argument("--baseline-tree", type=Path,
                        help="a folder holding an older tfrec/ package (info, record: before)")
    parser.add_argument("--no-hour", action="store_true", help="info: leave out the hour-long sqlite3 bag")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "tfrec-bench-limits",
                        help="where the recordings made once are kept")
    options = parser.parse_args(argv)
    options.cache.mkdir(parents=True, exist_ok=True)
    print(machine("rosbags", "zstandard"))
    for name in options.only:
        print(f"{name}:")
        if name == "info":
            bench_info(options.cache, options.repeat, options.baseline_tree, hour=not options.no_hour)
        elif name == "pacing":
            bench_pacing(options.repeat)
        elif name == "record":
            bench_record(options.cache, options.hours, min(options.repeat, 2), options.baseline_tree)
        elif name == "zstd":
            bench_zstd(options.minutes, min(options.repeat, 3))
        else:
            bench_reorder(options.minutes, min(options.repeat, 3))
    return 0


if __name__ == "__main__":
    sys.exit(main())
