"""Issue 21, part 1: robots without moving joints — the course's first robot (simple_cube: one link, no
joint) and a robot whose joints are all fixed, built here. A recording lasts what was asked (an empty
/joint_states message per sample, nothing on /tf, as robot_state_publisher answers empty joint states),
and every command works on it and on its description. Files are read back with rosbags, mcap and
Rerun's own reader."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import pytest

from tests.conftest import ROBOTS
from tfrec.cli import main

CUBE = str(ROBOTS / "simple_cube.xacro")
FIXED_URDF = """<robot name="statue">
  <link name="plinth"/>
  <link name="body"><visual><geometry><box size="0.2 0.2 0.5"/></geometry></visual></link>
  <link name="head"><visual><geometry><sphere radius="0.1"/></geometry></visual></link>
  <joint name="plinth_to_body" type="fixed"><parent link="plinth"/><child link="body"/><origin xyz="0 0 0.3"/></joint>
  <joint name="body_to_head" type="fixed"><parent link="body"/><child link="head"/>
    <origin xyz="0.1 0 0.35" rpy="0 0 1.5707963"/></joint>
</robot>
"""


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # simple_cube's material colour defined at the link level, etc.
        code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def statue(tmp_path_factory: pytest.TempPathFactory) -> str:
    path = tmp_path_factory.mktemp("statue") / "statue.urdf"
    path.write_text(FIXED_URDF)
    return str(path)


def _counts(path: Path) -> dict[str, int]:
    """Messages per topic as rosbags reads them (topics without messages left out)."""
    from rosbags.highlevel import AnyReader

    counts: dict[str, int] = {}
    with AnyReader([path]) as reader:
        for connection, _, _ in reader.messages():
            counts[connection.topic] = counts.get(connection.topic, 0) + 1
    return counts


def test_simple_cube_records_the_duration_asked(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`tfrec record simple_cube.xacro --duration 10` lasts 10 s: 501 empty JointState messages at 50 Hz
    (rosbags decodes them), nothing on /tf, /tf_static with no transform (robot_state_publisher's for one
    link); mcap's own reader gives the 10 s span from the file's statistics."""
    from mcap.reader import make_reader
    from rosbags.highlevel import AnyReader

    out = tmp_path / "cube.mcap"
    code, stdout, _ = run(capsys, "record", CUBE, "--duration", "10", "-o", str(out))
    assert code == 0
    assert "recorded simple_cube: 501 samples over 10 s (no moving joints, 1 link" in stdout
    assert _counts(out) == {"/robot_description": 1, "/tf_static": 1, "/joint_states": 501}
    with AnyReader([out]) as reader:
        connections = {c.topic: c for c in reader.connections}
        assert connections["/tf"].msgcount == 0  # the topic is there (robot_state_publisher offers it), empty
        states = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/joint_states"]
        (static,) = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/tf_static"]
    assert all(len(m.name) == len(m.position) == len(m.velocity) == 0 for m in states)
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in states]
    assert stamps[-1] - stamps[0] == 10 * 10**9 and len(set(stamps)) == 501
    assert static.transforms == []
    with open(out, "rb") as stream:
        statistics = make_reader(stream).get_summary().statistics  # type: ignore[union-attr]
    assert statistics.message_end_time - statistics.message_start_time == 10 * 10**9
    code, stdout, _ = run(capsys, "info", str(out))
    assert code == 0 and "Duration:    10.000000000 s" in stdout and "/joint_states       sensor_msgs/msg/JointState  501" in stdout
    assert "Joints (0): none" in stdout


def test_every_output_kind_lasts_the_duration(tmp_path: Path, statue: str, capsys: pytest.CaptureFixture[str]) -> None:
    """A robot of fixed joints only, recorded as a rosbag2 folder, a ROS 1 bag and an .rrd alone: each
    lasts the 3 s asked, read back by rosbags and by Rerun's reader."""
    from rerun.chunk import RrdReader

    assert run(capsys, "record", statue, "--duration", "3", "--rate", "10", "--bag", str(tmp_path / "bag"))[0] == 0
    assert run(capsys, "record", statue, "--duration", "3", "--rate", "10", "-o", str(tmp_path / "r1.bag"),
               "--no-rrd")[0] == 0
    assert run(capsys, "record", statue, "--duration", "3", "--rate", "10", "--no-mcap", "--rrd",
               str(tmp_path / "only.rrd"))[0] == 0
    for path in (tmp_path / "bag", tmp_path / "r1.bag"):
        assert _counts(path) == {"/robot_description": 1, "/tf_static": 1, "/joint_states": 31}
    from rosbags.highlevel import AnyReader

    with AnyReader([tmp_path / "r1.bag"]) as reader:
        static = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/tf_static"]
        assert reader.duration == 3 * 10**9 + 1  # rosbags counts the last nanosecond too
    assert [t.child_frame_id for t in static[0].transforms] == ["body", "head"]
    times = []
    for chunk in RrdReader(tmp_path / "only.rrd").stream():
        if chunk.entity_path == "/joints":
            batch = chunk.to_record_batch()
            times += batch.column("ros_time").cast("int64").to_pylist()
    assert len(times) == 31 and max(times) - min(times) == 3 * 10**9


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory, statue: str) -> dict[str, dict[str, Path]]:
    """simple_cube and the statue, each as an MCAP (with its .rrd), a rosbag2 folder and a ROS 1 bag."""
    out: dict[str, dict[str, Path]] = {}
    for name, robot in (("cube", CUBE), ("statue", statue)):
        folder = tmp_path_factory.mktemp(name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            assert main(["record", robot, "--duration", "2", "--rate", "20", "-o", str(folder / "r.mcap")]) == 0
            assert main(["record", robot, "--duration", "2", "--rate", "20", "--bag", str(folder / "bag"),
                         "--no-rrd"]) == 0
            assert main(["record", robot, "--duration", "2", "--rate", "20", "-o", str(folder / "r.bag"),
                         "--no-rrd"]) == 0
        out[name] = {"mcap": folder / "r.mcap", "rosbag2": folder / "bag", "rosbag1": folder / "r.bag",
                     "rrd": folder / "r.rrd"}
    return out


ROBOTS_AND_KINDS = [(robot, kind) for robot in ("cube", "statue") for kind in ("mcap", "rosbag2", "rosbag1", "rrd")]


@pytest.mark.parametrize(("robot", "kind"), ROBOTS_AND_KINDS)
def test_info_replay_check_and_plot_work(recordings: dict[str, dict[str, Path]], robot: str, kind: str,
                                         tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = recordings[robot][kind]
    code, out, _ = run(capsys, "info", str(source))
    assert code == 0 and "Duration:    2.000000000 s" in out
    for suffix in ("png", "svg", "dot"):
        graph = tmp_path / f"tree.{suffix}"
        code, out, err = run(capsys, "info", str(source), "--graph", str(graph))
        assert code == 0 and f"wrote {graph}" in out, err
    dot = (tmp_path / "tree.dot").read_text()
    assert ('"base_link" [fillcolor=' in dot) if robot == "cube" else ('"plinth" -> "body"' in dot)
    assert (tmp_path / "tree.png").read_bytes().startswith(b"\x89PNG")
    saved = tmp_path / "replayed.rrd"
    code, out, err = run(capsys, "replay", str(source), "--save", str(saved))
    assert code == 0 and saved.exists(), err
    code, out, _ = run(capsys, "info", str(saved))
    assert code == 0 and "Duration:    2.000000000 s" in out  # the replay keeps the clock of the empty joint states
    code, out, _ = run(capsys, "replay", str(source), "--check")
    assert code == 0 and "PASS" in out
    assert ("frame  parent" not in out) if robot == "cube" else ("head   body" in out)  # a table only of frames
    code, out, _ = run(capsys, "check", str(source))
    assert code == 0 and "1 pass, 0 fail, 0 error" in out
    picture = tmp_path / "plot.png"
    code, out, err = run(capsys, "plot", str(source), "-o", str(picture))
    assert code == 0 and picture.read_bytes().startswith(b"\x89PNG"), err


@pytest.mark.parametrize(("robot", "kind"), [pair for pair in ROBOTS_AND_KINDS if pair[1] != "rrd"])
def test_convert_to_every_kind_keeps_the_clock(recordings: dict[str, dict[str, Path]], robot: str, kind: str,
                                               tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = recordings[robot][kind]
    for target in ("c.mcap", "c.bag", "c.rrd"):
        code, out, err = run(capsys, "convert", str(source), str(tmp_path / target))
        assert code == 0, err
        code, out, err = run(capsys, "info", str(tmp_path / target))
        assert code == 0 and "Duration:    2.000000000 s" in out, (target, out)
    assert run(capsys, "convert", str(source), "--bag", str(tmp_path / "cb"))[0] == 0
    assert _counts(tmp_path / "cb")["/joint_states"] == 41
    code, out, err = run(capsys, "convert", str(source), str(tmp_path / "cut.mcap"), "--start", "0.5", "--end", "1.5")
    assert code == 0, err
    assert _counts(tmp_path / "cut.mcap") == {"/robot_description": 1, "/tf_static": 1, "/joint_states": 21}
    code, out, err = run(capsys, "convert", str(source), str(tmp_path / "tf.mcap"), "--tf-from-joints")
    assert code == 0, err
    assert _counts(tmp_path / "tf.mcap").get("/tf", 0) == 0  # no joint: robot_state_publisher computes no /tf


@pytest.mark.parametrize("robot", ["cube", "statue"])
def test_diff_and_inspect(recordings: dict[str, dict[str, Path]], robot: str, statue: str, tmp_path: Path,
                          capsys: pytest.CaptureFixture[str]) -> None:
    description = CUBE if robot == "cube" else statue
    paths = recordings[robot]
    code, out, _ = run(capsys, "inspect", description, "--graph", str(tmp_path / "tree.svg"))
    assert code == 0 and (tmp_path / "tree.svg").exists()
    pairs: list[tuple[Any, ...]] = [
        (paths["mcap"], paths["rosbag1"]), (paths["rosbag2"], paths["rrd"]), (description, description),
        (paths["mcap"], description), (description, paths["rosbag1"]),
    ]
    for a, b in pairs:
        code, out, err = run(capsys, "diff", str(a), str(b))
        assert code == 0 and out.startswith("identical"), (a, b, out, err)


@pytest.mark.parametrize("robot", ["cube", "statue"])
def test_diff_plot_of_every_pair(recordings: dict[str, dict[str, Path]], robot: str, statue: str, tmp_path: Path,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    """--plot draws what there is for recording vs recording, description vs description and recording vs
    description: the static frames, or the root link alone, nothing apart."""
    description = CUBE if robot == "cube" else statue
    paths = recordings[robot]
    for k, (a, b) in enumerate([(paths["mcap"], paths["rosbag2"]), (description, description),
                                (paths["rosbag1"], description)]):
        picture = tmp_path / f"diff{k}.svg"
        code, out, err = run(capsys, "diff", str(a), str(b), "--plot", str(picture))
        assert code == 0 and f"wrote {picture}" in out, err
        text = picture.read_text()
        assert ("base_link" in text) if robot == "cube" else ("head" in text)
