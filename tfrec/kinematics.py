"""Batched forward kinematics with robot_state_publisher's semantics.

For each joint the transform parent link ← child link (``parent_from_child``) is
``origin · motion(q)``: a rotation by q about the joint axis for revolute and continuous
joints, a translation by q along it for prismatic joints, nothing for fixed joints.
Fixed joints (and planar joints, which robot_state_publisher treats as fixed) are static;
revolute, continuous and prismatic joints are dynamic; floating joints get no transform.

Everything is computed for all samples at once: a joint's transforms for N samples are
one numpy expression, ``cos(q/2)·origin + sin(q/2)·(origin ⊗ axis)`` for a rotation, so
there is no Python loop over samples. Rotations are unit quaternions (x, y, z, w) with
w >= 0; translations are in metres; both float64.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tfrec.errors import KinematicsError
from tfrec.model import Joint, JointType, Robot
from tfrec.rotations import (
    canonical_quaternion,
    matrix_from_quaternion,
    quaternion_from_rpy,
    quaternion_multiply,
    quaternion_rotate,
)
from tfrec.trajectory import JointTrajectory, all_joint_states

__all__ = [
    "Transforms",
    "DynamicChunk",
    "static_transforms",
    "dynamic_transforms",
    "iter_dynamic_chunks",
    "world_from_link",
    "link_poses",
    "DEFAULT_CHUNK_SIZE",
]

Array = NDArray[np.float64]

DEFAULT_CHUNK_SIZE = 8192
"""Samples per chunk in :func:`iter_dynamic_chunks`: ~0.5 MB per transform per chunk."""

STATIC_TYPES = (JointType.FIXED, JointType.PLANAR)


@dataclass(frozen=True, slots=True)
class Transforms:
    """K transforms ``parent_from_child`` at N instants.

    Attributes:
        parents: frame ids of the parent frames (frame prefix included), length K.
        children: frame ids of the child frames, length K.
        translation: float64 (N, K, 3), metres: the child origin in the parent frame.
        rotation: float64 (N, K, 4), unit quaternions (x, y, z, w) with w >= 0.
    """

    parents: tuple[str, ...]
    children: tuple[str, ...]
    translation: Array
    rotation: Array

    def __post_init__(self) -> None:
        k = len(self.children)
        n = self.translation.shape[0] if self.translation.ndim == 3 else -1
        if len(self.parents) != k or self.translation.shape != (n, k, 3) or self.rotation.shape != (n, k, 4):
            raise ValueError(
                f"inconsistent transforms: {len(self.parents)} parents, {k} children, "
                f"translation {self.translation.shape}, rotation {self.rotation.shape}"
            )

    def __len__(self) -> int:
        """N, the number of instants."""
        return int(self.translation.shape[0])

    def matrices(self) -> Array:
        """Homogeneous matrices, float64 (N, K, 4, 4)."""
        out = np.zeros(self.translation.shape[:2] + (4, 4))
        out[..., :3, :3] = matrix_from_quaternion(self.rotation)
        out[..., :3, 3] = self.translation
        out[..., 3, 3] = 1.0
        return out


class DynamicChunk(NamedTuple):
    """One piece of a trajectory with its joint states and dynamic transforms."""

    time_ns: NDArray[np.int64]
    """int64 (n,) nanoseconds from the start."""
    names: tuple[str, ...]
    """Every moving joint (actuated and mimic) in URDF document order."""
    positions: Array
    """float64 (n, M)."""
    velocities: Array
    """float64 (n, M)."""
    transforms: Transforms
    """parent_from_child of the same joints, in the same order, N = n."""


def static_transforms(robot: Robot, *, frame_prefix: str = "") -> Transforms:
    """The transforms of fixed and planar joints (URDF document order), N = 1.

    They are published once, on /tf_static. A planar joint gets its origin alone, as
    robot_state_publisher does.
    """
    joints = [joint for joint in robot.joints if joint.type in STATIC_TYPES]
    translation = np.array([joint.origin.xyz for joint in joints], dtype=np.float64).reshape(1, -1, 3)
    rotation = _origin_rotations(joints).reshape(1, -1, 4)
    return _transforms(joints, frame_prefix, translation, canonical_quaternion(rotation))


def dynamic_transforms(
    robot: Robot, names: Sequence[str], positions: ArrayLike, *, frame_prefix: str = ""
) -> Transforms:
    """The transforms of moving joints at the given positions.

    Args:
        robot: the robot.
        names: moving joints (revolute, continuous, prismatic, mimic ones included), any
            order; usually the names from :func:`tfrec.trajectory.all_joint_states`. Mimic
            joints are not derived here: each joint takes the position given for it.
        positions: float (N, len(names)), radians or metres.
        frame_prefix: put in front of every frame id, as robot_state_publisher's frame_prefix.

    Returns:
        One transform per name, in the order of ``names``.

    Raises:
        KinematicsError: a name is not a moving joint of the robot, the array has the wrong
            shape, or a position is not finite.
    """
    q = np.asarray(positions, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != len(names):
        raise KinematicsError(f"positions of shape {q.shape} do not match {len(names)} joint names")
    joints = []
    for name in names:
        joint = robot.joint_by_name.get(name)
        if joint is None or not joint.type.moves:
            raise KinematicsError(f"'{name}' is not a moving joint of robot '{robot.name}'")
        joints.append(joint)
    bad = np.argwhere(~np.isfinite(q))
    if bad.size:
        sample, column = bad[0]
        raise KinematicsError(f"joint '{names[column]}' has position {q[sample, column]} at sample {sample}")

    origin_t = np.array([joint.origin.xyz for joint in joints], dtype=np.float64).reshape(-1, 3)
    origin_q = _origin_rotations(joints)
    axis = np.array([joint.axis for joint in joints], dtype=np.float64).reshape(-1, 3)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    prismatic = np.array([joint.type is JointType.PRISMATIC for joint in joints], dtype=bool)
    revolute = ~prismatic

    n = q.shape[0]
    translation = np.empty((n, len(joints), 3))
    rotation = np.empty((n, len(joints), 4))
    # revolute, continuous: origin ⊗ (sin(q/2)·axis, cos(q/2)) = cos(q/2)·origin + sin(q/2)·(origin ⊗ axis)
    spin = quaternion_multiply(origin_q[revolute], np.concatenate([axis[revolute], np.zeros((revolute.sum(), 1))], 1))
    half = q[:, revolute] * 0.5
    rotation[:, revolute] = np.cos(half)[..., np.newaxis] * origin_q[revolute] + np.sin(half)[..., np.newaxis] * spin
    translation[:, revolute] = origin_t[revolute]
    # prismatic: origin translation + q · (axis in the parent frame)
    direction = quaternion_rotate(origin_q[prismatic], axis[prismatic])
    translation[:, prismatic] = origin_t[prismatic] + q[:, prismatic, np.newaxis] * direction
    rotation[:, prismatic] = origin_q[prismatic]
    return _transforms(joints, frame_prefix, translation, canonical_quaternion(rotation))


def iter_dynamic_chunks(
    robot: Robot,
    trajectory: JointTrajectory,
    *,
    chunk_size: int = DEFAULT_CHUNK_SIZE,
    frame_prefix: str = "",
) -> Iterator[DynamicChunk]:
    """Joint states and dynamic transforms of a trajectory, ``chunk_size`` samples at a time.

    Memory stays bounded by the chunk size whatever the trajectory's length, so writers
    can stream long recordings.
    """
    for piece in trajectory.chunks(chunk_size):
        names, positions, velocities = all_joint_states(robot, piece)
        transforms = dynamic_transforms(robot, names, positions, frame_prefix=frame_prefix)
        yield DynamicChunk(piece.time_ns, names, positions, velocities, transforms)


def world_from_link(static: Transforms, dynamic: Transforms, *, root: str) -> Transforms:
    """Compose per-joint transforms into ``root_from_frame`` for every frame reachable from root.

    This is what a tf listener does with /tf_static and /tf: frames are joined by name, so a
    frame below a floating joint (which has no transform) is absent from the result.

    Args:
        static: transforms with N = 1 (or N matching ``dynamic``).
        dynamic: transforms with N instants.
        root: the frame id to start from (frame prefix included); it maps to the identity.

    Returns:
        Transforms whose parents are all ``root`` and whose children are the reachable frames,
        root first, then breadth-first in the order the transforms are given.

    Raises:
        KinematicsError: a frame has two parents.
    """
    n = max(len(static), len(dynamic))
    edges: dict[str, list[tuple[str, Array, Array]]] = {}
    has_parent: set[str] = set()
    for tfs in (static, dynamic):
        for k, (parent, child) in enumerate(zip(tfs.parents, tfs.children)):
            if child in has_parent:
                raise KinematicsError(f"frame '{child}' has two parents")
            has_parent.add(child)
            edges.setdefault(parent, []).append((child, tfs.translation[:, k], tfs.rotation[:, k]))
    frames = [root]
    translations = [np.zeros((n, 3))]
    rotations = [np.broadcast_to(np.array([0.0, 0.0, 0.0, 1.0]), (n, 4))]
    i = 0
    while i < len(frames):
        for child, t, r in edges.get(frames[i], []):
            frames.append(child)
            translations.append(translations[i] + quaternion_rotate(rotations[i], t))
            rotations.append(quaternion_multiply(rotations[i], r))
        i += 1
    translation = np.stack(translations, axis=1)
    rotation = canonical_quaternion(np.stack(rotations, axis=1))
    rotation /= np.linalg.norm(rotation, axis=-1, keepdims=True)
    return Transforms((root,) * len(frames), tuple(frames), translation, rotation)


def link_poses(robot: Robot, names: Sequence[str], positions: ArrayLike) -> dict[str, Array]:
    """Root → link poses of every link connected to the root, as 4×4 matrices.

    Composes the same transforms that are recorded (:func:`static_transforms` and
    :func:`dynamic_transforms`), so it doubles as a check of them.

    Args:
        robot: the robot.
        names, positions: every moving joint's positions, as from
            :func:`tfrec.trajectory.all_joint_states`.

    Returns:
        link name → float64 (N, 4, 4); links below a floating joint are absent.
    """
    composed = world_from_link(static_transforms(robot), dynamic_transforms(robot, names, positions), root=robot.root)
    poses = composed.matrices()
    return {frame: poses[:, k] for k, frame in enumerate(composed.children)}


def _origin_rotations(joints: Sequence[Joint]) -> Array:
    return quaternion_from_rpy(np.array([joint.origin.rpy for joint in joints], dtype=np.float64).reshape(-1, 3))


def _transforms(joints: Sequence[Joint], frame_prefix: str, translation: Array, rotation: Array) -> Transforms:
    parents = tuple(frame_prefix + joint.parent for joint in joints)
    children = tuple(frame_prefix + joint.child for joint in joints)
    return Transforms(parents, children, translation, rotation)
