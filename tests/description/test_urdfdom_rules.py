"""Issue 22: a URDF ROS 1 cannot load is refused as urdfdom 3.0.1 (Debian's ROS 1) refuses it; what urdfdom loads,
tfrec loads — a broken visual or inertial left out with a warning — except what has no defined motion. Each bad
input is built here; tests/interop compares the same cases with real check_urdf."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from tfrec.cli import main
from tfrec.description import load_description, parse_urdf
from tfrec.errors import DescriptionError
from tfrec.trajectory import make_trajectory

TWO = '<link name="a"/><link name="b"/>'
LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'


def _joint(jtype: str, inside: str) -> str:
    return f'<robot name="r">{TWO}<joint name="j" type="{jtype}"><parent link="a"/><child link="b"/>{inside}</joint></robot>'


def _quiet(text: str) -> object:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return parse_urdf(text, source="r.urdf")


# -- what urdfdom refuses ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("jtype, limit, attr", [
    ("revolute", '<limit lower="-1" upper="1" velocity="1"/>', "effort"),
    ("revolute", '<limit lower="-1" upper="1" effort="1"/>', "velocity"),
    ("prismatic", '<limit lower="-1" upper="1"/>', "effort"),
    ("continuous", '<limit velocity="1"/>', "effort"),
    ("continuous", '<limit effort="1"/>', "velocity"),
    ("fixed", "<limit/>", "effort"),
    ("floating", '<limit effort="2"/>', "velocity"),
])
def test_a_limit_without_effort_or_velocity_is_refused_on_any_joint(jtype: str, limit: str, attr: str) -> None:
    """check_urdf: "joint limit: no effort"; robot_state_publisher dies at start on such a URDF."""
    with pytest.raises(DescriptionError, match=rf"^r\.urdf:1: joint 'j' <limit> has no '{attr}': urdfdom 3\.0\.1 "
                                               rf"\(check_urdf, robot_state_publisher\) refuses it "
                                               rf"\(\"joint limit: no {attr}\"\)$"):
        parse_urdf(_joint(jtype, limit), source="r.urdf")


@pytest.mark.parametrize("inside, message", [
    (LIMIT + '<safety_controller soft_lower_limit="-0.5"/>',
     r"joint 'j' <safety_controller> has no 'k_velocity': urdfdom 3\.0\.1 .*\"joint safety: no k_velocity\""),
    (LIMIT + '<safety_controller k_velocity="1" k_position="x"/>',
     r"joint 'j' safety_controller: malformed k_position=\"x\""),
    (LIMIT + '<dynamics damping="x"/>', r"joint 'j' dynamics: malformed damping=\"x\""),
    (LIMIT + '<dynamics friction="1 2"/>', r"joint 'j' dynamics: malformed friction=\"1 2\""),
    (LIMIT + '<calibration rising="nan"/>', r"joint 'j' calibration: malformed rising=\"nan\""),
])
def test_malformed_joint_elements_urdfdom_reads_are_refused(inside: str, message: str) -> None:
    """tfrec does not use <dynamics>, <calibration> or k_velocity, but urdfdom reads them and refuses the joint."""
    with pytest.raises(DescriptionError, match=rf"^r\.urdf:1: {message}"):
        parse_urdf(_joint("revolute", inside), source="r.urdf")


def test_a_material_defined_twice_is_refused_even_when_equal() -> None:
    text = ('<robot name="r"><material name="m"><color rgba="1 0 0 1"/></material>\n'
            '<material name="m"><color rgba="1 0 0 1"/></material><link name="a"/></robot>')
    with pytest.raises(DescriptionError, match=r"^r\.urdf:2: material 'm' is defined twice: urdfdom 3\.0\.1 \(check_urdf, "
                                               r"robot_state_publisher\) refuses it \(\"material 'm' is not unique\.\"\)$"):
        parse_urdf(text, source="r.urdf")


@pytest.mark.parametrize("version, reason", [
    ("2.0", "Invalid 'version' specified; only version 1.0 is currently supported"),
    ("1.2", "Invalid 'version' specified; only version 1.0 is currently supported"),
    ("1", "The version attribute should be in the form 'x.y'"),
    ("1.0.0", "The version attribute should be in the form 'x.y'"),
    ("1.", "The version attribute should be in the form 'x.y'"),
    ("", "The version attribute should be in the form 'x.y'"),
    (".0", "One of the fields of the version attribute is blank"),
    ("a.b", "Version attribute is not an integer"),
    ("1.0x", "Extra characters after the version number"),
    ("1.0 ", "Extra characters after the version number"),
    ("-1.0", "Version number must be positive"),
])
def test_a_version_urdfdom_refuses_is_refused_with_its_reason(version: str, reason: str) -> None:
    with pytest.raises(DescriptionError) as info:
        parse_urdf(f'<robot name="r" version="{version}"><link name="a"/></robot>', source="r.urdf")
    assert str(info.value) == (f'r.urdf:1: <robot version="{version}">: urdfdom 3.0.1 (check_urdf, '
                               f'robot_state_publisher) refuses it ("{reason}")')


@pytest.mark.parametrize("version", ["1.0", "01.0", "+1.0", "1.-0", " 1. 0", "4294967297.0"])
def test_what_urdfdom_reads_as_version_1_0_is_read(version: str) -> None:
    """urdfdom reads each field with C's strtol into a uint32: leading blanks, a sign, zeros, even wrapping."""
    _quiet(f'<robot name="r" version="{version}"><link name="a"/></robot>')


def test_version_1_1_is_read_with_a_warning_and_its_quaternions() -> None:
    """urdfdom 3.0.1 refuses 1.1; newer urdfdom (ros/urdfdom#235) reads it, with <origin quat_xyzw>."""
    half = math.sqrt(0.5)
    text = (f'<robot name="r" version="1.1">{TWO}<joint name="j" type="fixed"><parent link="a"/><child link="b"/>'
            f'<origin xyz="1 0 0" quat_xyzw="0 0 {half} {half}"/></joint></robot>')
    with pytest.warns(UserWarning, match=r'^r\.urdf:1: <robot version="1\.1">: urdfdom 3\.0\.1 \(ROS 1\'s check_urdf and '
                                         r'robot_state_publisher\) refuses it .*newer urdfdom .* reads URDF 1\.1'):
        robot = parse_urdf(text, source="r.urdf")
    assert robot.joint_by_name["j"].origin.rpy == pytest.approx((0.0, 0.0, math.pi / 2))
    with pytest.warns(UserWarning, match="version"), pytest.raises(DescriptionError, match="both rpy and quat_xyzw"):
        parse_urdf(text.replace('quat_xyzw=', 'rpy="0 0 0" quat_xyzw='), source="r.urdf")
    # in a 1.0 document quat_xyzw is an unknown attribute, ignored as urdfdom 3.0.1 ignores it
    plain = parse_urdf(text.replace(' version="1.1"', ""), source="r.urdf")
    assert plain.joint_by_name["j"].origin.rpy == (0.0, 0.0, 0.0)


# -- what urdfdom loads ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("visual, problem", [
    ("<geometry><box/></geometry>", r"link 'a' visual 0 box has no 'size'"),
    ('<geometry><box size="1 1"/></geometry>', r"link 'a' visual 0 box: malformed size=\"1 1\""),
    ("<geometry><mesh/></geometry>", r"link 'a' visual 0 mesh has no filename"),
    ('<geometry><mesh filename="m.stl" scale="1 1"/></geometry>', r"link 'a' visual 0 mesh: malformed scale"),
    ('<geometry><cylinder length="1"/></geometry>', r"link 'a' visual 0 cylinder has no 'radius'"),
    ("<geometry/>", r"link 'a' visual 0 <geometry> is empty"),
    ('<geometry><capsule radius="1" length="1"/></geometry>', r"link 'a' visual 0 has unknown geometry <capsule>"),
    ("", r"link 'a' visual 0 has no <geometry>"),
    ('<origin xyz="1 2"/><geometry><sphere radius="1"/></geometry>', r"link 'a' visual 0 origin: malformed xyz"),
])
def test_a_broken_visual_is_left_out_with_a_warning_and_tf_is_recorded(tmp_path: Path, visual: str, problem: str,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """urdfdom 3.0.1 logs "Could not parse visual element" and loads the link; robot_state_publisher runs."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text(f'<robot name="r">\n<link name="a"><visual>{visual}</visual>'
                    '<visual><geometry><sphere radius="0.5"/></geometry></visual></link>\n<link name="b"/>\n'
                    f'<joint name="j" type="revolute"><parent link="a"/><child link="b"/>{LIMIT}</joint>\n</robot>\n')
    with pytest.warns(UserWarning, match=rf"r\.urdf:2: {problem}.*: the visual is left out, as urdfdom 3\.0\.1 leaves "
                                         r"it out \(TF is not affected\)$"):
        robot = load_description(urdf)
    assert [type(v.geometry).__name__ for v in robot.link_by_name["a"].visuals] == ["Sphere"]
    out = tmp_path / "r.mcap"
    assert main(["record", str(urdf), "-o", str(out), "--no-rrd", "--duration", "1"]) == 0
    assert "the visual is left out" in capsys.readouterr().err and out.stat().st_size > 0


@pytest.mark.parametrize("collision, problem", [
    ("<geometry><sphere/></geometry>", r"link 'a' collision 0 sphere has no 'radius'"),
    ('<geometry><sphere radius="x"/></geometry>', r"link 'a' collision 0 sphere: malformed radius"),
    ("<geometry><box/></geometry>", r"link 'a' collision 0 box has no 'size'"),
    ('<geometry><box size="1 1"/></geometry>', r"link 'a' collision 0 box: malformed size=\"1 1\""),
    ("<geometry><mesh/></geometry>", r"link 'a' collision 0 mesh has no filename"),
    ('<geometry><mesh filename="m.stl" scale="1 q 1"/></geometry>', r"link 'a' collision 0 mesh: malformed scale"),
    ('<geometry><cylinder radius="1"/></geometry>', r"link 'a' collision 0 cylinder has no 'length'"),
    ("<geometry/>", r"link 'a' collision 0 <geometry> is empty"),
    ('<geometry><cone radius="1"/></geometry>', r"link 'a' collision 0 has unknown geometry <cone>"),
    ("", r"link 'a' collision 0 has no <geometry>"),
    ('<origin xyz="1 2"/><geometry><sphere radius="1"/></geometry>', r"link 'a' collision 0 origin: malformed xyz"),
])
def test_a_broken_collision_is_left_out_with_a_warning_and_tf_is_recorded(tmp_path: Path, collision: str, problem: str,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """urdfdom 3.0.1 logs "Could not parse collision element for Link [a]" and loads the link (check_urdf succeeds);
    tfrec, which does not use collisions, said nothing. It warns now, naming the link, as for a broken visual."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text(f'<robot name="r">\n<link name="a"><collision>{collision}</collision>'
                    '<collision><geometry><sphere radius="0.5"/></geometry></collision></link>\n<link name="b"/>\n'
                    f'<joint name="j" type="revolute"><parent link="a"/><child link="b"/>{LIMIT}</joint>\n</robot>\n')
    with pytest.warns(UserWarning, match=rf"r\.urdf:2: {problem}.*: the collision is left out, as urdfdom 3\.0\.1 "
                                         r"leaves it out \(TF is not affected\)$") as found:
        robot = load_description(urdf)
    assert len(found) == 1  # the good collision says nothing
    assert [link.name for link in robot.links] == ["a", "b"]
    out = tmp_path / "r.mcap"
    assert main(["record", str(urdf), "-o", str(out), "--no-rrd", "--duration", "1"]) == 0
    assert "the collision is left out" in capsys.readouterr().err and out.stat().st_size > 0


def test_a_malformed_colour_or_mass_is_left_out_with_a_warning() -> None:
    text = ('<robot name="r"><material name="m"><color rgba="1 0"/></material>'
            '<link name="a"><inertial><mass/></inertial><visual><geometry><sphere radius="1"/></geometry>'
            '<material name="v"><color rgba="x 0 0 1"/></material></visual></link></robot>')
    with pytest.warns(UserWarning) as record:
        robot = parse_urdf(text, source="r.urdf")
    messages = [str(w.message) for w in record]
    assert any(m.startswith("r.urdf:1: robot material 'm' color: malformed rgba=\"1 0\"") and
               m.endswith(": the colour is left out, as urdfdom 3.0.1 leaves it out") for m in messages)
    assert any("link 'a' visual 0 material 'v' color: malformed rgba" in m for m in messages)
    assert any(m.startswith("r.urdf:1: link 'a' mass has no 'value'") and
               m.endswith("the inertial is left out, as urdfdom 3.0.1 leaves it out") for m in messages)
    link = robot.link_by_name["a"]
    assert link.mass is None and link.visuals[0].material is not None and link.visuals[0].material.rgba is None


def test_lower_above_upper_is_loaded_with_the_bounds_swapped() -> None:
    """urdfdom and robot_state_publisher load it (joint_state_publisher's range is then empty); tfrec moves the joint
    between the two bounds, with a warning."""
    text = _joint("revolute", '<limit lower="1" upper="-0.5" effort="1" velocity="1"/>')
    with pytest.warns(UserWarning, match=r"^r\.urdf:1: joint 'j' has lower limit 1 above upper limit -0\.5 \(urdfdom "
                                         r"3\.0\.1 loads it\): it moves between -0\.5 and 1$"):
        robot = parse_urdf(text, source="r.urdf")
    limit = robot.joint_by_name["j"].limit
    assert limit is not None and (limit.lower, limit.upper) == (-0.5, 1.0)
    positions = make_trajectory(robot, "sine", duration_s=2.0).positions
    assert positions.min() >= -0.5 and positions.max() <= 1.0 and np.ptp(positions) > 0.5


@pytest.mark.parametrize("declaration", [
    '<?xml verison="1.0"?>', '<?xml?>', '<?xml version=1.0?>', '<?XML version="1.0"?>',
    '<?xml version="1.0" standalone="maybe"?>', '\n  <?xml version="1.0"?>',
])
def test_a_malformed_xml_declaration_is_ignored_as_tinyxml2_ignores_it(declaration: str) -> None:
    """check_urdf reads these (TinyXML2 reads past any <?xml …?>); expat refused them ("XML declaration not
    well-formed"). Line numbers stay the file's own."""
    text = declaration + '\n<robot name="r">\n<link name="a"/>\n<link name="a"/>\n</robot>\n'
    line = declaration.count("\n") + 1
    with pytest.warns(UserWarning, match=rf"^r\.urdf:{line}: XML declaration .* ignored \(.*\), as urdfdom 3\.0\.1 "
                                         r"\(TinyXML2\) ignores it$"), \
            pytest.raises(DescriptionError, match=rf"^r\.urdf:{line + 3}: duplicate link name 'a'$"):
        parse_urdf(text, source="r.urdf")


def test_a_well_formed_declaration_is_read_without_a_word() -> None:
    _quiet('<?xml version="1.0" encoding="UTF-8" standalone="yes"?>\n<robot name="r"><link name="a"/></robot>')
    _quiet('<?xml-stylesheet href="x"?><robot name="r"><link name="a"/></robot>')


# -- what tfrec keeps refusing: no defined motion ----------------------------------------------------------------


@pytest.mark.parametrize("jtype", ["revolute", "prismatic", "continuous", "planar"])
def test_a_zero_axis_is_refused_saying_what_ros_does(jtype: str) -> None:
    """urdfdom loads it; robot_state_publisher publishes NaN for the joint (measured: tests/interop)."""
    with pytest.raises(DescriptionError, match=r"^r\.urdf:1: joint 'j' has a zero axis: it defines no motion \(urdfdom "
                                               r"3\.0\.1 loads it, and robot_state_publisher publishes NaN for it\)$"):
        parse_urdf(_joint(jtype, '<axis xyz="0 0 0"/>' + LIMIT), source="r.urdf")


def test_an_axis_on_a_fixed_or_floating_joint_is_not_read() -> None:
    """urdfdom reads no axis of a fixed or floating joint: a malformed one there is nothing to refuse."""
    for jtype in ("fixed", "floating"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # floating: "it gets no transform"
            robot = parse_urdf(_joint(jtype, '<axis xyz="x y"/>'), source="r.urdf")
        assert robot.joint_by_name["j"].axis == (1.0, 0.0, 0.0)
    with pytest.raises(DescriptionError, match=r"joint 'j' axis: malformed xyz=\"x y\""):
        parse_urdf(_joint("continuous", '<axis xyz="x y"/>'), source="r.urdf")


def test_an_empty_robot_name_is_loaded_with_a_warning(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """urdfdom loads <robot name="">; without a name attribute it refuses (tests/description/test_description.py)."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text('<robot name=""><link name="a"/><link name="b"/>'
                    '<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint></robot>')
    with pytest.warns(UserWarning, match=r'r\.urdf:1: <robot name="">: an empty robot name \(urdfdom 3\.0\.1 loads it\)$'):
        assert load_description(urdf).name == ""
    from tfrec.recorder import default_stem

    with pytest.warns(UserWarning, match="empty robot name"):
        assert default_stem(load_description(urdf), "sine", now=0).startswith("robot-sine-")
