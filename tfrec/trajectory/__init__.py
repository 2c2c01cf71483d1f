"""Joint trajectories, as joint_state_publisher(_gui) makes them: center, random, sine, sweep, or a CSV file.

- :mod:`~tfrec.trajectory.types`: :class:`JointTrajectory` (and the lazily evaluated :class:`GeneratedTrajectory`);
- :mod:`~tfrec.trajectory.generators`: :func:`make_trajectory` and the four generated kinds;
- :mod:`~tfrec.trajectory.csv_file`: trajectories from CSV files;
- :mod:`~tfrec.trajectory.joints`: a joint's range, center and column.

Imports only the base modules (errors, conventions, model).
"""

from __future__ import annotations

from tfrec.trajectory.clock import sample_times_ns
from tfrec.trajectory.csv_file import read_csv_trajectory
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.types import GeneratedTrajectory, JointTrajectory, TrajectoryKind

__all__ = [
    "GeneratedTrajectory",
    "JointTrajectory",
    "TrajectoryKind",
    "make_trajectory",
    "read_csv_trajectory",
    "sample_times_ns",
]
