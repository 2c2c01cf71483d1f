"""Issue 21, part 2: ROS habits. What a ROS user types (``tfrec play``, ``rosbag record -O``, ``-a``,
``rosbag play -r 2 -s 1``) is answered in the one usage-error line with tfrec's own command or option;
roslaunch's ``PKG FILE`` form is taken wherever a ROBOT is (record, inspect, diff, replay --robot, …), the
file found anywhere in the package as roslaunch finds it, an ambiguous name refused in one line."""

from __future__ import annotations

import shutil
import textwrap
import warnings
from pathlib import Path

import pytest

from tests.conftest import ROBOTS
from tfrec.cli import main
from tfrec.cli._habits import HABITS

MARM = str(ROBOTS / "marm.xacro")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> str:
    path = tmp_path_factory.mktemp("rec") / "marm.mcap"
    assert main(["record", MARM, "--duration", "1", "-o", str(path), "--no-rrd"]) == 0
    return str(path)


@pytest.mark.parametrize(("argv", "answer"), [
    (["play", "{rec}"], "'play' is not a tfrec command: did you mean `tfrec replay`?"),
    (["bag", "play", "{rec}"], "did you mean `tfrec replay`?"),
    (["bag", "info", "{rec}"], "did you mean `tfrec info`?"),
    (["view_frames"], "did you mean `tfrec info FILE --graph`?"),
    (["record", MARM, "-O", "{tmp}/out.bag"], "did you mean `-o {tmp}/out.bag`?"),
    (["record", MARM, "-a"], "tfrec records the robot's four topics always"),
    (["record", MARM, "-j"], "did you mean `--compression bz2`?"),
    (["replay", "{rec}", "-r", "2", "-s", "1"], "did you mean `--rate 2 --start 1`?"),
    (["replay", "-r", "2", "{rec}"], "did you mean `--rate 2`?"),  # argparse takes 2 for FILE: the answer does not
    (["replay", "{rec}", "--rate=2", "-l"], "did you mean `--loop`?"),
    (["replay", "{rec}", "-u", "3"], "did you mean `--end 3`?"),
    (["replay", "{rec}", "--start-offset", "1.5"], "did you mean `--start 1.5`?"),
    (["info", "{rec}", "-y"], "did you mean `--json`?"),
    (["convert", "{rec}", "-o", "{tmp}/x.mcap"], "did you mean `tfrec convert IN {tmp}/x.mcap`?"),
])
def test_a_ros_habit_is_answered_in_the_usage_error(argv: list[str], answer: str, recording: str, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    filled = [a.format(rec=recording, tmp=tmp_path) for a in argv]
    code, out, err = run(capsys, *filled)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("tfrec: error: ")
    assert answer.format(tmp=tmp_path) in err
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.parametrize("habit", [h for h in HABITS if h.commands], ids=lambda h: f"{h.commands[0]} {h.typed[0]}")
def test_every_option_habit_in_the_table_is_answered(habit: object, recording: str, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """The table is the one mechanism: each option it lists, typed after each command it names, gets its
    answer (what tfrec takes instead, or why there is none)."""
    from tfrec.cli._habits import Habit

    assert isinstance(habit, Habit)
    first = {"record": MARM, "replay": recording, "info": recording, "convert": recording}
    for command in habit.commands:
        for typed in habit.typed:
            code, _, err = run(capsys, command, first[command], typed)
            assert code == 2 and err.count("\n") == 1
            assert (habit.instead or habit.note) in err, (command, typed, err)


def test_an_unknown_option_without_a_habit_is_the_plain_argparse_error(recording: str,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "replay", recording, "--frobnicate")
    assert code == 2 and err == "tfrec: error: unrecognized arguments: --frobnicate (see 'tfrec replay --help')\n"
    code, _, err = run(capsys, "frobnicate")
    assert code == 2 and "invalid choice: 'frobnicate' (choose from" in err


# -- roslaunch's PKG FILE ---------------------------------------------------------------------------

CUBE_LAUNCH = """\
<launch>
  <param name="robot_description" command="$(find xacro)/xacro '$(find simple_cube)/urdf/simple_cube.xacro'"/>
  <node name="joint_state_publisher" pkg="joint_state_publisher" type="joint_state_publisher">
    <param name="rate" value="20"/>
  </node>
  <node name="robot_state_publisher" pkg="robot_state_publisher" type="robot_state_publisher"/>
  <node name="rviz" pkg="rviz" type="rviz" args="-d $(find simple_cube)/config/rviz.rviz"/>
</launch>
"""


@pytest.fixture
def workspace(tmp_path: Path) -> Path:
    """The course's catkin workspace: src/simple_cube with urdf/simple_cube.xacro and launch/launch.launch."""
    package = tmp_path / "mycatkin_ws" / "src" / "simple_cube"
    (package / "urdf").mkdir(parents=True)
    (package / "launch").mkdir()
    (package / "package.xml").write_text("<package format='2'><name>simple_cube</name></package>")
    shutil.copy(ROBOTS / "simple_cube.xacro", package / "urdf" / "simple_cube.xacro")
    (package / "launch" / "launch.launch").write_text(CUBE_LAUNCH)
    return tmp_path / "mycatkin_ws"


def test_record_pkg_file_as_roslaunch(workspace: Path, monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    """`roslaunch simple_cube launch.launch`, from the workspace: the launch file is found in launch/ of
    the package, its joint_state_publisher rate taken, and the robot without joints recorded for 2 s."""
    monkeypatch.chdir(workspace)
    code, out, err = run(capsys, "record", "simple_cube", "launch.launch", "--duration", "2", "-o", "cube.mcap",
                         "--no-rrd")
    assert code == 0, err
    assert "recorded simple_cube: 41 samples over 2 s" in out
    code, out, _ = run(capsys, "info", "cube.mcap")
    assert "/joint_states       sensor_msgs/msg/JointState  41 msgs  20.000 Hz" in out
    code, out, _ = run(capsys, "inspect", "simple_cube", "launch.launch")
    assert code == 0 and out.startswith("robot name is: simple_cube")


def test_pkg_file_through_the_package_path_and_ros_package_path(workspace: Path, tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    code, _, err = run(capsys, "inspect", "simple_cube", "launch.launch")
    assert code == 2 and err.startswith("tfrec: error: simple_cube launch.launch (roslaunch's form PKG FILE): "
                                        "package 'simple_cube' not found")
    code, out, _ = run(capsys, "inspect", "simple_cube", "launch.launch", "--package-path", str(workspace / "src"))
    assert code == 0 and out.startswith("robot name is: simple_cube")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(workspace / "src"))
    recording = elsewhere / "cube.bag"
    assert run(capsys, "record", "simple_cube", "launch.launch", "--duration", "1", "-o", str(recording),
               "--no-rrd")[0] == 0
    # --robot PKG FILE (replay, convert, plot, check) and diff's A and B
    code, out, err = run(capsys, "replay", str(recording), "--check", "--robot", "simple_cube", "launch.launch")
    assert code == 0 and "PASS" in out, err
    code, out, err = run(capsys, "diff", "simple_cube", "launch.launch", str(recording))
    assert code == 0 and "A: " + str(workspace / "src" / "simple_cube" / "launch" / "launch.launch") in out, err
    code, out, err = run(capsys, "check", str(recording), "--robot", "simple_cube", "launch.launch")
    assert code == 0 and "1 pass" in out, err


def test_pkg_file_ambiguous_or_missing_is_one_line(workspace: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(workspace)
    code, _, err = run(capsys, "record", "simple_cube", "view.launch")
    assert code == 2 and err == ("tfrec: error: package 'simple_cube' ({}) has no file named view.launch (roslaunch's "
                                 "form: PKG FILE, the file anywhere in the package)\n").format(
        workspace / "src" / "simple_cube")
    other = workspace / "src" / "simple_cube" / "test" / "launch.launch"
    other.parent.mkdir()
    other.write_text(CUBE_LAUNCH)
    hidden = workspace / "src" / "simple_cube" / ".git" / "launch.launch"  # hidden folders are not searched
    hidden.parent.mkdir()
    hidden.write_text(CUBE_LAUNCH)
    code, _, err = run(capsys, "inspect", "simple_cube", "launch.launch")
    assert code == 2 and err.count("\n") == 1
    assert "has 2 files named launch.launch (launch/launch.launch, test/launch.launch): give the file's path" in err
    code, out, _ = run(capsys, "inspect", "simple_cube", "launch/launch.launch")  # a path in the package
    assert code == 0 and out.startswith("robot name is: simple_cube")


def test_a_file_first_is_not_a_package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    """ROBOT that is a file keeps its meaning: the next word is a xacro argument (here a wrong one), not a
    file of a package."""
    monkeypatch.chdir(tmp_path)
    robot = tmp_path / "arm"
    robot.write_text(textwrap.dedent("""<robot name="arm"><link name="a"/></robot>"""))
    code, _, err = run(capsys, "inspect", "arm", "view.launch")
    assert code == 2 and "'view.launch' is not a xacro argument of the form name:=value" in err
