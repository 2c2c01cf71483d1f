"""URDF text → :class:`tfrec.model.Robot`, with urdfdom's checks and a few more.

Every failure is one :class:`DescriptionError` line naming the file, the line when the text
is the user's own file, and the element: ``arm.urdf:42: joint 'elbow' names unknown parent
link 'uper_arm'``.
"""

from __future__ import annotations

import math
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

__all__ = ["COMMON_COLOURS", "parse_urdf"]

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


def _parse_xml(text: str, where: str) -> tuple[ET.Element, dict[int, tuple[int, int]]]:
    """Parse XML keeping each element's line number and place in document order (ElementTree drops them)."""
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


class _Parser:
    def __init__(self, where: str, lines: dict[int, tuple[int, int]], *, user_lines: bool,
                 origins: Sequence[str | None] | None) -> None:
        self.where = where
        self._lines = lines
        self._user_lines = user_lines  # False: line numbers are not the user's (expanded xacro)
        self._origins = origins

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
        rpy = self.floats(origin, "rpy", 3, f"{what} origin", (0.0, 0.0, 0.0))
        return Pose(xyz=(xyz[0], xyz[1], xyz[2]), rpy=(rpy[0], rpy[1], rpy[2]))

    def unit_axis(self, elem: ET.Element | None, axis: tuple[float, ...], what: str) -> tuple[float, ...]:
        """``axis`` normalized, as robot_state_publisher does; scaled first, so that ``1e200 1e200 1e200``
        (whose squares overflow) is the diagonal it means and ``1e-200 0 0`` the x axis."""
        scale = max(abs(a) for a in axis)
        if not scale > 0.0:
            raise self.fail(elem, f"{what} has a zero axis")
        scaled = [a / scale for a in axis]
        norm = math.sqrt(sum(a * a for a in scaled))
        return tuple(a / norm for a in scaled)

    # ---- elements ----------------------------------------------------------------------

    def material(self, elem: ET.Element, what: str) -> Material:
        name = elem.get("name", "")
        color = elem.find("color")
        rgba = None
        if color is not None:
            c = self.floats(color, "rgba", 4, f"{what} material '{name}' color", None)
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
            geometry = self.geometry(visual, what)
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
            visuals.append(Visual(geometry=geometry, origin=self.pose(visual, what), material=material,
                                  name=visual.get("name")))
        mass = None
        inertial = elem.find("inertial")
        if inertial is not None and inertial.find("mass") is not None:
            mass = self.number(inertial.find("mass"), "value", f"link '{name}' mass")  # type: ignore[arg-type]
        return Link(name=name, visuals=tuple(visuals), mass=mass)

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
        if axis_elem is not None:
            axis = self.floats(axis_elem, "xyz", 3, f"{what} axis", (1.0, 0.0, 0.0))
        if jtype in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC, JointType.PLANAR):
            axis = self.unit_axis(axis_elem, axis, what)
        limit = None
        limit_elem = elem.find("limit")
        if limit_elem is not None:
            limit = Limit(
                lower=self.number(limit_elem, "lower", f"{what} limit", 0.0),
                upper=self.number(limit_elem, "upper", f"{what} limit", 0.0),
                effort=self.number(limit_elem, "effort", f"{what} limit", 0.0),
                velocity=self.number(limit_elem, "velocity", f"{what} limit", 0.0),
            )
        if jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
            if limit is None:
                raise self.fail(elem, f"{what} is {jtype.value} but has no <limit>")
            if limit.lower > limit.upper:
                raise self.fail(limit_elem, f"{what} has lower limit {limit.lower:g} above upper limit {limit.upper:g}")
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
    if not name:
        raise p.fail(root, "<robot> has no name")

    _warn_ignored(p, root)
    materials: dict[str, Material] = {}
    for elem in root:
        if elem.tag == "material":
            material = p.material(elem, "robot")
            if material.name in materials and materials[material.name] != material:
                p.warn(elem, f"material '{material.name}' is defined twice; the first definition is used")
            materials.setdefault(material.name, material)

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
