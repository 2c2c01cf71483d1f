"""TF that is no tree (issue 20): a frame that is its own parent, a 2-cycle, a cycle through the root, a cycle
apart from the tree, on /tf, on /tf_static or across both, a frame reparented over time — in recordings with and
without /joint_states and /robot_description. Before, a cycle through the root made ``replay --save`` (and
``convert`` to .rrd, ``plot``) compose frames forever (20 GB in minutes); every walk of a frame graph now keeps a
visited set (:mod:`tfrec.frames`), a cycle is a warning naming its frames and the rest of the tree still plays.
Each recording is built here, written by rosbags (an independent writer)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.bag_builders import Message, Robot, write_bag
from tests.faults.guarded import guarded, warnings_of
from tests.recording_helpers import _Messages, _typestore
from tfrec.formats import read_recording
from tfrec.frames import frame_tree, graph_problems
from tfrec.recording import FrameSeries, JointStates, Recording

START_NS = 1_700_000_000_000_000_000
SAMPLES = 20

URDF = """<robot name="r"><link name="world"/><link name="base"/><link name="a"/><link name="b"/>
<joint name="j0" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 0.2"/></joint>
<joint name="j1" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0.1 0 0"/><axis xyz="0 0 1"/>
  <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.1 0 0"/><axis xyz="0 0 1"/>
  <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""

# name: (/tf_static pairs, /tf pairs, the frames of the cycle the warning names, or None)
CASES: dict[str, tuple[list[tuple[str, str]], list[tuple[str, str]], tuple[str, ...] | None]] = {
    "self-parented": ([("world", "base")], [("base", "a"), ("a", "a"), ("a", "b")], ("a",)),
    "2-cycle": ([("world", "base")], [("base", "a"), ("a", "b"), ("b", "a")], ("a", "b")),
    "through the root": ([("world", "base")], [("base", "a"), ("a", "b"), ("b", "world")], ("world", "base", "a", "b")),
    "root pair": ([], [("world", "base"), ("base", "world"), ("base", "a")], ("world", "base")),
    "apart from the tree": ([("world", "base")], [("base", "a"), ("a", "b"), ("x", "y"), ("y", "x")], ("x", "y")),
    "static cycle": ([("world", "base"), ("base", "world")], [("base", "a"), ("a", "b")], ("world", "base")),
    "across static and tf": ([("world", "base"), ("a", "world")], [("base", "a"), ("a", "b")],
                             ("world", "base", "a")),
    "reparented": ([("world", "base")], [("base", "a"), ("a", "b"), ("world", "b")], None),
}


def _series(first: int, count: int) -> FrameSeries:
    time_ns = START_NS + (first + np.arange(count, dtype=np.int64)) * 50_000_000
    translation = np.tile([0.1, 0.0, 0.0], (count, 1))
    return FrameSeries(time_ns, translation, np.tile([0.0, 0.0, 0.0, 1.0], (count, 1)))


def _recording(case: str, *, joints: bool, description: bool) -> Recording:
    static, tf, _ = CASES[case]
    rec = Recording(path=case, format="mcap", start_ns=START_NS)
    rec.tf_static = {pair: (np.array([0.0, 0.0, 0.2]), np.array([0.0, 0.0, 0.0, 1.0])) for pair in static}
    rec.tf = {pair: _series(0, SAMPLES) for pair in tf}
    if joints:
        time_ns = START_NS + np.arange(SAMPLES, dtype=np.int64) * 50_000_000
        rec.joint_states = JointStates(time_ns, ("j1", "j2"), np.zeros((SAMPLES, 2)))
    if description:
        rec.robot_description = URDF
    return rec


def _reparenting(rec: Recording, *, ros1: bool) -> list[Message]:
    """'reparented': b below a for the first half of the recording, below world for the second (in messages
    of their own), the pairs taken out of ``rec``."""
    messages = _Messages(_typestore(ros1), ros1)
    out: list[Message] = []
    for pair in (("a", "b"), ("world", "b")):
        series = rec.tf.pop(pair)
        half = range(SAMPLES // 2) if pair[0] == "a" else range(SAMPLES // 2, SAMPLES)
        for i in half:
            time_ns = int(series.time_ns[i])
            out.append(("/tf", "tf2_msgs/msg/TFMessage", time_ns,
                        messages.tf([(pair, time_ns, series.translation[i], series.rotation[i])])))
    return out


def _write(tmp_path: Path, case: str, *, joints: bool, description: bool, kind: str = "mcap") -> Path:
    rec = _recording(case, joints=joints, description=description)
    extra = _reparenting(rec, ros1=kind == "ros1") if case == "reparented" else []
    return write_bag(tmp_path / ("in.bag" if kind == "ros1" else "in"), [Robot(rec)], kind=kind, extra=extra)


def _named(warnings: list[str], frames: tuple[str, ...]) -> bool:
    return any("cycle" in line or "its own parent" in line for line in warnings) and all(
        any(repr(frame) in line for line in warnings) for frame in frames)


@pytest.mark.parametrize("case", list(CASES))
def test_the_frame_graph_names_each_cycle(case: str) -> None:
    static, tf, cycle = CASES[case]
    tree = frame_tree([*static, *tf], roots=("world",))
    assert sorted(tree.order) == sorted({frame for pair in static + tf for frame in pair})  # each frame once
    assert set(tree.cycles) == ({cycle} if cycle else set())
    problems = graph_problems(tree, parents=False)
    assert bool(problems) == (cycle is not None)


COMBINATIONS = [(case, True, True) for case in CASES] + [
    (case, joints, description) for case in ("through the root", "root pair", "static cycle")
    for joints, description in ((True, False), (False, True), (False, False))]
"""(case, /joint_states, /robot_description): every case with both, the cycles through the root without."""


@pytest.mark.parametrize(("case", "joints", "description"), COMBINATIONS)
def test_replay_save_of_a_cycle_plays_the_rest_of_the_tree(tmp_path: Path, case: str, joints: bool,
                                                           description: bool) -> None:
    bag = _write(tmp_path, case, joints=joints, description=description)
    outcome = guarded(["replay", "in", "--save", "out.rrd"], tmp_path)
    cycle = CASES[case][2]
    assert outcome.code == 0, outcome.stderr
    if cycle is not None:
        assert _named(warnings_of(outcome), cycle), outcome.stderr
    # nothing lost: every recorded pair is in the .rrd, read back by Rerun's reader
    replayed = read_recording(tmp_path / "out.rrd")
    recorded = read_recording(bag)
    assert set(recorded.tf) <= set(replayed.tf)
    assert set(recorded.tf_static) <= set(replayed.tf_static) | set(replayed.tf)


@pytest.mark.parametrize("case", list(CASES))
def test_plot_of_a_cycle_is_a_plot_a_warning_or_one_line(tmp_path: Path, case: str) -> None:
    _write(tmp_path, case, joints=False, description=False)
    outcome = guarded(["plot", "in", "-o", "out.svg"], tmp_path)
    cycle = CASES[case][2]
    assert outcome.code == 0 and (tmp_path / "out.svg").stat().st_size > 0, outcome.stderr
    if cycle is not None:
        assert _named(warnings_of(outcome), cycle), outcome.stderr


def test_plot_of_nothing_but_a_self_transform_is_one_line(tmp_path: Path) -> None:
    rec = Recording(path="self", format="mcap", start_ns=START_NS)
    rec.tf = {("a", "a"): _series(0, SAMPLES)}
    write_bag(tmp_path / "in", [Robot(rec)], kind="mcap")
    outcome = guarded(["plot", "in", "-o", "out.svg"], tmp_path, isolated=False)
    assert outcome.code == 2 and "nothing to plot" in outcome.stderr and "'a' is its own parent" in outcome.stderr


@pytest.mark.parametrize("case", ["through the root", "root pair", "static cycle", "2-cycle"])
@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1"])
def test_every_command_ends_on_a_cycle(tmp_path: Path, case: str, kind: str) -> None:
    _write(tmp_path, case, joints=True, description=True, kind=kind)
    target = "in.bag" if kind == "ros1" else "in"
    cycle = CASES[case][2]
    assert cycle is not None
    for argv, codes in [
        (["info", target], (0,)),
        (["info", target, "--graph", "tree.svg"], (0,)),
        (["replay", "--check", target], (0, 1)),
        (["diff", target, target], (0, 1)),
        (["diff", "robot.urdf", target], (0, 1)),
        (["convert", target, "out.mcap"], (0,)),
    ]:
        (tmp_path / "robot.urdf").write_text(URDF)
        outcome = guarded(argv, tmp_path, codes=codes, isolated=False)
        if argv[0] in ("replay", "diff") and "robot.urdf" in argv or argv[0] == "replay":
            assert _named(warnings_of(outcome), cycle), f"{argv}: {outcome.stderr}"
    outcome = guarded(["convert", target, "out.rrd"], tmp_path)
    assert _named(warnings_of(outcome), cycle), outcome.stderr
    assert "cycle" in (tmp_path / "tree.svg").read_text() or "own parent" in (tmp_path / "tree.svg").read_text()


def test_a_hand_built_model_with_a_cycle_orders_its_joints_once() -> None:
    import dataclasses

    from tfrec.description import parse_urdf

    robot = parse_urdf(URDF)
    back = dataclasses.replace(robot.joint_by_name["j2"], name="back", parent="b", child="a")  # b -> a: a cycle
    cyclic = dataclasses.replace(robot, joints=(*robot.joints, back))
    assert [joint.name for joint in cyclic.tree_order] == ["j0", "j1", "j2"]
