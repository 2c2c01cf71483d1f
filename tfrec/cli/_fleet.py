"""``tfrec check PATH…`` and ``tfrec diff DIR_A DIR_B``: many recordings, one task per file, on a local
process pool or a Ray cluster (:mod:`tfrec.fleet`), with a report and a progress bar."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any, TextIO

from tfrec.cli._common import PROG, add_xacro_arguments, number, show, tolerance
from tfrec.conventions import CHECK_POS_TOL, CHECK_ROT_TOL
from tfrec.errors import printable

__all__ = ["add_engine_arguments", "add_parser", "run_diff_folders"]


def add_engine_arguments(parser: argparse.ArgumentParser) -> None:
    """The options a fleet run shares: where it runs and where its report goes."""
    group = parser.add_argument_group("many recordings")
    group.add_argument("--jobs", metavar="N", type=int, default=None,
                       help="worker processes on this machine (default: all cores)")
    group.add_argument("--engine", choices=("pool", "ray"), default="pool",
                       help="pool: a local process pool (default); ray: Ray tasks on a cluster (pip install "
                            "'tfrec-robotics[ray]')")
    group.add_argument("--address", metavar="ADDR", default=None,
                       help="the Ray cluster to use (default: RAY_ADDRESS, else a local one)")
    group.add_argument("--ray-timeout", metavar="S", type=float, default=None,
                       help="give up connecting to the Ray cluster at --address after S seconds (default 20)")
    group.add_argument("--report", metavar="OUT", default=None,
                       help="one row per recording and finding: OUT.parquet or OUT.jsonl (DuckDB, Polars, pandas)")
    group.add_argument("--resume", action="store_true",
                       help="skip recordings whose rows are in --report and that are unchanged since")


def add_ci_arguments(parser: argparse.ArgumentParser) -> None:
    """``--junit``, ``--summary`` and ``--format``: what ``check`` and ``diff`` give a CI job (docs/ci.md)."""
    group = parser.add_argument_group("reports for CI")
    group.add_argument("--junit", metavar="OUT.xml", default=None,
                       help="JUnit XML: one testcase per recording (pair, or comparison), findings as failures "
                            "(GitLab's and GitHub's test reporters read it)")
    group.add_argument("--summary", metavar="OUT.md", default=None,
                       help="a Markdown summary: verdicts, worst errors, artefacts (e.g. $GITHUB_STEP_SUMMARY)")
    group.add_argument("--format", choices=("text", "github"), default="text",
                       help="github: also print GitHub Actions ::error annotations, at the description's line "
                            "where a finding is about one of its elements (default text)")


def ci_targets(ns: argparse.Namespace) -> list[tuple[Any, Any]]:
    """``--junit`` and ``--summary`` with their kinds, for :func:`tfrec._outputs.check_outputs`."""
    from pathlib import Path

    from tfrec.fleet.ci import JUNIT, SUMMARY_MD

    return [(Path(path), kind) for path, kind in ((ns.junit, JUNIT), (ns.summary, SUMMARY_MD)) if path is not None]


def emit_ci(ns: argparse.Namespace, cases: Sequence[Any], *, suite: str, title: str,
            artefacts: Sequence[str] = ()) -> None:
    """Print the GitHub annotations (``--format github``) and write ``--junit`` and ``--summary``."""
    if ns.format == "github":
        from tfrec.fleet.ci import github_annotations

        show(*github_annotations(cases))
    if ns.junit is not None or ns.summary is not None:
        from tfrec.fleet.ci import write_ci_outputs

        write_ci_outputs(cases, suite=suite, title=title, junit=ns.junit, summary=ns.summary, force=ns.force,
                         artefacts=artefacts)
        for path in (ns.junit, ns.summary):
            if path is not None:
                show(f"wrote {path}", file=sys.stderr)


def add_parser(sub: Any) -> None:
    """Add ``tfrec check`` to ``sub`` (argparse subparsers)."""
    check = sub.add_parser(
        "check", help="check many recordings (files, folders, globs): re-simulated TF and health, one verdict each",
        description="Check every recording under the paths (files, rosbag2 folders, globs, folders searched "
                    "recursively): TF re-simulated from its joint states and its own /robot_description (or "
                    "--robot), as `tfrec replay --check` does, plus what a fleet needs — stamps non-zero and "
                    "increasing, steady rates (no gap over --gap-periods periods), frames missing, a description "
                    "present. One verdict per recording; exit 0 all pass, 1 any finding, 2 when nothing could be "
                    "read.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  tfrec check bags/ --report night.parquet\n"
               "  tfrec check 'bags/**/*.mcap' --robot arm_v2.xacro --jobs 8\n"
               "  tfrec check /data/bags --engine ray --address 10.0.0.5:6379 --report r.parquet --resume",
    )
    check.add_argument("paths", metavar="PATH", nargs="+", help="recordings, rosbag2 folders, globs or folders")
    check.add_argument("--robot", metavar=("FILE", "name:=value"), nargs="+",
                       help="check against this description instead of each recording's /robot_description")
    check.add_argument("--package-path", metavar="DIR", action="append", default=[],
                       help="a package, or a folder of packages, for $(find pkg) in --robot (repeatable)")
    add_xacro_arguments(check)
    check.add_argument("--pos-tol", metavar="M", type=tolerance, default=CHECK_POS_TOL,
                       help=f"translation tolerance (default {number(CHECK_POS_TOL)})")
    check.add_argument("--rot-tol", metavar="RAD", type=tolerance, default=CHECK_ROT_TOL,
                       help=f"rotation tolerance (default {number(CHECK_ROT_TOL)})")
    check.add_argument("--gap-periods", metavar="N", type=float, default=None,
                       help="a gap longer than N periods of a stream's rate is a finding (default 5)")
    check.add_argument("--max-accel", metavar="X", type=float, default=None,
                       help="a joint acceleration over X (rad/s² or m/s²) is a finding (default: not checked; URDF "
                            "gives velocity limits only)")
    check.add_argument("--force", action="store_true",
                       help="replace an existing --report (only a tfrec report; --resume replaces it too)")
    add_engine_arguments(check)
    add_ci_arguments(check)
    check.set_defaults(handler=_cmd_check)


def _cmd_check(ns: argparse.Namespace) -> int:
    from tfrec.fleet import DEFAULT_GAP_PERIODS, check_tasks, find_recordings

    recordings = find_recordings(ns.paths)
    if ns.robot:
        from tfrec.cli._common import package_form

        ns.robot = package_form(ns.robot, ns.package_path)
    _check_report(ns, [*recordings, ns.robot[0] if ns.robot else None])
    tasks = check_tasks(
        recordings, robot_path=ns.robot[0] if ns.robot else None, robot_args=tuple(ns.robot[1:]) if ns.robot else (),
        package_paths=ns.package_path, strict_xacro=ns.strict_xacro, pos_tol=ns.pos_tol, rot_tol=ns.rot_tol,
        gap_periods=DEFAULT_GAP_PERIODS if ns.gap_periods is None else ns.gap_periods, max_accel=ns.max_accel,
    )
    return _run(ns, tasks, what="recordings")


def run_diff_folders(ns: argparse.Namespace) -> int:
    """``tfrec diff DIR_A DIR_B``: pair the recordings by relative path and diff each pair."""
    from tfrec.fleet import diff_tasks, pair_recordings

    pairs = pair_recordings(ns.a, ns.b)
    _check_report(ns, [path for pair in pairs for path in (pair.a, pair.b)])
    tasks = diff_tasks(pairs, pos_tol=ns.pos_tol, rot_tol=ns.rot_tol, joint_tol=ns.joint_tol,
                       topics=ns.topics, absolute=ns.absolute)
    return _run(ns, tasks, what="pairs")


def _check_report(ns: argparse.Namespace, inputs: Sequence[Any]) -> None:
    """``--report`` before anything is read: an existing one only with ``--force`` or ``--resume`` (which reads it
    first), and only a tfrec report; never a recording of the run (:func:`tfrec._outputs.check_target`)."""
    if ns.junit is not None or ns.summary is not None:
        from tfrec._outputs import check_outputs

        check_outputs(ci_targets(ns), force=ns.force, inputs=[*inputs, ns.report])
    if ns.report is None:
        return
    import os
    from pathlib import Path

    from tfrec._outputs import check_target
    from tfrec.fleet.report import check_report, report_kind

    if ns.resume and os.path.lexists(ns.report):
        check_report(ns.report)  # the report --resume reads: one line when it is not a tfrec report, not replaced
    check_target(Path(ns.report), report_kind(ns.report), force=ns.force or ns.resume, inputs=inputs)


def _run(ns: argparse.Namespace, tasks: Sequence[Any], *, what: str) -> int:
    """Run the tasks, write the report, draw the bar; the exit code: 0 all pass, 1 any finding, 2 nothing read."""
    from tfrec.errors import FleetError
    from tfrec.fleet import DEFAULT_RAY_TIMEOUT_S, PASS, SUMMARY, Progress, Row, resume, run, tally

    kept: list[dict[str, Any]] = []
    if ns.resume:
        if ns.report is None:
            raise FleetError("`resume` needs `report`: the report of the run it resumes")
        from tfrec.fleet.report import read_report

        tasks, kept = resume(tasks, read_report(ns.report, missing_ok=True))
    before = tally(kept)
    bar = _Bar(sys.stderr, total=len(tasks) + before.done, what=what)
    failing: list[str] = []

    collected: list[Any] = list(kept)

    def on_result(rows: list[Row], progress: Progress) -> None:
        collected.extend(rows)
        if writer is not None:
            writer.write(row.to_dict() for row in rows)
        for row in rows:
            if row.check == SUMMARY and row.verdict != PASS:
                first = next((r for r in rows if r.file == row.file and r.check != SUMMARY and r.verdict != PASS
                              and r.detail and r.detail not in row.detail), None)
                why = f" — first: {first.check}: {first.detail}" if first is not None else ""
                failing.append(f"{row.verdict.upper()} {row.file}: {row.detail}{why}")
        bar(progress, before)

    writer = None
    started = time.monotonic()
    engine = {"jobs": ns.jobs, "engine": ns.engine, "address": ns.address, "on_result": on_result,
              "ray_timeout_s": DEFAULT_RAY_TIMEOUT_S if ns.ray_timeout is None else ns.ray_timeout}
    try:
        if ns.report is not None:
            from tfrec.fleet.report import ReportWriter

            with ReportWriter(ns.report, force=ns.force or ns.resume) as writer:
                writer.write(kept)
                progress = run(tasks, **engine)
        else:
            progress = run(tasks, **engine)
    finally:
        bar.close()
    for line in failing:
        show(line)
    if ns.junit is not None or ns.summary is not None or ns.format != "text":
        from tfrec.fleet.ci import cases_from_rows

        robot = ns.robot[0] if getattr(ns, "robot", None) else None
        suite = "check" if what == "recordings" else "diff"
        emit_ci(ns, cases_from_rows(collected, description=robot), suite=suite,
                title=f"tfrec {suite}: {' '.join(ns.paths) if suite == 'check' else f'{ns.a} vs {ns.b}'}",
                artefacts=[ns.report] if ns.report else [])
    passed, failed = progress.passed + before.passed, progress.failed + before.failed
    errors, total = progress.errors + before.errors, progress.total + before.total
    skipped = f" ({before.done} unchanged, from the report)" if before.done else ""
    show(f"{total} {what}: {passed} pass, {failed} fail, {errors} error{skipped} in {time.monotonic() - started:.1f} s"
          + (f"; report: {ns.report}" if ns.report else ""))
    if total == 0 or errors == total:
        where = " ".join(ns.paths) if getattr(ns, "paths", None) else f"{ns.a} and {ns.b}"
        show(f"{PROG}: error: {printable(where)}: nothing could be read ({errors} of {total} {what} an error; see above)",
              file=sys.stderr)
        return 2
    return 0 if passed == total else 1 if (failed or errors) else 0


class _Bar:
    """A progress bar with the counts of pass, fail and error, on stderr when it is a terminal."""

    def __init__(self, stream: TextIO, *, total: int, what: str, clock: Callable[[], float] = time.monotonic) -> None:
        self._stream = stream
        self._enabled = stream.isatty()
        self._total = total
        self._what = what
        self._shown = False

    def __call__(self, progress: Any, before: Any) -> None:
        if not self._enabled:
            return
        self._shown = True
        done = progress.done + before.done
        width = 30
        filled = int(width * done / max(self._total, 1))
        self._stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{self._total} {self._what}: "
                           f"{progress.passed + before.passed} pass, {progress.failed + before.failed} fail, "
                           f"{progress.errors + before.errors} error")
        self._stream.flush()

    def close(self) -> None:
        if self._shown:
            self._stream.write("\n")
            self._stream.flush()
