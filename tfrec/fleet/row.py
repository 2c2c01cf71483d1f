"""One row of a fleet report (:class:`Row`): a recording's (or a pair's) summary, or one finding.

Every per-file function of :mod:`tfrec.fleet.tasks` returns a list of rows whose first row is the
summary (``check == "summary"``) and whose other rows are the findings; :mod:`tfrec.fleet.report`
writes them as Parquet or JSON lines, one column per field, in this order.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Literal

__all__ = ["ERROR", "FAIL", "PASS", "SUMMARY", "Row", "Verdict"]

Verdict = Literal["pass", "fail", "error"]
"""``pass``: nothing found; ``fail``: a finding; ``error``: the recording could not be checked at all."""

PASS: Verdict = "pass"
FAIL: Verdict = "fail"
ERROR: Verdict = "error"

SUMMARY = "summary"
"""The ``check`` of the one summary row per recording (or pair)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class Row:
    """One row of a fleet report; flat, so that it is one line of a table.

    Attributes:
        file: the recording as found (``tfrec check``), or the relative path of a pair of
            recordings (``tfrec diff DIR_A DIR_B``).
        robot: the robot's name (``<robot name>``), or ``""`` when unknown.
        check: ``summary`` for the row that gives the recording's verdict; for a finding, what
            found it: ``read`` (a damaged file), ``description`` (no usable /robot_description),
            ``resim`` (recorded TF against TF re-simulated from the joint states), ``frames``
            (a frame of the robot missing from /tf and /tf_static), ``stamps`` (zero or repeated
            header stamps), ``rate`` (gaps in a series); for a pair, ``missing`` (a recording on
            one side only) or the kind of difference of :class:`tfrec.diff_report.Difference`
            (``description``, ``topic``, ``joint_states``, ``tf``, ``tf_static``, ``frame``).
        topic: the topic concerned, or ``""``.
        frame: the child frame (or the joint, or ``parent → child``) concerned, or ``""``.
        max_error: the largest error (see ``unit``), or None.
        unit: the unit of ``max_error``: ``m``, ``rad``, ``s`` (a gap), ``stamps`` (a count),
            ``joint`` (rad or m), or ``""``.
        first_exceed_s: when the finding starts, in seconds since the recording's start (its
            first /joint_states or /tf stamp); None for latched data or findings without a time.
        verdict: ``pass``, ``fail`` or ``error``; a finding is ``fail``.
        detail: one readable line (an internal error's row holds its traceback).
        size, mtime_ns: the recording's bytes and modification time when it was checked (a pair:
            both sides' bytes, the later time).
        fingerprint: ``size:mtime_ns:digest`` of the recording's summary section
            (:func:`tfrec.fleet.fingerprint.fingerprint`); a pair's two joined by ``|``.
        config: a digest of the options the recording was checked with (tolerances, robot, …);
            ``resume`` re-checks a recording when it changed.
        elapsed_s: wall time of the task (summary rows), including reading.
        cpu_s: the CPU time the worker spent on it (``elapsed_s - cpu_s`` is waiting: for the
            disk, or for a core shared with other processes).
        read_s: the part of ``elapsed_s`` spent reading and decoding the recording(s).
        peak_rss_bytes: the worker process's peak resident memory so far (``VmHWM``), when known.
        worker: ``host:pid`` of the process that ran the task.
    """

    file: str
    robot: str = ""
    check: str = SUMMARY
    topic: str = ""
    frame: str = ""
    max_error: float | None = None
    unit: str = ""
    first_exceed_s: float | None = None
    verdict: Verdict = PASS
    detail: str = ""
    size: int | None = None
    mtime_ns: int | None = None
    fingerprint: str = ""
    config: str = ""
    elapsed_s: float | None = None
    cpu_s: float | None = None
    read_s: float | None = None
    peak_rss_bytes: int | None = None
    worker: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The row as a mapping of column name to value, in column order."""
        return asdict(self)
