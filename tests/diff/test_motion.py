"""``tfrec diff`` on robot descriptions: URDF changes, then every link's world displacement."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tfrec import cli
from tfrec.description import parse_urdf
from tfrec.diff import (
    assert_descriptions_match,
    assert_recordings_match,
    compare_descriptions,
    compare_motion,
)
from tfrec.diff.inputs import is_recording_path, trajectory_from_joint_states
from tfrec.errors import DescriptionError, DiffError
from tfrec.recording import JointStates

ARM = """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="hand" default="false"/>
  <material name="grey"><color rgba="0.6 0.6 0.6 1"/></material>
  <link name="base"><visual><geometry><cylinder radius="0.05" length="0.1"/></geometry></visual></link>
  <link name="upper"><visual><geometry><box size="0.04 0.04 0.3"/></geometry><material name="grey"/></visual></link>
  <link name="fore"><visual><geometry><box size="0.04 0.04 0.25"/></geometry></visual></link>
  <link name="tool"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="0 0 ELBOW_Z"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="fore"/><child link="tool"/><origin xyz="0 0 0.25"/></joint>
  <xacro:if value="$(arg hand)">
    <link name="finger"/>
    <joint name="finger_joint" type="prismatic"><parent link="tool"/><child link="finger"/>
      <axis xyz="1 0 0"/><limit lower="0" upper="0.02" effort="1" velocity="1"/></joint>
  </xacro:if>
</robot>
"""


def arm(folder: Path, name: str = "arm.urdf.xacro", *, elbow_z: str = "0.3") -> Path:
    path = folder / name
    path.write_text(ARM.replace("ELBOW_Z", elbow_z))
    return path


def plain_arm(elbow_z: str = "0.3"):  # type: ignore[no-untyped-def]
    text = ARM.replace("ELBOW_Z", elbow_z)
    start, end = text.index("  <xacro:if"), text.index("</xacro:if>\n") + len("</xacro:if>\n")
    text = text[:start] + text[end:]
    return parse_urdf(text.replace(' xmlns:xacro="http://www.ros.org/wiki/xacro"', "").replace(
        '  <xacro:arg name="hand" default="false"/>\n', ""))


# -- the done-when: a 1 mm change of a joint origin ----------------------------------------------


def test_one_millimetre_at_a_joint_origin_is_the_world_displacement_of_every_link_below(tmp_path: Path) -> None:
    report = compare_descriptions(arm(tmp_path, "a.xacro"), arm(tmp_path, "b.xacro", elbow_z="0.301"))
    assert not report.equal
    kinds = [d.kind for d in report.differences]
    assert kinds[0] == "description"  # the URDF-level change first
    assert report.differences[0].detail == "joint 'elbow' changed: origin xyz (0 0 0.3) → (0 0 0.301)"
    moved = {d.what: d for d in report.differences if d.kind == "link"}
    assert set(moved) == {"link 'fore'", "link 'tool'"}  # below the elbow; base and upper stay
    deltas = {link.link: link for link in report.links}
    assert set(deltas) == {"upper", "fore", "tool"}
    for name in ("fore", "tool"):
        assert deltas[name].position_m == pytest.approx(1e-3, abs=1e-12)
        assert deltas[name].samples_over == report.samples
        assert deltas[name].rotation_rad < 1e-12
        assert moved[f"link '{name}'"].detail.startswith(f"{name}: position differs by up to 0.001 m at t=")
    assert deltas["upper"].position_m == 0.0 and deltas["upper"].first_exceed_ns is None
    assert report.largest["position"].value == pytest.approx(1e-3)
    assert set(report.worst["joints"]) == {"shoulder", "elbow"} and report.worst["link"] in {"fore", "tool"}
    text = report.to_text()
    assert text.splitlines()[0] == "3 differences"
    assert "world poses (root → link):" in text and "worst configuration at t=" in text
    assert "motion: `traj` random (`seed` 0), 10 s at 50 Hz" in text


def test_the_same_description_is_identical_along_every_trajectory(tmp_path: Path) -> None:
    path = arm(tmp_path)
    for traj in ("random", "sweep", "sine", "center"):
        report = assert_descriptions_match(path, path, traj=traj, duration_s=2.0)
        assert report.equal and report.verdict == "identical within tolerance"
        assert report.samples == 101 and {link.link for link in report.links} == {"upper", "fore", "tool"}


def test_a_rotated_origin_turns_the_links_below(tmp_path: Path) -> None:
    a = plain_arm()
    b = parse_urdf(a.urdf.replace('<origin xyz="0 0 0.3"/>', '<origin xyz="0 0 0.3" rpy="0.001 0 0"/>'))
    report = compare_descriptions(a, b, duration_s=2.0)
    fore = next(link for link in report.links if link.link == "fore")
    tool = next(link for link in report.links if link.link == "tool")
    assert fore.rotation_rad == pytest.approx(1e-3) and fore.position_m < 1e-12  # turns in place
    assert tool.position_m == pytest.approx(0.25 * 1e-3, rel=1e-3)  # 25 cm further out it moves
    assert "orientation differs by up to 0.001 rad" in next(d.detail for d in report.differences if d.what == "link 'fore'")


# -- arguments per side ------------------------------------------------------------------------


def test_xacro_arguments_belong_to_the_input_they_follow(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = str(arm(tmp_path))
    assert cli.main(["diff", path, path, "hand:=true", "--duration", "1"]) == 1
    out = capsys.readouterr().out
    assert f"B: {path} hand:=true (description of robot 'arm')" in out
    assert "joint 'finger_joint' added (only in B) (prismatic, tool → finger)" in out
    assert "placed only in B (no pose in the other): finger" in out
    assert cli.main(["diff", path, "hand:=true", path, "hand:=true", "--duration", "1"]) == 0
    assert capsys.readouterr().out.startswith("identical within tolerance\n")
    assert cli.main(["diff", path, "hand:=false", path, "--duration", "1"]) == 0
    capsys.readouterr()


@pytest.mark.parametrize(("argv", "message"), [
    (["hand:=true", "A", "B"], "xacro argument 'hand:=true' before A"),
    (["A"], "diff takes two inputs, A and B, each followed by its xacro arguments; got 1 (A)"),
    (["A", "B", "C"], "got 3 (A, B, C)"),
    (["A", "x:=", "B", "bad"], "got 3"),
    (["A", ":=1", "B"], "':=1' is not a xacro argument of the form name:=value"),
])
def test_inputs_that_do_not_split_into_two(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["diff", *argv]) == 2
    assert message in capsys.readouterr().err


# -- a description against a recording ---------------------------------------------------------


@pytest.fixture(scope="module")
def arm_recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """robots-like arm: its description, its recording (.mcap) and that recording's .rrd."""
    folder = tmp_path_factory.mktemp("arm")
    path = arm(folder)
    mcap = folder / "arm.mcap"
    assert cli.main(["record", str(path), "--traj", "random", "--duration", "2", "-o", str(mcap)]) == 0
    return path, mcap, mcap.with_suffix(".rrd")


def test_a_description_equals_its_own_recording_either_way(arm_recording: tuple[Path, Path, Path]) -> None:
    path, mcap, rrd = arm_recording
    for a, b in ((path, mcap), (mcap, path)):
        report = assert_descriptions_match(a, b)
        assert report.motion == f"the /joint_states of {mcap}" and report.samples == 101
    kinds = {(report.a.kind, report.b.kind)}
    assert kinds == {("recording", "description")}
    # the .rrd holds float32 transforms: compared at float32's precision, and the report says so
    report = assert_descriptions_match(path, rrd)
    assert any("float32" in note for note in report.notes)
    assert 0 < report.largest["position"].value < 1e-6


def test_a_changed_description_against_a_recording(arm_recording: tuple[Path, Path, Path], tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    _, mcap, _ = arm_recording
    moved = arm(tmp_path, elbow_z="0.301")
    assert cli.main(["diff", str(mcap), str(moved)]) == 1
    out = capsys.readouterr().out
    assert "joint 'elbow' changed: origin xyz (0 0 0.3) → (0 0 0.301)" in out
    assert "  fore: position differs by up to 0.001 m" in out and "  tool: position differs" in out
    # --joints REC: with a recording of either side it may name that recording (the default)
    assert cli.main(["diff", str(moved), str(mcap), "--joints", str(mcap), "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    assert data["equal"] is False and data["b"]["kind"] == "recording" and data["a"]["kind"] == "description"
    assert {d["what"] for d in data["differences"] if d["kind"] == "link"} == {"link 'fore'", "link 'tool'"}
    assert data["worst"]["joints"].keys() == {"shoulder", "elbow"}


def test_two_descriptions_along_a_recordings_joint_states(arm_recording: tuple[Path, Path, Path], tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    path, mcap, _ = arm_recording
    moved = arm(tmp_path, elbow_z="0.301")
    comparison = compare_motion(path, moved, joints=mcap)
    assert comparison.report.motion == f"the /joint_states of {mcap}"
    assert len(comparison.time_ns) == 101 and comparison.time_ns[0] == 0
    np.testing.assert_allclose(comparison.position_error[:, comparison.links.index("tool")], 1e-3, atol=1e-12)
    assert cli.main(["diff", str(path), str(moved), "--joints", str(mcap)]) == 1
    capsys.readouterr()


@pytest.mark.parametrize(("extra", "message"), [
    (["--traj", "sweep"], "--traj: {mcap} is a recording, which brings its own motion"),
    (["--joints", "{other}"], "--joints {other}: {mcap} is a recording, whose own /joint_states drive"),
    (["--topics", "/tf"], "--topics compares two recordings"),
])
def test_options_that_do_not_fit_a_recording(arm_recording: tuple[Path, Path, Path], tmp_path: Path,
                                             extra: list[str], message: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    path, mcap, rrd = arm_recording
    argv = [a.format(mcap=mcap, other=rrd) for a in extra]
    assert cli.main(["diff", str(path), str(mcap), *argv]) == 2
    assert message.format(mcap=mcap, other=rrd) in capsys.readouterr().err


def test_two_recordings_still_compare_as_recordings(arm_recording: tuple[Path, Path, Path],
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    _, mcap, _ = arm_recording
    assert cli.main(["diff", str(mcap), str(mcap)]) == 0
    assert "4 topics)" in capsys.readouterr().out  # the recordings' report, not the descriptions'
    assert cli.main(["diff", str(mcap), str(mcap), "--traj", "sweep"]) == 2
    assert "--traj drives descriptions" in capsys.readouterr().err
    assert cli.main(["diff", str(mcap), "x:=1", str(mcap)]) == 2
    assert "xacro arguments given for a recording (x:=1)" in capsys.readouterr().err


def test_a_description_that_does_not_load_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='r'><link name='a'/><joint name='j' type='fixed'/></robot>")
    assert cli.main(["diff", str(bad), str(arm(tmp_path))]) == 2
    assert "joint 'j' has no <parent link=...>" in capsys.readouterr().err
    with pytest.raises(DescriptionError, match="nothing.xacro: no such file"):
        compare_descriptions(tmp_path / "nothing.xacro", arm(tmp_path))


def test_a_loader_for_other_kinds_of_description(tmp_path: Path) -> None:
    """Launch files (another engineer's) come in through the loader: anything that is no recording."""
    launch = tmp_path / "arm.launch.py"
    launch.write_text("# a launch file")
    seen = []

    def loader(path: object, **options: object):  # type: ignore[no-untyped-def]
        seen.append((Path(str(path)).name, options["args"]))
        return plain_arm()

    report = compare_descriptions(launch, launch, args_b={"hand": "true"}, loader=loader, duration_s=1.0)
    assert report.equal and seen == [("arm.launch.py", {}), ("arm.launch.py", {"hand": "true"})]
    assert not is_recording_path(launch) and is_recording_path(tmp_path / "missing.mcap")


# -- pytest helpers ----------------------------------------------------------------------------


def test_assert_helpers_accept_descriptions(tmp_path: Path) -> None:
    a, b = arm(tmp_path, "a.xacro"), arm(tmp_path, "b.xacro", elbow_z="0.301")
    assert assert_recordings_match(a, a, duration_s=1.0).equal
    with pytest.raises(AssertionError) as info:
        assert_recordings_match(a, b, duration_s=1.0)
    assert str(info.value).startswith("descriptions differ: 3 differences\n")
    with pytest.raises(AssertionError, match="fore: position differs by up to 0.001 m"):
        assert_descriptions_match(plain_arm(), plain_arm("0.301"), duration_s=1.0)
    # within `pos_tol` the origins are equal as URDF too
    assert assert_descriptions_match(plain_arm(), plain_arm("0.301"), duration_s=1.0, pos_tol=2e-3).equal


# -- the motion --------------------------------------------------------------------------------


def test_joint_states_become_a_trajectory_by_name() -> None:
    robot = plain_arm()
    states = JointStates(np.array([10, 20, 20, 30], dtype=np.int64) + 5, ("elbow", "other"),
                         np.array([[np.nan, 1.0], [0.5, 1.0], [0.6, 1.0], [np.nan, 1.0]]))
    trajectory, held = trajectory_from_joint_states(robot, states, origin_ns=5)
    assert held == ["shoulder"] and trajectory.joint_names == ("shoulder", "elbow")
    np.testing.assert_array_equal(trajectory.time_ns, [10, 20, 30])  # a repeated stamp keeps its last sample
    np.testing.assert_array_equal(trajectory.positions, [[0.0, 0.6], [0.0, 0.6], [0.0, 0.6]])
    with pytest.raises(DiffError, match="no /joint_states samples"):
        trajectory_from_joint_states(robot, JointStates(np.zeros(0, np.int64), (), np.zeros((0, 0))), origin_ns=0)


def test_the_report_as_json_and_text_agree(tmp_path: Path) -> None:
    report = compare_descriptions(plain_arm(), plain_arm("0.301"), traj="sweep", duration_s=2.0)
    data = json.loads(report.to_json())
    assert data["verdict"] == report.verdict and data["root"] == "base" and data["samples"] == 101
    assert [d["kind"] for d in data["differences"]] == ["description", "link", "link"]
    assert {link["link"] for link in data["links"]} == {"upper", "fore", "tool"}
    assert data["largest"]["position"]["what"] in {"link 'fore'", "link 'tool'"}
    assert data["a"] == {"path": "<robot 'arm'>", "kind": "description", "format": None, "robot": "arm", "args": {}}
    assert "`traj` sweep, 2 s at 50 Hz" in data["motion"]
