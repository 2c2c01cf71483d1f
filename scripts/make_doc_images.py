"""Regenerate the pictures of tfrec.plots in docs/images/ from the robots in robots/.

- ``tf-tree-marm.svg``: ``tfrec inspect robots/marm.xacro --graph`` (links, joints with type, axis, limits);
- ``tf-tree-recorded.svg``: ``tfrec info REC --graph`` of a marm recording (frames, rates, topics);
- ``plot-marm.png``: ``tfrec plot REC`` of 10 s of ``--traj random`` (joint states, gripper paths);
- ``diff-plot.png``: ``tfrec diff A B --plot`` of two marm recordings: B's joint3 origin is moved by
  1.5 mm and its sine trajectory is 0.1 % larger, so link3 is off from the start and the other
  frames exceed the 1 mrad tolerance from time to time;
- ``check-plot.png``: ``tfrec replay --check --plot`` of A against that edited description.

Recordings go to a temporary folder, which is the working folder while they are drawn, so the
pictures name the recordings by file name alone and come out the same bytes on every run (the SVGs;
PNGs too with the same matplotlib and fonts). Not part of the tests.

Usage::

    python scripts/make_doc_images.py              # docs/images/
    python scripts/make_doc_images.py --out /tmp/pictures
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

from tfrec.description import load_description, parse_urdf
from tfrec.diff.compare import compare
from tfrec.formats.reader import read_recording
from tfrec.model import Robot
from tfrec.plots import plot_check, plot_diff, plot_recording, recorded_graph, render_graph, robot_graph
from tfrec.recorder import RecordingPlan, record
from tfrec.replay.check import check_replay
from tfrec.replay.load import load_replay
from tfrec.trajectory.generators import make_trajectory

REPO = Path(__file__).resolve().parents[1]


def _edited(robot: Robot) -> Robot:
    """marm with joint3's origin 1.5 mm off along y: a typo-sized change to a description."""
    old = '<origin rpy="0 0 0" xyz="0 0 0.14"/>'
    if robot.urdf.count(old) != 1:
        raise SystemExit(f"robots/marm.xacro changed: joint3's origin is no longer {old}")
    return parse_urdf(robot.urdf.replace(old, '<origin rpy="0 0 0" xyz="0 0.0015 0.14"/>'))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images", help="folder of the pictures")
    out = parser.parse_args().out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    os.chdir(REPO)
    robot = load_description("robots/marm.xacro")  # named as given: the title says robots/marm.xacro
    render_graph(robot_graph(robot), out / "tf-tree-marm.svg", force=True)
    edited = _edited(robot)
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        random = make_trajectory(robot, "random", duration_s=10.0, rate_hz=50.0, seed=0)
        record(robot, random, RecordingPlan(mcap=Path("marm-random.mcap"), rrd=None))
        rec = read_recording("marm-random.mcap")
        render_graph(recorded_graph(rec), out / "tf-tree-recorded.svg", force=True)
        plot_recording(rec, out / "plot-marm.png", force=True)
        record(robot, make_trajectory(robot, "sine", duration_s=6.0), RecordingPlan(mcap=Path("marm.mcap"), rrd=None))
        record(edited, make_trajectory(edited, "sine", duration_s=6.0, amplitude=0.8008),
               RecordingPlan(mcap=Path("marm-edited.mcap"), rrd=None))
        plot_diff(compare("marm.mcap", "marm-edited.mcap", pos_tol=1e-3, rot_tol=1e-3), out / "diff-plot.png", force=True)
        replay = load_replay("marm.mcap", robot=edited)
        plot_check(check_replay(replay), out / "check-plot.png", force=True)
        os.chdir(REPO)
    for name in ("tf-tree-marm.svg", "tf-tree-recorded.svg", "plot-marm.png", "diff-plot.png", "check-plot.png"):
        print(f"wrote {out / name} ({(out / name).stat().st_size:,} bytes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
