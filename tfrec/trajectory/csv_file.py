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
import io
import math
import os
import re
import stat
import warnings
from collections.abc import Iterator, Mapping

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import STAMP_LIMIT_NS, STAMP_RANGE
from tfrec.errors import TrajectoryError
from tfrec.model import Joint, Robot
from tfrec.trajectory.joints import actuated_column, center_positions, position_range
from tfrec.trajectory.types import JointTrajectory

__all__ = ["read_csv_trajectory"]

_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
"""A plain decimal number, optionally in scientific notation (ASCII digits only)."""

_NOT_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


def _joint_columns(robot: Robot, columns: list[str], overrides: Mapping[str, float],
                   where: str) -> dict[int, tuple[int, Joint]]:
    """The header's joint columns: CSV column → (trajectory column, joint).

    Raises:
        TrajectoryError: a column that appears twice, is not an actuated joint or is also overridden; no ``time``.
    """
    joints: dict[int, tuple[int, Joint]] = {}
    seen: set[str] = set()
    for c, column in enumerate(columns):
        at = f"{where}: column '{column}'"
        if column in seen:
            raise TrajectoryError(f"{at} appears twice")
        seen.add(column)
        if column == "time":
            continue
        joints[c] = actuated_column(robot, column, at, verb="give")
        if column in overrides:
            raise TrajectoryError(f"{at} is also set by an override")
    if "time" not in seen:
        raise TrajectoryError(f"{where}: no 'time' column")
    return joints


def read_csv_trajectory(
    path: str | os.PathLike[str],
    robot: Robot,
    *,
    overrides: Mapping[str, float] = {},
    soft_limits: bool = True,
) -> JointTrajectory:
    """Read a trajectory from CSV: a ``time`` column in seconds and one column per joint.

    Samples are at the file's own times (``time_ns = round(time * 1e9)``, which must be
    non-negative, less than :data:`~tfrec.conventions.STAMP_LIMIT_NS` and increasing). A single
    row is a trajectory of one sample. Joints without a column stay at their center (or their
    override; ``soft_limits`` as for :func:`~tfrec.trajectory.joints.center_positions`). Velocities
    are ``numpy.gradient`` of the positions over the times (0 for a single sample).

    Files of up to :data:`MAX_CSV_BYTES` are read; a file of plain numbers is parsed in one go by
    numpy (a million rows of 8 columns in about 3 s, see docs/performance.md), anything else cell by cell.

    Raises:
        TrajectoryError: the file cannot be read; a column is not an actuated joint, repeated,
            or also overridden; there is no row after the header; a cell is not a plain finite
            number; a row has the wrong number of cells; a time is negative, out of range or
            does not increase; a position is beyond its joint's limits (continuous joints
            excepted) or changes too fast for a finite velocity. The message starts with
            ``file:line:``.
    """
    name = os.fspath(path)
    center = center_positions(robot, overrides=overrides, soft_limits=soft_limits)  # checks the overrides first
    text = _read_text(path, name)
    header_line, header, body_start = _header(text, name)
    columns = [cell.strip() for cell in header]
    joints = _joint_columns(robot, columns, overrides, f"{name}:{header_line}")
    values = _fast_values(text, body_start, len(columns))
    lines: NDArray[np.int64] | None = None
    if values is None:  # anything unusual: read cell by cell, as strictly, naming the line of a fault
        lines, values = _exact_values(text, body_start, header_line, name, columns)
    if not len(values):
        raise TrajectoryError(f"{name}: no samples after the header")

    def line(row: int) -> int:
        """The line a row is on (worked out only for a message)."""
        nonlocal lines
        if lines is None:
            lines = _row_lines(text, body_start, header_line)
        return int(lines[row])

    seconds = values[:, columns.index("time")]
    with np.errstate(over="ignore"):  # beyond float64: inf, refused below
        rounded_ns = np.rint(seconds * 1e9)
    bad = np.flatnonzero(~((rounded_ns >= 0) & (rounded_ns < STAMP_LIMIT_NS)))
    if bad.size:
        r = bad[0]
        problem = "negative" if seconds[r] < 0 else f"out of range: {STAMP_RANGE}"
        raise TrajectoryError(f"{name}:{line(r)}: time {float(seconds[r])!r} is {problem}")
    time_ns = rounded_ns.astype(np.int64)
    stuck = np.flatnonzero(np.diff(time_ns) <= 0)
    if stuck.size:
        r = stuck[0] + 1
        raise TrajectoryError(
            f"{name}:{line(r)}: time {float(seconds[r])!r} does not increase (previous {float(seconds[r - 1])!r})"
        )

    if len(values) * max(len(center), 1) > MAX_CSV_POSITIONS:
        raise TrajectoryError(f"{name}: {len(values):,} rows of {len(center)} joints are more than "
                              f"{MAX_CSV_POSITIONS:,} joint positions, the most a CSV trajectory may hold (it is read "
                              "whole): split the file, or keep fewer rows")
    positions = np.broadcast_to(center, (len(values), len(center))).copy()
    for c, (j, joint) in joints.items():
        positions[:, j] = values[:, c]
        lower, upper = position_range(joint)
        beyond = np.flatnonzero((values[:, c] < lower) | (values[:, c] > upper))
        if beyond.size:
            r = beyond[0]
            raise TrajectoryError(
                f"{name}:{line(r)}: {joint.name} = {float(values[r, c])!r} is beyond its limits [{lower!r}, {upper!r}]"
            )
    velocities = np.zeros_like(positions)
    if len(time_ns) > 1 and positions.shape[1]:
        with np.errstate(over="ignore", invalid="ignore"):  # refused below
            # integer spacings: times 1 ns apart stay apart even far from 0; a still joint gets exactly 0;
            # a column at a time, so that the temporaries are one column's
            for j in range(positions.shape[1]):
                velocities[:, j] = np.gradient(positions[:, j] - positions[0, j], time_ns) * 1e9
        fast = np.argwhere(~np.isfinite(velocities))
        if fast.size:
            r, j = fast[0]
            column = robot.actuated_joints[j].name
            raise TrajectoryError(f"{name}:{line(r)}: {column} changes too fast for a finite velocity")
    return JointTrajectory(tuple(joint.name for joint in robot.actuated_joints), time_ns, positions, velocities)


MAX_CSV_POSITIONS = 1 << 24
"""Rows × actuated joints of a CSV trajectory at most (16.8 million: 2.4 million rows of a 7-joint arm, 33 minutes
at 1 kHz): positions and velocities are held whole, 268 MB at this size; with the file's text and parsed
values the read stays under 1 GiB."""

MAX_CSV_BYTES = 128 << 20
"""The largest CSV file read (about 1.5 million rows of 10 joints); reading it stays under 1 GiB."""

_BLOCK_CHARS = 4 << 20
"""Characters of the body numpy parses at a time."""

_MAX_LINE_CHARS = 1 << 20
"""A line longer than this is not given to numpy (which needs several times a line's size to parse it): it is
read by :mod:`csv`, whose fields are at most 128 KiB."""

_PLAIN = re.compile(r"[0-9eE+\-.,\t \n]*")
"""The characters of a body of plain numbers, which numpy parses as :func:`_number` would."""


def _read_text(path: str | os.PathLike[str], name: str) -> str:
    """The file's text, at most :data:`MAX_CSV_BYTES`: a regular file only (a FIFO or a device could be
    read forever), UTF-8 with an optional byte-order mark, line ends as ``\\n``."""
    try:
        with open(path, "rb") as stream:
            if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
                raise TrajectoryError(f"{name}: not a regular file")
            data = stream.read(MAX_CSV_BYTES + 1)
    except FileNotFoundError as err:
        raise TrajectoryError(f"{name}: no such CSV file") from err
    except OSError as err:
        raise TrajectoryError(f"{name}: cannot read CSV: {err.strerror or err}") from err
    if len(data) > MAX_CSV_BYTES:
        raise TrajectoryError(f"{name}: larger than {MAX_CSV_BYTES >> 20} MiB, the most a CSV trajectory may be")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise TrajectoryError(f"{name}: cannot read CSV: not UTF-8 (byte {err.start:,})") from err
    return text.replace("\r\n", "\n").replace("\r", "\n")


def _header(text: str, name: str) -> tuple[int, list[str], int]:
    """The header: its line number, its cells, and where the body after it starts."""
    start, number = 0, 1
    while start < len(text):
        end = text.find("\n", start)
        end = len(text) if end < 0 else end
        row = text[start:end]
        if row.strip():
            try:
                cells = next(csv.reader([row]))
            except csv.Error as err:
                raise TrajectoryError(f"{name}:{number}: cannot read CSV: {err}") from err
            return number, cells, end + 1
        start, number = end + 1, number + 1
    raise TrajectoryError(f"{name}: empty file, expected a header with 'time' and joint names")


def _fast_values(text: str, start: int, columns: int) -> NDArray[np.float64] | None:
    """The body parsed by numpy, block by block (memory: the values and one block), when it is plain
    numbers in ``columns`` columns, all finite; else None (then :func:`_exact_values` says what is wrong)."""
    if not _PLAIN.fullmatch(text, start):
        return None
    rows = text.count("\n", start) + 1
    values = np.empty((rows, columns))
    filled = 0
    at = start
    while at < len(text):
        end = text.find("\n", min(at + _BLOCK_CHARS, len(text)))
        end = len(text) if end < 0 else end + 1
        if end - at > _BLOCK_CHARS + _MAX_LINE_CHARS:
            return None  # an endless line
        block = text[at:end]
        at = end
        if not block.strip():
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # numpy warns about a block of blank lines
                part = np.loadtxt(io.StringIO(block), delimiter=",", dtype=np.float64, ndmin=2, comments=None)
        except ValueError:
            return None
        if part.shape[1] != columns or not np.isfinite(part).all():
            return None
        values[filled : filled + len(part)] = part
        filled += len(part)
    return values[:filled]


def _exact_values(text: str, start: int, header_line: int, name: str,
                  columns: list[str]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The body read row by row with :mod:`csv`, every cell checked by :func:`_number`: the rows' line
    numbers and values. Raises on the first fault, naming its line."""
    lines: list[int] = []
    rows: list[list[float]] = []
    reader = csv.reader(_lines(text, start))  # not a StringIO of the text: it holds 4 bytes a character
    try:
        for row in reader:
            if not any(cell.strip() for cell in row):
                continue
            number = header_line + reader.line_num
            if len(row) != len(columns):
                raise TrajectoryError(f"{name}:{number}: {len(row)} cells, expected {len(columns)} as in the header")
            rows.append([_number(cell, f"{name}:{number}", columns[c]) for c, cell in enumerate(row)])
            lines.append(number)
    except csv.Error as err:
        raise TrajectoryError(f"{name}:{header_line + reader.line_num}: cannot read CSV: {err}") from err
    return np.array(lines, dtype=np.int64), np.array(rows, dtype=np.float64).reshape(len(rows), len(columns))


def _lines(text: str, start: int) -> Iterator[str]:
    """The lines of ``text`` from ``start``, each with its ``\\n``."""
    while start < len(text):
        end = text.find("\n", start)
        end = len(text) if end < 0 else end + 1
        yield text[start:end]
        start = end


def _row_lines(text: str, start: int, header_line: int) -> NDArray[np.int64]:
    """The line number of each non-blank row of a body of plain numbers (for messages)."""
    rows = text[start:].split("\n")
    return np.array([header_line + 1 + i for i, row in enumerate(rows) if row.strip()], dtype=np.int64)


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


