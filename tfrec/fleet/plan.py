"""The tasks of ``tfrec check`` and ``tfrec diff DIR_A DIR_B``, and ``--resume``.

:func:`check_tasks` and :func:`diff_tasks` validate the options once, in the driver, before
anything runs (a bad tolerance or ``robot_path`` is a :class:`~tfrec.errors.TfrecError` there,
not one error row per recording), and give one :class:`~tfrec.fleet.engine.Task` per recording
or pair, each carrying the digest of its options (``config``).

:func:`resume` keeps the rows of a previous report for the tasks whose recordings are unchanged
— same ``fingerprint`` (size, modification time and summary hash,
:func:`tfrec.fleet.fingerprint.fingerprint`) and same ``config`` — and a ``pass`` or ``fail``
verdict; ``error`` rows (an unreadable file, a worker that died) are run again.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from tfrec._version import __version__
from tfrec.conventions import CHECK_POS_TOL, CHECK_ROT_TOL, DIFF_JOINT_TOL, DIFF_POS_TOL, DIFF_ROT_TOL
from tfrec.errors import FleetError
from tfrec.fleet.discover import Pair
from tfrec.fleet.engine import Task
from tfrec.fleet.fingerprint import fingerprint
from tfrec.fleet.health import DEFAULT_GAP_PERIODS
from tfrec.fleet.row import FAIL, PASS, SUMMARY
from tfrec.fleet.tasks import check_recording, diff_pair

__all__ = ["check_config", "check_tasks", "diff_config", "diff_tasks", "inputs_fingerprint", "resume"]


def _tolerance(name: str, value: float) -> float:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise FleetError(f"{name} {value!r} is not a tolerance (a number >= 0)")
    return float(value)


def _digest(options: Mapping[str, Any]) -> str:
    text = json.dumps({"tfrec": __version__, **options}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def check_config(
    *,
    robot_path: str | os.PathLike[str] | None = None,
    robot_args: Sequence[str] = (),
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
    pos_tol: float = CHECK_POS_TOL,
    rot_tol: float = CHECK_ROT_TOL,
    gap_periods: float = DEFAULT_GAP_PERIODS,
    max_accel: float | None = None,
) -> str:
    """The digest of ``tfrec check``'s options (and tfrec's version): rows of a previous run
    with another digest are not kept by :func:`resume`. A description file counts by its path,
    size and modification time (files it includes do not count)."""
    robot: list[Any] | None = None
    if robot_path is not None:
        where = os.path.abspath(robot_path)
        stat = os.stat(where) if os.path.exists(where) else None
        robot = [where, list(robot_args), [os.path.abspath(p) for p in package_paths], strict_xacro,
                 None if stat is None else [stat.st_size, stat.st_mtime_ns]]
    options = {"kind": "check", "robot": robot, "pos_tol": pos_tol, "rot_tol": rot_tol, "gap_periods": gap_periods}
    if max_accel is not None:  # (absent from the digest when not given: earlier reports stay resumable)
        options["max_accel"] = max_accel
    return _digest(options)


def check_tasks(
    recordings: Sequence[str | os.PathLike[str]],
    *,
    robot_path: str | os.PathLike[str] | None = None,
    robot_args: Sequence[str] = (),
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
    pos_tol: float = CHECK_POS_TOL,
    rot_tol: float = CHECK_ROT_TOL,
    gap_periods: float = DEFAULT_GAP_PERIODS,
    max_accel: float | None = None,
) -> list[Task]:
    """One :func:`~tfrec.fleet.tasks.check_recording` task per recording.

    ``robot_path`` is loaded here once, so that a bad description is one error before the run
    (its warnings, such as legacy xacro calls, are raised here once too).

    Raises:
        FleetError: a tolerance < 0 or not finite, ``gap_periods`` < 1.
        DescriptionError: ``robot_path`` cannot be loaded.
    """
    pos_tol = _tolerance("pos_tol", pos_tol)
    rot_tol = _tolerance("rot_tol", rot_tol)
    if not (isinstance(gap_periods, (int, float)) and math.isfinite(gap_periods) and gap_periods >= 1):
        raise FleetError(f"gap_periods {gap_periods!r} is not a number of periods >= 1")
    if max_accel is not None and not (isinstance(max_accel, (int, float)) and math.isfinite(max_accel) and max_accel > 0):
        raise FleetError(f"max_accel {max_accel!r} is not a positive number")
    if robot_path is not None:
        from tfrec.description import load_description, parse_xacro_args

        load_description(robot_path, args=parse_xacro_args(robot_args), package_paths=package_paths,
                         strict_xacro=strict_xacro)
    options: dict[str, Any] = {
        "robot_path": None if robot_path is None else os.fspath(robot_path),
        "robot_args": tuple(robot_args),
        "package_paths": tuple(os.fspath(p) for p in package_paths),
        "strict_xacro": strict_xacro,
        "pos_tol": pos_tol,
        "rot_tol": rot_tol,
        "gap_periods": float(gap_periods),
    }
    if max_accel is not None:
        options["max_accel"] = float(max_accel)
    config = check_config(**options)
    out = []
    for recording in recordings:
        where = os.fspath(recording)
        out.append(Task(where, check_recording, (where,), {**options, "config": config}, (where,), config))
    return out


def diff_config(
    *,
    pos_tol: float = DIFF_POS_TOL,
    rot_tol: float = DIFF_ROT_TOL,
    joint_tol: float = DIFF_JOINT_TOL,
    topics: Sequence[str] | None = None,
    absolute: bool = False,
) -> str:
    """The digest of ``tfrec diff``'s options (and tfrec's version), as :func:`check_config`."""
    return _digest({"kind": "diff", "pos_tol": pos_tol, "rot_tol": rot_tol, "joint_tol": joint_tol,
                    "topics": None if topics is None else sorted(topics), "absolute": absolute})


def diff_tasks(
    pairs: Sequence[Pair],
    *,
    pos_tol: float = DIFF_POS_TOL,
    rot_tol: float = DIFF_ROT_TOL,
    joint_tol: float = DIFF_JOINT_TOL,
    topics: Sequence[str] | None = None,
    absolute: bool = False,
) -> list[Task]:
    """One :func:`~tfrec.fleet.tasks.diff_pair` task per pair (of :func:`tfrec.fleet.discover.pair_recordings`).

    Raises:
        FleetError: a tolerance < 0 or not finite.
    """
    options: dict[str, Any] = {
        "pos_tol": _tolerance("pos_tol", pos_tol),
        "rot_tol": _tolerance("rot_tol", rot_tol),
        "joint_tol": _tolerance("joint_tol", joint_tol),
        "topics": None if topics is None else tuple(topics),
        "absolute": absolute,
    }
    config = diff_config(**options)
    out = []
    for pair in pairs:
        a = None if pair.a is None else os.fspath(pair.a)
        b = None if pair.b is None else os.fspath(pair.b)
        out.append(Task(pair.key, diff_pair, (a, b), {**options, "key": pair.key, "config": config}, (a, b), config))
    return out


def inputs_fingerprint(inputs: Sequence[str | os.PathLike[str] | None]) -> str:
    """The ``fingerprint`` column a task's rows will carry: one recording's key, or a pair's two
    joined by ``|`` (``-`` for a missing side).

    Raises:
        FleetError: a recording that cannot be read.
    """
    return "|".join("-" if path is None else fingerprint(Path(path)).key for path in inputs)


def resume(tasks: Sequence[Task], previous: Sequence[Mapping[str, Any]]) -> tuple[list[Task], list[dict[str, Any]]]:
    """Split tasks into those to run and the rows of a previous report to keep instead.

    A task is skipped when the previous report has a summary row for its ``file`` with a ``pass``
    or ``fail`` verdict, the task's ``config``, and the ``fingerprint`` its recordings have now;
    its rows (summary and findings) are kept. Rows of recordings that are no longer among the
    tasks are dropped.

    Args:
        tasks: from :func:`check_tasks` or :func:`diff_tasks`.
        previous: the rows of the previous report (:func:`tfrec.fleet.report.read_report`).

    Returns:
        (tasks to run, in their order; rows to keep, grouped by task in the same order).
    """
    by_file: dict[str, list[Mapping[str, Any]]] = {}
    for row in previous:
        by_file.setdefault(str(row.get("file")), []).append(row)
    todo: list[Task] = []
    kept: list[dict[str, Any]] = []
    for task in tasks:
        rows = by_file.get(task.key, [])
        head = next((row for row in rows if row.get("check") == SUMMARY), None)
        if head is not None and head.get("verdict") in (PASS, FAIL) and head.get("config") == task.config:
            try:
                unchanged = head.get("fingerprint") == inputs_fingerprint(task.inputs)
            except FleetError:
                unchanged = False
            if unchanged:
                kept.extend(dict(row) for row in rows)
                continue
        todo.append(task)
    return todo, kept
