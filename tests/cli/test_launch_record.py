"""The course flows from launch files: `tfrec record pkg/launch/x.launch` records the robot of the xacro
it names, `name:=value` sets launch arguments, and node parameters become recording options."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from tests.description.test_launch import write, ws  # noqa: F401 - the workspace fixture
from tfrec.cli import main
from tfrec.formats import read_recording


def _record(args: list[str], out: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # simple_cube's undefined material "red"; marm's legacy calls
        assert main(["record", *args, "-o", str(out), "--no-rrd", "--duration", "2"]) == 0


def _recipe(path: Path) -> dict[str, str]:
    from mcap.reader import make_reader

    with open(path, "rb") as stream:
        return next(dict(m.metadata) for m in make_reader(stream).iter_metadata() if m.name == "tfrec.recipe")


def _without_recipe(path: Path) -> bytes:
    """The file's bytes up to its recipe's record (the messages, the rosbag2 metadata record): opcode, uint64 length
    and uint32 name length before the name."""
    data = path.read_bytes()
    return data[: data.index(b"\x0c\x00\x00\x00tfrec.recipe") - 9]


def test_a_launch_file_records_the_robot_of_the_xacro_it_names(ws: Path, tmp_path: Path,  # noqa: F811
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    src = ws / "src"
    for launch, xacro in ((src / "simple_cube" / "launch" / "launch.launch", src / "simple_cube" / "urdf" / "simple_cube.xacro"),
                          (src / "marm_description" / "launch" / "view_marm.launch", src / "marm_description" / "urdf" / "marm.xacro")):
        a, b = tmp_path / "from_launch" / f"{launch.stem}.mcap", tmp_path / "from_xacro" / f"{launch.stem}.mcap"
        _record([str(launch), "--traj", "random"], a)
        _record([str(xacro), "--traj", "random"], b)
        assert _without_recipe(a) == _without_recipe(b)  # the same robot, the same bytes; each says what made it
        assert _recipe(a)["description"] == str(launch) and _recipe(b)["description"] == str(xacro)
    capsys.readouterr()
    assert main(["inspect", str(src / "marm_description" / "launch" / "view_marm.launch")]) == 0
    assert "robot name is: marm" in capsys.readouterr().out


def test_name_value_sets_a_launch_argument(ws: Path, tmp_path: Path) -> None:  # noqa: F811
    launch = write(ws / "src" / "cube_robot" / "launch" / "cube.launch", """\
        <launch>
          <arg name="size" default="0.2"/>
          <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro size:=$(arg size) name:=body"/>
          <node pkg="joint_state_publisher" type="joint_state_publisher" name="jsp"><param name="rate" value="20"/></node>
          <node pkg="robot_state_publisher" type="robot_state_publisher" name="rsp"><param name="tf_prefix" value="r1"/></node>
        </launch>
        """)
    out = tmp_path / "cube.mcap"
    _record([str(launch), "size:=0.5"], out)
    recording = read_recording(out)
    assert recording.robot_description is not None and 'size="0.5 0.5 0.5"' in recording.robot_description
    assert "body" in recording.robot_description


def test_node_parameters_become_recording_options(ws: Path, tmp_path: Path) -> None:  # noqa: F811
    launch = write(ws / "src" / "marm_description" / "launch" / "params.launch", """\
        <launch>
          <param name="robot_description" command="$(find xacro)/xacro $(find marm_description)/urdf/marm.xacro"/>
          <node pkg="joint_state_publisher" type="joint_state_publisher" name="jsp"><param name="rate" value="20"/></node>
          <node pkg="robot_state_publisher" type="robot_state_publisher" name="rsp"><param name="tf_prefix" value="r1"/></node>
        </launch>
        """)
    out = tmp_path / "p.mcap"
    _record([str(launch), "--traj", "sine"], out)
    recording = read_recording(out)
    assert recording.topics["/joint_states"].count == 41  # 2 s at joint_state_publisher's 20 Hz
    assert all(child.startswith("r1/") for _, child in recording.tf)  # robot_state_publisher's tf_prefix
    out2 = tmp_path / "q.mcap"
    _record([str(launch), "--traj", "sine", "--rate", "10", "--frame-prefix", ""], out2)  # the command line wins
    recording = read_recording(out2)
    assert recording.topics["/joint_states"].count == 21
    assert not any(child.startswith("r1/") for _, child in recording.tf)


def test_a_python_launch_file_is_one_line(ws: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: F811
    launch = write(ws / "src" / "marm_description" / "launch" / "display.launch.py",
                   "import os\nurdf = os.path.join(get_package_share_directory('marm_description'), 'urdf', 'marm.xacro')\n")
    assert main(["record", str(launch)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "display.launch.py" in err and "marm.xacro" in err
