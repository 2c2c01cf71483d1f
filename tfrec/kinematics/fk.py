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
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tfrec.errors import KinematicsError
from tfrec.frames import frame_tree
from tfrec.kinematics.joints import all_joint_states
from tfrec.kinematics.rotations import (
    matrix_from_quaternion,
    quaternion_from_rpy,
    quaternion_multiply,
    quaternion_rotate,
)
from tfrec.model import Joint, JointType, Robot
from tfrec.recording import Transforms
from tfrec.trajectory.types import JointTrajectory

__all__ = [
    "DEFAULT_CHUNK_SAMPLES",
    "DynamicChunk",
    "Transforms",
    "dynamic_components",
    "dynamic_transforms",
    "iter_dynamic_chunks",
    "link_poses",
    "root_from_link",
    "static_transforms",
    "transform_matrices",
]

Array = NDArray[np.float64]

DEFAULT_CHUNK_SAMPLES = 8192
"""Samples per chunk in :func:`iter_dynamic_chunks`: ~0.5 MB per transform per chunk."""

CHUNK_VALUES = 2_000_000
"""Joint samples (samples × moving joints) of one chunk of :func:`iter_dynamic_chunks` at most: its
transforms take 112 MB (7 float64 each), whatever the robot."""

STATIC_TYPES = (JointType.FIXED, JointType.PLANAR)

BLOCK = 4096
"""Samples computed together inside the functions below. Blocks keep numpy's temporaries at
32 kB, which the C allocator recycles; temporaries of ~100 kB and more are handed back to the
OS and page-faulted in again on every operation, three times slower on the same samples."""


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
    components = _static_components(joints)
    return _transforms(joints, frame_prefix, components[:, :3].transpose(2, 0, 1), components[:, 3:].transpose(2, 0, 1))


def dynamic_transforms(
    robot: Robot, names: Sequence[str], positions: ArrayLike, *, frame_prefix: str = ""
) -> Transforms:
    """The transforms of moving joints at the given positions.

    Args:
        robot: the robot.
        names: moving joints (revolute, continuous, prismatic, mimic ones included), any
            order; usually the names from :func:`tfrec.kinematics.joints.all_joint_states`. Mimic
            joints are not derived here: each joint takes the position given for it.
        positions: float (N, len(names)), radians or metres.
        frame_prefix: put in front of every frame id, as robot_state_publisher's frame_prefix.

    Returns:
        One transform per name, in the order of ``names``.

    Raises:
        KinematicsError: a name is not a moving joint of the robot, the array has the wrong
            shape, or a position is not finite.
    """
    joints, q = _moving_joints(robot, names, positions)
    translation = np.empty((q.shape[0], len(joints), 3))
    rotation = np.empty((q.shape[0], len(joints), 4))
    for block in _blocks(q.shape[0]):
        components = _dynamic_components(joints, q[block])
        translation[block] = components[:, :3].transpose(2, 0, 1)
        rotation[block] = components[:, 3:].transpose(2, 0, 1)
    return _transforms(joints, frame_prefix, translation, rotation)


def dynamic_components(robot: Robot, names: Sequence[str], positions: ArrayLike) -> Array:
    """The transforms of :func:`dynamic_transforms`, laid out (K, 7, N): per joint, translation x, y, z and
    quaternion x, y, z, w, each a contiguous row over the N samples — the layout for comparing one joint's
    transforms with a series of them (the values are :func:`dynamic_transforms`' own)."""
    joints, q = _moving_joints(robot, names, positions)
    out = np.empty((len(joints), 7, q.shape[0]))
    for block in _blocks(q.shape[0]):
        _dynamic_components(joints, q[block], out[:, :, block])
    return out


def iter_dynamic_chunks(
    robot: Robot,
    trajectory: JointTrajectory,
    *,
    chunk_samples: int = DEFAULT_CHUNK_SAMPLES,
    frame_prefix: str = "",
) -> Iterator[DynamicChunk]:
    """Joint states and dynamic transforms of a trajectory, ``chunk_samples`` samples at a time.

    Memory stays bounded by the chunk size whatever the trajectory's length, so writers
    can stream long recordings; a robot of many moving joints gets chunks of fewer samples
    (at most :data:`CHUNK_VALUES` joint samples a chunk: 100,000 joints, 20 samples).
    """
    chunk_samples = max(1, min(chunk_samples, CHUNK_VALUES // max(1, len(robot.moving_joints))))
    for piece in trajectory.chunks(chunk_samples):
        names, positions, velocities = all_joint_states(robot, piece)
        transforms = dynamic_transforms(robot, names, positions, frame_prefix=frame_prefix)
        yield DynamicChunk(piece.time_ns, names, positions, velocities, transforms)


def root_from_link(static: Transforms, dynamic: Transforms, *, root: str) -> Transforms:
    """Compose per-joint transforms into ``root_from_frame`` for every frame reachable from root.

    This is what a tf listener does with /tf_static and /tf: frames are joined by name, so a
    frame below a floating joint (which has no transform) is absent from the result.

    Args:
        static: transforms with N = 1 (or N matching ``dynamic``).
        dynamic: transforms with N instants.
        root: the frame id to start from (frame prefix included); it maps to the identity.

    Returns:
        Transforms whose parents are all ``root`` and whose children are the reachable frames,
        root first, then breadth-first in the order the transforms are given. A frame with several
        parents is composed through the first that reaches it (static transforms are given first);
        a transform that closes a cycle, or names a frame as its own parent, is not followed
        (:func:`tfrec.frames.frame_tree`; callers warn with :func:`tfrec.frames.graph_problems`).
    """
    n = max(len(static), len(dynamic))
    translation = rotation = np.empty(0)
    frames: list[str] = []
    for block in _blocks(n):
        fixed = _unpack(static, block if len(static) > 1 else slice(None))
        moving = _unpack(dynamic, block if len(dynamic) > 1 else slice(None))
        edges = [
            (parent, child, components)
            for tfs, stacked in ((static, fixed), (dynamic, moving))
            for parent, child, components in zip(tfs.parents, tfs.children, stacked)
        ]
        frames, poses = _compose(edges, root)
        if not translation.size:
            translation, rotation = np.empty((n, len(frames), 3)), np.empty((n, len(frames), 4))
        stacked = np.stack(poses, axis=1)  # (7, L, m)
        _canonicalize(stacked)
        translation[block] = stacked[:3].transpose(2, 1, 0)
        rotation[block] = stacked[3:].transpose(2, 1, 0)
    return Transforms((root,) * len(frames), tuple(frames), translation, rotation)


def transform_matrices(transforms: Transforms) -> Array:
    """Homogeneous matrices of transforms, float64 (N, K, 4, 4)."""
    out = np.zeros(transforms.translation.shape[:2] + (4, 4))
    out[..., :3, :3] = matrix_from_quaternion(transforms.rotation)
    out[..., :3, 3] = transforms.translation
    out[..., 3, 3] = 1.0
    return out


def link_poses(robot: Robot, names: Sequence[str], positions: ArrayLike) -> dict[str, Array]:
    """Root → link poses of every link connected to the root, as 4×4 matrices.

    Composes the same transforms that are recorded (:func:`static_transforms` and
    :func:`dynamic_transforms`), so it doubles as a check of them.

    Args:
        robot: the robot.
        names, positions: every moving joint's positions, as from
            :func:`tfrec.kinematics.joints.all_joint_states`.

    Returns:
        link name → float64 (N, 4, 4); links below a floating joint are absent.

    Raises:
        KinematicsError: as :func:`dynamic_transforms`.
    """
    joints, q = _moving_joints(robot, names, positions)
    fixed = [joint for joint in robot.joints if joint.type in STATIC_TYPES]
    fixed_edges = [(j.parent, j.child, c) for j, c in zip(fixed, _static_components(fixed))]
    n = q.shape[0]
    out: dict[str, Array] = {}
    for block in _blocks(n):
        moving = _dynamic_components(joints, q[block])
        frames, poses = _compose(fixed_edges + [(j.parent, j.child, c) for j, c in zip(joints, moving)], robot.root)
        for frame, pose in zip(frames, poses):
            if frame not in out:
                out[frame] = np.zeros((n, 4, 4))
                out[frame][:, 3, 3] = 1.0
            matrix = out[frame][block]
            matrix[:, :3, :3] = matrix_from_quaternion(pose[3:].T)
            matrix[:, :3, 3] = pose[:3].T
    if n == 0:
        return {frame: np.empty((0, 4, 4)) for frame in _compose(fixed_edges, robot.root)[0]}
    return out


# Internally a set of K transforms at N instants is a "component-major" array (K, 7, N):
# tx, ty, tz, qx, qy, qz, qw as contiguous rows of N. numpy is several times faster on those
# rows than on the (N, K, 4) layout, whose innermost axis is only 3 or 4 long.

_Pose = Array
"""(7, N) or (7, 1): one transform's components; (7, 1) broadcasts for transforms that do not move."""


def _moving_joints(robot: Robot, names: Sequence[str], positions: ArrayLike) -> tuple[list[Joint], Array]:
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
    return joints, q


def _origins(joints: Sequence[Joint]) -> tuple[Array, Array]:
    """Origin translations (K, 3) and rotations (K, 4) of joints."""
    xyz = np.array([joint.origin.xyz for joint in joints], dtype=np.float64).reshape(-1, 3)
    rpy = np.array([joint.origin.rpy for joint in joints], dtype=np.float64).reshape(-1, 3)
    return xyz, quaternion_from_rpy(rpy)


def _static_components(joints: Sequence[Joint]) -> Array:
    """(K, 7, 1): the origins alone."""
    xyz, rotation = _origins(joints)
    out = np.concatenate([xyz, rotation], axis=1)[:, :, np.newaxis]
    _canonicalize(out.transpose(1, 0, 2))
    return out


def _dynamic_components(joints: Sequence[Joint], q: Array, out: Array | None = None) -> Array:
    """(K, 7, N): origin · motion(q) for moving joints, with w >= 0 (written into ``out`` when given)."""
    xyz, rotation = _origins(joints)
    axis = np.array([joint.axis for joint in joints], dtype=np.float64).reshape(-1, 3)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    slides = np.array([joint.type is JointType.PRISMATIC for joint in joints], dtype=bool)
    revolute, prismatic = _selection(np.flatnonzero(~slides)), _selection(np.flatnonzero(slides))
    by_joint = np.ascontiguousarray(q.T)  # (K, N)
    if out is None:
        out = np.empty((len(joints), 7, q.shape[0]))
    if revolute is not None:
        # origin ⊗ (sin(q/2)·axis, cos(q/2)) = cos(q/2)·origin + sin(q/2)·(origin ⊗ (axis, 0))
        spin = quaternion_multiply(rotation[revolute], np.pad(axis[revolute], ((0, 0), (0, 1))))
        half = by_joint[revolute] * 0.5
        cos, sin = np.cos(half), np.sin(half)
        for c in range(4):
            out[revolute, 3 + c] = cos * rotation[revolute, c, np.newaxis] + sin * spin[:, c, np.newaxis]
        out[revolute, :3] = xyz[revolute, :, np.newaxis]
    if prismatic is not None:
        # origin translation + q · (axis in the parent frame)
        direction = quaternion_rotate(rotation[prismatic], axis[prismatic])
        for c in range(3):
            out[prismatic, c] = xyz[prismatic, c, np.newaxis] + by_joint[prismatic] * direction[:, c, np.newaxis]
        out[prismatic, 3:] = rotation[prismatic, :, np.newaxis]
    _canonicalize(out.transpose(1, 0, 2))
    return out


def _selection(index: NDArray[np.intp]) -> slice | NDArray[np.intp] | None:
    """Joints picked by ``index`` as a slice when they are consecutive (numpy then works on views, not
    copies), the index otherwise, None when there are none."""
    if not index.size:
        return None
    if index[-1] - index[0] == index.size - 1:
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def _canonicalize(components: Array) -> None:
    """Flip quaternions to w >= 0 in place; ``components`` is (7, ...)."""
    np.negative(components[3:], out=components[3:], where=components[6] < 0.0)


def _transforms(joints: Sequence[Joint], frame_prefix: str, translation: Array, rotation: Array) -> Transforms:
    parents = tuple(frame_prefix + joint.parent for joint in joints)
    children = tuple(frame_prefix + joint.child for joint in joints)
    return Transforms(parents, children, np.ascontiguousarray(translation), np.ascontiguousarray(rotation))


def _unpack(tfs: Transforms, block: slice = slice(None)) -> Array:
    """Transforms (of the samples in ``block``) → (K, 7, m)."""
    return np.ascontiguousarray(
        np.concatenate([tfs.translation[block], tfs.rotation[block]], axis=2).transpose(1, 2, 0)
    )


def _blocks(n: int) -> Iterator[slice]:
    """Slices of at most BLOCK samples covering range(n) (one empty slice when n is 0)."""
    for start in range(0, max(n, 1), BLOCK):
        yield slice(start, start + BLOCK)


def _compose(edges: Sequence[tuple[str, str, _Pose]], root: str) -> tuple[list[str], list[_Pose]]:
    """Breadth-first composition from ``root``: one (7, N) pose per reachable frame, each frame once
    (:func:`tfrec.frames.frame_tree`: below the first parent that reaches it; a pair given twice counts
    once, as first given; a cycle or a second parent is not followed)."""
    local: dict[tuple[str, str], _Pose] = {}
    for parent, child, components in edges:
        local.setdefault((parent, child), components)
    tree = frame_tree(local, roots=(root,))
    n = max((components.shape[-1] for _, _, components in edges), default=1)
    frames = tree.reachable(root)
    poses: dict[str, _Pose] = {root: np.array([[0.0], [0.0], [0.0], [0.0], [0.0], [0.0], [1.0]])}
    for frame in frames[1:]:
        parent = tree.parent[frame]
        poses[frame] = _compose_pair(poses[parent], local[(parent, frame)])
    return frames, [np.broadcast_to(poses[frame], (7, n)) for frame in frames]


def _compose_pair(a: _Pose, b: _Pose) -> _Pose:
    """The pose a · b: translation a.t + a.q b.t, rotation a.q ⊗ b.q."""
    atx, aty, atz, ax, ay, az, aw = a
    btx, bty, btz, bx, by, bz, bw = b
    # rotate b's translation by a's rotation: v + w·t + u × t with t = 2 u × v
    cx = 2.0 * (ay * btz - az * bty)
    cy = 2.0 * (az * btx - ax * btz)
    cz = 2.0 * (ax * bty - ay * btx)
    return np.stack(
        [
            atx + btx + aw * cx + (ay * cz - az * cy),
            aty + bty + aw * cy + (az * cx - ax * cz),
            atz + btz + aw * cz + (ax * cy - ay * cx),
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )
