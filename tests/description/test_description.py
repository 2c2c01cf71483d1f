"""Loading robot descriptions: the seed robots, the legacy xacro dialect, and every class of bad input."""

from __future__ import annotations

import math
import re
import textwrap
import warnings
from pathlib import Path

import pytest

from tests.conftest import ROBOTS
from tfrec.description import load_description, parse_urdf, parse_xacro_args
from tfrec.errors import DescriptionError, LegacyXacroWarning
from tfrec.model import Box, Cylinder, JointType, Sphere

LEGACY = r"expanded legacy macro calls without the 'xacro:' prefix: <caster>, <wheel>"


def load_mbot(**kwargs):
    with pytest.warns(LegacyXacroWarning, match=LEGACY):
        return load_description(ROBOTS / "mbot.xacro", **kwargs)


# ---- the seed robots ------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["simple_cube.xacro", "simple_cube_params.xacro"])
def test_simple_cube(name: str) -> None:
    robot = load_description(ROBOTS / name)
    assert robot.name == "simple_cube"
    assert [link.name for link in robot.links] == ["base_link"]
    assert robot.joints == ()
    (visual,) = robot.links[0].visuals
    assert visual.geometry == Box(size=(0.2, 0.2, 0.2))
    assert visual.origin.xyz == (1.0, 0.5, 0.0) and visual.origin.rpy == (0.0, 0.0, 0.0)
    assert visual.material is not None and visual.material.rgba == (1.0, 0.0, 0.0, 1.0)
    assert robot.links[0].mass == 1.0
    assert 'ixx="0.01"' in robot.urdf and 'izz="0.01"' in robot.urdf


def test_mbot() -> None:
    robot = load_mbot()
    assert robot.name == "mbot"
    assert robot.root == "base_footprint"
    assert {link.name for link in robot.links} == {
        "base_footprint", "base_link", "left_wheel_link", "right_wheel_link",
        "front_caster_link", "back_caster_link", "camera_link",
    }
    j = robot.joint_by_name
    assert j["base_footprint_joint"].type is JointType.FIXED
    assert j["base_footprint_joint"].origin.xyz == pytest.approx((0, 0, 0.16 / 2 + 2 * 0.015))
    base = robot.link_by_name["base_link"].visuals[0]
    assert base.geometry == Cylinder(radius=0.20, length=0.16)
    for side, reflect in (("left", -1), ("right", 1)):
        wheel = j[f"{side}_wheel_joint"]
        assert wheel.type is JointType.CONTINUOUS
        assert (wheel.parent, wheel.child) == ("base_link", f"{side}_wheel_link")
        assert wheel.axis == (0.0, 1.0, 0.0)
        assert wheel.origin.xyz == pytest.approx((0, reflect * 0.19, -0.05))
        visual = robot.link_by_name[f"{side}_wheel_link"].visuals[0]
        assert visual.geometry == Cylinder(radius=0.06, length=0.025)
        assert visual.origin.rpy[0] == pytest.approx(math.pi / 2, abs=1e-6)
    for side, x in (("front", -0.18), ("back", 0.18)):
        caster = j[f"{side}_caster_joint"]
        assert caster.type is JointType.FIXED and caster.child == f"{side}_caster_link"
        assert caster.origin.xyz == pytest.approx((x, 0, -(0.16 / 2 + 0.015)))
        assert robot.link_by_name[f"{side}_caster_link"].visuals[0].geometry == Sphere(radius=0.015)
    assert j["camera_joint"].type is JointType.FIXED and j["camera_joint"].child == "camera_link"
    assert [joint.name for joint in robot.actuated_joints] == ["left_wheel_joint", "right_wheel_joint"]


def test_mbot_writes_legacy_calls() -> None:
    """The project exercises the legacy dialect: an included file calls macros without the prefix."""
    text = (ROBOTS / "mbot" / "mbot_base.xacro").read_text()
    assert re.search(r"<wheel\s+prefix=\"left\"\s+reflect=\"-1\"\s*/>", text)
    assert "$(find tfrec_robots)" in (ROBOTS / "mbot.xacro").read_text()


def test_marm() -> None:
    robot = load_description(ROBOTS / "marm.xacro")
    assert robot.name == "marm"
    names = [link.name for link in robot.links]
    assert [f"link{i}" for i in range(7)] == names[:7]
    sizes = {"link0": (0.05, 0.04), "link1": (0.03, 0.10), "link2": (0.03, 0.14), "link3": (0.03, 0.15)}
    for link, (radius, length) in sizes.items():
        assert robot.link_by_name[link].visuals[0].geometry == Cylinder(radius=radius, length=length)
    assert robot.link_by_name["link0"].mass == 1.0 and robot.link_by_name["link2"].mass == 0.8
    for i in range(1, 7):
        joint = robot.joint_by_name[f"joint{i}"]
        assert joint.type is JointType.REVOLUTE
        assert joint.limit is not None
        assert (joint.limit.lower, joint.limit.upper) == pytest.approx((-3.14159, 3.14159))
        assert (joint.limit.effort, joint.limit.velocity) == (300.0, 1.0)
    j1 = robot.joint_by_name["joint1"]
    assert (j1.parent, j1.child) == ("link0", "link1")
    assert j1.origin.xyz == pytest.approx((0, 0, 0.02)) and j1.origin.rpy == pytest.approx((0, 3.14159 / 2, 0))
    assert j1.axis == (-1.0, 0.0, 0.0)
    f1, f2 = robot.joint_by_name["finger_joint1"], robot.joint_by_name["finger_joint2"]
    assert f1.type is JointType.PRISMATIC and f1.mimic is None
    assert f2.type is JointType.PRISMATIC and f2.mimic is not None and f2.mimic.joint == "finger_joint1"
    colours = {v.material.name: v.material.rgba for link in robot.links for v in link.visuals if v.material}
    assert colours["White"] == (1, 1, 1, 1) and colours["Blue"] == (0, 0, 1, 1)
    assert "cylinder_inertial_matrix" in (ROBOTS / "marm.xacro").read_text()
    for name in ("Black", "White", "Blue", "Red"):
        assert f'material name="{name}"' in robot.urdf


# ---- the legacy dialect -------------------------------------------------------------------------


def test_strict_xacro_leaves_legacy_calls_as_ros2_xacro_does() -> None:
    """`strict_xacro` is PyPI xacro: mbot's legacy calls stay unexpanded (no wheels), with a warning."""
    with pytest.warns(LegacyXacroWarning, match=r"mbot_base\.xacro: left legacy macro calls without the 'xacro:' "
                                                r"prefix: <caster>, <wheel> unexpanded, as ROS 2's xacro does"), \
            pytest.warns(UserWarning, match=r"ignored 4 elements"):
        robot = load_description(ROBOTS / "mbot.xacro", strict_xacro=True)
    assert {link.name for link in robot.links} == {"base_footprint", "base_link", "camera_link"}


def test_legacy_call_in_top_file(tmp_path: Path) -> None:
    f = tmp_path / "r.xacro"
    f.write_text(textwrap.dedent("""\
        <robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
          <xacro:macro name="box_link" params="name size">
            <link name="${name}"><visual><geometry><box size="${size} ${size} ${size}"/></geometry></visual></link>
          </xacro:macro>
          <box_link name="a" size="1"/>
        </robot>"""))
    with pytest.warns(LegacyXacroWarning, match=r"r\.xacro: .*expanded legacy macro calls .*<box_link>"):
        robot = load_description(f)
    assert robot.links[0].visuals[0].geometry == Box(size=(1.0, 1.0, 1.0))


# ---- $(find) through each source -------------------------------------------------------------


def _pkg(root: Path, name: str, folder: str | None = None) -> Path:
    pkg = root / (folder or name)
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "package.xml").write_text(f"<package format='3'><name>{name}</name></package>")
    (pkg / "urdf" / "part.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="from_' + name + '"/></robot>')
    return pkg


def _main_file(tmp_path: Path, pkg: str) -> Path:
    main = tmp_path / "main" / "robot.xacro"
    main.parent.mkdir(parents=True, exist_ok=True)
    main.write_text(f'<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                    f'<xacro:include filename="$(find {pkg})/urdf/part.xacro"/></robot>')
    return main


def test_find_via_package_path(tmp_path: Path) -> None:
    _pkg(tmp_path / "ws" / "src", "my_pkg", folder="checkout_dir")  # folder name differs from the package name
    robot = load_description(_main_file(tmp_path, "my_pkg"), package_paths=[tmp_path / "ws"])
    assert robot.links[0].name == "from_my_pkg"


def test_find_via_ros_package_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _pkg(tmp_path / "rpp", "env_pkg")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "nothing") + ":" + str(tmp_path / "rpp"))
    assert load_description(_main_file(tmp_path, "env_pkg")).links[0].name == "from_env_pkg"


def test_find_via_ament_prefix_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _pkg(tmp_path / "install" / "share", "ament_pkg")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    assert load_description(_main_file(tmp_path, "ament_pkg")).links[0].name == "from_ament_pkg"


def test_find_via_enclosing_and_sibling_packages(tmp_path: Path) -> None:
    src = tmp_path / "ws" / "src"
    own = _pkg(src, "own_pkg")
    _pkg(src / "group", "sibling_pkg")
    main = own / "urdf" / "robot.xacro"
    main.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                    '<xacro:include filename="$(find own_pkg)/urdf/part.xacro"/>'
                    '<xacro:include filename="$(find sibling_pkg)/urdf/part.xacro"/>'
                    '<joint name="j" type="fixed"><parent link="from_own_pkg"/><child link="from_sibling_pkg"/></joint>'
                    '</robot>')
    robot = load_description(main)
    assert [link.name for link in robot.links] == ["from_own_pkg", "from_sibling_pkg"]


def test_package_path_comes_first(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _pkg(tmp_path / "a", "dup_pkg")
    other = _pkg(tmp_path / "b", "dup_pkg")
    (other / "urdf" / "part.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="from_b"/></robot>')
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "a"))
    with pytest.warns(UserWarning, match=r"package 'dup_pkg' is in .*/b/dup_pkg and .*/a/dup_pkg; using .*/b/dup_pkg$"):
        robot = load_description(_main_file(tmp_path, "dup_pkg"), package_paths=[tmp_path / "b"])
    assert robot.links[0].name == "from_b"


def test_find_is_isolated_per_load(tmp_path: Path) -> None:
    """A package found through one load's --package-path is not found by the next load."""
    _pkg(tmp_path / "pp", "iso_pkg")
    main = _main_file(tmp_path, "iso_pkg")
    load_description(main, package_paths=[tmp_path / "pp"])
    with pytest.raises(DescriptionError, match="package 'iso_pkg' not found"):
        load_description(main)


# ---- xacro args -----------------------------------------------------------------------------


def test_xacro_args(tmp_path: Path) -> None:
    f = tmp_path / "a.urdf.xacro"
    f.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                 '<xacro:arg name="n" default="dflt"/><link name="$(arg n)"/></robot>')
    assert load_description(f).links[0].name == "dflt"
    assert load_description(f, args=parse_xacro_args(["n:=given"])).links[0].name == "given"
    with pytest.raises(DescriptionError, match="'n=given' is not a xacro argument of the form name:=value"):
        parse_xacro_args(["n=given"])


# ---- bad input: one line naming the file and the element ----------------------------------------


def _write(tmp_path: Path, name: str, text: str) -> Path:
    f = tmp_path / name
    f.write_text(textwrap.dedent(text))
    return f


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(DescriptionError, match=r"nope\.urdf: no such file"):
        load_description(tmp_path / "nope.urdf")


def test_malformed_xml_plain_urdf(tmp_path: Path) -> None:
    f = _write(tmp_path, "bad.urdf", '<robot name="r">\n  <link name="a">\n</robot>\n')
    with pytest.raises(DescriptionError, match=r"bad\.urdf:3:2: malformed XML: mismatched tag"):
        load_description(f)


def test_malformed_xml_in_included_xacro(tmp_path: Path) -> None:
    _write(tmp_path, "inc.xacro", '<robot xmlns:xacro="http://www.ros.org/wiki/xacro">\n<link name="a"\n</robot>')
    f = _write(tmp_path, "top.xacro",
               '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:include filename="inc.xacro"/></robot>')
    with pytest.raises(DescriptionError, match=r"inc\.xacro:3:0: malformed XML"):
        load_description(f)


def test_missing_include(tmp_path: Path) -> None:
    f = _write(tmp_path, "top.xacro",
               '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:include filename="gone.xacro"/></robot>')
    with pytest.raises(DescriptionError, match=r"top\.xacro:1: No such file or directory: .*gone\.xacro"):
        load_description(f)


def test_unknown_package_lists_places(tmp_path: Path) -> None:
    f = _write(tmp_path, "top.xacro", '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
               '<xacro:include filename="$(find no_such_pkg)/x.xacro"/></robot>')
    with pytest.raises(DescriptionError, match=r"top\.xacro:1: package 'no_such_pkg' not found; searched: `package_paths` .*elsewhere"):
        load_description(f, package_paths=[tmp_path / "elsewhere"])


def test_undefined_property(tmp_path: Path) -> None:
    f = _write(tmp_path, "p.xacro", '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
               '<link name="${nothing_here}"/></robot>')
    with pytest.raises(DescriptionError, match=r"p\.xacro:1: .*name 'nothing_here' is not defined"):
        load_description(f)


def test_undefined_macro(tmp_path: Path) -> None:
    f = _write(tmp_path, "m.xacro", '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
               '<xacro:no_such_macro a="1"/></robot>')
    with pytest.raises(DescriptionError, match=r"m\.xacro:1: unknown macro 'no_such_macro'$"):
        load_description(f)


def _robot(body: str) -> str:
    return f'<robot name="r">\n{textwrap.dedent(body)}</robot>\n'


TWO_LINKS = '<link name="a"/>\n<link name="b"/>\n'


@pytest.mark.parametrize(
    "body, message",
    [
        (TWO_LINKS + '<joint name="j" type="fixed"><parent link="x"/><child link="b"/></joint>\n',
         r"r\.urdf:4: joint 'j' names unknown parent link 'x'"),
        (TWO_LINKS + '<joint name="j" type="fixed"><parent link="a"/><child link="y"/></joint>\n',
         r"r\.urdf:4: joint 'j' names unknown child link 'y'"),
        (TWO_LINKS + '<link name="a"/>\n', r"r\.urdf:4: duplicate link name 'a'"),
        (TWO_LINKS + '<link name="c"/>\n<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>\n'
         '<joint name="j" type="fixed"><parent link="a"/><child link="c"/></joint>\n',
         r"r\.urdf:6: duplicate joint name 'j'"),
        (TWO_LINKS, r"r\.urdf: robot 'r' has several root links: a, b"),
        (TWO_LINKS + '<joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>\n'
         '<joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint>\n',
         r"r\.urdf: robot 'r' has no root link: its joints form a cycle"),
        (TWO_LINKS + '<link name="c"/>\n<joint name="j1" type="fixed"><parent link="b"/><child link="c"/></joint>\n'
         '<joint name="j2" type="fixed"><parent link="c"/><child link="b"/></joint>\n',
         r"r\.urdf:\d+: joints 'j1', 'j2' form a cycle"),
        (TWO_LINKS + '<joint name="j" type="hinge"><parent link="a"/><child link="b"/></joint>\n',
         r"r\.urdf:4: joint 'j' has type 'hinge', not one of URDF's revolute, continuous"),
        (TWO_LINKS + '<joint name="j" type="revolute"><parent link="a"/><child link="b"/></joint>\n',
         r"r\.urdf:4: joint 'j' is revolute but has no <limit>"),
        (TWO_LINKS + '<joint name="j" type="prismatic"><parent link="a"/><child link="b"/></joint>\n',
         r"r\.urdf:4: joint 'j' is prismatic but has no <limit>"),
        (TWO_LINKS + '<joint name="j" type="continuous"><parent link="a"/><child link="b"/>\n<axis xyz="0 0 0"/></joint>\n',
         r"r\.urdf:5: joint 'j' has a zero axis"),
        (TWO_LINKS + '<joint name="j" type="continuous"><parent link="a"/><child link="b"/>\n<axis xyz="0 nan 1"/></joint>\n',
         r"r\.urdf:5: joint 'j' axis: malformed xyz=\"0 nan 1\""),
        (TWO_LINKS + '<joint name="j" type="fixed"><parent link="a"/><child link="b"/>\n<origin xyz="0 0"/></joint>\n',
         r"r\.urdf:5: joint 'j' origin: malformed xyz=\"0 0\" \(expected 3 finite numbers\)"),
        (TWO_LINKS + '<joint name="j" type="fixed"><parent link="a"/><child link="b"/>\n<origin rpy="0 x 0"/></joint>\n',
         r"r\.urdf:5: joint 'j' origin: malformed rpy=\"0 x 0\""),
        (TWO_LINKS + '<link name="c"/>\n'
         '<joint name="j1" type="continuous"><parent link="a"/><child link="b"/><mimic joint="j2"/></joint>\n'
         '<joint name="j2" type="continuous"><parent link="a"/><child link="c"/><mimic joint="j1"/></joint>\n',
         r"r\.urdf:5: mimic joints form a cycle: j1 -> j2 -> j1"),
    ],
)
def test_invalid_urdf(tmp_path: Path, body: str, message: str) -> None:
    f = tmp_path / "r.urdf"
    f.write_text(_robot(body))
    with pytest.raises(DescriptionError, match=message) as info:
        load_description(f)
    assert "\n" not in str(info.value)


def test_validation_after_xacro_names_file_and_element(tmp_path: Path) -> None:
    f = _write(tmp_path, "v.xacro", '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
               '<link name="a"/><link name="b"/>'
               '<joint name="j" type="fixed"><parent link="uper_arm"/><child link="b"/></joint></robot>')
    with pytest.raises(DescriptionError, match=r"/v\.xacro:1: joint 'j' names unknown parent link 'uper_arm'$"):
        load_description(f)


def test_unknown_element_after_xacro_is_ignored_with_a_warning(tmp_path: Path) -> None:
    f = _write(tmp_path, "u.xacro", '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
               '<link name="a"/><gripper side="left"/></robot>')
    with pytest.warns(UserWarning, match=r"u\.xacro: ignored 1 element that URDF does not define \(as urdfdom "
                      r"does\): <gripper> \(line 1\)$"):
        robot = load_description(f)
    assert [link.name for link in robot.links] == ["a"]


@pytest.mark.parametrize(
    "body, message",
    [
        ('<link name="a"/>\n<wheel prefix="left"/>\n', r"r\.urdf: ignored 1 element .*: <wheel> \(line 3\)$"),
        (('<link name="a"><visual><origin xyz="1 0 0"/><geometry><box size="1 1 1"/></geometry></visual>'
         '<xacro:thing/></link>\n'), r"r\.urdf: ignored 1 element .*: <xacro:thing> \(line 2\)$"),
        (TWO_LINKS + '<joint name="j" type="fixed"><parent link="a"/><child link="b"/>\n<orgin xyz="1 0 0"/></joint>\n',
         r"r\.urdf: ignored 1 element .*: <orgin> \(line 5\)$"),
    ],
)
def test_what_urdfdom_ignores_is_ignored_with_one_warning(tmp_path: Path, body: str, message: str) -> None:
    f = tmp_path / "r.urdf"
    f.write_text(_robot(body))
    with pytest.warns(UserWarning, match=message) as record:
        load_description(f)
    assert len(record) == 1


def test_other_tools_elements_are_ignored_silently(tmp_path: Path) -> None:
    """PR2's <controller:…>, <drake:…>, <sensor:…> inside <gazebo>, <mujoco>, <klampt> at the top: urdfdom
    ignores them, and so does tfrec, without a word."""
    f = tmp_path / "r.urdf"
    f.write_text(_robot(
        TWO_LINKS + '<joint name="j" type="fixed"><parent link="a"/><child link="b"/>'
        '<drake:rotor_inertia value="1"/></joint>\n'
        '<gazebo><controller:gazebo_ros_controller_manager name="m"/><sensor:camera name="c"/></gazebo>\n'
        '<mujoco><compiler meshdir="x"/></mujoco>\n<klampt/>\n<controller:plugin name="p"/>\n'
    ).replace("<robot ", '<robot xmlns:drake="d" xmlns:controller="c" xmlns:sensor="s" '))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        robot = load_description(f)
    assert robot.joint_by_name["j"].parent == "a"


def test_a_mimic_of_an_unknown_joint_warns_and_stays_at_its_offset(tmp_path: Path) -> None:
    f = tmp_path / "r.urdf"
    f.write_text(_robot(TWO_LINKS + '<joint name="j" type="continuous"><parent link="a"/><child link="b"/>\n'
                        '<mimic joint="ghost" offset="0.25"/></joint>\n'))
    with pytest.warns(UserWarning, match=r"r\.urdf:4: joint 'j' mimics unknown joint 'ghost': it stays at its mimic "
                      "offset"):
        robot = load_description(f)
    from tfrec.kinematics import all_joint_states
    from tfrec.trajectory import make_trajectory

    names, positions, _ = all_joint_states(robot, make_trajectory(robot, "sine", duration_s=1.0))
    assert names == ("j",) and (positions == 0.25).all()


def test_huge_and_tiny_axes_are_normalized_not_zeroed(tmp_path: Path) -> None:
    f = tmp_path / "r.urdf"
    f.write_text(_robot(TWO_LINKS + '<link name="c"/>\n'
                        '<joint name="j" type="continuous"><parent link="a"/><child link="b"/>'
                        '<axis xyz="1e200 1e200 1e200"/></joint>\n'
                        '<joint name="k" type="continuous"><parent link="a"/><child link="c"/>'
                        '<axis xyz="1e-200 0 0"/></joint>\n'))
    robot = load_description(f)
    third = 1 / 3 ** 0.5
    assert robot.joint_by_name["j"].axis == pytest.approx((third, third, third))
    assert robot.joint_by_name["k"].axis == (1.0, 0.0, 0.0)


def test_planar_and_floating_warn() -> None:
    text = _robot(TWO_LINKS + '<link name="c"/>\n'
                  '<joint name="p" type="planar"><parent link="a"/><child link="b"/><axis xyz="0 0 2"/></joint>\n'
                  '<joint name="f" type="floating"><parent link="a"/><child link="c"/></joint>\n')
    with pytest.warns(UserWarning) as record:
        robot = parse_urdf(text, source="x.urdf")
    messages = [str(w.message) for w in record]
    assert any("joint 'p' is planar: treated as fixed" in m for m in messages)
    assert any("joint 'f' is floating: it gets no transform" in m for m in messages)
    assert robot.joint_by_name["p"].axis == (0.0, 0.0, 1.0)
    assert robot.actuated_joints == ()


def test_axis_is_normalized_and_materials_resolve() -> None:
    text = _robot('<material name="m"><color rgba="0.1 0.2 0.3 1"/></material>\n'
                  '<link name="a"><visual><geometry><mesh filename="package://p/m.stl" scale="2 2 2"/></geometry>'
                  '<material name="m"/></visual></link>\n<link name="b"/>\n'
                  '<joint name="j" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="0 3 4"/>'
                  '<limit lower="0" upper="1" effort="1" velocity="1"/></joint>\n')
    robot = parse_urdf(text)
    assert robot.joints[0].axis == pytest.approx((0, 0.6, 0.8))
    visual = robot.links[0].visuals[0]
    assert visual.material is not None and visual.material.rgba == (0.1, 0.2, 0.3, 1.0)
    assert visual.geometry.scale == (2.0, 2.0, 2.0)  # type: ignore[union-attr]


@pytest.mark.parametrize(
    "body",
    [
        '<xacro:include filename="self.xacro"/>',
        '<xacro:macro name="m"><xacro:m/></xacro:macro><xacro:m/>',
        '<include filename="self.xacro"/>',
    ],
    ids=["include", "macro", "legacy-include"],
)
def test_endless_recursion_is_one_line(tmp_path: Path, body: str) -> None:
    f = _write(tmp_path, "self.xacro", f'<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">{body}</robot>')
    with pytest.raises(DescriptionError, match=r"self\.xacro:1: xacro recursion too deep"), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the legacy call warns before it recurses
        load_description(f)


def test_paths_from_the_root_folder_stay_absolute(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir("/")
    with pytest.raises(DescriptionError, match=rf"^{re.escape(str(tmp_path))}/nope\.urdf: no such file$"):
        load_description(tmp_path / "nope.urdf")


def test_legacy_expansion_leaves_elements_that_do_not_fit_the_macro(tmp_path: Path) -> None:
    """A Gazebo <camera> with children beside a 'camera' macro is SDF, not a legacy call; nor is an
    element missing a required parameter, nor anything inside <gazebo>."""
    f = _write(tmp_path, "c.xacro", """\
        <robot name="c" xmlns:xacro="http://www.ros.org/wiki/xacro">
          <xacro:macro name="camera" params="name"><link name="${name}"/>
            <joint name="${name}_j" type="fixed"><parent link="base"/><child link="${name}"/></joint>
          </xacro:macro>
          <xacro:macro name="mark" params="name size"><link name="${name}"/></xacro:macro>
          <link name="base"/>
          <xacro:camera name="cam"/>
          <gazebo reference="cam">
            <sensor type="camera" name="camera1"><camera name="head"><horizontal_fov>1.39</horizontal_fov></camera>
            </sensor>
            <mark name="sdf_mark" size="1"/>
          </gazebo>
        </robot>""")
    for strict in (False, True):
        robot = load_description(f, strict_xacro=strict)
        assert [link.name for link in robot.links] == ["base", "cam"]
    assert '<camera name="head">' in robot.urdf and '<mark name="sdf_mark" size="1"/>' in robot.urdf


def test_relative_package_paths_in_the_environment(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _pkg(tmp_path / "rel", "rel_pkg")
    _pkg(tmp_path / "pre" / "share", "ament_rel_pkg")
    main = _main_file(tmp_path, "rel_pkg")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ROS_PACKAGE_PATH", "rel")
    assert load_description(main).links[0].name == "from_rel_pkg"
    monkeypatch.setenv("AMENT_PREFIX_PATH", "pre")
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    assert load_description(_main_file(tmp_path, "ament_rel_pkg")).links[0].name == "from_ament_rel_pkg"


def test_two_packages_of_one_name_in_a_folder_warn(tmp_path: Path) -> None:
    _pkg(tmp_path / "ws", "twin_pkg", folder="a_first")
    second = _pkg(tmp_path / "ws", "twin_pkg", folder="b_second")
    (second / "urdf" / "part.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="from_b"/></robot>')
    with pytest.warns(UserWarning, match=r"package 'twin_pkg' is in .*a_first and .*b_second; using .*a_first"):
        robot = load_description(_main_file(tmp_path, "twin_pkg"), package_paths=[tmp_path / "ws"])
    assert robot.links[0].name == "from_twin_pkg"


@pytest.mark.parametrize(("name", "rgba"), [("red", (0.8, 0.0, 0.0, 1.0)), ("Grey", (0.5, 0.5, 0.5, 1.0)),
                                             ("light gray", (0.75, 0.75, 0.75, 1.0)), ("ORANGE", (1.0, 0.42, 0.04, 1.0))])
def test_an_undefined_material_with_a_common_colour_name_gets_that_colour(name: str, rgba: tuple[float, ...]) -> None:
    text = (f'<robot name="cube"><link name="base"><visual><geometry><box size="1 1 1"/></geometry>'
            f'<material name="{name}"/></visual></link></robot>')
    with pytest.warns(UserWarning, match=rf"<urdf>:1: link 'base' visual 0 uses material '{name}', which is not "
                                         r"defined; shown as the colour of that name"):
        robot = parse_urdf(text)
    material = robot.links[0].visuals[0].material
    assert material is not None and material.name == name and material.rgba == rgba


def test_an_undefined_material_with_another_name_has_no_colour() -> None:
    text = ('<robot name="cube"><link name="base"><visual><geometry><box size="1 1 1"/></geometry>'
            '<material name="anodized"/></visual></link></robot>')
    with pytest.warns(UserWarning, match=r"uses material 'anodized', which is not defined$"):
        robot = parse_urdf(text)
    material = robot.links[0].visuals[0].material
    assert material is not None and material.rgba is None
