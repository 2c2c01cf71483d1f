"""How a tfrec recording is laid out in the Rerun viewer: the camera, the plots, the TF tree.

- the 3D view's eye frames the robot's whole reach: :class:`Reach` gathers the space the links
  and their visuals take up over the recording (chunk by chunk, a bounded sample of each), and
  :meth:`Reach.eye` looks at it from front-left and above (45° yaw, 30° pitch, Z up), from the
  distance at which it fills the view;
- joint plots are split by unit — revolute and continuous joints in rad, prismatic in m — and
  each joint has its own colour, the same in every recording of the robot (:func:`joint_colour`,
  by the joint's place in the URDF);
- the TF tree (what ROS's ``view_frames`` draws) is a graph of frames, parent above child
  (:func:`tf_tree_layout`), in a panel of its own.

Only builds Rerun objects; :mod:`tfrec.viewer.sink` logs and sends them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from tfrec.formats.rrd.paths import (
    ELAPSED_TIMELINE,
    JOINTS_ROOT,
    ROBOT_ROOT,
    TF_TREE_ROOT,
    VELOCITIES_ROOT,
    joint_entity,
    velocity_entity,
)
from tfrec.frames import frame_tree
from tfrec.kinematics.rotations import quaternion_rotate
from tfrec.model import JointType, Robot
from tfrec.recording import Transforms

__all__ = [
    "EYE_PITCH_DEG",
    "EYE_YAW_DEG",
    "JOINT_PALETTE",
    "Reach",
    "blueprint_of",
    "joint_colour",
    "joint_units",
    "recording_blueprint",
    "robot_layout",
    "stable_ids",
    "tf_tree_columns",
    "tf_tree_layout",
    "view_distance",
]

Array = NDArray[np.float64]

EYE_YAW_DEG = 45.0
"""The eye looks from front-left (RViz's orbit view starts at 45° yaw)..."""
EYE_PITCH_DEG = 30.0
"""...and from above."""
FIELD_OF_VIEW_DEG = 55.0
"""The vertical field of view of Rerun's 3D eye (its default)."""
FILL = 0.7
"""The part of the view's height the ball around the robot's reach fills."""
MAX_POINTS = 50_000
"""Points :class:`Reach` keeps (every other one is dropped when there are more): memory stays bounded."""
EYE_SAMPLES = 64
"""Instants of each chunk (evenly spread) the robot's reach, and so the camera, is fitted to..."""
EYE_POSES = 1_000_000
"""...and poses (instants × frames) composed for it at most (56 MB): fewer instants for a robot of many links."""
MIN_RADIUS_M = 0.05
"""A reach smaller than this (a robot of points) is framed as a ball of this radius."""

JOINT_PALETTE = (
    0x1F77B4FF, 0xFF7F0EFF, 0x2CA02CFF, 0xD62728FF, 0x9467BDFF, 0x8C564BFF, 0xE377C2FF, 0x7F7F7FFF,
    0xBCBD22FF, 0x17BECFFF, 0xAEC7E8FF, 0xFFBB78FF, 0x98DF8AFF, 0xFF9896FF, 0xC5B0D5FF, 0xC49C94FF,
)
"""Distinct colours (matplotlib's tab10, then tab20's light shades), as 0xRRGGBBAA."""


def joint_colour(index: int) -> int:
    """The plot colour of the joint at ``index`` among the robot's joints (URDF order): stable
    from recording to recording, distinct for the first 16."""
    return JOINT_PALETTE[index % len(JOINT_PALETTE)]


def joint_units(robot: Robot | None, names: Sequence[str]) -> dict[str, str]:
    """``m`` for prismatic joints, ``rad`` for the others; ``""`` for joints the robot does not name."""
    joints = robot.joint_by_name if robot is not None else {}
    out: dict[str, str] = {}
    for name in names:
        joint = joints.get(name)
        out[name] = "" if joint is None else "m" if joint.type is JointType.PRISMATIC else "rad"
    return out


def view_distance(radius_m: float, fill: float = FILL) -> float:
    """How far from its centre the eye sees a ball of ``radius_m`` fill ``fill`` of the view's height."""
    half = math.radians(FIELD_OF_VIEW_DEG) / 2.0
    return max(radius_m, MIN_RADIUS_M) / (fill * math.sin(half))


@dataclass
class Reach:
    """The space the robot's links and visuals take up over a recording, gathered sample by sample:
    its bounding box, and a bounded sample of the points (link origins and visual centres, each
    with the radius of its visual) for the ball around them.

    Args:
        robot: the robot.
        frame_prefix: in front of the link names in the frame ids given to :meth:`add`.
        radii: (link, visual index) → the radius of the visual (0 when unknown).
    """

    robot: Robot
    frame_prefix: str = ""
    radii: Mapping[tuple[str, int], float] = field(default_factory=dict)
    low: Array | None = None
    high: Array | None = None
    points: list[tuple[Array, Array]] = field(default_factory=list)
    """(points (m, 3), their radii (m,)): the link origins and visual centres gathered."""
    _count: int = 0

    @staticmethod
    def instants(samples: int, *, frames: int) -> NDArray[np.intp]:
        """Which of a chunk's ``samples`` the camera is fitted to: :data:`EYE_SAMPLES` evenly spread, fewer when
        ``frames`` frames would compose more than :data:`EYE_POSES` poses (100,000 frames: 10 instants)."""
        count = max(1, min(samples, EYE_SAMPLES, EYE_POSES // max(1, frames)))
        return np.unique(np.linspace(0, samples - 1, count).astype(np.intp))

    def merge(self, other: Reach) -> None:
        """Widen by another robot's reach (the two robots of an overlay)."""
        for points, pads in other.points:
            self._widen(points, pads)

    def add(self, world: Transforms) -> None:
        """Widen the box by the robot at the poses ``world`` (root_from_frame, N instants); NaN
        poses (frames not placed at an instant) are left out. All links at once: linear in links."""
        by_frame = {child: k for k, child in enumerate(world.children)}
        columns: list[int] = []
        offsets: list[tuple[float, float, float]] = []
        pads: list[float] = []
        origins: list[int] = []
        for link in self.robot.links:
            k = by_frame.get(self.frame_prefix + link.name)
            if k is None:
                continue
            origins.append(k)
            for index, visual in enumerate(link.visuals):
                columns.append(k)
                offsets.append(visual.origin.xyz)
                pads.append(self.radii.get((link.name, index), 0.0))
        n = len(world)
        if origins:
            self._widen(world.translation[:, origins].reshape(-1, 3), np.zeros(n * len(origins)))
        if columns:
            centres = world.translation[:, columns] + quaternion_rotate(world.rotation[:, columns], np.asarray(offsets))
            self._widen(centres.reshape(-1, 3), np.tile(np.asarray(pads, dtype=np.float64), n))

    def _widen(self, points: Array, pads: Array) -> None:
        kept = np.all(np.isfinite(points), axis=1)
        points, pads = points[kept], pads[kept]
        if not len(points):
            return
        low, high = (points - pads[:, np.newaxis]).min(axis=0), (points + pads[:, np.newaxis]).max(axis=0)
        self.low = low if self.low is None else np.minimum(self.low, low)
        self.high = high if self.high is None else np.maximum(self.high, high)
        self.points.append((points, pads))
        self._count += len(points)
        while self._count > MAX_POINTS:
            self.points = [(p[::2], r[::2]) for p, r in self.points if len(p[::2])]
            self._count = sum(len(p) for p, _ in self.points)

    def eye(self, fill: float = FILL) -> rrb.EyeControls3D | None:
        """A ¾ view of the ball around the reach (centred on its box), Z up; None before anything was added."""
        if self.low is None or self.high is None:
            return None
        centre = (self.low + self.high) / 2.0
        radius = max(float(np.max(np.linalg.norm(p - centre, axis=1) + pads)) for p, pads in self.points)
        distance = view_distance(radius, fill)
        yaw, pitch = math.radians(EYE_YAW_DEG), math.radians(EYE_PITCH_DEG)
        direction = np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)])
        return rrb.EyeControls3D(position=(centre + distance * direction).tolist(), look_target=centre.tolist(),
                                 eye_up=[0.0, 0.0, 1.0])


def tf_tree_layout(pairs: Sequence[tuple[str, str]]) -> dict[str, tuple[float, float]]:
    """Positions of the frames of a TF tree for a graph view: each parent above its children,
    leaves side by side in the order given, a parent centred over its children (2D, y down).
    Every frame is placed once (:func:`tfrec.frames.frame_tree`: a second parent or a cycle is not
    followed), depth-first without recursion: a chain of 100,000 frames is laid out like a short one."""
    tree = frame_tree(pairs)
    children: dict[str, list[str]] = {}
    for parent, child in tree.edges():
        children.setdefault(parent, []).append(child)
    widest = max((len(frame) for pair in pairs for frame in pair), default=8)
    dx, dy = 7.0 * widest + 10.0, 30.0
    x: dict[str, float] = {}
    preorder: list[str] = []
    next_x = 0.0
    for root in tree.roots:
        stack = [(root, False)]
        while stack:
            frame, done = stack.pop()
            kids = children.get(frame, [])
            if not done:
                preorder.append(frame)
            if not done and kids:
                stack.append((frame, True))
                stack.extend((kid, False) for kid in reversed(kids))
            elif kids:
                x[frame] = (min(x[kid] for kid in kids) + max(x[kid] for kid in kids)) / 2.0
            else:
                x[frame] = next_x
                next_x += dx
    return {frame: (x[frame], tree.depth[frame] * dy) for frame in preorder}


def tf_tree_columns(pairs: Sequence[tuple[str, str]]) -> list[Any]:
    """The TF tree as one static row of ``GraphNodes`` (every frame, laid out by
    :func:`tf_tree_layout`) and directed ``GraphEdges`` (parent → child), for ``send_columns``."""
    layout = tf_tree_layout(pairs)
    frames = list(layout)
    return [
        *rr.GraphNodes.columns(node_ids=frames, labels=frames, positions=[layout[f] for f in frames]).partition(
            [len(frames)]),
        *rr.GraphNodes.columns(show_labels=[True]),
        *rr.GraphEdges.columns(edges=list(pairs)).partition([len(pairs)]),
        *rr.GraphEdges.columns(graph_type=["directed"]),
    ]


def robot_layout(
    *,
    eye: rrb.EyeControls3D | None,
    units: Mapping[str, str],
    velocities: bool,
    tf_tree: bool,
    root: str = "",
    name: str | None = None,
) -> rrb.Container | rrb.View:
    """One robot's views: the 3D view beside the joint plots (one per unit, positions and, when
    logged, velocities as tabs) above the TF tree.

    Args:
        eye: the 3D view's camera (None: the viewer's own).
        units: each joint logged → its unit (:func:`joint_units`).
        velocities: joint velocities were logged.
        tf_tree: the TF tree was logged at ``/tf_tree``.
        root: the entity path the robot was logged under (``/robot1``: one robot of several).
        name: the layout's title (a tab's, for one robot of several).
    """
    view3d = rrb.Spatial3DView(name="robot", origin=f"{root}/{ROBOT_ROOT}", eye_controls=eye)
    right: list[rrb.Container | rrb.View] = []
    by_unit: dict[str, list[str]] = {}
    for joint, unit in units.items():
        by_unit.setdefault(unit, []).append(joint)
    for unit in sorted(by_unit, key=lambda u: {"rad": 0, "m": 1}.get(u, 2)):
        names = by_unit[unit]
        suffix = f" ({unit})" if unit else ""
        positions = rrb.TimeSeriesView(name=f"joint positions{suffix}", origin=f"{root}/{JOINTS_ROOT}",
                                       contents=[root + joint_entity(joint) for joint in names])
        if velocities:
            speed = f" ({unit}/s)" if unit else ""
            right.append(rrb.Tabs(positions, rrb.TimeSeriesView(
                name=f"joint velocities{speed}", origin=f"{root}/{VELOCITIES_ROOT}",
                contents=[root + velocity_entity(joint) for joint in names])))
        else:
            right.append(positions)
    if tf_tree:
        right.append(rrb.GraphView(name="TF tree", origin=f"{root}/{TF_TREE_ROOT}"))
    shares = [2.0] * (len(right) - 1 if tf_tree else len(right)) + ([1.5] if tf_tree else [])
    if not right:  # a robot without joints and frames: the 3D view alone
        return rrb.Horizontal(view3d, name=name) if name is not None else view3d
    return rrb.Horizontal(view3d, rrb.Vertical(*right, row_shares=shares), column_shares=[3, 2], name=name)


def recording_blueprint(
    *,
    eye: rrb.EyeControls3D | None,
    units: Mapping[str, str],
    velocities: bool,
    tf_tree: bool,
) -> rrb.Blueprint:
    """The layout of a recording (:func:`robot_layout`), panels collapsed."""
    return blueprint_of(robot_layout(eye=eye, units=units, velocities=velocities, tf_tree=tf_tree))


def blueprint_of(*layouts: rrb.Container | rrb.View) -> rrb.Blueprint:
    """One layout, or several robots' as tabs (a replay of several robots), with the panels collapsed."""
    return stable_ids(rrb.Blueprint(
        layouts[0] if len(layouts) == 1 else rrb.Tabs(*layouts),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline=ELAPSED_TIMELINE),
    ))


def stable_ids(blueprint: rrb.Blueprint, namespace: str = "tfrec") -> rrb.Blueprint:
    """Give every container and view of ``blueprint`` an id derived from its place in the layout
    (Rerun draws random ones), so the same layout gives the same blueprint entities."""
    import uuid

    def visit(part: rrb.Container | rrb.View, path: str) -> None:
        part.id = uuid.uuid5(uuid.NAMESPACE_URL, f"{namespace}/{path}")
        for index, child in enumerate(getattr(part, "contents", None) or ()):
            if isinstance(child, (rrb.Container, rrb.View)):
                visit(child, f"{path}/{index}")

    visit(blueprint.root_container, "root")
    return blueprint
