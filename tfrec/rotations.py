"""Vectorized unit-quaternion arithmetic for the kinematics stage.

Quaternions are float64 arrays whose last axis is (x, y, z, w), the order of
geometry_msgs/Quaternion. Every function broadcasts over leading axes, so one call
handles all samples of a trajectory at once.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "canonical_quaternion",
    "matrix_from_quaternion",
    "quaternion_from_axis_angle",
    "quaternion_from_rpy",
    "quaternion_multiply",
    "quaternion_rotate",
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


def canonical_quaternion(q: ArrayLike) -> Array:
    """The same rotations with the sign chosen so that w >= 0."""
    q = np.asarray(q, dtype=np.float64)
    return np.where(q[..., 3:4] < 0.0, -q, q)


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
