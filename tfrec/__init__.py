"""tfrec: record, replay and compare what a robot description does — headless, without ROS.

The data flows one way: description → model → trajectory → kinematics → sinks → replay/diff.
Importing :mod:`tfrec` is cheap; each stage imports its heavy libraries itself.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "TfrecError",
    "DescriptionError",
    "TrajectoryError",
    "KinematicsError",
    "RecordingError",
    "Robot",
    "Joint",
    "JointType",
    "Link",
    "load_description",
    "parse_urdf",
]

from .errors import DescriptionError, KinematicsError, RecordingError, TfrecError, TrajectoryError
from .model import Joint, JointType, Link, Robot

if TYPE_CHECKING:
    from .description import load_description, parse_urdf


def __getattr__(name: str) -> Any:  # lazy: loading descriptions imports xacro
    if name in ("load_description", "parse_urdf"):
        from . import description

        return getattr(description, name)
    raise AttributeError(f"module 'tfrec' has no attribute {name!r}")
