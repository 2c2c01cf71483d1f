"""joint_state_publisher's rules for one joint: its range, its center, and which column it is.

A trajectory holds the actuated joints of a robot (revolute, continuous and prismatic joints
that mimic nothing, in URDF document order). These rules are shared by the generators and by
CSV trajectories.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import TrajectoryError
from tfrec.model import Joint, JointType, Robot

__all__ = [
    "actuated_column",
    "bounds_arrays",
    "center_positions",
    "joint_bounds",
    "pinned_columns",
    "position_range",
    "velocity_limits",
]

Array = NDArray[np.float64]


def joint_bounds(joint: Joint, *, soft_limits: bool = True) -> tuple[float, float]:
    """The range joint_state_publisher gives a moving joint: its limits, or [-π, π] for a continuous
    joint, narrowed to its ``<safety_controller>`` soft limits unless ``soft_limits`` is False (what
    joint_state_publisher's ``use_smallest_joint_limits`` parameter, True by default, does). Soft
    limits that leave no range (lower above upper) are not used."""
    if joint.type is JointType.CONTINUOUS:
        lower, upper = -math.pi, math.pi
    elif joint.limit is None:
        raise TrajectoryError(f"joint '{joint.name}' is {joint.type.value} but has no <limit>")
    else:
        lower, upper = joint.limit.lower, joint.limit.upper
    safety = joint.safety
    if soft_limits and safety is not None:
        soft_lower = lower if safety.soft_lower_limit is None else max(lower, safety.soft_lower_limit)
        soft_upper = upper if safety.soft_upper_limit is None else min(upper, safety.soft_upper_limit)
        if soft_lower <= soft_upper:
            return soft_lower, soft_upper
    return lower, upper


def center_positions(robot: Robot, *, overrides: Mapping[str, float] = {}, soft_limits: bool = True) -> Array:
    """joint_state_publisher_gui's Center: 0, or the middle of the range (:func:`joint_bounds`) when 0
    is outside it.

    Returns:
        float64 (J,), one value per actuated joint; ``overrides`` replace the computed ones.
    """
    pinned = pinned_columns(robot, overrides)
    center = np.empty(len(robot.actuated_joints))
    for i, joint in enumerate(robot.actuated_joints):
        lower, upper = joint_bounds(joint, soft_limits=soft_limits)
        center[i] = 0.0 if lower <= 0.0 <= upper else (lower + upper) / 2.0
    for i, value in pinned.items():
        center[i] = value
    return center


def actuated_column(robot: Robot, name: str, where: str, *, verb: str = "set") -> tuple[int, Joint]:
    """The column of the actuated joint ``name`` in a trajectory (the order of ``robot.actuated_joints``).

    Args:
        robot: the robot.
        name: the joint a user named (an override, a CSV column).
        where: how messages name it, e.g. ``elbow=0.5: 'elbow'`` or ``arm.csv:1: column 'elbow'``.
        verb: what the user does with a joint, for the message about a mimic joint: ``set`` or ``give``.

    Returns:
        (the column, the joint).

    Raises:
        TrajectoryError: ``name`` is not a joint of the robot, is a mimic joint, or has no position
            (a fixed, floating or planar joint).
    """
    joint = robot.joint_by_name.get(name)
    if joint is None:
        raise TrajectoryError(f"{where} is not a joint of robot '{robot.name}'")
    if joint.mimic is not None and joint.type.moves:
        raise TrajectoryError(f"{where} is a mimic joint; {verb} '{joint.mimic.joint}' instead")
    if not joint.actuated:
        raise TrajectoryError(f"{where} is a {joint.type.value} joint, which has no position")
    return robot.actuated_joints.index(joint), joint


def position_range(joint: Joint) -> tuple[float, float]:
    """The positions a moving joint may take: its limits; unbounded for a continuous joint.

    Raises:
        TrajectoryError: a revolute or prismatic joint without ``<limit>``.
    """
    if joint.type is JointType.CONTINUOUS:
        return -math.inf, math.inf
    return joint_bounds(joint, soft_limits=False)


def pinned_columns(robot: Robot, overrides: Mapping[str, float]) -> dict[int, float]:
    """Check ``overrides`` (joint name → position) and map them to actuated-joint columns.

    Raises:
        TrajectoryError: a name that is not an actuated joint, a value that is not finite or is
            beyond the joint's limits.
    """
    pinned: dict[int, float] = {}
    for name, value in overrides.items():
        where = f"{name}={value!r}"
        column, joint = actuated_column(robot, name, f"{where}: '{name}'")
        if not (isinstance(value, numbers.Real) and math.isfinite(value)):
            raise TrajectoryError(f"{where}: not a finite number")
        lower, upper = position_range(joint)
        if not lower <= value <= upper:
            raise TrajectoryError(f"{where}: beyond the limits [{lower!r}, {upper!r}] of joint '{name}'")
        pinned[column] = float(value)
    return pinned


def velocity_limits(robot: Robot) -> Array:
    """The ``<limit velocity>`` of each actuated joint, float64 (J,); inf where there is none (no ``<limit>``, or a
    velocity of 0 or less, which limits nothing)."""
    out = np.full(len(robot.actuated_joints), np.inf)
    for i, joint in enumerate(robot.actuated_joints):
        if joint.limit is not None and math.isfinite(joint.limit.velocity) and joint.limit.velocity > 0:
            out[i] = joint.limit.velocity
    return out


def bounds_arrays(robot: Robot, *, soft_limits: bool = True) -> tuple[Array, Array]:
    """Lower and upper bounds (:func:`joint_bounds`) of the actuated joints, float64 (J,) each."""
    bounds = [joint_bounds(joint, soft_limits=soft_limits) for joint in robot.actuated_joints]
    return np.array([b[0] for b in bounds], dtype=np.float64), np.array([b[1] for b in bounds], dtype=np.float64)
