"""Vectorized unit-quaternion arithmetic: kinematics, and comparing rotations in diff and replay.

Quaternions are float64 arrays whose last axis is (x, y, z, w), the order of
geometry_msgs/Quaternion. Every function broadcasts over leading axes, so one call
handles all samples of a trajectory at once.

The angle between two rotations is :func:`rotation_error` everywhere in tfrec (recordings,
robot descriptions, re-simulation): ``2·atan2(|v|, |w|)`` of the relative rotation, which keeps
its precision for tiny angles where ``2·acos(|q_a·q_b|)`` rounds to 0.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "matrix_from_quaternion",
    "quaternion_from_axis_angle",
    "quaternion_from_rpy",
    "quaternion_multiply",
    "quaternion_rotate",
    "relative_angle",
    "rotation_error",
    "slerp",
]

Array = NDArray[np.float64]


def quaternion_from_rpy(rpy: ArrayLike) -> Array:
    """The rotation of a URDF ``rpy`` triple: fixed-axis roll, pitch, yaw.

    The matrix is Rz(yaw) @ Ry(pitch) @ Rx(roll), as in urdfdom and tf2's ``setRPY``.

    Args:
        rpy: roll, pitch, yaw in radians, shape (..., 3).

    Returns:
        Unit quaternions (x, y, z, w), shape (..., 4).
    """
    half = np.asarray(rpy, dtype=np.float64) * 0.5
    cr, cp, cy = np.cos(half[..., 0]), np.cos(half[..., 1]), np.cos(half[..., 2])
    sr, sp, sy = np.sin(half[..., 0]), np.sin(half[..., 1]), np.sin(half[..., 2])
    return np.stack(
        [
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ],
        axis=-1,
    )


def quaternion_from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> Array:
    """The rotation by ``angle`` radians about the unit vector ``axis``.

    Args:
        axis: unit vectors, shape (..., 3).
        angle: angles in radians, shape (...,), broadcast against ``axis``.
    """
    half = np.asarray(angle, dtype=np.float64)[..., np.newaxis] * 0.5
    return np.concatenate([np.sin(half) * np.asarray(axis, dtype=np.float64), np.cos(half)], axis=-1)


def quaternion_multiply(a: ArrayLike, b: ArrayLike) -> Array:
    """The Hamilton product ``a ⊗ b``: the rotation b followed, in the outer frame, by a."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def quaternion_rotate(q: ArrayLike, v: ArrayLike) -> Array:
    """Rotate vectors ``v`` (..., 3) by unit quaternions ``q`` (..., 4)."""
    q = np.asarray(q, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    u = q[..., :3]
    t = 2.0 * np.cross(u, v)
    return v + q[..., 3:4] * t + np.cross(u, t)


def matrix_from_quaternion(q: ArrayLike) -> Array:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4)."""
    q = np.asarray(q, dtype=np.float64)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    rows = [
        [1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy)],
        [2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx)],
        [2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy)],
    ]
    out = np.empty(q.shape[:-1] + (3, 3), dtype=np.float64)
    for i, row in enumerate(rows):
        for j, value in enumerate(row):
            out[..., i, j] = value
    return out


def rotation_error(qa: Array, qb: Array) -> Array:
    """The angle (rad) of ``qa⁻¹ qb`` for quaternions (..., 4) in (x, y, z, w) order.

    ``2·atan2(|v|, |w|)`` of the relative rotation: in [0, π], the same for q and -q, and
    accurate for tiny angles (unlike ``acos``). The quaternions need not be normalized.
    """
    return relative_angle([qa[..., i] for i in range(4)], [qb[..., i] for i in range(4)])


def relative_angle(qa: Sequence[Array], qb: Sequence[Array]) -> Array:
    """:func:`rotation_error` of quaternions given by their components (x, y, z, w), each an array: the same
    values, for quaternions held one component per row (no strided reads of an (n, 4) array)."""
    ax, ay, az, aw = qa
    bx, by, bz, bw = qb
    # v = wa·vb − wb·va − va × vb, by components (np.cross costs ~30 µs a call on small arrays)
    vx = aw * bx - bw * ax - (ay * bz - az * by)
    vy = aw * by - bw * ay - (az * bx - ax * bz)
    vz = aw * bz - bw * az - (ax * by - ay * bx)
    w = aw * bw + ax * bx + ay * by + az * bz
    angle: Array = 2.0 * np.arctan2(np.sqrt(vx * vx + vy * vy + vz * vz), np.abs(w))
    return angle


def slerp(q0: Array, q1: Array, frac: Array) -> Array:
    """Spherical interpolation between unit quaternions (n, 4) at fractions (n,), the short way round."""
    q0 = q0 / np.linalg.norm(q0, axis=-1, keepdims=True)
    q1 = q1 / np.linalg.norm(q1, axis=-1, keepdims=True)
    dot = np.einsum("ij,ij->i", q0, q1)
    q1 = np.where(dot[:, None] < 0.0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin = np.sin(theta)
    small = sin < 1e-9
    safe = np.where(small, 1.0, sin)
    w0 = np.where(small, 1.0 - frac, np.sin((1.0 - frac) * theta) / safe)
    w1 = np.where(small, frac, np.sin(frac * theta) / safe)
    out = w0[:, None] * q0 + w1[:, None] * q1
    unit: Array = out / np.linalg.norm(out, axis=-1, keepdims=True)  # numpy types norm(axis=...) as Any
    return unit
