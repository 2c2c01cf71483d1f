"""Issue 21, the xacro part: the course's Kinetic-era xacro, as the slides write it, expands as
Kinetic's xacro did; every valid modern file expands exactly as PyPI xacro (ROS 2) does.

The oracle is PyPI xacro itself, untouched by tfrec, run in a process of its own
(tests/description/xacro_oracle.py); expansions are compared canonically (C14N 2.0, whitespace-only
text stripped, comments kept). "As Kinetic's xacro did" is checked against the migration xacro 1.13
itself printed with its deprecation warning: the same file with the ``xacro:`` prefixes written out
(:func:`modernize`), expanded by PyPI xacro.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import textwrap
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from tests.conftest import CORPUS, ROBOTS
from tests.description.xacro_suite_cases import CASES, FILES
from tfrec.cli import main
from tfrec.description import load_description, parse_urdf
from tfrec.description.packages import PackageFinder
from tfrec.description.xacro import expand_xacro
from tfrec.errors import DescriptionError, LegacyXacroWarning, TfrecWarning

ORACLE = Path(__file__).with_name("xacro_oracle.py")
XACRO = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
ERD = next((Path(p) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" for p in sys.path
            if (Path(p) / "cmeel.prefix" / "share" / "example-robot-data" / "robots").is_dir()), None)
"""example-robot-data's robots (PyPI), when installed: two hector_description xacros."""


# ---- the oracle and the comparison -------------------------------------------------------------


def oracle(jobs: Sequence[Mapping[str, Any]], *, cwd: Path) -> list[dict[str, str]]:
    """PyPI xacro's expansion of each job (``path``, ``args``, ``packages``), in one process of its own."""
    done = subprocess.run([sys.executable, str(ORACLE)], input=json.dumps(list(jobs)), capture_output=True, text=True,
                          check=True, cwd=cwd, timeout=600)
    results: list[dict[str, str]] = json.loads(done.stdout)
    return results


def canonical(text: str) -> str:
    return ET.canonicalize(text, with_comments=True, strip_text=True)


@dataclass
class Expanded:
    """What tfrec made of a file: the URDF text or the one-line error, and the warnings."""

    text: str | None = None
    error: str | None = None
    warnings: list[warnings.WarningMessage] = field(default_factory=list)

    @property
    def legacy(self) -> list[str]:
        return [str(w.message) for w in self.warnings if issubclass(w.category, LegacyXacroWarning)]


def expand(path: Path, args: Mapping[str, str] | None = None, *, strict: bool = False,
           package_paths: Sequence[Path] = ()) -> Expanded:
    got = Expanded()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            got.text = expand_xacro(path, args=args, finder=PackageFinder(package_paths, near=path), strict=strict,
                                    package_paths=package_paths)
        except DescriptionError as err:
            got.error = str(err)
    got.warnings = list(caught)
    return got


def assert_same(got: Expanded, expected: Mapping[str, str]) -> None:
    """tfrec's expansion is PyPI xacro's: the same document, or an error (one line) where it fails."""
    if "error" in expected:
        assert got.error is not None, f"PyPI xacro fails ({expected['error']}), tfrec gave a document"
        assert "\n" not in got.error
    else:
        assert got.error is None, f"PyPI xacro expands it, tfrec said: {got.error}"
        assert got.text is not None and canonical(got.text) == canonical(expected["text"])


_LEGACY_TAG = re.compile(r"<(/?)(if|unless|include|arg|property|macro|insert_block)\b")


def modernize(text: str, calls: Iterable[str] = ()) -> str:
    """``text`` as xacro 1.13's deprecation warning told its users to fix it (its ``sed`` line: the
    seven tags prefixed), with the legacy calls of ``calls`` prefixed as well."""
    text = _LEGACY_TAG.sub(r"<\1xacro:\2", text)
    for name in calls:
        text = re.sub(rf"<(/?){re.escape(name)}\b", rf"<\1xacro:{name}", text)
    return text


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


def package(root: Path, name: str) -> Path:
    write(root / "package.xml", f"<package format='3'><name>{name}</name></package>\n")
    return root


def packages(*roots: Path) -> dict[str, str]:
    """The packages under ``roots`` (each a package, or a folder of them), by the name their package.xml gives."""
    found: dict[str, str] = {}
    for root in roots:
        for manifest in [root / "package.xml", *sorted(root.glob("*/package.xml"))]:
            if manifest.is_file():
                name = ET.parse(manifest).getroot().findtext("name")
                if name:
                    found.setdefault(name.strip(), str(manifest.parent))
    return found


# ---- 1. every real description: exactly as PyPI xacro ------------------------------------------

UR5E = CORPUS / "ur_description" / "config" / "ur5e"
REAL: dict[str, tuple[Path, dict[str, str], list[Path]]] = {
    f"robots/{p.relative_to(ROBOTS)}": (p, {}, [ROBOTS]) for p in sorted(ROBOTS.rglob("*.xacro"))}
if CORPUS.is_dir():
    REAL.update({f"corpus/{p.relative_to(CORPUS)}": (p, {}, [CORPUS]) for p in sorted(CORPUS.rglob("*.xacro"))})
    REAL["corpus/franka_description/robots/panda/panda.urdf.xacro hand:=true"] = (
        CORPUS / "franka_description/robots/panda/panda.urdf.xacro", {"hand": "true"}, [CORPUS])
    REAL["corpus/ur_description/urdf/ur.xacro robot_model:=ur5e ..."] = (
        CORPUS / "ur_description/urdf/ur.xacro",
        {"robot_model": "ur5e", "joint_limit_params": str(UR5E / "joint_limits.yaml"),
         "kinematics_params": str(UR5E / "default_kinematics.yaml"),
         "physical_params": str(UR5E / "physical_parameters.yaml"),
         "visual_params": str(UR5E / "visual_parameters.yaml"), "safety_limits": "true"}, [CORPUS])
if ERD is not None:
    REAL.update({f"example-robot-data/{p.relative_to(ERD)}": (p, {}, [ERD]) for p in sorted(ERD.rglob("*.xacro"))})
LEGACY_REAL = {"robots/mbot.xacro"}
"""The real descriptions written in the Kinetic-era dialect: the project's own mbot (its wheels and
casters are legacy calls in mbot/mbot_base.xacro, after the course's slides)."""


@pytest.fixture(scope="module")
def real_expected(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, str]]:
    jobs = [{"path": str(path), "args": args, "packages": packages(*paths)} for path, args, paths in REAL.values()]
    return dict(zip(REAL, oracle(jobs, cwd=tmp_path_factory.mktemp("oracle")), strict=True))


def test_the_real_descriptions_are_found() -> None:
    assert {"robots/mbot.xacro", "robots/marm.xacro"} <= set(REAL)
    if CORPUS.is_dir():
        assert sum(name.startswith("corpus/") for name in REAL) >= 50


@pytest.mark.parametrize("name", sorted(REAL))
def test_a_real_description_expands_exactly_as_pypi_xacro(name: str, real_expected: dict[str, dict[str, str]]) -> None:
    """Default and strict expansion both give PyPI xacro's document (or fail where it fails); only a
    description written in the legacy dialect warns, and is expanded in it by default (checked next)."""
    path, args, paths = REAL[name]
    strict = expand(path, args, strict=True, package_paths=paths)
    assert_same(strict, real_expected[name])
    default = expand(path, args, package_paths=paths)
    assert bool(default.legacy) == (name in LEGACY_REAL), default.legacy
    if name not in LEGACY_REAL:
        assert_same(default, real_expected[name])
        assert not strict.legacy


def test_mbot_expands_as_kinetic_did(tmp_path: Path) -> None:
    """robots/mbot.xacro by default is the PyPI expansion of mbot with the prefixes written out."""
    shutil.copytree(ROBOTS, tmp_path / "robots")
    for file in (tmp_path / "robots").rglob("*.xacro"):
        file.write_text(modernize(file.read_text(encoding="utf-8"), calls=["wheel", "caster"]), encoding="utf-8")
    (expected,) = oracle([{"path": str(tmp_path / "robots/mbot.xacro"), "packages": packages(tmp_path / "robots")}],
                         cwd=tmp_path)
    got = expand(ROBOTS / "mbot.xacro", package_paths=[ROBOTS])
    assert_same(got, expected)
    assert "left_wheel_link" in (got.text or "") and "back_caster_link" in (got.text or "")
    assert got.legacy == [("robots/mbot/mbot_base.xacro: the course's Kinetic-era xacro dialect (xacro <= 1.13): "
                          "expanded legacy macro calls without the 'xacro:' prefix: <caster>, <wheel>, as ROS "
                          "Kinetic/Melodic's xacro did (ROS 2's xacro leaves them unexpanded); write the prefix, or "
                          "silence this warning with the warning filter ignore::tfrec.LegacyXacroWarning")]


# ---- 2. xacro's own test suite: exactly as PyPI xacro ------------------------------------------


@pytest.fixture(scope="module")
def suite(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, dict[str, str]]]:
    """The suite's inputs and support files in a folder, and PyPI xacro's results, by case (and
    ``<case>.modern`` for the legacy twin of a case)."""
    folder = tmp_path_factory.mktemp("xacro-suite")
    for name, text in FILES.items():
        write(folder / name, text)
    jobs: dict[str, dict[str, Any]] = {}
    for name, case in CASES.items():
        jobs[name] = {"path": str(write(folder / f"{name}.xacro", case.src)), "args": case.args}
        if case.legacy is not None:
            jobs[f"{name}.modern"] = {"path": str(write(folder / f"{name}.modern.xacro", case.legacy)),
                                      "args": case.args}
    return folder, dict(zip(jobs, oracle(list(jobs.values()), cwd=folder), strict=True))


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_case_of_xacros_test_suite_expands_as_pypi_xacro(name: str, suite: tuple[Path, dict[str, dict[str, str]]],
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """Strict: PyPI xacro's result. Default: the same, or for a case in the legacy dialect (an
    un-prefixed call, ``<include>``) PyPI xacro's result for it with the prefixes written out."""
    folder, expected = suite
    case = CASES[name]
    monkeypatch.chdir(folder)  # $(cwd), and the oracle ran there
    path = folder / f"{name}.xacro"
    strict = expand(path, case.args, strict=True)
    assert_same(strict, expected[name])
    default = expand(path, case.args)
    assert_same(default, expected[f"{name}.modern" if case.legacy is not None else name])
    assert bool(default.legacy) == (case.legacy is not None and "text" in expected[f"{name}.modern"])


def test_the_suites_legacy_cases_are_what_kinetic_did_in_a_robot(suite: tuple[Path, dict[str, dict[str, str]]],
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """xacro 1.13's own expectations, in a robot description: an element named like a macro is a call
    (test_macro_name_clash), also in a namespace (test_include_with_namespace), and an <include>
    holding an element is not an include (test_include_deprecated); in a document of another kind
    (xacro's <a>), PyPI xacro's result."""
    folder, _ = suite
    monkeypatch.chdir(folder)
    clash = expand(folder / "macro_name_clash-robot.xacro")
    assert clash.text is not None and "<bar/>" in clash.text and "<foo" not in clash.text and clash.legacy
    namespaced = expand(folder / "include_with_namespace-robot.xacro")
    assert namespaced.text is not None and "<inc2/>" in namespaced.text and "B.foo" not in namespaced.text
    kept = expand(folder / "include_deprecated.xacro")
    assert kept.text is not None and '<include filename="nada">' in kept.text and not kept.warnings
    other = expand(folder / "macro_name_clash.xacro")
    assert other.text is not None and "<foo/>" in other.text and not other.warnings


# ---- 3. the course's fragments, as the slides write them ---------------------------------------


def course_two_arms(root: Path) -> Path:
    """The slides' two-arm robot (seed 001): a macro in its own file, included and called twice, an
    un-prefixed ``offset`` property, ``M_PI`` for a visual's roll, the whole file in Kinetic's dialect."""
    package(root, "two_arms_description")
    write(root / "urdf/myRobot.xacro", f"""\
        <?xml version="1.0"?>
        <robot {XACRO}>
          <property name="M_PI" value="3.14159"/>
          <macro name="myRobot" params="prefix">
            <link name="${{prefix}}_base_link">
              <visual>
                <origin xyz="0 0 0" rpy="${{M_PI/2}} 0 0"/>
                <geometry><cylinder radius="0.05" length="0.1"/></geometry>
              </visual>
            </link>
          </macro>
        </robot>
        """)
    return write(root / "urdf/two_arms.xacro", f"""\
        <?xml version="1.0"?>
        <robot name="two_arms" {XACRO}>
          <include filename="myRobot.xacro"/>
          <myRobot prefix="left"/>
          <myRobot prefix="right"/>
          <property name="offset" value="1.3"/>
          <link name="world"/>
          <joint name="world_to_left" type="fixed">
            <parent link="world"/>
            <child link="left_base_link"/>
            <origin xyz="${{offset/2}} 0 0" rpy="0 0 0"/>
          </joint>
          <joint name="world_to_right" type="fixed">
            <parent link="world"/>
            <child link="right_base_link"/>
            <origin xyz="${{-offset/2}} 0 0" rpy="0 0 0"/>
          </joint>
        </robot>
        """)


def course_two_arms_slide(root: Path) -> Path:
    """The two-arm slide word for word: ``xacro:include`` and the ``xacro:myRobot`` calls prefixed, the
    ``offset`` property not; ``M_PI`` without the prefix in the included file (the issue's two examples)."""
    package(root, "two_arms_description")
    write(root / "urdf/myRobot.xacro", f"""\
        <?xml version="1.0"?>
        <robot {XACRO}>
          <property name="M_PI" value="3.14159"/>
          <xacro:macro name="myRobot" params="prefix">
            <link name="${{prefix}}_base_link">
              <visual>
                <origin xyz="0 0 0" rpy="${{M_PI/2}} 0 0"/>
                <geometry><box size="0.1 0.1 0.1"/></geometry>
              </visual>
            </link>
          </xacro:macro>
        </robot>
        """)
    return write(root / "urdf/two_arms.xacro", f"""\
        <?xml version="1.0"?>
        <robot name="two_arms" {XACRO}>
          <xacro:include filename="myRobot.xacro"/>
          <xacro:myRobot prefix="left"/>
          <xacro:myRobot prefix="right"/>
          <property name="offset" value="1.3"/>
          <link name="world"/>
          <joint name="world_to_left" type="fixed">
            <parent link="world"/>
            <child link="left_base_link"/>
            <origin xyz="${{offset/2}} 0 0" rpy="0 0 0"/>
          </joint>
          <joint name="world_to_right" type="fixed">
            <parent link="world"/>
            <child link="right_base_link"/>
            <origin xyz="${{-offset/2}} 0 0" rpy="0 0 0"/>
          </joint>
        </robot>
        """)


def course_mbot(root: Path) -> Path:
    """The slides' mbot_description: the property list, inertia, wheel and caster macros and the base
    macro that calls them, all without the prefix, included with ``$(find)``."""
    package(root, "mbot_description")
    write(root / "urdf/xacro/mbot_base.xacro", f"""\
        <?xml version="1.0"?>
        <robot {XACRO}>
          <!-- PROPERTY LIST -->
          <property name="M_PI" value="3.1415926"/>
          <property name="base_radius" value="0.20"/>
          <property name="base_length" value="0.16"/>
          <property name="wheel_radius" value="0.06"/>
          <property name="wheel_length" value="0.025"/>
          <property name="wheel_joint_y" value="0.19"/>
          <property name="wheel_joint_z" value="0.05"/>
          <property name="caster_radius" value="0.015"/>
          <property name="caster_joint_x" value="0.18"/>

          <macro name="cylinder_inertial_matrix" params="m r h">
            <inertial>
              <mass value="${{m}}"/>
              <inertia ixx="${{m*(3*r*r+h*h)/12}}" ixy="0" ixz="0" iyy="${{m*(3*r*r+h*h)/12}}" iyz="0"
                       izz="${{m*r*r/2}}"/>
            </inertial>
          </macro>

          <!-- Macro for robot wheel -->
          <macro name="wheel" params="prefix reflect">
            <joint name="${{prefix}}_wheel_joint" type="continuous">
              <origin xyz="0 ${{reflect*wheel_joint_y}} ${{-wheel_joint_z}}" rpy="0 0 0"/>
              <parent link="base_link"/>
              <child link="${{prefix}}_wheel_link"/>
              <axis xyz="0 1 0"/>
            </joint>
            <link name="${{prefix}}_wheel_link">
              <visual>
                <origin xyz="0 0 0" rpy="${{M_PI/2}} 0 0"/>
                <geometry><cylinder radius="${{wheel_radius}}" length="${{wheel_length}}"/></geometry>
              </visual>
              <cylinder_inertial_matrix m="0.2" r="${{wheel_radius}}" h="${{wheel_length}}"/>
            </link>
          </macro>

          <macro name="caster" params="prefix reflect">
            <joint name="${{prefix}}_caster_joint" type="fixed">
              <origin xyz="${{reflect*caster_joint_x}} 0 ${{-(base_length/2 + caster_radius)}}" rpy="0 0 0"/>
              <parent link="base_link"/>
              <child link="${{prefix}}_caster_link"/>
            </joint>
            <link name="${{prefix}}_caster_link">
              <visual><geometry><sphere radius="${{caster_radius}}"/></geometry></visual>
            </link>
          </macro>

          <macro name="mbot_base">
            <link name="base_footprint"/>
            <joint name="base_footprint_joint" type="fixed">
              <origin xyz="0 0 ${{base_length/2 + caster_radius*2}}" rpy="0 0 0"/>
              <parent link="base_footprint"/>
              <child link="base_link"/>
            </joint>
            <link name="base_link">
              <visual>
                <origin xyz=" 0 0 0" rpy="0 0 0"/>
                <geometry><cylinder length="${{base_length}}" radius="${{base_radius}}"/></geometry>
                <material name="yellow"><color rgba="1 0.4 0 1"/></material>
              </visual>
            </link>
            <wheel prefix="left" reflect="-1"/>
            <wheel prefix="right" reflect="1"/>
            <caster prefix="front" reflect="-1"/>
            <caster prefix="back" reflect="1"/>
          </macro>
        </robot>
        """)
    return write(root / "urdf/xacro/mbot.xacro", f"""\
        <?xml version="1.0"?>
        <robot name="mbot" {XACRO}>
          <include filename="$(find mbot_description)/urdf/xacro/mbot_base.xacro"/>
          <mbot_base/>
        </robot>
        """)


def course_options(root: Path) -> Path:
    """``<arg>``, ``<if>``, ``<unless>``, a property block and ``<insert_block>``, all without the prefix;
    and the slides' generic macro ``name`` called as ``<name A= B= C=/>``."""
    return write(root / "options.xacro", f"""\
        <?xml version="1.0"?>
        <robot name="options" {XACRO}>
          <arg name="use_camera" default="false"/>
          <property name="camera_pose"><origin xyz="0.1 0 0.2" rpy="0 0 0"/></property>
          <xacro:macro name="name" params="A B C">
            <link name="${{A}}_${{B}}_${{C}}"/>
            <joint name="to_${{A}}" type="fixed"><parent link="base"/><child link="${{A}}_${{B}}_${{C}}"/></joint>
          </xacro:macro>
          <link name="base"/>
          <name A="A_value" B="B_value" C="C_value"/>
          <if value="$(arg use_camera)">
            <link name="camera_link"/>
            <joint name="camera_joint" type="fixed">
              <insert_block name="camera_pose"/>
              <parent link="base"/><child link="camera_link"/>
            </joint>
          </if>
          <unless value="$(arg use_camera)">
            <link name="no_camera"/>
            <joint name="no_camera_joint" type="fixed"><parent link="base"/><child link="no_camera"/></joint>
          </unless>
        </robot>
        """)


def course_marm(root: Path) -> Path:
    """marm's link0 as the slides write it: a macro defined with the prefix, called without it."""
    return write(root / "marm.xacro", f"""\
        <?xml version="1.0"?>
        <robot name="marm" {XACRO}>
          <xacro:property name="link0_radius" value="0.05"/>
          <xacro:property name="link0_length" value="0.04"/>
          <xacro:property name="link0_mass" value="1"/>
          <xacro:macro name="cylinder_inertial_matrix" params="m r h">
            <inertial><mass value="${{m}}"/>
              <inertia ixx="${{m*(3*r*r+h*h)/12}}" ixy="0" ixz="0" iyy="${{m*(3*r*r+h*h)/12}}" iyz="0"
                       izz="${{m*r*r/2}}"/></inertial>
          </xacro:macro>
          <link name="link0">
            <visual>
              <origin xyz="0 0 0" rpy="0 0 0"/>
              <geometry><cylinder radius="${{link0_radius}}" length="${{link0_length}}"/></geometry>
            </visual>
            <cylinder_inertial_matrix m="${{link0_mass}}" r="${{link0_radius}}" h="${{link0_length}}"/>
          </link>
        </robot>
        """)


COURSE = {
    "two_arms": (course_two_arms, ["myRobot"], {}),
    "two_arms as on the slide": (course_two_arms_slide, [], {}),
    "mbot": (course_mbot, ["mbot_base", "wheel", "caster", "cylinder_inertial_matrix"], {}),
    "options": (course_options, ["name"], {}),
    "options use_camera:=true": (course_options, ["name"], {"use_camera": "true"}),
    "marm": (course_marm, ["cylinder_inertial_matrix"], {}),
}


@pytest.mark.parametrize("name", sorted(COURSE))
def test_the_courses_fragments_expand_as_kinetic_did(name: str, tmp_path: Path) -> None:
    """Each fragment gives what PyPI xacro gives for it with the prefixes written out, with one warning."""
    make, calls, args = COURSE[name]
    legacy = make(tmp_path / "legacy")
    modern = make(tmp_path / "modern")
    for file in (tmp_path / "modern").rglob("*.xacro"):
        file.write_text(modernize(file.read_text(encoding="utf-8"), calls), encoding="utf-8")
    (expected,) = oracle([{"path": str(modern), "args": args, "packages": packages(tmp_path / "modern")}],
                         cwd=tmp_path)
    assert "text" in expected, expected
    got = expand(legacy, args, package_paths=[tmp_path / "legacy"])
    assert_same(got, expected)
    assert len(got.legacy) == 1, got.legacy


def test_the_slides_offset_and_m_pi_properties(tmp_path: Path) -> None:
    """The issue's example: '<property name="offset" value="1.3"/>' was "name 'offset' is not defined"."""
    with pytest.warns(LegacyXacroWarning, match=r"two_arms\.xacro, \S*myRobot\.xacro: the course's Kinetic-era xacro "
                                                r"dialect \(xacro <= 1\.13\): expanded legacy tags and macro calls "
                                                r"without the 'xacro:' prefix: <include>, <macro>, <property>; calls "
                                                r"of <myRobot>"):
        robot = load_description(course_two_arms(tmp_path))
    assert sorted(link.name for link in robot.links) == ["left_base_link", "right_base_link", "world"]
    assert robot.joint_by_name["world_to_left"].origin.xyz == pytest.approx((0.65, 0, 0))
    assert robot.joint_by_name["world_to_right"].origin.xyz == pytest.approx((-0.65, 0, 0))
    assert robot.link_by_name["left_base_link"].visuals[0].origin.rpy == pytest.approx((3.14159 / 2, 0, 0))


def test_the_course_mbot_has_its_wheels_and_casters(tmp_path: Path) -> None:
    top = course_mbot(tmp_path / "mbot_description")
    with pytest.warns(LegacyXacroWarning) as caught:
        robot = load_description(top, package_paths=[tmp_path])
    assert len(caught) == 1
    message = str(caught[0].message)
    assert "mbot_base.xacro" in message and "mbot.xacro" in message
    assert "<include>, <macro>, <property>; calls of <caster>, <cylinder_inertial_matrix>, <mbot_base>, <wheel>" \
        in message
    assert {link.name for link in robot.links} == {"base_footprint", "base_link", "left_wheel_link",
                                                   "right_wheel_link", "front_caster_link", "back_caster_link"}
    assert robot.link_by_name["left_wheel_link"].mass == pytest.approx(0.2)
    assert robot.joint_by_name["left_wheel_joint"].origin.xyz == pytest.approx((0, -0.19, -0.05))


def test_a_legacy_property_used_before_it_is_defined_says_so(tmp_path: Path) -> None:
    """Kinetic's default (not --inorder) read every property first; xacro since Melodic, and tfrec,
    read in order (the course's launch files ask for --inorder): the message says where it is."""
    f = write(tmp_path / "late.xacro", f"""\
        <robot name="late" {XACRO}>
          <link name="a"><visual><geometry><box size="${{size}} 1 1"/></geometry></visual></link>
          <property name="size" value="2"/>
        </robot>
        """)
    with pytest.raises(DescriptionError, match=r"late\.xacro:2: name 'size' is not defined when evaluating "
                                               r"expression 'size' \(it is defined later, at \S*late\.xacro:3: xacro "
                                               r"evaluates in order\)$"):
        load_description(f)


def test_strict_xacro_says_an_undefined_name_is_a_legacy_property(tmp_path: Path) -> None:
    f = write(tmp_path / "p.xacro", f"""\
        <robot name="p" {XACRO}>
          <property name="offset" value="1.3"/>
          <link name="a"><visual><origin xyz="${{offset/2}} 0 0"/><geometry><box size="1 1 1"/></geometry></visual>
          </link>
        </robot>
        """)
    with pytest.raises(DescriptionError, match=r"p\.xacro:3: name 'offset' is not defined when evaluating expression "
                                               r"'offset/2' \(<property name=\"offset\"> at \S*p\.xacro:2 is the "
                                               r"Kinetic-era dialect, which `strict_xacro` leaves unexpanded\)$"):
        load_description(f, strict_xacro=True)


def test_legacy_forms_inside_foreign_blocks_are_left_alone(tmp_path: Path) -> None:
    """SDF's <include><uri>, and anything in <gazebo>, <ros2_control>, <transmission>, <sensor> — also
    when a macro or an included file puts it there — is somebody else's, as in PyPI xacro."""
    write(tmp_path / "plugin.xacro", f"""\
        <robot {XACRO}>
          <arg name="ns" default="robot"/><property name="rate" value="10"/>
        </robot>
        """)
    f = write(tmp_path / "g.xacro", f"""\
        <robot name="g" {XACRO}>
          <xacro:macro name="sdf_args"><arg name="rate" default="5"/><if value="1"><tag/></if></xacro:macro>
          <xacro:macro name="plugin"><p/></xacro:macro>
          <link name="base"/>
          <gazebo><include><uri>model://sun</uri></include><include filename="world.sdf"/></gazebo>
          <gazebo reference="base"><xacro:sdf_args/><plugin name="p" filename="libp.so"/></gazebo>
          <gazebo><xacro:include filename="plugin.xacro"/></gazebo>
          <ros2_control name="c" type="system"><property name="x" value="1"/></ros2_control>
        </robot>
        """)
    (expected,) = oracle([{"path": str(f)}], cwd=tmp_path)
    got = expand(f)
    assert_same(got, expected)
    assert not got.legacy
    root = ET.fromstring(got.text or "")
    assert root.find("gazebo/include[@filename='world.sdf']") is not None
    assert root.find("gazebo/arg[@name='rate']") is not None and root.find("gazebo/if/tag") is not None
    assert root.find("gazebo/property[@name='rate']") is not None and root.find("ros2_control/property") is not None


@pytest.mark.parametrize(("flag", "links"), [("--inorder", {"base", "left_wheel"}), ("--xacro-ns", {"base"})])
def test_a_launch_files_xacro_flags_choose_the_dialect(tmp_path: Path, flag: str, links: set[str]) -> None:
    """The course's launch files run `xacro --inorder`; xacro 1.13's --xacro-ns required the prefix and
    left un-prefixed tags alone, which is `strict_xacro`."""
    pkg = package(tmp_path / "src" / "wheel_robot", "wheel_robot")
    write(pkg / "urdf/robot.xacro", f"""\
        <robot name="r" {XACRO}>
          <xacro:macro name="wheel" params="prefix"><link name="${{prefix}}_wheel"/>
            <joint name="${{prefix}}_joint" type="fixed"><parent link="base"/><child link="${{prefix}}_wheel"/></joint>
          </xacro:macro>
          <link name="base"/>
          <wheel prefix="left"/>
        </robot>
        """)
    launch = write(pkg / "launch/view.launch", f"""\
        <launch>
          <param name="robot_description" command="$(find xacro)/xacro {flag} $(find wheel_robot)/urdf/robot.xacro"/>
        </launch>
        """)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = load_description(launch, package_paths=[tmp_path / "src"])
    assert {link.name for link in robot.links} == links
    legacy = [str(w.message) for w in caught if issubclass(w.category, LegacyXacroWarning)]
    assert len(legacy) == 1 and (("left legacy macro calls" in legacy[0]) == (flag == "--xacro-ns"))


def test_a_legacy_include_is_confined_as_any_include(tmp_path: Path) -> None:
    """The sandbox refuses an un-prefixed <include> of a file outside the description's places, as it
    refuses <xacro:include>: the legacy dialect is expanded by the same, sandboxed, xacro."""
    f = write(tmp_path / "ws/robot.xacro", f"""\
        <robot name="r" {XACRO}>
          <include filename="/etc/passwd"/>
          <link name="a"/>
        </robot>
        """)
    with pytest.raises(DescriptionError, match=r"robot\.xacro: <xacro:include filename=\"/etc/passwd\"> refused") \
            as info:
        load_description(f)
    assert "root:" not in str(info.value)


# ---- 4. valid modern files that look like legacy: exactly as PyPI xacro ------------------------

MODERN = {
    "cylinder": """<xacro:macro name="cylinder" params="radius:=0.1 length:=0.2">
          <cylinder radius="${radius}" length="${length}"/></xacro:macro>
        <link name="a"><visual><geometry><xacro:cylinder/></geometry></visual>
          <collision><geometry><cylinder radius="1" length="2"/></geometry></collision></link>""",
    "origin": """<xacro:macro name="origin" params="xyz:='0 0 0' rpy:='0 0 0'"><origin xyz="${xyz}" rpy="${rpy}"/>
        </xacro:macro>
        <link name="a"><visual><origin xyz="1 2 3"/><geometry><box size="1 1 1"/></geometry></visual></link>
        <link name="b"/><joint name="j" type="fixed"><parent link="a"/><child link="b"/><xacro:origin xyz="0 0 1"/>
        </joint>""",
    "material": """<xacro:macro name="material" params="name:=grey"><material name="${name}"><color rgba="1 1 1 1"/>
        </material></xacro:macro>
        <material name="red"><color rgba="1 0 0 1"/></material><xacro:material/>
        <link name="a"><visual><geometry><box size="1 1 1"/></geometry><material name="red"/></visual></link>""",
    "box": """<xacro:macro name="box" params="size:='1 1 1'"><box size="${size}"/></xacro:macro>
        <link name="a"><visual><geometry><box size="2 2 2"/></geometry></visual>
          <collision><geometry><xacro:box/></geometry></collision></link>""",
    "mesh": """<xacro:macro name="mesh" params="file:=m.stl"><mesh filename="package://p/${file}"/></xacro:macro>
        <link name="a"><visual><geometry><mesh filename="package://p/n.stl" scale="2 2 2"/></geometry></visual>
          <collision><geometry><xacro:mesh/></geometry></collision></link>""",
    "link": """<xacro:macro name="link" params="name:=extra"><link name="${name}"/></xacro:macro>
        <link name="a"/><xacro:link/><joint name="j" type="fixed"><parent link="a"/><child link="extra"/></joint>""",
    "joint": """<xacro:macro name="joint" params="name:=j parent:=a child:=b"><joint name="${name}" type="fixed">
          <parent link="${parent}"/><child link="${child}"/></joint></xacro:macro>
        <link name="a"/><link name="b"/><link name="c"/><xacro:joint/>
        <joint name="k" type="fixed"><parent link="b"/><child link="c"/></joint>""",
    "nested": """<xacro:macro name="box" params="size:=1"><box size="${size} ${size} ${size}"/></xacro:macro>
        <xacro:macro name="visual_box" params="size:=2"><visual><origin xyz="0 0 0"/>
          <geometry><box size="${size} 1 1"/></geometry></visual></xacro:macro>
        <link name="a"><xacro:visual_box/></link>""",
    "if-in-macro": """<xacro:macro name="geometry" params="round:=true"><geometry>
          <xacro:if value="${round}"><sphere radius="1"/></xacro:if>
          <xacro:unless value="${round}"><box size="1 1 1"/></xacro:unless></geometry></xacro:macro>
        <link name="a"><visual><xacro:geometry/></visual><collision><geometry><box size="2 2 2"/></geometry>
          </collision></link>""",
    "origin-block": """<xacro:macro name="fixed" params="child *origin"><link name="${child}"/>
          <joint name="${child}_joint" type="fixed"><parent link="a"/><child link="${child}"/>
          <xacro:insert_block name="origin"/></joint></xacro:macro>
        <link name="a"/><xacro:fixed child="b"><origin xyz="1 0 0"/></xacro:fixed>""",
    "self-named": """<xacro:macro name="tire" params="width:=0.1"><link name="t"><tire width="${width}"/></link>
        </xacro:macro><xacro:tire/>""",
}


@pytest.fixture(scope="module")
def modern(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, dict[str, str]]]:
    folder = tmp_path_factory.mktemp("modern")
    paths = {name: write(folder / f"{name}.xacro", f'<robot name="r" {XACRO}>\n{body}\n</robot>\n')
             for name, body in MODERN.items()}
    return folder, dict(zip(MODERN, oracle([{"path": str(p)} for p in paths.values()], cwd=folder), strict=True))


@pytest.mark.parametrize("name", sorted(MODERN))
def test_a_macro_named_like_a_urdf_element_never_rewrites_modern_xacro(
        name: str, modern: tuple[Path, dict[str, dict[str, str]]]) -> None:
    """A macro named cylinder, origin, material, box, mesh, link or joint (all parameters defaulted, so
    that an ordinary element of that name would fit a call), macros writing elements named like macros,
    xacro:if in macro bodies, a block named origin, and an element named like the macro that writes it:
    tfrec's document is PyPI xacro's, no legacy warning, also with `strict_xacro`."""
    folder, expected = modern
    for strict in (False, True):
        got = expand(folder / f"{name}.xacro", strict=strict)
        assert_same(got, expected[name])
        assert not got.legacy
        assert "text" in expected[name]


# ---- 5. messages for typos ---------------------------------------------------------------------


def test_an_undefined_property_suggests_the_closest_defined(tmp_path: Path) -> None:
    f = write(tmp_path / "t.xacro", f"""\
        <robot name="t" {XACRO}>
          <xacro:property name="link1_length" value="0.5"/>
          <link name="link1"><visual><geometry><box size="${{link1_lenght}} 1 1"/></geometry></visual></link>
        </robot>
        """)
    with pytest.raises(DescriptionError, match=r"t\.xacro:3: name 'link1_lenght' is not defined when evaluating "
                                               r"expression 'link1_lenght' \(did you mean 'link1_length'\?\)$"):
        load_description(f)


def test_an_undefined_macro_suggests_the_closest_defined(tmp_path: Path) -> None:
    write(tmp_path / "parts.xacro", f"""\
        <robot {XACRO}>
          <xacro:macro name="arm_link" params="name"><link name="${{name}}"/></xacro:macro>
        </robot>
        """)
    f = write(tmp_path / "m.xacro", f"""\
        <robot name="m" {XACRO}>
          <xacro:include filename="parts.xacro"/>
          <xacro:arm_lnk name="a"/>
        </robot>
        """)
    with pytest.raises(DescriptionError, match=r"m\.xacro:3: unknown macro 'arm_lnk' \(did you mean 'arm_link'\?\)$"):
        load_description(f)


def test_an_undefined_link_suggests_the_closest_and_names_the_xacro_line(tmp_path: Path) -> None:
    f = write(tmp_path / "l.xacro", f"""\
        <robot name="l" {XACRO}>
          <xacro:macro name="arm" params="n"><link name="link${{n}}"/></xacro:macro>
          <xacro:arm n="1"/>
          <xacro:arm n="2"/>
          <joint name="j" type="fixed">
            <parent link="lnk1"/><child link="link2"/>
          </joint>
        </robot>
        """)
    with pytest.raises(DescriptionError, match=r"l\.xacro:5: joint 'j' names unknown parent link 'lnk1' "
                                               r"\(did you mean 'link1'\?\)$"):
        load_description(f)


def test_a_missing_macro_parameter_names_the_call_in_an_included_file(tmp_path: Path) -> None:
    """The call is in a macro body of an included file: its own file and line are named."""
    write(tmp_path / "inc/parts.xacro", f"""\
        <robot {XACRO}>
          <xacro:macro name="wheel" params="prefix radius">
            <link name="${{prefix}}_wheel"/>
          </xacro:macro>
          <xacro:macro name="two_wheels">
            <xacro:wheel prefix="left" radius="1"/>
            <wheel prefix="right"/>
          </xacro:macro>
        </robot>
        """)
    f = write(tmp_path / "top.xacro", f"""\
        <robot name="top" {XACRO}>
          <xacro:include filename="inc/parts.xacro"/>
          <link name="base"/>
          <xacro:two_wheels/>
        </robot>
        """)
    with pytest.raises(DescriptionError, match=r"^\S*inc/parts\.xacro:7: the call of macro 'wheel' lacks parameter "
                                               r"'radius' \(the macro is defined at \S*inc/parts\.xacro:2\)$"), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore", LegacyXacroWarning)
        load_description(f)


def test_a_misspelled_macro_parameter_suggests_the_closest(tmp_path: Path) -> None:
    f = write(tmp_path / "p.xacro", f"""\
        <robot name="p" {XACRO}>
          <xacro:macro name="wheel" params="prefix radius"><link name="${{prefix}}"/></xacro:macro>
          <xacro:wheel prefix="left" radus="1"/>
        </robot>
        """)
    with pytest.raises(DescriptionError, match=r"p\.xacro:3: the call of macro 'wheel' gives parameter 'radus', "
                                               r"which it does not have \(did you mean 'radius'\?\)$"):
        load_description(f)


def test_a_mimic_of_a_misspelled_joint_suggests_the_closest() -> None:
    text = ('<robot name="g"><link name="a"/><link name="b"/><link name="c"/>'
            '<joint name="f1" type="prismatic"><parent link="a"/><child link="b"/>'
            '<limit lower="0" upper="1" effort="1" velocity="1"/></joint>'
            '<joint name="f2" type="prismatic"><parent link="a"/><child link="c"/>'
            '<mimic joint="f11"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint></robot>')
    with pytest.warns(UserWarning, match=r"joint 'f2' mimics unknown joint 'f11' \(did you mean 'f1'\?\)"):
        parse_urdf(text)


# ---- 6. the warning: once, a tfrec category, silenced by filter or --quiet-legacy ---------------


def test_the_legacy_warning_is_one_tfrec_warning_per_expansion() -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_description(ROBOTS / "mbot.xacro")
    legacy = [w for w in caught if issubclass(w.category, LegacyXacroWarning)]
    assert len(legacy) == 1 and len(caught) == 1
    assert issubclass(LegacyXacroWarning, TfrecWarning) and issubclass(TfrecWarning, UserWarning)
    assert "Kinetic-era" in str(legacy[0].message)


def test_warnings_as_errors_setups_filter_it_by_category() -> None:
    import tfrec

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(tfrec.LegacyXacroWarning):
            load_description(ROBOTS / "mbot.xacro")
        warnings.filterwarnings("ignore", category=tfrec.LegacyXacroWarning)
        assert len(load_description(ROBOTS / "mbot.xacro").links) == 7


def test_make_demo_prints_one_legacy_warning(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`make demo` records robots/mbot.xacro: one warning, saying what it is and how to silence it."""
    out = tmp_path / "mbot.mcap"
    assert main(["record", str(ROBOTS / "mbot.xacro"), "--traj", "sine", "-o", str(out), "--no-rrd",
                 "--duration", "0.2"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("tfrec: warning: robots/mbot/mbot_base.xacro: the course's Kinetic-era xacro dialect "
                             "(xacro <= 1.13): expanded legacy macro calls")
    assert err[0].endswith("write the prefix, or silence this warning with --quiet-legacy")
    assert main(["record", str(ROBOTS / "mbot.xacro"), "--traj", "sine", "-o", str(out), "--no-rrd",
                 "--duration", "0.2", "--force", "--quiet-legacy"]) == 0
    assert capsys.readouterr().err == ""
