"""Fleets of recordings: ``tfrec check PATH…`` and ``tfrec diff DIR_A DIR_B``, one task per file.

Each recording (or pair of recordings) is independent and needs the whole file, so the unit of
work is a file: :func:`find_recordings` / :func:`pair_recordings` find them, :func:`check_tasks` /
:func:`diff_tasks` make one :class:`Task` each (a per-file function of :mod:`tfrec.fleet.tasks`
and its options), :func:`resume` drops those a previous report already holds, and :func:`run`
runs the rest on a local process pool or a Ray cluster, handing each task's :class:`Row`\\ s to a
callback as it finishes (the CLI writes them with :class:`tfrec.fleet.report.ReportWriter`).
"""

from __future__ import annotations

from tfrec.errors import FleetError
from tfrec.fleet.discover import Pair, find_recordings, pair_recordings
from tfrec.fleet.engine import ENGINES, RAY_MISSING, Progress, ResultCallback, Task, default_jobs, execute, run, tally
from tfrec.fleet.fingerprint import Fingerprint, fingerprint
from tfrec.fleet.health import DEFAULT_GAP_PERIODS
from tfrec.fleet.plan import check_config, check_tasks, diff_config, diff_tasks, inputs_fingerprint, resume
from tfrec.fleet.raycluster import DEFAULT_RAY_TIMEOUT_S
from tfrec.fleet.row import ERROR, FAIL, PASS, SUMMARY, Row, Verdict
from tfrec.fleet.tasks import check_recording, diff_pair

__all__ = [
    "DEFAULT_GAP_PERIODS",
    "DEFAULT_RAY_TIMEOUT_S",
    "ENGINES",
    "ERROR",
    "FAIL",
    "PASS",
    "RAY_MISSING",
    "SUMMARY",
    "Fingerprint",
    "FleetError",
    "Pair",
    "Progress",
    "ResultCallback",
    "Row",
    "Task",
    "Verdict",
    "check_config",
    "check_recording",
    "check_tasks",
    "default_jobs",
    "diff_config",
    "diff_pair",
    "diff_tasks",
    "execute",
    "find_recordings",
    "fingerprint",
    "inputs_fingerprint",
    "pair_recordings",
    "resume",
    "run",
    "tally",
]
