"""Forward kinematics with robot_state_publisher's semantics, batched over whole trajectories.

- :mod:`~tfrec.kinematics.rotations`: vectorized unit-quaternion arithmetic;
- :mod:`~tfrec.kinematics.joints`: mimic joints (actuated joints → every moving joint);
- :mod:`~tfrec.kinematics.fk`: :class:`Transforms`, static and dynamic transforms, composition.

Imports the trajectory type and the base modules.
"""

from __future__ import annotations

from tfrec.kinematics.fk import (
    DEFAULT_CHUNK_SAMPLES,
    DynamicChunk,
    Transforms,
    dynamic_transforms,
    iter_dynamic_chunks,
    link_poses,
    root_from_link,
    static_transforms,
)
from tfrec.kinematics.joints import all_joint_states, apply_mimic

__all__ = [
    "DEFAULT_CHUNK_SAMPLES",
    "DynamicChunk",
    "Transforms",
    "all_joint_states",
    "apply_mimic",
    "dynamic_transforms",
    "iter_dynamic_chunks",
    "link_poses",
    "root_from_link",
    "static_transforms",
]
