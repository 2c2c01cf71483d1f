"""tfrec: record, replay and compare what a robot description does — headless, without ROS.

The data flows one way, one subpackage per stage (docs/architecture.md)::

    description → trajectory → kinematics → formats (MCAP, rosbag2, ROS 1, .rrd) → record / replay / diff

This module is the public API (docs/api.md); everything else is reached through its subpackage.
Importing :mod:`tfrec` is cheap: each function imports its stage when first used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from tfrec._version import __version__

__all__ = [
    "ConvertError",
    "DescriptionError",
    "DiffError",
    "FleetError",
    "Joint",
    "JointTrajectory",
    "JointType",
    "KinematicsError",
    "LegacyXacroWarning",
    "Link",
    "ReadError",
    "RecordedRobot",
    "Recording",
    "RecordingError",
    "ReplayError",
    "Robot",
    "TfrecError",
    "TfrecWarning",
    "TrajectoryError",
    "Transforms",
    "WriteError",
    "__version__",
    "assert_descriptions_match",
    "assert_recordings_match",
    "check_replay",
    "compare",
    "compare_descriptions",
    "find_robots",
    "load_description",
    "load_replay",
    "make_trajectory",
    "parse_urdf",
    "plan_outputs",
    "read_recording",
    "record",
]

from tfrec.errors import (
    ConvertError,
    DescriptionError,
    DiffError,
    FleetError,
    KinematicsError,
    LegacyXacroWarning,
    ReadError,
    RecordingError,
    ReplayError,
    TfrecError,
    TfrecWarning,
    TrajectoryError,
    WriteError,
)
from tfrec.model import Joint, JointType, Link, Robot

if TYPE_CHECKING:
    from tfrec.description import load_description, parse_urdf
    from tfrec.diff import assert_descriptions_match, assert_recordings_match, compare, compare_descriptions
    from tfrec.formats import read_recording
    from tfrec.recorder import plan_outputs, record
    from tfrec.recording import RecordedRobot, Recording, Transforms
    from tfrec.replay import check_replay, load_replay
    from tfrec.robots import find_robots
    from tfrec.trajectory import JointTrajectory, make_trajectory

_LAZY = {
    "load_description": "tfrec.description",
    "parse_urdf": "tfrec.description",
    "make_trajectory": "tfrec.trajectory",
    "JointTrajectory": "tfrec.trajectory",
    "Transforms": "tfrec.recording",
    "record": "tfrec.recorder",
    "plan_outputs": "tfrec.recorder",
    "Recording": "tfrec.recording",
    "read_recording": "tfrec.formats",
    "compare": "tfrec.diff",
    "assert_recordings_match": "tfrec.diff",
    "compare_descriptions": "tfrec.diff",
    "assert_descriptions_match": "tfrec.diff",
    "load_replay": "tfrec.replay",
    "check_replay": "tfrec.replay",
    "find_robots": "tfrec.robots",
    "RecordedRobot": "tfrec.recording",
}
"""Each lazily exported name and the module it comes from (docs/api.md)."""


def _stage(module: str) -> Any:
    """The stage ``module``, imported by an import statement (no ``importlib``: the import graph stays what
    import-linter sees)."""
    if module == "tfrec.description":
        import tfrec.description

        return tfrec.description
    if module == "tfrec.trajectory":
        import tfrec.trajectory

        return tfrec.trajectory
    if module == "tfrec.kinematics":
        import tfrec.kinematics

        return tfrec.kinematics
    if module == "tfrec.recording":
        import tfrec.recording

        return tfrec.recording
    if module == "tfrec.recorder":
        import tfrec.recorder

        return tfrec.recorder
    if module == "tfrec.formats":
        import tfrec.formats

        return tfrec.formats
    if module == "tfrec.diff":
        import tfrec.diff

        return tfrec.diff
    if module == "tfrec.replay":
        import tfrec.replay

        return tfrec.replay
    import tfrec.robots

    return tfrec.robots


def __getattr__(name: str) -> Any:  # lazy: each stage imports its heavy libraries itself
    if name in _LAZY:
        return getattr(_stage(_LAZY[name]), name)
    raise AttributeError(f"module 'tfrec' has no attribute {name!r}")
