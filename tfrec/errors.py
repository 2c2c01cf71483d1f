"""Errors raised by tfrec, one class per stage of the data flow.

Library code raises these and never prints; the CLI turns them into one line
``tfrec: error: <message>`` and exit code 2.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = [
    "DescriptionError",
    "KinematicsError",
    "RecordingError",
    "TfrecError",
    "TrajectoryError",
]


class TfrecError(Exception):
    """Base class of every error tfrec reports to a user (one line, input first)."""


class DescriptionError(TfrecError):
    """A robot description could not be loaded: xacro, XML, packages or URDF validation."""


class TrajectoryError(TfrecError):
    """A joint trajectory could not be made (bad option, bad CSV file, unknown joint)."""


class KinematicsError(TfrecError):
    """Forward kinematics could not be computed for the given positions."""


class RecordingError(TfrecError):
    """A recording could not be written or read."""


def display_path(path: str | os.PathLike[str] | None) -> str:
    """A path as a user would type it in messages: relative to the working folder when inside it."""
    if path is None:
        return "<string>"
    p = Path(path)
    cwd = Path.cwd().resolve()
    if cwd == Path(cwd.anchor):  # from / every path is "relative": keep it as given
        return str(p)
    try:
        return str(p.resolve().relative_to(cwd))
    except ValueError:
        return str(p)


def one_line(text: str) -> str:
    """A library's error message on one line: runs of whitespace (newlines too) become one space."""
    return " ".join(text.split())
