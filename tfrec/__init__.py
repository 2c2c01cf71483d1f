"""tfrec: record, replay and compare what a robot description does — headless, without ROS.

The data flows one way: description → model → trajectory → kinematics → sinks → replay/diff.
Importing :mod:`tfrec` is cheap; each stage imports its heavy libraries itself.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

__all__ = [
    "DescriptionError",
    "Joint",
    "JointType",
    "KinematicsError",
    "Link",
    "RecordingError",
    "Robot",
    "TfrecError",
    "TrajectoryError",
    "__version__",
    "assert_recordings_match",
    "compare",
    "load_description",
    "make_trajectory",
    "parse_urdf",
    "read_recording",
]

from tfrec.errors import DescriptionError, KinematicsError, RecordingError, TfrecError, TrajectoryError
from tfrec.model import Joint, JointType, Link, Robot

if TYPE_CHECKING:
    from tfrec.description import load_description, parse_urdf
    from tfrec.diff.compare import assert_recordings_match, compare
    from tfrec.formats.reader import read_recording
    from tfrec.trajectory.generators import make_trajectory

_LAZY = {
    "load_description": "description",
    "parse_urdf": "description",
    "make_trajectory": "trajectory",
    "read_recording": "readers",
    "compare": "diff",
    "assert_recordings_match": "diff",
}


def __getattr__(name: str) -> Any:  # lazy: each stage imports its heavy libraries itself
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'tfrec' has no attribute {name!r}")
