"""URDF text → :class:`tfrec.model.Robot`, with urdfdom's checks and a few more.

Every failure is one :class:`DescriptionError` line naming the file, the line when the text
is the user's own file, and the element: ``arm.urdf:42: joint 'elbow' names unknown parent
link 'uper_arm'``.

The rules follow :data:`URDFDOM`, the urdfdom Debian's ROS 1 loads URDFs with (check_urdf,
robot_state_publisher): what it refuses, tfrec refuses, saying what urdfdom would say; what it
loads, tfrec loads, except what has no defined motion (a zero axis, mimic joints in a cycle, a
link without a name). A broken visual, collision or inertial never stops TF: urdfdom leaves it out
with an error message and so does tfrec, with a warning. docs/ros-parity.md lists each difference.
"""

from __future__ import annotations

import math
import re
import warnings
import xml.etree.ElementTree as ET
import xml.parsers.expat
from collections.abc import Callable, Sequence

from tfrec.errors import DescriptionError, TfrecWarning, display_path, suggest
from tfrec.model import (
    Box,
    Cylinder,
    Geometry,
    Joint,
    JointType,
    Limit,
    Link,
    Material,
    Mesh,
    Mimic,
    MimicCycle,
    Pose,
    Robot,
    SafetyController,
    Sphere,
    Visual,
    mimic_levels,
)

__all__ = ["COMMON_COLOURS", "URDFDOM", "parse_urdf", "parse_xml_with_lines"]

URDFDOM = "urdfdom 3.0.1"
"""The urdfdom whose rules :func:`parse_urdf` follows: Debian's liburdfdom 3.0.1, which Debian's ROS 1
(check_urdf, robot_state_publisher, joint_state_publisher's URDF) uses. Messages about a rule of it
name it, so that a user of another ROS knows what to compare with."""

COMMON_COLOURS: dict[str, tuple[float, float, float, float]] = {
    "red": (0.8, 0.0, 0.0, 1.0),
    "green": (0.0, 0.8, 0.0, 1.0),
    "blue": (0.0, 0.0, 0.8, 1.0),
    "yellow": (0.8, 0.8, 0.0, 1.0),
    "orange": (1.0, 0.42, 0.04, 1.0),
    "cyan": (0.0, 0.8, 0.8, 1.0),
    "magenta": (0.8, 0.0, 0.8, 1.0),
    "purple": (0.5, 0.0, 0.5, 1.0),
    "pink": (1.0, 0.6, 0.8, 1.0),
    "brown": (0.55, 0.35, 0.17, 1.0),
    "grey": (0.5, 0.5, 0.5, 1.0),
    "gray": (0.5, 0.5, 0.5, 1.0),
    "light_grey": (0.75, 0.75, 0.75, 1.0),
    "light_gray": (0.75, 0.75, 0.75, 1.0),
    "dark_grey": (0.25, 0.25, 0.25, 1.0),
    "dark_gray": (0.25, 0.25, 0.25, 1.0),
    "silver": (0.75, 0.75, 0.75, 1.0),
    "black": (0.0, 0.0, 0.0, 1.0),
    "white": (1.0, 1.0, 1.0, 1.0),
}
"""Colours of common names (any case), for a visual naming a material the description never defines:
shown in that colour (with a warning) rather than in the viewer's default. Primary colours at 0.8, as
the ROS tutorials define them (``urdf_tutorial``'s blue is ``0 0 0.8 1``)."""


def _common_colour(name: str) -> tuple[float, float, float, float] | None:
    """The colour of a common name: ``Red``, ``light grey`` and ``dark-gray`` are found."""
    return COMMON_COLOURS.get(name.strip().lower().replace(" ", "_").replace("-", "_"))

# The URDF elements; every other element is ignored, as urdfdom (check_urdf, robot_state_publisher) does.
_KNOWN_CHILDREN = {
    "robot": {"link", "joint", "material"},
    "link": {"inertial", "visual", "collision"},
    "joint": {"origin", "parent", "child", "axis", "calibration", "dynamics", "limit", "mimic", "safety_controller"},
    "visual": {"origin", "geometry", "material"},
    "material": {"color", "texture"},
}
"""Where an unknown element is worth a warning: what tfrec reads. Inside ``<collision>`` and ``<inertial>``
(Gazebo's ``<surface>``, say), which tfrec does not use, nothing is looked at."""
# Elements for other tools (simulators, controllers, planners), ignored without a word.
_OTHER_TOOLS = {"transmission", "gazebo", "ros2_control", "sensor", "webots", "drake", "mujoco", "klampt",
                "sdf", "plugin", "xacro"}
_SHOWN = 5
"""Ignored elements named in the one warning about them; the rest are counted."""


_DECLARATION = re.compile(r"\A(\s*)(<\?xml(?=[\s?]).*?\?>)", re.DOTALL | re.IGNORECASE)


def _declaration_ignored(text: str, where: str) -> str:
    """``text`` with its XML declaration blanked (its lines kept) when expat would refuse it and TinyXML2,
    urdfdom's parser, reads past it: a misspelled ``<?xml verison="1.0"?>``, an unknown encoding, a
    declaration after blank lines. TinyXML2 reads any ``<?xml …?>`` and always as UTF-8, which ``text`` is."""
    found = _DECLARATION.match(text)
    if found is None:
        return text
    declaration = found.group(2)
    problem = ""
    if found.group(1):
        problem = "not at the start of the file"
    else:
        probe = xml.parsers.expat.ParserCreate()
        try:
            probe.Parse(declaration.encode("utf-8") + b"<r/>", True)
        except xml.parsers.expat.ExpatError as err:
            problem = xml.parsers.expat.ErrorString(err.code) or "malformed"
        except (LookupError, ValueError) as err:
            problem = f"unsupported encoding ({err})"
    if not problem:
        return text
    shown = declaration if len(declaration) <= 60 else declaration[:57] + "..."
    line = text.count("\n", 0, found.start(2)) + 1
    warnings.warn(f"{where}:{line}: XML declaration {shown!r} ignored ({problem}), as {URDFDOM} (TinyXML2) "
                  "ignores it", TfrecWarning, stacklevel=4)
    blank = "".join(c if c == "\n" else " " for c in declaration)
    return text[: found.start(2)] + blank + text[found.end(2) :]


def _parse_xml(text: str, where: str) -> tuple[ET.Element, dict[int, tuple[int, int]]]:
    """Parse XML keeping each element's line number and place in document order (ElementTree drops them)."""
    if isinstance(text, str):
        text = _declaration_ignored(text, where)
    builder = ET.TreeBuilder()
    lines: dict[int, tuple[int, int]] = {}
    parser = xml.parsers.expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        elem = builder.start(tag, attrs)
        lines[id(elem)] = (parser.CurrentLineNumber, len(lines))

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    try:
        parser.Parse(text.encode("utf-8") if isinstance(text, str) else text, True)
    except xml.parsers.expat.ExpatError as err:
        raise DescriptionError(
            f"{where}:{err.lineno}:{err.offset}: malformed XML: {xml.parsers.expat.ErrorString(err.code)}"
        ) from err
    except (LookupError, ValueError) as err:  # an encoding declaration expat cannot read (unknown, multi-byte)
        raise DescriptionError(f"{where}:1: unsupported XML encoding: {err}") from None
    return builder.close(), lines


def parse_xml_with_lines(text: str, where: str) -> tuple[ET.Element, dict[int, tuple[int, int]]]:
    """An XML document as an ElementTree, with each element's line (``lines[id(element)][0]``); malformed XML is a
    :class:`DescriptionError` naming ``where``, the line and the column."""
    return _parse_xml(text, where)


class _Parser:
    def __init__(self, where: str, lines: dict[int, tuple[int, int]], *, user_lines: bool,
                 origins: Sequence[str | None] | None) -> None:
        self.where = where
        self._lines = lines
        self._user_lines = user_lines  # False: line numbers are not the user's (expanded xacro)
        self._origins = origins
        self.version = (1, 0)  # the <robot version>: 1.1 reads <origin quat_xyzw>

    def place(self, elem: ET.Element | None) -> str | None:
        """``file:line`` of an element: where the user wrote it (a xacro file's line, with ``origins``)."""
        line, index = self._lines.get(id(elem), (0, -1)) if elem is not None else (0, -1)
        if self._origins is not None and 0 <= index < len(self._origins):
            return self._origins[index]
        return f"{self.where}:{line}" if self._user_lines and line else None

    def fail(self, elem: ET.Element | None, message: str) -> DescriptionError:
        return DescriptionError(f"{self.place(elem) or self.where}: {message}")

    def warn(self, elem: ET.Element | None, message: str) -> None:
        warnings.warn(str(self.fail(elem, message)), TfrecWarning, stacklevel=4)

    # ---- attribute readers -------------------------------------------------------------

    def floats(self, elem: ET.Element, attr: str, count: int, what: str, default: tuple[float, ...] | None) -> tuple[float, ...]:
        raw = elem.get(attr)
        if raw is None:
            if default is None:
                raise self.fail(elem, f"{what} has no '{attr}'")
            return default
        try:
            values = tuple(float(v) for v in raw.split())
        except ValueError:
            raise self.fail(elem, f"{what}: malformed {attr}=\"{raw}\" (expected {count} numbers)")
        if len(values) != count or not all(math.isfinite(v) for v in values):
            raise self.fail(elem, f"{what}: malformed {attr}=\"{raw}\" (expected {count} finite numbers)")
        return values

    def number(self, elem: ET.Element, attr: str, what: str, default: float | None = None) -> float:
        return self.floats(elem, attr, 1, what, None if default is None else (default,))[0]

    def pose(self, parent: ET.Element, what: str) -> Pose:
        origin = parent.find("origin")
        if origin is None:
            return Pose()
        xyz = self.floats(origin, "xyz", 3, f"{what} origin", (0.0, 0.0, 0.0))
        if self.version >= (1, 1) and origin.get("quat_xyzw") is not None:
            if origin.get("rpy") is not None:
                raise self.fail(origin, f"{what} origin has both rpy and quat_xyzw (URDF 1.1 allows one)")
            return Pose(xyz=(xyz[0], xyz[1], xyz[2]), rpy=self.quat_rpy(origin, what))
        rpy = self.floats(origin, "rpy", 3, f"{what} origin", (0.0, 0.0, 0.0))
        return Pose(xyz=(xyz[0], xyz[1], xyz[2]), rpy=(rpy[0], rpy[1], rpy[2]))

    def quat_rpy(self, origin: ET.Element, what: str) -> tuple[float, float, float]:
        """URDF 1.1's ``quat_xyzw`` as fixed-axis roll, pitch, yaw (the quaternion normalized)."""
        x, y, z, w = self.floats(origin, "quat_xyzw", 4, f"{what} origin", None)
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        if not norm > 0.0:
            raise self.fail(origin, f"{what} origin has a zero quat_xyzw")
        x, y, z, w = x / norm, y / norm, z / norm, w / norm
        roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return roll, pitch, yaw

    def unit_axis(self, elem: ET.Element | None, axis: tuple[float, ...], what: str) -> tuple[float, ...]:
        """``axis`` normalized, as robot_state_publisher does; scaled first, so that ``1e200 1e200 1e200``
        (whose squares overflow) is the diagonal it means and ``1e-200 0 0`` the x axis."""
        scale = max(abs(a) for a in axis)
        if not scale > 0.0:  # urdfdom loads it; robot_state_publisher then publishes NaN transforms
            raise self.fail(elem, f"{what} has a zero axis: it defines no motion ({URDFDOM} loads it, and "
                            "robot_state_publisher publishes NaN for it)")
        scaled = [a / scale for a in axis]
        norm = math.sqrt(sum(a * a for a in scaled))
        return tuple(a / norm for a in scaled)

    # ---- elements ----------------------------------------------------------------------

    def material(self, elem: ET.Element, what: str) -> Material:
        name = elem.get("name", "")
        color = elem.find("color")
        rgba = None
        if color is not None:
            try:
                c = self.floats(color, "rgba", 4, f"{what} material '{name}' color", None)
            except DescriptionError as err:  # urdfdom keeps the material without its colour
                warnings.warn(f"{err}: the colour is left out, as {URDFDOM} leaves it out", TfrecWarning, stacklevel=5)
            else:
                rgba = (c[0], c[1], c[2], c[3])
        texture = elem.find("texture")
        return Material(name=name, rgba=rgba, texture=texture.get("filename") if texture is not None else None)

    def geometry(self, visual: ET.Element, what: str) -> Geometry:
        geometry = visual.find("geometry")
        if geometry is None:
            raise self.fail(visual, f"{what} has no <geometry>")
        shapes = [child for child in geometry if isinstance(child.tag, str)]
        if not shapes:
            raise self.fail(geometry, f"{what} <geometry> is empty")
        shape = shapes[0]
        if shape.tag == "box":
            s = self.floats(shape, "size", 3, f"{what} box", None)
            return Box(size=(s[0], s[1], s[2]))
        if shape.tag == "cylinder":
            return Cylinder(
                radius=self.number(shape, "radius", f"{what} cylinder"),
                length=self.number(shape, "length", f"{what} cylinder"),
            )
        if shape.tag == "sphere":
            return Sphere(radius=self.number(shape, "radius", f"{what} sphere"))
        if shape.tag == "mesh":
            filename = shape.get("filename")
            if not filename:
                raise self.fail(shape, f"{what} mesh has no filename")
            s = self.floats(shape, "scale", 3, f"{what} mesh", (1.0, 1.0, 1.0))
            return Mesh(filename=filename, scale=(s[0], s[1], s[2]))
        raise self.fail(shape, f"{what} has unknown geometry <{shape.tag}>")

    def link(self, elem: ET.Element, materials: dict[str, Material]) -> Link:
        name = elem.get("name")
        if not name:
            raise self.fail(elem, "<link> has no name")
        visuals = []
        for index, visual in enumerate(elem.findall("visual")):
            what = f"link '{name}' visual {index}"
            try:
                geometry = self.geometry(visual, what)
                origin = self.pose(visual, what)
            except DescriptionError as err:  # urdfdom leaves the visual out; TF does not need it
                warnings.warn(f"{err}: the visual is left out, as {URDFDOM} leaves it out (TF is not affected)", TfrecWarning,
                              stacklevel=4)
                continue
            material = None
            mat = visual.find("material")
            if mat is not None:
                material = self.material(mat, what)
                if material.rgba is None and material.texture is None:
                    if material.name in materials:
                        material = materials[material.name]
                    elif (rgba := _common_colour(material.name)) is not None:
                        self.warn(mat, f"{what} uses material '{material.name}', which is not defined; "
                                       f"shown as the colour of that name ({' '.join(f'{c:g}' for c in rgba)})")
                        material = Material(name=material.name, rgba=rgba)
                    else:
                        self.warn(mat, f"{what} uses material '{material.name}', which is not defined")
            visuals.append(Visual(geometry=geometry, origin=origin, material=material, name=visual.get("name")))
        for index, collision in enumerate(elem.findall("collision")):
            self.collision(collision, f"link '{name}' collision {index}")
        return Link(name=name, visuals=tuple(visuals), mass=self.mass(elem, name))

    def collision(self, elem: ET.Element, what: str) -> None:
        """Check a ``<collision>`` as urdfdom reads it (tfrec does not use it): one urdfdom leaves out — no or a
        broken geometry (a sphere without ``radius``, a box without ``size``, a mesh without ``filename``), a
        malformed origin — is said with a warning, as a broken visual is; the link and TF are not affected."""
        try:
            self.geometry(elem, what)
            self.pose(elem, what)
        except DescriptionError as err:
            warnings.warn(f"{err}: the collision is left out, as {URDFDOM} leaves it out (TF is not affected)",
                          TfrecWarning, stacklevel=5)

    def mass(self, elem: ET.Element, name: str) -> float | None:
        """The link's mass; None without one, or (with a warning) with a malformed one: urdfdom leaves
        such an ``<inertial>`` out and loads the link."""
        inertial = elem.find("inertial")
        mass = inertial.find("mass") if inertial is not None else None
        if mass is None:
            return None
        try:
            return self.number(mass, "value", f"link '{name}' mass")
        except DescriptionError as err:
            warnings.warn(f"{err}: the inertial is left out, as {URDFDOM} leaves it out", TfrecWarning, stacklevel=5)
            return None

    def limit(self, elem: ET.Element | None, what: str) -> Limit | None:
        """A joint's ``<limit>``: ``lower`` and ``upper`` default to 0, ``effort`` and ``velocity`` are
        required (urdfdom refuses a limit without them, on any joint type). Lower above upper is loaded
        by urdfdom and robot_state_publisher: the bounds are swapped, with a warning."""
        if elem is None:
            return None
        for attr in ("effort", "velocity"):
            if elem.get(attr) is None:
                raise self.fail(elem, f"{what} <limit> has no '{attr}': {URDFDOM} (check_urdf, robot_state_publisher) "
                                f"refuses it (\"joint limit: no {attr}\")")
        limit = Limit(
            lower=self.number(elem, "lower", f"{what} limit", 0.0),
            upper=self.number(elem, "upper", f"{what} limit", 0.0),
            effort=self.number(elem, "effort", f"{what} limit"),
            velocity=self.number(elem, "velocity", f"{what} limit"),
        )
        if limit.lower > limit.upper:
            self.warn(elem, f"{what} has lower limit {limit.lower:g} above upper limit {limit.upper:g} ({URDFDOM} "
                      f"loads it): it moves between {limit.upper:g} and {limit.lower:g}")
            limit = Limit(lower=limit.upper, upper=limit.lower, effort=limit.effort, velocity=limit.velocity)
        return limit

    def check_numbers(self, elem: ET.Element, what: str) -> None:
        """The numbers of ``<dynamics>``, ``<calibration>`` and ``<safety_controller>``, which tfrec does not
        use but urdfdom refuses when malformed (robot_state_publisher then dies at start)."""
        for tag, attrs in (("dynamics", ("damping", "friction")), ("calibration", ("rising", "falling")),
                           ("safety_controller", ("k_position", "k_velocity"))):
            child = elem.find(tag)
            if child is None:
                continue
            for attr in attrs:
                if child.get(attr) is not None:
                    self.number(child, attr, f"{what} {tag}")

    def joint(self, elem: ET.Element) -> Joint:
        name = elem.get("name")
        if not name:
            raise self.fail(elem, "<joint> has no name")
        what = f"joint '{name}'"
        raw_type = elem.get("type")
        try:
            jtype = JointType(raw_type)
        except ValueError:
            raise self.fail(elem, f"{what} has type '{raw_type}', not one of URDF's "
                            + ", ".join(t.value for t in JointType))
        links = {}
        for role in ("parent", "child"):
            node = elem.find(role)
            if node is None or not node.get("link"):
                raise self.fail(elem, f"{what} has no <{role} link=...>")
            links[role] = node.get("link", "")
        axis: tuple[float, ...] = (1.0, 0.0, 0.0)
        axis_elem = elem.find("axis")
        if axis_elem is not None and jtype not in (JointType.FIXED, JointType.FLOATING):  # urdfdom reads no other
            axis = self.floats(axis_elem, "xyz", 3, f"{what} axis", (1.0, 0.0, 0.0))
        if jtype in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC, JointType.PLANAR):
            axis = self.unit_axis(axis_elem, axis, what)
        limit = self.limit(elem.find("limit"), what)
        if jtype in (JointType.REVOLUTE, JointType.PRISMATIC) and limit is None:
            raise self.fail(elem, f"{what} is {jtype.value} but has no <limit>")
        self.check_numbers(elem, what)
        mimic = None
        mimic_elem = elem.find("mimic")
        if mimic_elem is not None:
            master = mimic_elem.get("joint")
            if not master:
                raise self.fail(mimic_elem, f"{what} <mimic> has no joint")
            mimic = Mimic(
                joint=master,
                multiplier=self.number(mimic_elem, "multiplier", f"{what} mimic", 1.0),
                offset=self.number(mimic_elem, "offset", f"{what} mimic", 0.0),
            )
        safety = None
        safety_elem = elem.find("safety_controller")
        if safety_elem is not None:
            if safety_elem.get("k_velocity") is None:
                raise self.fail(safety_elem, f"{what} <safety_controller> has no 'k_velocity': {URDFDOM} "
                                "(check_urdf, robot_state_publisher) refuses it (\"joint safety: no k_velocity\")")
            soft = [self.number(safety_elem, attr, f"{what} safety_controller") if safety_elem.get(attr) is not None
                    else None for attr in ("soft_lower_limit", "soft_upper_limit")]
            safety = SafetyController(soft[0], soft[1])
        return Joint(
            name=name, type=jtype, parent=links["parent"], child=links["child"],
            origin=self.pose(elem, what), axis=(axis[0], axis[1], axis[2]), limit=limit, mimic=mimic,
            safety=safety,
        )


def parse_urdf(text: str, *, source: str | None = None, user_lines: bool = True,
               origins: Sequence[str | None] | None = None) -> Robot:
    """Build a validated :class:`Robot` from URDF text.

    Args:
        text: the URDF document.
        source: the file it came from, for messages (and kept on the Robot).
        user_lines: whether line numbers in ``text`` are the user's (False for expanded xacro).
        origins: ``file:line`` each element of ``text`` was written at, in document order (expanded
            xacro: :attr:`tfrec.description.xacro.XacroExpansion.origins`), for messages.

    Raises:
        DescriptionError: malformed XML or an invalid robot, one line naming the element.
    """
    where = display_path(source) if source else "<urdf>"
    root, lines = _parse_xml(text, where)
    p = _Parser(where, lines, user_lines=user_lines, origins=origins)
    if root.tag != "robot":
        raise p.fail(root, f"root element is <{root.tag}>, not <robot>")
    name = root.get("name")
    if name is None:
        raise p.fail(root, "<robot> has no name")
    if not name:
        p.warn(root, f'<robot name="">: an empty robot name ({URDFDOM} loads it)')

    p.version = _version(p, root)
    _warn_ignored(p, root)
    materials: dict[str, Material] = {}
    for elem in root:
        if elem.tag == "material":
            material = p.material(elem, "robot")
            if material.name in materials:
                raise p.fail(elem, f"material '{material.name}' is defined twice: {URDFDOM} (check_urdf, "
                             f"robot_state_publisher) refuses it (\"material '{material.name}' is not unique.\")")
            materials[material.name] = material

    links: list[Link] = []
    joints: list[Joint] = []
    link_elems: dict[str, ET.Element] = {}
    joint_elems: dict[str, ET.Element] = {}
    for elem in root.findall("link"):
        link = p.link(elem, materials)
        if link.name in link_elems:
            raise p.fail(elem, f"duplicate link name '{link.name}'")
        link_elems[link.name] = elem
        links.append(link)
    for elem in root.findall("joint"):
        joint = p.joint(elem)
        if joint.name in joint_elems:
            raise p.fail(elem, f"duplicate joint name '{joint.name}'")
        joint_elems[joint.name] = elem
        joints.append(joint)

    _check_tree(p, name, links, joints, joint_elems.__getitem__)
    _check_mimic(p, joints, joint_elems.__getitem__)
    frozen = [joint.name for joint in joints if joint.type in (JointType.REVOLUTE, JointType.PRISMATIC)
              and joint.mimic is None and joint.limit is not None and joint.limit.lower == joint.limit.upper]
    if frozen:
        shown = ", ".join(f"'{name}'" for name in frozen[:_SHOWN]) + (f" and {len(frozen) - _SHOWN} more"
                                                                      if len(frozen) > _SHOWN else "")
        warnings.warn(f"{where}: joint{'s' if len(frozen) > 1 else ''} {shown} cannot move: lower and upper limit "
                      "are equal (blank limits, as sw_urdf_exporter writes them?)", TfrecWarning, stacklevel=2)
    for joint in joints:
        if joint.type is JointType.PLANAR:
            p.warn(joint_elems[joint.name], f"joint '{joint.name}' is planar: treated as fixed, "
                   "as robot_state_publisher does")
        elif joint.type is JointType.FLOATING:
            p.warn(joint_elems[joint.name], f"joint '{joint.name}' is floating: it gets no transform, "
                   "as robot_state_publisher does")
    return Robot(name=name, links=tuple(links), joints=tuple(joints), urdf=text, source=source)


_STRTOL = re.compile(r"[ \t\n\v\f\r]*([+-]?[0-9]+)")
_ONLY_1_0 = "Invalid 'version' specified; only version 1.0 is currently supported"


def _version_field(field: str) -> int | str:
    """One field of a ``<robot version>`` as urdfdom's ``strToUnsigned`` reads it (C's ``strtol``, then a
    uint32), or urdfdom's reason for refusing it."""
    if not field:
        return "One of the fields of the version attribute is blank"
    number = _STRTOL.match(field)
    if number is None:
        return "Version attribute is not an integer"
    if number.end() != len(field):
        return "Extra characters after the version number"
    value = int(number.group(1))
    return "Version number must be positive" if value < 0 else min(value, 2**63 - 1) % 2**32


def _version(p: _Parser, root: ET.Element) -> tuple[int, int]:
    """The ``<robot version>`` as urdfdom reads it (``URDFVersion``: two fields split at dots). 1.0 is
    read; 1.1 is read with a warning (urdfdom 3.0.1 refuses it, urdfdom 5 reads it); anything else is
    refused with urdfdom's reason."""
    raw = root.get("version")
    if raw is None:
        return (1, 0)
    fields = raw.split(".")
    if fields and not fields[-1]:
        fields.pop()  # urdfdom's split drops one empty last field: "1." is one field
    values = [_version_field(field) for field in fields] if len(fields) == 2 else []
    shown = f'<robot version="{raw}">'
    if values == [1, 0]:
        return (1, 0)
    if values == [1, 1]:
        p.warn(root, f"{shown}: {URDFDOM} (ROS 1's check_urdf and robot_state_publisher) refuses it (\"only version "
               "1.0 is currently supported\"); newer urdfdom (ROS 2 Rolling's, since ros/urdfdom#235) reads URDF 1.1, and so does tfrec")
        return (1, 1)
    reasons = [value for value in values if isinstance(value, str)]
    reason = reasons[0] if reasons else "The version attribute should be in the form 'x.y'" if not values else _ONLY_1_0
    raise p.fail(root, f"{shown}: {URDFDOM} (check_urdf, robot_state_publisher) refuses it (\"{reason}\")")


def _warn_ignored(p: _Parser, root: ET.Element) -> None:
    """Warn once about the elements urdfdom would ignore that a user would want to know of: unknown
    un-prefixed elements where urdfdom reads (a typo like ``<orgin>``, a macro call left unexpanded) and
    leftover ``xacro:`` elements. Elements of other tools (``<gazebo>``, ``<transmission>``,
    ``<drake:…>``, ``<mujoco>``…) are ignored without a word."""
    ignored: list[str] = []
    stack = [root]
    while stack:
        elem = stack.pop()
        known = _KNOWN_CHILDREN.get(elem.tag)
        if known is None:
            continue  # inside an element urdfdom does not read (or a leaf): nothing of it is looked at
        for child in elem:
            tag = child.tag
            if not isinstance(tag, str):
                continue
            prefix, colon, _ = tag.partition(":")
            if tag in known or (elem.tag == "visual" and tag == "geometry"):
                stack.append(child)
            elif (colon and prefix != "xacro") or tag in _OTHER_TOOLS:
                continue
            else:
                place = p.place(child)
                if place is not None and place.startswith(f"{p.where}:"):
                    place = "line " + place.removeprefix(f"{p.where}:")
                ignored.append(f"<{tag}>" + (f" ({place})" if place else f" in <{elem.tag}>"))
    if ignored:
        more = f" and {len(ignored) - _SHOWN} more" if len(ignored) > _SHOWN else ""
        warnings.warn(f"{p.where}: ignored {len(ignored)} element{'s' if len(ignored) > 1 else ''} that URDF "
                      f"does not define (as urdfdom does): {', '.join(ignored[:_SHOWN])}{more}", TfrecWarning, stacklevel=3)


def _check_tree(p: _Parser, robot: str, links: list[Link], joints: list[Joint],
                elem_of: Callable[[str], ET.Element]) -> None:
    if not links:
        raise p.fail(None, f"robot '{robot}' has no links")
    names = {link.name for link in links}
    parent_of: dict[str, str] = {}
    for joint in joints:
        for role in ("parent", "child"):
            link = getattr(joint, role)
            if link not in names:
                raise p.fail(elem_of(joint.name), f"joint '{joint.name}' names unknown {role} link '{link}'"
                                                  + suggest(link, names))
        if joint.parent == joint.child:
            raise p.fail(elem_of(joint.name), f"joint '{joint.name}' has link '{joint.child}' as both parent and child")
        if joint.child in parent_of:
            raise p.fail(elem_of(joint.name), f"link '{joint.child}' is the child of two joints: "
                         f"'{parent_of[joint.child]}' and '{joint.name}'")
        parent_of[joint.child] = joint.name
    roots = [link.name for link in links if link.name not in parent_of]
    if len(roots) > 1:
        raise p.fail(None, f"robot '{robot}' has several root links: {', '.join(roots)} "
                     "(every link but one must be a joint's child)")
    if not roots:
        raise p.fail(None, f"robot '{robot}' has no root link: its joints form a cycle")
    joint_by_child = {joint.child: joint for joint in joints}
    reached = {roots[0]}
    frontier = [roots[0]]
    children: dict[str, list[str]] = {}
    for joint in joints:
        children.setdefault(joint.parent, []).append(joint.child)
    while frontier:
        link = frontier.pop()
        for child in children.get(link, []):
            if child not in reached:
                reached.add(child)
                frontier.append(child)
    unreached = [link.name for link in links if link.name not in reached]
    if unreached:
        order = {joint.name: i for i, joint in enumerate(joints)}
        cycle = sorted((joint_by_child[name].name for name in unreached if name in joint_by_child), key=order.__getitem__)
        raise p.fail(elem_of(cycle[0]) if cycle else None,
                     f"joints {', '.join(repr(c) for c in cycle)} form a cycle (links "
                     f"{', '.join(unreached)} are not reachable from root '{roots[0]}')")


def _check_mimic(p: _Parser, joints: list[Joint], elem_of: Callable[[str], ET.Element]) -> None:
    by_name = {joint.name: joint for joint in joints}
    for joint in joints:
        if joint.mimic is not None and joint.mimic.joint not in by_name:
            # urdfdom keeps the name; robot_state_publisher then never moves the joint
            p.warn(elem_of(joint.name), f"joint '{joint.name}' mimics unknown joint '{joint.mimic.joint}'"
                   f"{suggest(joint.mimic.joint, by_name)}: it stays at its mimic offset")
    try:
        mimic_levels(joints)  # each chain walked once: a chain of 100,000 mimics is linear
    except MimicCycle as cycle:
        raise p.fail(elem_of(cycle.start), str(cycle)) from None
