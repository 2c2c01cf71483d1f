"""Forward kinematics with robot_state_publisher's semantics, batched over whole trajectories.

- :mod:`~tfrec.kinematics.rotations`: vectorized unit-quaternion arithmetic;
- :mod:`~tfrec.kinematics.joints`: mimic joints (actuated joints → every moving joint);
- :mod:`~tfrec.kinematics.fk`: :class:`Transforms`, static and dynamic transforms, composition.

Imports the trajectory type and the base modules.
"""

from __future__ import annotations

from tfrec.kinematics.fk import (
    DEFAULT_CHUNK_SIZE,
    DynamicChunk,
    Transforms,
    dynamic_transforms,
    iter_dynamic_chunks,
    link_poses,
    static_transforms,
    world_from_link,
)
from tfrec.kinematics.joints import all_joint_states, apply_mimic

__all__ = [
    "DEFAULT_CHUNK_SIZE",
    "DynamicChunk",
    "Transforms",
    "all_joint_states",
    "apply_mimic",
    "dynamic_transforms",
    "iter_dynamic_chunks",
    "link_poses",
    "static_transforms",
    "world_from_link",
]
