"""Compare ``tfrec info`` (text and ``--json``) of this checkout with an older one, byte for byte, on every recording
at hand: what a change made for speed must not change what ``info`` says.

The recordings: every bag in ../shared/bags (rosbag2's and rosbag.js's own test bags), tests/golden's MCAPs, and
recordings made here once (kept in ``--cache``): ``tfrec record`` of robots/mbot.xacro and robots/marm.xacro as an
MCAP, a rosbag2 folder and ROS 1 bags (uncompressed, bz2, lz4), and the golden recordings re-written by rosbags'
writers (tests/bag_builders.py) as rosbag2 MCAP and sqlite3 folders and ROS 1 bags: one robot, two namespaced
robots, two robots sharing /tf with prefixed frames, relative topic names, sim-time and zero header stamps.

Each recording is summarized in a fresh ``python -m tfrec info`` process by both trees; stdout, stderr and the exit
code must be the same. The older tree is a folder holding its ``tfrec/`` package, e.g.
``git archive <commit> tfrec | tar -x -C DIR``. Run from the repository root:

    .venv/bin/python scripts/compare_info.py --baseline-tree DIR [--cache DIR]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tests.bag_builders import Robot, renamed, sim_time, write_bag, zeros
from tests.conftest import BAGS
from tfrec.formats.reader import read_recording

GOLDEN = sorted((REPO / "tests" / "golden").glob("*.mcap"))


def _recorded(cache: Path) -> list[Path]:
    """``tfrec record`` of mbot and marm in each format it writes."""
    out = []
    for robot in ("mbot", "marm"):
        for name, flags in ((f"{robot}.mcap", ["-o"]), (f"{robot}_bag2", ["--bag"]), (f"{robot}.bag", ["-o"]),
                            (f"{robot}-bz2.bag", ["--compression", "bz2", "-o"]),
                            (f"{robot}-lz4.bag", ["--compression", "lz4", "-o"])):
            path = cache / name
            if not path.exists():
                subprocess.run([sys.executable, "-m", "tfrec", "record", f"robots/{robot}.xacro", "--traj", "random",
                                "--duration", "2", "--seed", "1", "--no-rrd", *flags, str(path)],
                               check=True, cwd=REPO, capture_output=True)
            out.append(path)
    return out


def _rewritten(cache: Path) -> list[Path]:
    """The golden recordings re-written by rosbags' writers, the ways other systems publish."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        marm, mbot = (read_recording(path) for path in GOLDEN)
    start = marm.start_ns or 0
    cases = {
        "one": [Robot(marm)],
        "namespaced": [Robot(marm, namespace="/robot1"), Robot(mbot, namespace="/robot2")],
        "prefixed": [Robot(marm, frame_prefix="arm/"),
                     Robot(mbot, frame_prefix="base/",
                           description=renamed(mbot.robot_description or "", "base"))],
        "relative": [Robot(marm, relative=True, frame_prefix="/")],
        "simtime": [Robot(marm, header=sim_time(start))],
        "zeros": [Robot(marm, header=zeros)],
    }
    out = []
    for case, robots in cases.items():
        for kind, suffix in (("mcap", "_mcap"), ("sqlite3", "_sqlite3"), ("ros1", ".bag")):
            path = cache / f"{case}{suffix}"
            if not path.exists():
                write_bag(path, robots, kind=kind)
            out.append(path)
    return out


def recordings(cache: Path) -> list[Path]:
    shared = []
    if BAGS.is_dir():
        shared = sorted((BAGS / "rosbag2").iterdir()) + sorted((BAGS / "rosbagjs").glob("*.bag"))
    cache.mkdir(parents=True, exist_ok=True)
    return shared + GOLDEN + _recorded(cache) + _rewritten(cache)


def info(path: Path, flags: list[str], tree: Path | None) -> tuple[int, bytes, bytes]:
    """(exit code, stdout, stderr) of ``python -m tfrec info PATH FLAGS``, with ``tree``'s tfrec (None: this one)."""
    env = {**os.environ, "PYTHONPATH": os.fspath(tree)} if tree is not None else None
    done = subprocess.run([sys.executable, "-m", "tfrec", "info", str(path), *flags], capture_output=True, check=False,
                          cwd=tree if tree is not None else REPO, env=env, timeout=120)
    return done.returncode, done.stdout, done.stderr


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--baseline-tree", type=Path, required=True, help="a folder holding an older tfrec/ package")
    parser.add_argument("--cache", type=Path, default=Path("/tmp/tfrec-compare-info"),
                        help="where the recordings made here are kept")
    options = parser.parse_args()
    tree = options.baseline_tree.resolve()
    if not (tree / "tfrec" / "__init__.py").is_file():
        raise SystemExit(f"{tree}: no tfrec/ package in it")
    paths = recordings(options.cache)
    differ = 0
    for path in paths:
        for flags in ([], ["--json"]):
            now, before = info(path.resolve(), flags, None), info(path.resolve(), flags, tree)
            same = now == before
            differ += not same
            print(f"{'same' if same else 'DIFFERENT'}: info {' '.join(flags)} {path} (exit {now[0]})")
            if not same:
                for label, a, b in (("exit", now[0], before[0]), ("stdout", now[1], before[1]),
                                    ("stderr", now[2], before[2])):
                    if a != b:
                        print(f"  {label}: now {a!r}\n  {label}: before {b!r}")
    print(f"{len(paths)} recordings, {2 * len(paths)} commands: {differ} different")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
