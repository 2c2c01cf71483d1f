"""robot_state_publisher's joint rules: from the actuated joints to every moving joint.

A trajectory holds the actuated joints; a mimic joint's position is derived from the joint it
mimics (``multiplier · master + offset``), chains resolved in dependency order
(:attr:`tfrec.model.Robot.mimic_order`). Record and replay both go through :func:`apply_mimic`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import TrajectoryError
from tfrec.model import Robot
from tfrec.trajectory.types import JointTrajectory

__all__ = [
    "all_joint_states",
    "apply_mimic",
]

Array = NDArray[np.float64]


def all_joint_states(robot: Robot, trajectory: JointTrajectory) -> tuple[tuple[str, ...], Array, Array]:
    """Every moving joint, as joint_state_publisher publishes it: actuated and mimic joints.

    A mimic joint's position is ``multiplier · master + offset`` and its velocity
    ``multiplier · master velocity``; chains are resolved in dependency order
    (:attr:`Robot.mimic_order`). A mimic of a joint that does not move stays at ``offset``.
    Works on any piece of a trajectory (see :meth:`JointTrajectory.chunks`).

    Returns:
        (names, positions, velocities): the moving joints in URDF document order, and
        float64 (N, M) arrays.

    Raises:
        TrajectoryError: the trajectory does not have exactly the robot's actuated joints.
    """
    column = {name: i for i, name in enumerate(trajectory.joint_names)}
    for joint in robot.actuated_joints:
        if joint.name not in column:
            raise TrajectoryError(f"trajectory has no position for joint '{joint.name}' of robot '{robot.name}'")
    if len(column) != len(robot.actuated_joints):
        extra = next(n for n in trajectory.joint_names if n not in {j.name for j in robot.actuated_joints})
        raise TrajectoryError(f"trajectory joint '{extra}' is not an actuated joint of robot '{robot.name}'")
    names = tuple(joint.name for joint in robot.moving_joints)
    index = {name: k for k, name in enumerate(names)}
    positions = np.zeros((len(trajectory), len(names)))
    velocities = np.zeros((len(trajectory), len(names)))
    for joint in robot.actuated_joints:
        positions[:, index[joint.name]] = trajectory.positions[:, column[joint.name]]
        velocities[:, index[joint.name]] = trajectory.velocities[:, column[joint.name]]
    apply_mimic(robot, names, positions, velocities)
    return names, positions, velocities


def apply_mimic(
    robot: Robot, names: Sequence[str], positions: Array, velocities: Array | None = None, *,
    only_missing: bool = False,
) -> None:
    """Fill in the columns of the mimic joints from their masters, in place.

    A mimic joint's position is ``multiplier · master + offset`` and its velocity
    ``multiplier · master velocity``; chains are resolved in dependency order
    (:attr:`Robot.mimic_order`). A mimic of a joint that does not move stays at ``offset``
    (and its velocity is left as it is).

    Args:
        robot: the robot.
        names: the joints of the columns; every moving mimic joint of the robot must be among them.
        positions: float64 (N, len(names)).
        velocities: float64 (N, len(names)), or None.
        only_missing: fill only the rows where a mimic joint's position is NaN (a /joint_states
            message without it, as robot_state_publisher does); the others keep their own.
    """
    index = {name: k for k, name in enumerate(names)}
    for joint in robot.mimic_order:
        assert joint.mimic is not None
        k = index[joint.name]
        rows: NDArray[np.bool_] | slice = np.isnan(positions[:, k]) if only_missing else slice(None)
        master = index.get(joint.mimic.joint)
        if master is None:
            positions[rows, k] = joint.mimic.offset
            continue
        with np.errstate(over="ignore", invalid="ignore"):  # a multiplier of 1e308: inf, refused by the caller
            positions[rows, k] = joint.mimic.multiplier * positions[rows, master] + joint.mimic.offset
            if velocities is not None:
                velocities[rows, k] = joint.mimic.multiplier * velocities[rows, master] + 0.0  # no -0.0
