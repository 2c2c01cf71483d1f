"""The kinematic model of a robot: frozen records for links, joints and geometry.

No I/O here: :mod:`tfrec.description` builds a :class:`Robot` from URDF text, and the
later stages (trajectory, kinematics, sinks) only read it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum
from functools import cached_property

__all__ = [
    "Box",
    "Cylinder",
    "Geometry",
    "Joint",
    "JointType",
    "Limit",
    "Link",
    "Material",
    "Mesh",
    "Mimic",
    "MimicCycle",
    "Pose",
    "Robot",
    "SafetyController",
    "Sphere",
    "Visual",
    "mimic_levels",
]

Vec3 = tuple[float, float, float]


class JointType(str, Enum):
    """URDF's six joint types."""

    REVOLUTE = "revolute"
    CONTINUOUS = "continuous"
    PRISMATIC = "prismatic"
    FIXED = "fixed"
    FLOATING = "floating"
    PLANAR = "planar"

    @property
    def moves(self) -> bool:
        """True for the one-degree-of-freedom types whose value is a joint position."""
        return self in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)


@dataclass(frozen=True, slots=True)
class Pose:
    """A URDF ``<origin>``: translation in metres, fixed-axis roll, pitch, yaw in radians."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class Limit:
    """A joint's ``<limit>``: position bounds (rad or m), effort and velocity."""

    lower: float
    upper: float
    effort: float
    velocity: float


@dataclass(frozen=True, slots=True)
class SafetyController:
    """A joint's ``<safety_controller>``: the soft limits (rad or m) joint_state_publisher narrows its
    range to (``use_smallest_joint_limits``), None where not given."""

    soft_lower_limit: float | None = None
    soft_upper_limit: float | None = None


@dataclass(frozen=True, slots=True)
class Mimic:
    """``<mimic>``: position = multiplier * position(joint) + offset."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True, slots=True)
class Joint:
    """A URDF joint. ``axis`` is normalized (as robot_state_publisher does)."""

    name: str
    type: JointType
    parent: str
    child: str
    origin: Pose = Pose()
    axis: Vec3 = (1.0, 0.0, 0.0)
    limit: Limit | None = None
    mimic: Mimic | None = None
    safety: SafetyController | None = None

    @property
    def actuated(self) -> bool:
        """True when the joint has a position of its own: it moves and mimics nothing."""
        return self.type.moves and self.mimic is None


@dataclass(frozen=True, slots=True)
class Box:
    size: Vec3


@dataclass(frozen=True, slots=True)
class Cylinder:
    """A cylinder along its local z axis, centred on its origin."""

    radius: float
    length: float


@dataclass(frozen=True, slots=True)
class Sphere:
    radius: float


@dataclass(frozen=True, slots=True)
class Mesh:
    """A mesh file as the URDF names it (``package://``, ``file://`` or a relative path)."""

    filename: str
    scale: Vec3 = (1.0, 1.0, 1.0)


Geometry = Box | Cylinder | Sphere | Mesh


@dataclass(frozen=True, slots=True)
class Material:
    """A material; ``rgba`` is resolved from robot-level materials referenced by name."""

    name: str
    rgba: tuple[float, float, float, float] | None = None
    texture: str | None = None


@dataclass(frozen=True, slots=True)
class Visual:
    geometry: Geometry
    origin: Pose = Pose()
    material: Material | None = None
    name: str | None = None


@dataclass(frozen=True, slots=True)
class Link:
    name: str
    visuals: tuple[Visual, ...] = ()
    mass: float | None = None


class MimicCycle(ValueError):
    """Mimic joints that mimic each other in a cycle.

    Attributes:
        start: the first joint (document order) whose chain of mimics leads into the cycle.
        cycle: the joints of the cycle, its first one again at the end.
    """

    def __init__(self, start: str, cycle: list[str]) -> None:
        super().__init__("mimic joints form a cycle: " + " -> ".join(cycle))
        self.start = start
        self.cycle = cycle


def mimic_levels(joints: Sequence[Joint]) -> dict[str, int]:
    """Each mimic joint's depth in its chain of mimics: 0 when it mimics a joint that mimics none (or an
    unknown joint), else one more than the joint it mimics. Each chain is walked once (linear in joints,
    without recursion: a chain of 100,000 mimics is fine).

    Raises:
        MimicCycle: joints that mimic each other in a cycle.
    """
    by_name = {joint.name: joint for joint in joints}
    levels: dict[str, int] = {}
    for start in joints:
        path: list[str] = []
        on_path: set[str] = set()
        current: Joint | None = start
        while current is not None and current.mimic is not None and current.name not in levels:
            if current.name in on_path:
                raise MimicCycle(start.name, [*path[path.index(current.name):], current.name])
            path.append(current.name)
            on_path.add(current.name)
            current = by_name.get(current.mimic.joint)
        level = -1 if current is None or current.mimic is None else levels[current.name]
        for name in reversed(path):
            level += 1
            levels[name] = level
    return levels


@dataclass(frozen=True)
class Robot:
    """A validated robot: a tree of links joined by joints, in URDF document order.

    Attributes:
        name: the ``<robot name>``.
        links: links in document order.
        joints: joints in document order.
        urdf: the expanded URDF text the model was built from.
        source: the file it was loaded from, or None for text.
    """

    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    urdf: str = field(default="", repr=False, compare=False)
    source: str | None = field(default=None, compare=False)

    @cached_property
    def link_by_name(self) -> dict[str, Link]:
        return {link.name: link for link in self.links}

    @cached_property
    def joint_by_name(self) -> dict[str, Joint]:
        return {joint.name: joint for joint in self.joints}

    @cached_property
    def root(self) -> str:
        """The one link that is no joint's child."""
        children = {joint.child for joint in self.joints}
        return next(link.name for link in self.links if link.name not in children)

    @cached_property
    def child_joints(self) -> dict[str, tuple[Joint, ...]]:
        """For each link, the joints that have it as parent, in document order."""
        out: dict[str, list[Joint]] = {link.name: [] for link in self.links}
        for joint in self.joints:
            out[joint.parent].append(joint)
        return {name: tuple(joints) for name, joints in out.items()}

    @cached_property
    def actuated_joints(self) -> tuple[Joint, ...]:
        """Joints with a position of their own (revolute, continuous, prismatic; no mimic)."""
        return tuple(joint for joint in self.joints if joint.actuated)

    @cached_property
    def moving_joints(self) -> tuple[Joint, ...]:
        """Joints whose transform changes with position: actuated and mimic joints."""
        return tuple(joint for joint in self.joints if joint.type.moves)

    @cached_property
    def mimic_order(self) -> tuple[Joint, ...]:
        """Moving mimic joints ordered so that every joint comes after the joint it mimics (by their depth in
        their chain of mimics, then document order)."""
        levels = mimic_levels(self.joints)  # description.py rejects cycles; a hand-built model raises here
        ordered = sorted((joint for joint in self.joints if joint.mimic is not None),
                         key=lambda joint: levels[joint.name])
        return tuple(joint for joint in ordered if joint.type.moves)

    @cached_property
    def tree_order(self) -> tuple[Joint, ...]:
        """All joints, parents before children (breadth-first from the root; each link once, so that a
        hand-built model with a cycle ends too: parsed descriptions have none)."""
        ordered: list[Joint] = []
        frontier = [self.root]
        seen = {self.root}
        while frontier:
            nxt: list[str] = []
            for link in frontier:
                for joint in self.child_joints[link]:
                    if joint.child in seen:
                        continue
                    seen.add(joint.child)
                    ordered.append(joint)
                    nxt.append(joint.child)
            frontier = nxt
        return tuple(ordered)
