"""Joint trajectories from CSV files: a ``time`` column in seconds, one column per joint.

Example (joints without a column stay at their center)::

    time,joint1,joint2
    0.0,0.0,0.0
    0.5,0.2,-0.1
    1.0,0.4,-0.2
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterator, Mapping
from typing import IO

import numpy as np

from tfrec.errors import TrajectoryError
from tfrec.model import JointType, Robot
from tfrec.trajectory import JointTrajectory, center_positions, joint_bounds

__all__ = ["read_csv_trajectory"]


def read_csv_trajectory(
    path: str | os.PathLike[str],
    robot: Robot,
    *,
    overrides: Mapping[str, float] = {},
) -> JointTrajectory:
    """Read a trajectory from CSV: a ``time`` column in seconds and one column per joint.

    Samples are at the file's own times (``time_ns = round(time * 1e9)``, which must be
    non-negative and increasing). Joints without a column stay at their center (or their
    override). Velocities are ``numpy.gradient`` of the positions over the times.

    Raises:
        TrajectoryError: the file cannot be read; a column is not an actuated joint, repeated,
            or also overridden; a cell is not a finite number; a row has the wrong number of
            cells; times do not increase; a position is beyond its joint's limits
            (continuous joints excepted). The message starts with ``file:line:``.
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
    actuated = {joint.name: i for i, joint in enumerate(robot.actuated_joints)}
    seen: set[str] = set()
    for column in columns:
        where = f"{name}:{header_line}: column '{column}'"
        if column in seen:
            raise TrajectoryError(f"{where} appears twice")
        seen.add(column)
        if column == "time":
            continue
        joint = robot.joint_by_name.get(column)
        if joint is None:
            raise TrajectoryError(f"{where} is not a joint of robot '{robot.name}'")
        if joint.mimic is not None and joint.type.moves:
            raise TrajectoryError(f"{where} is a mimic joint; give '{joint.mimic.joint}' instead")
        if column not in actuated:
            raise TrajectoryError(f"{where} is a {joint.type.value} joint, which has no position")
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
            try:
                value = float(cell)
            except ValueError:
                raise TrajectoryError(f"{name}:{number}: '{cell}' in column '{columns[c]}' is not a number") from None
            if not math.isfinite(value):
                raise TrajectoryError(f"{name}:{number}: '{cell.strip()}' in column '{columns[c]}' is not finite")
            values[r, c] = value

    seconds = values[:, columns.index("time")]
    time_ns = np.rint(seconds * 1e9).astype(np.int64)
    negative = np.flatnonzero(time_ns < 0)
    if negative.size:
        r = negative[0]
        raise TrajectoryError(f"{name}:{lines[r]}: time {float(seconds[r])!r} is negative")
    stuck = np.flatnonzero(np.diff(time_ns) <= 0)
    if stuck.size:
        r = stuck[0] + 1
        raise TrajectoryError(
            f"{name}:{lines[r]}: time {float(seconds[r])!r} does not increase (previous {float(seconds[r - 1])!r})"
        )

    positions = np.broadcast_to(center, (len(rows) - 1, len(actuated))).copy()
    for c, column in enumerate(columns):
        if column == "time":
            continue
        joint = robot.joint_by_name[column]
        positions[:, actuated[column]] = values[:, c]
        if joint.type is JointType.CONTINUOUS:
            continue
        lower, upper = joint_bounds(joint)
        beyond = np.flatnonzero((values[:, c] < lower) | (values[:, c] > upper))
        if beyond.size:
            r = beyond[0]
            raise TrajectoryError(
                f"{name}:{lines[r]}: {column} = {float(values[r, c])!r} is beyond its limits [{lower!r}, {upper!r}]"
            )
    if len(time_ns) > 1 and positions.shape[1]:
        velocities = np.gradient(positions, time_ns * 1e-9, axis=0)
    else:
        velocities = np.zeros_like(positions)
    return JointTrajectory(tuple(actuated), time_ns, positions, velocities)


def _numbered_rows(stream: IO[str]) -> Iterator[tuple[int, list[str]]]:
    """CSV rows with the (1-based) line number on which each ends."""
    reader = csv.reader(stream)
    for row in reader:
        yield reader.line_num, row
