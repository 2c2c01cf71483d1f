"""Errors raised by tfrec, one class per stage of the data flow.

Library code raises these and never prints; the CLI turns them into one line
``tfrec: error: <message>`` and exit code 2. Messages start with the input they are about
(file, line, element) and name the library's parameters in backquotes (```start_s```); the CLI
shows each as its flag (``--start``). Foreign errors are chained (``raise ... from err``) so that
a traceback (``--debug``, tests) keeps the cause.

Recoverable oddities are warnings (``warnings.warn``), shown by the CLI as ``tfrec: warning: ...``;
:class:`TfrecWarning` is the category of tfrec's warnings, for filters (``warnings.filterwarnings("error",
category=tfrec.TfrecWarning)``; pytest's ``filterwarnings = ignore::tfrec.LegacyXacroWarning``).
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any, ClassVar

__all__ = [
    "ConvertError",
    "DescriptionError",
    "DiffError",
    "FleetError",
    "KinematicsError",
    "LackingWarning",
    "LegacyXacroWarning",
    "PlotError",
    "ReadError",
    "RecordingError",
    "ReplayError",
    "TfrecError",
    "TfrecWarning",
    "TrajectoryError",
    "WriteError",
    "display_path",
    "one_line",
    "printable",
    "warn_again",
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
    """A recording could not be written or read: the base of :class:`ReadError` and :class:`WriteError`."""


class ReadError(RecordingError):
    """A recording could not be read: a missing file, not a recording, nothing readable, bad metadata."""


class WriteError(RecordingError):
    """An output could not be written: bad options, an existing target, a failed write."""


class ReplayError(TfrecError):
    """A recording could not be replayed or re-simulated (bad window, topics, no robot, no viewer)."""


class DiffError(TfrecError):
    """Two recordings or descriptions could not be compared (bad tolerances, topics in neither)."""


class ConvertError(TfrecError):
    """A recording could not be converted (bad options, a message that cannot be carried over)."""


class PlotError(TfrecError):
    """A picture could not be made: an unknown output format, nothing to draw, an unknown frame."""


class FleetError(TfrecError):
    """A fleet run (``tfrec check``, a directory ``diff``) could not start: no recordings, no engine."""


class TfrecWarning(UserWarning):
    """The category of tfrec's warnings: something recoverable in an input, named as an error would be."""


class LackingWarning(TfrecWarning):
    """What is replayed lacks something (a joint's positions, any sample in the window). Of a recording read piece
    by piece (``replay --check``, ``tfrec check``), said only when every piece lacks it."""


class LegacyXacroWarning(TfrecWarning):
    """A xacro description written in the Kinetic-era dialect (xacro <= 1.13: ``<property>``, ``<macro>``,
    ``<include>``, macro calls … without the ``xacro:`` prefix), expanded as ROS Kinetic/Melodic's xacro did
    (docs/xacro.md); with ``strict_xacro``, left unexpanded as ROS 2's xacro does. Silence it with the
    filter ``ignore::tfrec.LegacyXacroWarning`` (``warnings.filterwarnings("ignore",
    category=tfrec.LegacyXacroWarning)``, pytest's ``filterwarnings``), or ``--quiet-legacy``."""

    SILENCE: ClassVar[str] = "the warning filter ignore::tfrec.LegacyXacroWarning"
    """How its message says to silence it (the CLI says ``--quiet-legacy`` instead)."""


def display_path(path: str | os.PathLike[str] | None) -> str:
    """A path as a user would type it in messages and titles: relative to the working folder when inside it,
    with the characters a terminal acts on and the bytes that are not UTF-8 escaped (:func:`printable`: a
    matplotlib title or a Rerun name cannot hold a lone surrogate)."""
    if path is None:
        return "<string>"
    p = Path(path)
    cwd = Path.cwd().resolve()
    if cwd == Path(cwd.anchor):  # from / every path is "relative": keep it as given
        return printable(str(p))
    try:
        return printable(str(p.resolve().relative_to(cwd)))
    except ValueError:
        return printable(str(p))


def one_line(text: str) -> str:
    """A library's error message on one line: runs of whitespace (newlines too) become one space."""
    return " ".join(text.split())


def suggest(name: str, names: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of names (a typo), or ``""``."""
    import difflib

    close = difflib.get_close_matches(name, sorted(set(names)), n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def printable(text: str, *, keep: str = "") -> str:
    """``text`` as a terminal may show it: every character that is not printable is written as its Python
    escape — control characters (ESC ``\\x1b``, CR ``\\r``, BEL ``\\x07``, NUL), format characters such as a
    right-to-left override (``\\u202e``), the lone surrogates that stand for the undecodable bytes of a file
    name (``\\udcff``) — so that a name from an input (a file found in a folder, a topic, frame or joint name)
    cannot clear the screen, move the cursor, recolour a verdict or set the window title.

    Args:
        text: what is to be shown.
        keep: characters left as they are: ``"\\n\\t"`` for text of several lines that tfrec laid out itself.
    """
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() or c in keep else c.encode("unicode_escape").decode("ascii") for c in text)


def warn_again(warning: warnings.WarningMessage, registry: dict[Any, Any] | None = None) -> None:
    """Give a warning caught (``warnings.catch_warnings(record=True)``) again, as it was given: its category, place
    and module — so that filters on the module (``-W ignore::...:tfrec.formats``) still match it."""
    module = next((name for name, loaded in list(sys.modules.items())
                   if getattr(loaded, "__file__", None) == warning.filename), None)
    warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno,
                           module=module, registry=registry, source=warning.source)
