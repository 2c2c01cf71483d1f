"""The joint_state_publisher_gui half of ``tfrec serve``: the actuated joints' positions, which a client sets.

Each actuated joint is one value, kept within its range (:func:`tfrec.trajectory.joints.joint_bounds`: its limits,
narrowed to its soft limits unless ``soft_limits`` is False; -π..π for a continuous joint), as the sliders of
joint_state_publisher_gui keep it. ``Center`` and ``Randomize`` are that GUI's two buttons. Mimic joints are never
set: forward kinematics derives them (:func:`tfrec.kinematics.joints.all_joint_states`).

Clients call in from the server's threads; every method takes a lock.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import TrajectoryError
from tfrec.model import Robot
from tfrec.trajectory.joints import bounds_arrays, center_positions

__all__ = ["JointControl"]

Array = NDArray[np.float64]


class JointControl:
    """The positions of a robot's actuated joints, each within its range.

    Args:
        robot: the robot.
        seed: the seed of :meth:`randomize`.
        soft_limits: keep joints within their ``<safety_controller>`` soft limits, as joint_state_publisher does
            (``use_smallest_joint_limits``); False: their hard limits.
        overrides: joint name → position where ``Center`` puts it (joint_state_publisher's ``zeros``).

    Raises:
        TrajectoryError: a revolute or prismatic joint without ``<limit>``, or a bad override.
    """

    def __init__(self, robot: Robot, *, seed: int = 0, soft_limits: bool = True,
                 overrides: Mapping[str, float] = {}) -> None:
        self.names = tuple(joint.name for joint in robot.actuated_joints)
        self.lower, self.upper = bounds_arrays(robot, soft_limits=soft_limits)
        self._center = center_positions(robot, overrides=overrides, soft_limits=soft_limits)
        self._column = {name: i for i, name in enumerate(self.names)}
        self._positions = self._center.copy()
        self._rng = np.random.default_rng(seed)
        self._lock = threading.Lock()
        self._version = 0

    @property
    def version(self) -> int:
        """Counts the changes: a caller that saw this number has seen every change before it."""
        with self._lock:
            return self._version

    def positions(self) -> Array:
        """The actuated joints' positions, float64 (J,), in the order of :attr:`names` (a copy)."""
        with self._lock:
            positions: Array = self._positions.copy()
        return positions

    def set(self, name: str, value: object) -> float:
        """Move joint ``name`` to ``value``, clamped to its range; returns the position taken.

        Raises:
            TrajectoryError: ``name`` is no actuated joint, or ``value`` is no finite number.
        """
        column = self._column.get(name)
        if column is None:
            raise TrajectoryError(f"'{name}' is not an actuated joint")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise TrajectoryError(f"joint '{name}': {value!r} is not a finite number")
        position = min(max(float(value), float(self.lower[column])), float(self.upper[column]))
        with self._lock:
            self._positions[column] = position
            self._version += 1
        return position

    def center(self) -> None:
        """joint_state_publisher_gui's Center: 0, or the middle of a range without 0."""
        with self._lock:
            self._positions[:] = self._center
            self._version += 1

    def randomize(self) -> None:
        """joint_state_publisher_gui's Randomize: each joint uniform within its range."""
        with self._lock:
            middle = self.lower / 2.0 + self.upper / 2.0  # in halves: a range of ±1.8e308 would overflow
            half = self.upper / 2.0 - self.lower / 2.0
            self._positions[:] = middle + half * self._rng.uniform(-1.0, 1.0, size=len(self.names))
            self._version += 1
