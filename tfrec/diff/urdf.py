"""Comparing two robot descriptions as URDF, element by element — not as text.

Both texts are parsed into :class:`tfrec.model.Robot` and compared by meaning: the robot name,
the links (added, removed, or changed mass or visuals) and the joints (type, parent, child,
origin, axis, limits, mimic). Lengths compare within a position tolerance; orientations by the
angle of the rotation between them (:func:`tfrec.kinematics.rotations.rotation_error`, as for recorded
transforms), so ``rpy="3.14159265358979 0 0"`` and ``"-3.14159265358979 0 0"`` are the same
origin; axes by the angle ``atan2(|a×b|, a·b)`` between them; other numbers within a value
tolerance. Both angles keep their precision for tiny changes: at a tolerance of 1e-9 rad a
change of 1e-8 rad shows. Each added, removed or changed element is one line, e.g.
``joint 'joint2' changed: origin xyz (0 0 0.1) → (0 0 0.11)``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import DIFF_JOINT_TOL, DIFF_POS_TOL, DIFF_ROT_TOL
from tfrec.description.urdf import parse_urdf
from tfrec.errors import DescriptionError
from tfrec.kinematics.rotations import quaternion_from_rpy, rotation_error
from tfrec.model import Joint, JointType, Limit, Link, Mimic, Pose, Robot, Visual

__all__ = ["ElementChange", "diff_robots", "diff_urdf_texts", "rotation_angle"]

_Element = TypeVar("_Element", Link, Joint)


@dataclass(frozen=True, slots=True)
class ElementChange:
    """One added, removed or changed element.

    Attributes:
        what: the element, e.g. ``joint 'joint2'``.
        detail: the whole line, e.g. ``joint 'joint2' changed: origin xyz (0 0 0.1) → (0 0 0.11)``.
    """

    what: str
    detail: str


def _num(x: float) -> str:
    return f"{x:.9g}"


def _vec(v: Sequence[float]) -> str:
    return "(" + " ".join(_num(x) for x in v) + ")"


def _limit(limit: Limit | None) -> str:
    return "none" if limit is None else f"[{_num(limit.lower)}, {_num(limit.upper)}]"


def _mimic(mimic: Mimic | None) -> str:
    return "none" if mimic is None else f"'{mimic.joint}' ×{_num(mimic.multiplier)} {mimic.offset:+.9g}"


def rotation_angle(rpy_a: Sequence[float], rpy_b: Sequence[float]) -> float:
    """The angle (rad) of the rotation taking one URDF rpy orientation to the other."""
    return float(rotation_error(quaternion_from_rpy(rpy_a), quaternion_from_rpy(rpy_b)))


def _axis_angle(a: Sequence[float], b: Sequence[float]) -> float:
    """The angle (rad) between two axes, ``atan2(|a×b|, a·b)``: accurate for tiny angles, unlike ``acos``."""
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


def _differs(a: Sequence[float] | NDArray[Any], b: Sequence[float] | NDArray[Any], tol: float) -> bool:
    return bool(np.max(np.abs(np.subtract(a, b))) > tol) if len(a) else False


class _Comparer:
    def __init__(self, pos_tol: float, rot_tol: float, value_tol: float) -> None:
        self.pos_tol = pos_tol
        self.rot_tol = rot_tol
        self.value_tol = value_tol

    def pose(self, label: str, a: Pose, b: Pose) -> list[str]:
        out = []
        if _differs(a.xyz, b.xyz, self.pos_tol):
            out.append(f"{label} xyz {_vec(a.xyz)} → {_vec(b.xyz)}")
        if rotation_angle(a.rpy, b.rpy) > self.rot_tol:
            out.append(f"{label} rpy {_vec(a.rpy)} → {_vec(b.rpy)}")
        return out

    def value(self, label: str, a: float | None, b: float | None) -> list[str]:
        if a is None and b is None:
            return []
        if a is None or b is None or abs(a - b) > self.value_tol:
            return [f"{label} {'none' if a is None else _num(a)} → {'none' if b is None else _num(b)}"]
        return []

    def joint(self, a: Joint, b: Joint) -> list[str]:
        out: list[str] = []
        if a.type is not b.type:
            out.append(f"type {a.type.value} → {b.type.value}")
        if a.parent != b.parent:
            out.append(f"parent '{a.parent}' → '{b.parent}'")
        if a.child != b.child:
            out.append(f"child '{a.child}' → '{b.child}'")
        out += self.pose("origin", a.origin, b.origin)
        if a.type.moves and b.type.moves and _axis_angle(a.axis, b.axis) > self.rot_tol:
            out.append(f"axis {_vec(a.axis)} → {_vec(b.axis)}")
        if (a.limit is None) != (b.limit is None):
            out.append(f"limit {_limit(a.limit)} → {_limit(b.limit)}")
        elif a.limit is not None and b.limit is not None:
            for name in ("lower", "upper", "effort", "velocity"):
                out += self.value(f"limit {name}", getattr(a.limit, name), getattr(b.limit, name))
        if (a.mimic is None) != (b.mimic is None):
            out.append(f"mimic {_mimic(a.mimic)} → {_mimic(b.mimic)}")
        elif a.mimic is not None and b.mimic is not None:
            if a.mimic.joint != b.mimic.joint:
                out.append(f"mimic joint '{a.mimic.joint}' → '{b.mimic.joint}'")
            out += self.value("mimic multiplier", a.mimic.multiplier, b.mimic.multiplier)
            out += self.value("mimic offset", a.mimic.offset, b.mimic.offset)
        return out

    def moving_joint(self, a: Joint, b: Joint) -> list[str]:
        """What a URDF and a MuJoCo model of one joint both say: type, axis, position limits, mimic. A continuous
        joint's limits mean nothing to either, and a revolute joint with equal limits (blank ones, which MuJoCo's
        URDF import ignores: "limit ignored") is compared as the continuous joint MuJoCo makes of it."""
        a, b = _as_mujoco_reads(a), _as_mujoco_reads(b)
        return [change for change in self.joint(a, b)
                if not change.startswith(("parent ", "child ", "origin ", "limit effort", "limit velocity"))]

    def visual(self, label: str, a: Visual, b: Visual) -> list[str]:
        out = []
        if type(a.geometry) is not type(b.geometry):
            out.append(f"{label} geometry {type(a.geometry).__name__.lower()} → {type(b.geometry).__name__.lower()}")
        else:
            for name in a.geometry.__slots__:
                va, vb = getattr(a.geometry, name), getattr(b.geometry, name)
                if isinstance(va, str):
                    if va != vb:
                        out.append(f"{label} {name} '{va}' → '{vb}'")
                elif _differs(np.atleast_1d(va), np.atleast_1d(vb), self.pos_tol):
                    shown_a = _vec(va) if isinstance(va, tuple) else _num(va)
                    shown_b = _vec(vb) if isinstance(vb, tuple) else _num(vb)
                    out.append(f"{label} {type(a.geometry).__name__.lower()} {name} {shown_a} → {shown_b}")
        out += self.pose(f"{label} origin", a.origin, b.origin)
        rgba_a = a.material.rgba if a.material else None
        rgba_b = b.material.rgba if b.material else None
        if (rgba_a is None) != (rgba_b is None) or (
            rgba_a is not None and rgba_b is not None and _differs(rgba_a, rgba_b, self.value_tol)
        ):
            out.append(f"{label} color {_vec(rgba_a) if rgba_a else 'none'} → {_vec(rgba_b) if rgba_b else 'none'}")
        return out

    def link(self, a: Link, b: Link) -> list[str]:
        out = self.value("mass", a.mass, b.mass)
        if len(a.visuals) != len(b.visuals):
            out.append(f"{len(a.visuals)} visuals → {len(b.visuals)}")
        for index, (va, vb) in enumerate(zip(a.visuals, b.visuals)):
            out += self.visual(f"visual {index}", va, vb)
        return out


def _as_mujoco_reads(joint: Joint) -> Joint:
    blank = joint.type is JointType.REVOLUTE and joint.limit is not None and joint.limit.lower == joint.limit.upper
    if blank or joint.type is JointType.CONTINUOUS:
        return replace(joint, type=JointType.CONTINUOUS, limit=None)
    return joint


def diff_robots(
    a: Robot, b: Robot, *, pos_tol: float = DIFF_POS_TOL, rot_tol: float = DIFF_ROT_TOL,
    value_tol: float = DIFF_JOINT_TOL, moving_joints_only: bool = False,
) -> list[ElementChange]:
    """The elements added, removed or changed from robot ``a`` to robot ``b``.

    Args:
        a, b: the two robots.
        pos_tol: metres within which lengths (origins, geometry sizes) are equal.
        rot_tol: radians within which orientations and axes are equal.
        value_tol: within which other numbers (limits, mimic factors, mass, colours) are equal.
        moving_joints_only: compare only the joints that move, by type, axis, position limits and mimic
            (a URDF and a MuJoCo model: what both formats say alike; links, fixed joints, origins, effort and
            velocity limits are left to the comparison of world poses, or are not in MJCF).

    Returns:
        One :class:`ElementChange` per element, robot name first, then links and joints in
        ``a``'s document order, then those only in ``b``; empty when the robots are the same.
    """
    cmp = _Comparer(pos_tol, rot_tol, value_tol)
    out: list[ElementChange] = []
    if moving_joints_only:
        moving_a = {joint.name: joint for joint in a.moving_joints}
        moving_b = {joint.name: joint for joint in b.moving_joints}
        return _diff_elements("joint", moving_a, moving_b, cmp.moving_joint)
    if a.name != b.name:
        out.append(ElementChange("robot name", f"robot name '{a.name}' → '{b.name}'"))
    out += _diff_elements("link", a.link_by_name, b.link_by_name, cmp.link)
    out += _diff_elements("joint", a.joint_by_name, b.joint_by_name, cmp.joint)
    return out


def _diff_elements(
    kind: str, items_a: Mapping[str, _Element], items_b: Mapping[str, _Element],
    compare: Callable[[_Element, _Element], list[str]],
) -> list[ElementChange]:
    """The ``kind`` elements removed or changed, in ``a``'s order, then those added, in ``b``'s."""
    out: list[ElementChange] = []
    for name, item in items_a.items():
        what = f"{kind} '{name}'"
        other = items_b.get(name)
        if other is None:
            out.append(ElementChange(what, f"{what} removed (only in A)"))
            continue
        changes = compare(item, other)
        if changes:
            out.append(ElementChange(what, f"{what} changed: " + "; ".join(changes)))
    for name, item in items_b.items():
        if name not in items_a:
            what = f"{kind} '{name}'"
            extra = ""
            if isinstance(item, Joint):
                extra = f" ({item.type.value}, {item.parent} → {item.child})"
            out.append(ElementChange(what, f"{what} added (only in B){extra}"))
    return out


def _parse(text: str, label: str) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return parse_urdf(text, source=label, user_lines=True)


def diff_urdf_texts(
    a: str, b: str, *, pos_tol: float = DIFF_POS_TOL, rot_tol: float = DIFF_ROT_TOL,
    value_tol: float = DIFF_JOINT_TOL, labels: tuple[str, str] = ("A", "B"),
) -> list[ElementChange]:
    """:func:`diff_robots` of two URDF texts; a text that does not parse is one change.

    Identical texts are not parsed. Texts that differ only where tfrec does not look
    (comments, inertia, collision geometry, attribute order) give no changes.
    """
    if a == b:
        return []
    robots: list[Robot] = []
    out: list[ElementChange] = []
    for text, label in zip((a, b), labels):
        try:
            robots.append(_parse(text, f"{label}'s robot description"))
        except DescriptionError as err:
            out.append(ElementChange("robot description", f"not a valid URDF: {err}"))
    if out:
        return out
    return diff_robots(robots[0], robots[1], pos_tol=pos_tol, rot_tol=rot_tol, value_tol=value_tol)
