"""Issue 12: every description ROS accepts — twin packages, legacy calls, argument typos, .urdf files
with xacro leftovers, joint_state_publisher's soft limits — each with its bad input built here."""

from __future__ import annotations

import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

from tfrec.cli import main
from tfrec.description import load_description
from tfrec.errors import DescriptionError
from tfrec.trajectory import make_trajectory
from tfrec.trajectory.joints import center_positions, joint_bounds

XACRO = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


def _package(root: Path, name: str, files: dict[str, str]) -> Path:
    pkg = root / name
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text(f"<package format='3'><name>{name}</name></package>")
    for rel, text in files.items():
        (pkg / rel).parent.mkdir(parents=True, exist_ok=True)
        (pkg / rel).write_text(textwrap.dedent(text))
    return pkg


# -- twin packages ----------------------------------------------------------------------------------

def test_the_inputs_own_package_comes_before_a_twin_on_the_package_path(tmp_path: Path) -> None:
    """A workspace with the package twice (the checkout and an older vendored copy): `$(find)` takes the
    package the input is in, even when --package-path also reaches the other copy."""
    new = _package(tmp_path / "ws" / "src", "arm", {
        "urdf/arm.xacro": f'<robot name="arm" {XACRO}><xacro:include filename="$(find arm)/urdf/new_part.xacro"/>'
                          '</robot>',
        "urdf/new_part.xacro": f'<robot {XACRO}><link name="new"/></robot>',
    })
    _package(tmp_path / "ws" / "vendor" / "deep" / "er", "arm", {"urdf/old_part.xacro": "<robot/>"})
    with pytest.warns(UserWarning, match=r"package 'arm' is in .*/ws/src/arm and .*/ws/vendor/deep/er/arm; "
                                         r"using .*/ws/src/arm$"):
        robot = load_description(new / "urdf" / "arm.xacro", package_paths=[tmp_path / "ws"])
    assert [link.name for link in robot.links] == ["new"]


def test_shallower_copy_first_and_the_error_says_which_copy_was_taken(tmp_path: Path) -> None:
    _package(tmp_path / "ws", "parts", {"urdf/a.xacro": f'<robot {XACRO}><link name="shallow"/></robot>'})
    _package(tmp_path / "ws" / "old" / "copy", "parts", {"urdf/b.xacro": f'<robot {XACRO}><link name="deep"/></robot>'})
    main_file = tmp_path / "robot.xacro"
    main_file.write_text(f'<robot name="r" {XACRO}><xacro:include filename="$(find parts)/urdf/a.xacro"/></robot>')
    with pytest.warns(UserWarning, match="package 'parts'"):
        assert load_description(main_file, package_paths=[tmp_path / "ws"]).links[0].name == "shallow"
    main_file.write_text(f'<robot name="r" {XACRO}><xacro:include filename="$(find parts)/urdf/b.xacro"/></robot>')
    with pytest.raises(DescriptionError, match=r"No such file or directory: .*/ws/parts/urdf/b\.xacro \(package "
                                               r"'parts' is .*/ws/parts \(not .*/ws/old/copy/parts\)\)$"):
        load_description(main_file, package_paths=[tmp_path / "ws"])


def test_no_warning_for_a_twin_the_robot_does_not_use(tmp_path: Path) -> None:
    _package(tmp_path / "ws" / "a", "unused", {})
    _package(tmp_path / "ws" / "b", "unused", {})
    _package(tmp_path / "ws", "used", {"urdf/p.xacro": f'<robot {XACRO}><link name="l"/></robot>'})
    main_file = tmp_path / "robot.xacro"
    main_file.write_text(f'<robot name="r" {XACRO}><xacro:include filename="$(find used)/urdf/p.xacro"/></robot>')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_description(main_file, package_paths=[tmp_path / "ws"])


# -- legacy macro calls and argument typos ------------------------------------------------------------

LEGACY = f'''<robot name="r" {XACRO}>
  <xacro:macro name="wheel" params="prefix mass">
    <link name="${{prefix}}_wheel"><inertial><mass value="${{mass}}"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  </xacro:macro>
  <link name="base"/>
  CALL
</robot>'''


@pytest.mark.parametrize(("call", "message"), [
    ('<wheel prefix="left"/>',
     r"l\.xacro:7: the call of macro 'wheel' lacks parameter 'mass' \(the macro is defined at \S*l\.xacro:2\)$"),
    ('<wheel prefix="left" mass="1" radius="2"/>',
     (r"l\.xacro:7: the call of macro 'wheel' gives parameter 'radius', which it does not have \(its parameters: "
     r"prefix, mass\)$")),
])
def test_a_legacy_call_with_a_missing_or_unknown_parameter_is_an_error(tmp_path: Path, call: str,
                                                                       message: str) -> None:
    """Left unexpanded, the <link> of the macro would silently be lost; xacro <= 1.13 said why."""
    f = tmp_path / "l.xacro"
    f.write_text(LEGACY.replace("CALL", call))
    with pytest.raises(DescriptionError, match=message):
        load_description(f)


def test_a_literal_urdf_element_named_like_a_macro_is_left_alone(tmp_path: Path) -> None:
    f = tmp_path / "m.xacro"
    f.write_text(f'''<robot name="r" {XACRO}>
      <xacro:macro name="inertial" params="m"><inertial><mass value="${{m}}"/></inertial></xacro:macro>
      <link name="a"><inertial><mass value="2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
      </inertial></link>
      <link name="b"><xacro:inertial m="3"/></link>
      <joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>
    </robot>''')
    robot = load_description(f)
    assert [link.mass for link in robot.links] == [2.0, 3.0]


def test_a_typo_in_a_xacro_argument_warns_with_the_closest_name(tmp_path: Path) -> None:
    f = tmp_path / "hand.xacro"
    f.write_text(f'''<robot name="r" {XACRO}>
      <xacro:arg name="hand" default="false"/><xacro:arg name="arm_id" default="panda"/>
      <link name="$(arg arm_id)_link0"/>
      <xacro:if value="$(arg hand)"><link name="hand"/>
        <joint name="j" type="fixed"><parent link="panda_link0"/><child link="hand"/></joint></xacro:if>
    </robot>''')
    with pytest.warns(UserWarning, match=r"hand\.xacro: xacro argument hnad:=true is not an argument of this "
                                         r"description, and is ignored; did you mean 'hand'\?$"):
        robot = load_description(f, args={"hnad": "true"})
    assert len(robot.links) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a declared argument, or one only read by $(arg), is no typo
        assert len(load_description(f, args={"hand": "true", "arm_id": "panda"}).links) == 2
    g = tmp_path / "read.xacro"
    g.write_text(f'<robot name="$(arg name)" {XACRO}><link name="a"/></robot>')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_description(g, args={"name": "undeclared_but_read"}).name == "undeclared_but_read"


# -- a .urdf is never re-expanded ---------------------------------------------------------------------

def test_a_urdf_mentioning_the_xacro_namespace_is_not_run_through_xacro(tmp_path: Path) -> None:
    f = tmp_path / "left_over.urdf"
    f.write_text(f'<robot name="r" {XACRO}>\n<link name="a"/>\n<xacro:wheel prefix="x"/>\n</robot>\n')
    with pytest.warns(UserWarning, match=r"left_over\.urdf: ignored 1 element .*: <xacro:wheel> \(line 3\)$"):
        robot = load_description(f)
    assert [link.name for link in robot.links] == ["a"]


# -- joint_state_publisher's limits -------------------------------------------------------------------

TIAGO_LIKE = '''<robot name="tiago_like">
  <link name="torso"/><link name="arm_1"/><link name="wheel"/>
  <joint name="arm_1_joint" type="revolute"><parent link="torso"/><child link="arm_1"/><axis xyz="0 0 1"/>
    <limit lower="0.0" upper="2.748" effort="43" velocity="1.95"/>
    <safety_controller k_position="20" k_velocity="20" soft_lower_limit="0.07" soft_upper_limit="2.68"/>
  </joint>
  <joint name="wheel_joint" type="continuous"><parent link="torso"/><child link="wheel"/>
    <safety_controller k_velocity="10" soft_lower_limit="-1.0" soft_upper_limit="1.0"/></joint>
</robot>'''


def test_joint_state_publisher_narrows_ranges_to_soft_limits(tmp_path: Path) -> None:
    f = tmp_path / "t.urdf"
    f.write_text(TIAGO_LIKE)
    robot = load_description(f)
    arm, wheel = robot.joint_by_name["arm_1_joint"], robot.joint_by_name["wheel_joint"]
    assert joint_bounds(arm) == (0.07, 2.68) and joint_bounds(arm, soft_limits=False) == (0.0, 2.748)
    assert joint_bounds(wheel) == (-1.0, 1.0)
    np.testing.assert_allclose(center_positions(robot), [(0.07 + 2.68) / 2, 0.0])  # 0 is outside the soft range
    np.testing.assert_allclose(center_positions(robot, soft_limits=False), [0.0, 0.0])
    random = make_trajectory(robot, "random", duration_s=20.0)
    assert random.positions[:, 0].min() >= 0.07 and random.positions[:, 0].max() <= 2.68
    hard = make_trajectory(robot, "sweep", duration_s=20.0, soft_limits=False)
    assert hard.positions[:, 0].min() == 0.0 and hard.positions[:, 0].max() == pytest.approx(2.748)


def test_record_hard_limits_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tfrec.formats import read_recording

    f = tmp_path / "t.urdf"
    f.write_text(TIAGO_LIKE)
    for flag, low in (([], 0.07), (["--hard-limits"], 0.0)):
        out = tmp_path / f"t{len(flag)}.mcap"
        assert main(["record", str(f), "--traj", "sweep", "--duration", "4", "--no-rrd", "-o", str(out), *flag]) == 0
        states = read_recording(out).joint_states
        assert states is not None
        assert states.positions[:, states.names.index("arm_1_joint")].min() == pytest.approx(low)


def test_blank_limits_warn_that_the_joint_cannot_move(tmp_path: Path) -> None:
    f = tmp_path / "sw.urdf"
    f.write_text('<robot name="sw"><link name="a"/><link name="b"/><joint name="j1" type="revolute">'
                 '<parent link="a"/><child link="b"/><limit lower="0" upper="0" effort="0" velocity="0"/></joint>'
                 '</robot>')
    with pytest.warns(UserWarning, match=r"sw\.urdf: joint 'j1' cannot move: lower and upper limit are equal"):
        load_description(f)


STL = (b"solid part\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 0.05 0 0\n  vertex 0 0.05 0\n"
       b" endloop\nendfacet\nendsolid part\n")


def _installed(tmp_path: Path, folder: str, declared: str, uri_package: str) -> Path:
    """An install space as pip's example-robot-data has one: prefix/share/<folder>, whose package.xml names
    ``declared``, and a URDF in it whose mesh is ``package://<uri_package>/meshes/part.stl``."""
    share = tmp_path / "prefix" / "share" / folder
    (share / "meshes").mkdir(parents=True)
    (share / "urdf").mkdir()
    (share / "package.xml").write_text(f"<package><name>{declared}</name></package>\n")
    (share / "meshes" / "part.stl").write_bytes(STL)
    urdf = share / "urdf" / "r.urdf"
    urdf.write_text(f'<robot name="r"><link name="a"><visual><geometry><mesh filename="package://{uri_package}/'
                    'meshes/part.stl"/></geometry></visual></link></robot>')
    return urdf


def test_an_install_spaces_share_folder_is_found_by_its_name(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    """example-robot-data's URDFs say package://example-robot-data/…, and that is the folder in share/ (as ament
    finds it), but its package.xml says example_robot_descriptions: every mesh was 'not found'."""
    urdf = _installed(tmp_path, "example-robot-data", "example_robot_descriptions", "example-robot-data")
    assert main(["record", str(urdf), "-o", str(tmp_path / "r.mcap"), "--rrd", str(tmp_path / "r.rrd"),
                 "--duration", "0.1"]) == 0
    assert "warning" not in capsys.readouterr().err  # the mesh was found (else: one warning naming it)


def test_a_folder_whose_package_xml_names_another_package_is_said(tmp_path: Path) -> None:
    from tfrec.description.packages import PackageFinder

    _installed(tmp_path, "robot-data", "robot_descriptions", "robot-data")
    share = tmp_path / "prefix" / "share"
    with pytest.raises(DescriptionError, match=r"package 'robot-data' not found; searched: .*\(.*share/robot-data is "
                                               r"named so, but its package.xml names package 'robot_descriptions'"):
        PackageFinder([share]).find("robot-data")
    assert PackageFinder([share]).find("robot_descriptions") == share / "robot-data"


def test_an_argument_without_default_says_how_to_give_it(tmp_path: Path) -> None:
    path = tmp_path / "arm.xacro"
    path.write_text('<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                    '<link name="$(arg model)"/></robot>')
    with pytest.raises(DescriptionError) as caught:
        load_description(path)
    assert str(caught.value).endswith("Undefined substitution argument model (give it as model:=VALUE after the "
                                      "description)")
    assert load_description(path, args={"model": "base"}).links[0].name == "base"
