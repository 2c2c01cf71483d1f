"""The command line, called in-process: exit codes, one-line errors, inspect's outputs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO, ROBOTS
from tfrec.cli import main


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_inspect_tree(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "inspect", str(ROBOTS / "marm.xacro"))
    assert code == 0 and err == ""
    assert out.splitlines()[0] == "robot name is: marm"
    assert "root link: link0" in out
    assert "link1  (joint1: revolute, axis -1 0 0, limits [-3.14159, 3.14159])" in out
    assert "mimics finger_joint1 ×-1 +0" in out


def test_inspect_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "inspect", str(ROBOTS / "marm.xacro"), "--json")
    assert code == 0
    doc = json.loads(out)
    assert set(doc) == {"name", "root", "links", "joints"}
    assert doc["name"] == "marm" and doc["root"] == "link0"
    joints = {j["name"]: j for j in doc["joints"]}
    assert joints["joint1"] == {
        "name": "joint1", "type": "revolute", "parent": "link0", "child": "link1", "axis": [-1.0, 0.0, 0.0],
        "limit": {"lower": -3.14159, "upper": 3.14159}, "mimic": None,
    }
    assert joints["finger_joint2"]["mimic"] == {"joint": "finger_joint1", "multiplier": -1.0, "offset": 0.0}
    assert joints["gripper_joint"]["limit"] is None


def test_inspect_urdf(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "inspect", str(ROBOTS / "mbot.xacro"), "--urdf")
    assert code == 0
    assert '<joint name="left_wheel_joint" type="continuous">' in out
    assert "<wheel" not in out and "xacro" not in out.split("-->")[-1]
    assert err.startswith("tfrec: warning: robots/mbot/mbot_base.xacro: expanded legacy macro calls") or \
        "expanded legacy macro calls" in err


def test_strict_xacro_is_ros2_xacro(capsys: pytest.CaptureFixture[str]) -> None:
    """--strict-xacro expands as PyPI xacro: mbot's legacy calls are left out (a robot without wheels),
    and a warning says so; --quiet-legacy silences only that warning."""
    code, out, err = run(capsys, "inspect", str(ROBOTS / "mbot.xacro"), "--strict-xacro", "--json")
    assert code == 0 and "left_wheel_link" not in json.loads(out)["links"]
    assert "tfrec: warning: robots/mbot/mbot_base.xacro: left legacy macro calls without the 'xacro:' prefix: " \
           "<caster>, <wheel> unexpanded, as ROS 2's xacro does (--strict-xacro)" in err
    code, out, err = run(capsys, "inspect", str(ROBOTS / "mbot.xacro"), "--json", "--quiet-legacy")
    assert code == 0 and "left_wheel_link" in json.loads(out)["links"] and err == ""


def test_xacro_args_on_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "a.xacro"
    f.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                 '<xacro:arg name="n" default="d"/><link name="$(arg n)"/></robot>')
    code, out, _ = run(capsys, "inspect", str(f), "n:=given", "--json")
    assert code == 0 and json.loads(out)["links"] == ["given"]
    code, _, err = run(capsys, "inspect", str(f), "n=given")
    assert code == 2 and err == "tfrec: error: 'n=given' is not a xacro argument of the form name:=value\n"


@pytest.mark.parametrize(
    "text, message",
    [
        ('<robot name="r">\n<link name="a">\n</robot>', r"bad\.urdf:3:2: malformed XML: mismatched tag"),
        ('<robot name="r"><link name="a"/><link name="a"/></robot>', r"bad\.urdf:1: duplicate link name 'a'"),
        (None, r"bad\.urdf: no such file"),
    ],
)
def test_bad_input_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str | None,
                                   message: str) -> None:
    import re

    f = tmp_path / "bad.urdf"
    if text is not None:
        f.write_text(text)
    code, out, err = run(capsys, "inspect", str(f))
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("tfrec: error: ")
    assert re.search(message, err), err


def test_usage_error_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "inspect")
    assert code == 2 and err == ("tfrec: error: the following arguments are required: ROBOT "
                                 "(see 'tfrec inspect --help')\n")


CORPUS_ROBOTS = [
    ("urdf_tutorial/urdf/08-macroed.urdf.xacro", [], "macroed", 15),
    ("turtlebot3_description/urdf/turtlebot3_burger.urdf.xacro", [], "turtlebot3_burger", 6),
    ("turtlebot3_description/urdf/turtlebot3_waffle.urdf.xacro", [], "turtlebot3_waffle", 12),
    ("turtlebot3_description/urdf/turtlebot3_waffle_pi.urdf.xacro", [], "turtlebot3_waffle_pi", 10),
    ("ur_description/urdf/ur5.xacro", [], "ur5_robot", 10),
    ("franka_description/robots/panda/panda.urdf.xacro", ["hand:=true"], "panda", 21),
    ("robotiq_description/urdf/robotiq_2f_85_gripper.urdf.xacro", [], "robotiq_gripper", 9),
]


@pytest.mark.parametrize("path, args, name, joints", CORPUS_ROBOTS, ids=[c[0].split("/")[-1] for c in CORPUS_ROBOTS])
def test_corpus_loads_through_inspect(corpus: Path, capsys: pytest.CaptureFixture[str], path: str,
                                      args: list[str], name: str, joints: int) -> None:
    code, out, err = run(capsys, "inspect", str(corpus / path), *args, "--package-path", str(corpus), "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["name"] == name
    assert len(doc["joints"]) == joints
    assert len(doc["links"]) == joints + 1


def test_corpus_details(corpus: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "inspect", str(corpus / "franka_description/robots/panda/panda.urdf.xacro"),
                       "hand:=true", "--json")
    assert code == 0  # found through the sibling-package rule, no --package-path
    joints = {j["name"]: j for j in json.loads(out)["joints"]}
    assert joints["panda_finger_joint2"]["mimic"]["joint"] == "panda_finger_joint1"
    code, out, _ = run(capsys, "inspect", str(corpus / "robotiq_description/urdf/robotiq_2f_85_gripper.urdf.xacro"),
                       "--json")
    mimics = [j for j in json.loads(out)["joints"] if j["mimic"]]
    assert len(mimics) == 5 and {m["mimic"]["multiplier"] for m in mimics} >= {-1.0}
    code, out, _ = run(capsys, "inspect", str(corpus / "ur_description/urdf/ur5.xacro"), "--json")
    names = [j["name"] for j in json.loads(out)["joints"] if j["type"] == "revolute"]
    assert names == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                     "wrist_3_joint"]


def _modules_after(argv: list[str]) -> set[str]:
    code = (
        "import sys\n"
        "from tfrec.cli import main\n"
        "try:\n"
        f"    main({argv!r})\n"
        "except SystemExit:\n"
        "    pass\n"
        "print('MODULES: ' + ' '.join(sorted(sys.modules)))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, check=True)
    (line,) = [line for line in result.stdout.splitlines() if line.startswith("MODULES: ")]  # not the help's words
    return set(line.split()[1:])


@pytest.mark.parametrize("argv", [["--help"], ["inspect", "robots/marm.xacro"]])
def test_light_imports(argv: list[str]) -> None:
    modules = _modules_after(argv)
    heavy = {"rerun", "rosbags", "yourdfpy", "trimesh", "mcap", "mcap_ros2"}
    assert not heavy & {m.split(".")[0] for m in modules}


def test_python_dash_m() -> None:
    result = subprocess.run([sys.executable, "-m", "tfrec", "inspect", "robots/simple_cube.xacro"],
                            capture_output=True, text=True, cwd=REPO, check=False)
    assert result.returncode == 0 and "robot name is: simple_cube" in result.stdout
    result = subprocess.run([sys.executable, "-m", "tfrec", "inspect", "robots/none.xacro"],
                            capture_output=True, text=True, cwd=REPO, check=False)
    assert result.returncode == 2 and result.stderr == "tfrec: error: robots/none.xacro: no such file\n"


def test_usage_errors_are_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "record", str(ROBOTS / "marm.xacro"), "--compression", "foo")
    assert code == 2
    assert err == ("tfrec: error: argument --compression: invalid choice: 'foo' (choose from 'bz2', 'lz4', "
                   "'none', 'zstd') (see 'tfrec record --help')\n")
    code, _, err = run(capsys, "diff", "a.mcap")
    assert code == 2 and err == ("tfrec: error: diff takes two inputs, A and B, each followed by its xacro "
                                 "arguments; got 1 (a.mcap)\n")
    code, _, err = run(capsys, "diff")
    assert code == 2 and err.count("\n") == 1 and err.startswith("tfrec: error: the following arguments")


def test_tree_of_a_very_long_chain(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    n = 3000  # longer than Python's recursion limit
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = "".join(f'<joint name="j{i}" type="fixed"><parent link="l{i}"/><child link="l{i + 1}"/></joint>'
                     for i in range(n))
    f = tmp_path / "chain.urdf"
    f.write_text(f'<robot name="chain">{links}{joints}</robot>')
    code, out, err = run(capsys, "inspect", str(f))
    assert code == 0, err
    lines = out.splitlines()
    assert lines[4] == "└── l1  (j0: fixed)" and lines[-1].endswith(f"└── l{n}  (j{n - 1}: fixed)")


def test_write_errors_name_the_target(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    for argv, target in (
        (["-o", str(blocker / "x.mcap"), "--no-rrd"], blocker / "x.mcap"),
        (["--no-mcap", "--rrd", str(blocker / "x.rrd")], blocker / "x.rrd"),
        (["--no-mcap", "--rrd", "/proc/x.rrd"], Path("/proc/x.rrd")),
        (["-o", "/proc/x.mcap", "--no-rrd"], Path("/proc/x.mcap")),
    ):
        if str(target).startswith("/proc"):
            code, _, err = run(capsys, "record", str(ROBOTS / "marm.xacro"), "--duration", "0.1", *argv)
            assert code == 2 and err.startswith(f"tfrec: error: {target}: cannot write") and ".tfrec-" not in err
            continue
        code, _, err = run(capsys, "record", str(ROBOTS / "marm.xacro"), "--duration", "0.1", *argv)
        assert code == 2 and err.count("\n") == 1
        assert err.startswith(f"tfrec: error: {blocker}") and ".tfrec-" not in err
        assert not target.exists()


def test_replay_save_errors_name_the_target(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """replay --save writes atomically like record: errors name the output, never its temporary file."""
    source = tmp_path / "r.mcap"
    assert main(["record", str(ROBOTS / "marm.xacro"), "--duration", "0.1", "--no-rrd", "-o", str(source)]) == 0
    capsys.readouterr()
    code, _, err = run(capsys, "replay", str(source), "--save", "/proc/out.rrd")
    assert code == 2 and err.startswith("tfrec: error: /proc/out.rrd: cannot write") and ".tfrec-" not in err
    assert not [p for p in Path("/proc").iterdir() if p.name.startswith((".out.rrd", ".tfrec-"))]
    out = tmp_path / "out.rrd"
    out.write_bytes(b"RRF2older")
    code, _, err = run(capsys, "replay", str(source), "--save", str(out))
    assert code == 2 and err == f"tfrec: error: {out}: already exists (use --force to overwrite)\n"
    assert out.read_bytes() == b"RRF2older" and sorted(p.name for p in tmp_path.iterdir()) == ["out.rrd", "r.mcap"]


@pytest.mark.parametrize("argv, message", [
    (["diff", "a.mcap", "b.mcap", "--joint-tol", "x"], "argument --joint-tol: 'x' is not a number"),
    (["replay", "a.mcap", "--check", "--pos-tol", "-1"], "argument --pos-tol: -1 is not a tolerance (a number >= 0)"),
    (["replay", "a.mcap", "--check", "--rot-tol", "nan"], "argument --rot-tol: nan is not a tolerance (a number >= 0)"),
])
def test_tolerances_are_checked_when_parsed(capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    code, _, err = run(capsys, *argv)
    assert code == 2 and err == f"tfrec: error: {message} (see 'tfrec {argv[0]} --help')\n"


def test_help_shows_the_default_tolerances(capsys: pytest.CaptureFixture[str]) -> None:
    _, out, _ = run(capsys, "replay", "--help")
    assert "translation tolerance (default 1e-6)" in " ".join(out.split())
    _, out, _ = run(capsys, "diff", "--help")
    assert "(rad or m) are equal (default 1e-9)" in " ".join(out.split())


def test_xacro_arguments_in_the_wrong_place_get_a_hint(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "inspect", str(ROBOTS / "marm.xacro"), "--json", "hand:=true")
    assert code == 2
    assert "unrecognized arguments: hand:=true (xacro arguments name:=value go right after ROBOT)" in err
