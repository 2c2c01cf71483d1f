"""Joint trajectories from CSV files: a ``time`` column in seconds, one column per joint.

Example (joints without a column stay at their center)::

    time,joint1,joint2
    0.0,0.0,0.0
    0.5,0.2,-0.1
    1.0,0.4,-0.2

Cells are plain decimal numbers, optionally in scientific notation (``-1.5``, ``.5``, ``2e-3``),
with spaces around them allowed; Python's other float spellings (``1_0``, ``nan``, ``inf``,
``0x10``) are refused. A UTF-8 byte-order mark and Windows line endings are accepted.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Iterator, Mapping
from typing import IO

import numpy as np

from tfrec.conventions import STAMP_LIMIT_NS, STAMP_RANGE
from tfrec.errors import TrajectoryError
from tfrec.model import Joint, Robot
from tfrec.trajectory.joints import actuated_column, center_positions, position_range
from tfrec.trajectory.types import JointTrajectory

__all__ = ["read_csv_trajectory"]

_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
"""A plain decimal number, optionally in scientific notation (ASCII digits only)."""

_NOT_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


def read_csv_trajectory(
    path: str | os.PathLike[str],
    robot: Robot,
    *,
    overrides: Mapping[str, float] = {},
) -> JointTrajectory:
    """Read a trajectory from CSV: a ``time`` column in seconds and one column per joint.

    Samples are at the file's own times (``time_ns = round(time * 1e9)``, which must be
    non-negative, less than :data:`~tfrec.conventions.STAMP_LIMIT_NS` and increasing). A single
    row is a trajectory of one sample. Joints without a column stay at their center (or their
    override). Velocities are ``numpy.gradient`` of the positions over the times (0 for a
    single sample).

    Raises:
        TrajectoryError: the file cannot be read; a column is not an actuated joint, repeated,
            or also overridden; there is no row after the header; a cell is not a plain finite
            number; a row has the wrong number of cells; a time is negative, out of range or
            does not increase; a position is beyond its joint's limits (continuous joints
            excepted) or changes too fast for a finite velocity. The message starts with
            ``file:line:``.
    """
    name = os.fspath(path)
    center = center_positions(robot, overrides=overrides)  # checks the overrides first
    try:
        with open(path, newline="", encoding="utf-8-sig") as stream:
            rows = [(number, row) for number, row in _numbered_rows(stream) if any(cell.strip() for cell in row)]
    except FileNotFoundError as err:
        raise TrajectoryError(f"{name}: no such CSV file") from err
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise TrajectoryError(f"{name}: cannot read CSV: {err}") from err
    if not rows:
        raise TrajectoryError(f"{name}: empty file, expected a header with 'time' and joint names")
    header_line, header = rows[0]
    columns = [cell.strip() for cell in header]
    joints: dict[int, tuple[int, Joint]] = {}  # CSV column → (trajectory column, joint)
    seen: set[str] = set()
    for c, column in enumerate(columns):
        where = f"{name}:{header_line}: column '{column}'"
        if column in seen:
            raise TrajectoryError(f"{where} appears twice")
        seen.add(column)
        if column == "time":
            continue
        joints[c] = actuated_column(robot, column, where, verb="give")
        if column in overrides:
            raise TrajectoryError(f"{where} is also set by an override")
    if "time" not in seen:
        raise TrajectoryError(f"{name}:{header_line}: no 'time' column")
    if len(rows) == 1:
        raise TrajectoryError(f"{name}: no samples after the header")

    lines = np.array([number for number, _ in rows[1:]])
    values = np.empty((len(rows) - 1, len(columns)))
    for r, (number, row) in enumerate(rows[1:]):
        if len(row) != len(columns):
            raise TrajectoryError(f"{name}:{number}: {len(row)} cells, expected {len(columns)} as in the header")
        for c, cell in enumerate(row):
            values[r, c] = _number(cell, f"{name}:{number}", columns[c])

    seconds = values[:, columns.index("time")]
    with np.errstate(over="ignore"):  # beyond float64: inf, refused below
        rounded_ns = np.rint(seconds * 1e9)
    bad = np.flatnonzero(~((rounded_ns >= 0) & (rounded_ns < STAMP_LIMIT_NS)))
    if bad.size:
        r = bad[0]
        problem = "negative" if seconds[r] < 0 else f"out of range: {STAMP_RANGE}"
        raise TrajectoryError(f"{name}:{lines[r]}: time {float(seconds[r])!r} is {problem}")
    time_ns = rounded_ns.astype(np.int64)
    stuck = np.flatnonzero(np.diff(time_ns) <= 0)
    if stuck.size:
        r = stuck[0] + 1
        raise TrajectoryError(
            f"{name}:{lines[r]}: time {float(seconds[r])!r} does not increase (previous {float(seconds[r - 1])!r})"
        )

    positions = np.broadcast_to(center, (len(rows) - 1, len(center))).copy()
    for c, (j, joint) in joints.items():
        positions[:, j] = values[:, c]
        lower, upper = position_range(joint)
        beyond = np.flatnonzero((values[:, c] < lower) | (values[:, c] > upper))
        if beyond.size:
            r = beyond[0]
            raise TrajectoryError(
                f"{name}:{lines[r]}: {joint.name} = {float(values[r, c])!r} is beyond its limits [{lower!r}, {upper!r}]"
            )
    velocities = np.zeros_like(positions)
    if len(time_ns) > 1 and positions.shape[1]:
        with np.errstate(over="ignore", invalid="ignore"):  # refused below
            # integer spacings: times 1 ns apart stay apart even far from 0; a still joint gets exactly 0
            velocities = np.gradient(positions - positions[0], time_ns, axis=0) * 1e9
        fast = np.argwhere(~np.isfinite(velocities))
        if fast.size:
            r, j = fast[0]
            column = robot.actuated_joints[j].name
            raise TrajectoryError(f"{name}:{lines[r]}: {column} changes too fast for a finite velocity")
    return JointTrajectory(tuple(joint.name for joint in robot.actuated_joints), time_ns, positions, velocities)


def _number(cell: str, where: str, column: str) -> float:
    """The value of a cell: a plain finite decimal number, spaces around it allowed."""
    text = cell.strip()
    if _NUMBER.fullmatch(text):
        value = float(text)
        if math.isfinite(value):
            return value
    elif not _NOT_FINITE.fullmatch(text):
        raise TrajectoryError(f"{where}: '{text}' in column '{column}' is not a number")
    raise TrajectoryError(f"{where}: '{text}' in column '{column}' is not a finite number")


def _numbered_rows(stream: IO[str]) -> Iterator[tuple[int, list[str]]]:
    """CSV rows with the (1-based) line number on which each ends."""
    reader = csv.reader(stream)
    for row in reader:
        yield reader.line_num, row
