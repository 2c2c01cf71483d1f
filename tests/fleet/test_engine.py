"""The process-pool engine: verdicts, dead workers, bugs, Ctrl-C, and --resume."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.fleet import helpers
from tests.fleet.helpers import EXPECTED, copy_fleet
from tfrec.fleet import (
    ERROR,
    PASS,
    RAY_MISSING,
    FleetError,
    Progress,
    Row,
    Task,
    check_tasks,
    find_recordings,
    resume,
    run,
    tally,
)
from tfrec.fleet.report import ReportWriter, read_report


def _by_file(rows: list[Row], folder: Path) -> dict[str, tuple[str, set[str]]]:
    out: dict[str, tuple[str, set[str]]] = {}
    for row in rows:
        name = Path(row.file).relative_to(folder).as_posix()
        verdict, checks = out.get(name, ("", set()))
        if row.check == "summary":
            verdict = row.verdict
        else:
            checks = checks | {row.check}
        out[name] = (verdict, checks)
    return out


def test_a_pool_of_two_gives_every_verdict(fleet_dir: Path) -> None:
    tasks = check_tasks(find_recordings([fleet_dir]))
    calls: list[tuple[list[Row], Progress]] = []
    progress = run(tasks, jobs=2, on_result=lambda rows, p: calls.append((rows, p)))
    assert progress == Progress(done=9, total=9, passed=3, failed=4, errors=2)
    assert [p.done for _, p in calls] == list(range(1, 10))
    assert all(rows[0].check == "summary" for rows, _ in calls)
    rows = [row for rows, _ in calls for row in rows]
    assert _by_file(rows, fleet_dir) == EXPECTED
    heads = [rows[0] for rows, _ in calls]
    assert all(h.elapsed_s is not None and h.worker.rsplit(":", 1)[1].isdigit() for h in heads)
    assert len({h.worker for h in heads}) == 2  # two worker processes
    assert all(h.peak_rss_bytes is not None and h.peak_rss_bytes > 10_000_000 for h in heads)
    assert tally(rows) == progress


def _task(func: object, *args: object) -> Task:
    return Task(str(args[0]), func, args)  # type: ignore[arg-type]


def test_a_dead_worker_costs_its_task_only(tmp_path: Path) -> None:
    marker = tmp_path / "died"
    tasks = [_task(helpers.ok, f"ok{i}", 0.2) for i in range(4)]
    tasks.insert(1, _task(helpers.die_once, "die_once", str(marker)))
    tasks.insert(3, _task(helpers.die_always, "die_always"))
    rows: dict[str, Row] = {}
    progress = run(tasks, jobs=2, on_result=lambda result, _: rows.update({result[0].file: result[0]}))
    assert progress == Progress(done=6, total=6, passed=5, failed=0, errors=1)
    assert marker.exists()
    assert rows["die_once"].verdict == PASS
    assert rows["die_once"].detail == "survived; run again after worker died (signal SIGKILL) (out of memory?)"
    assert rows["die_always"].verdict == ERROR
    assert rows["die_always"].detail == "worker died (exit code 137) (out of memory?), 2 times"
    assert all(rows[f"ok{i}"].detail == "ok" for i in range(4))  # lost with a broken pool, run again uncharged


def test_without_retries_a_dead_worker_is_an_error_at_once(tmp_path: Path) -> None:
    rows: list[Row] = []
    run([_task(helpers.die_once, "d", str(tmp_path / "m"))], jobs=1, retries=0,
        on_result=lambda result, _: rows.extend(result))
    assert [(r.verdict, r.detail) for r in rows] == [(ERROR, "worker died (signal SIGKILL) (out of memory?)")]


def test_a_bug_is_the_files_error_row_and_the_run_goes_on() -> None:
    rows: list[Row] = []
    progress = run([_task(helpers.buggy, "b"), _task(helpers.ok, "o")], jobs=2,
                   on_result=lambda result, _: rows.extend(result))
    assert progress.errors == 1 and progress.passed == 1
    (bug,) = [r for r in rows if r.file == "b"]
    assert bug.detail.startswith("internal error (a tfrec bug: please report it): Traceback")
    assert "ZeroDivisionError: division by zero" in bug.detail


def _workers() -> set[int]:
    """This process's live children, the pool's forkserver and resource tracker left out."""
    out = set()
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            stat = Path(f"/proc/{name}/stat").read_text()
            cmdline = Path(f"/proc/{name}/cmdline").read_bytes()
        except OSError:
            continue
        state, parent = stat[stat.rindex(")") + 2 :].split()[:2]
        if (int(parent) == os.getpid() and state != "Z" and b"forkserver" not in cmdline
                and b"resource_tracker" not in cmdline):  # the pool's helpers, started once per process
            out.add(int(name))
    return out


def test_ctrl_c_stops_the_workers_and_the_report_keeps_what_finished(tmp_path: Path) -> None:
    tasks = [_task(helpers.ok, "fast", 0.0)] + [_task(helpers.ok, f"slow{i}", 600.0) for i in range(4)]
    report = tmp_path / "r.jsonl"
    before = _workers()

    def on_result(rows: list[Row], _: Progress) -> None:
        writer.write(row.to_dict() for row in rows)
        threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()  # Ctrl-C while slow tasks run

    # Python's own Ctrl-C handler, whatever this process was started with (a shell's background job ignores SIGINT,
    # and Python then leaves it ignored: the signal would never reach the driver)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    started = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt), ReportWriter(report) as writer:
            run(tasks, jobs=2, on_result=on_result)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - started < 300  # a hang guard: waiting for the slow tasks would take 600 s
    assert [row["file"] for row in read_report(report)] == ["fast"]
    assert _workers() <= before  # the workers are gone


def test_options_are_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(FleetError, match=r"^jobs 0 is not a number of processes >= 1$"):
        run([], jobs=0)
    with pytest.raises(FleetError, match=r"^engine 'spark' is not one of pool, ray$"):
        run([], engine="spark")
    with pytest.raises(FleetError, match=r"^address is for engine='ray' only$"):
        run([], address="127.0.0.1:6379")
    for bad in (0, -1.0, float("nan"), float("inf")):
        with pytest.raises(FleetError, match=r"^`ray_timeout_s` .* is not a number of seconds > 0$"):
            run([], engine="ray", ray_timeout_s=bad)
    assert run([], jobs=3) == Progress()
    monkeypatch.setitem(sys.modules, "ray", None)  # as if Ray were not installed
    with pytest.raises(FleetError) as caught:
        run([_task(helpers.ok, "o")], engine="ray")
    assert str(caught.value) == RAY_MISSING == "engine='ray' needs Ray: pip install 'tfrec-robotics[ray]'"


def test_check_tasks_validate_their_options(tmp_path: Path) -> None:
    with pytest.raises(FleetError, match=r"^pos_tol -1 is not a tolerance \(a number >= 0\)$"):
        check_tasks([], pos_tol=-1)
    with pytest.raises(FleetError, match=r"^gap_periods 0.5 is not a number of periods >= 1$"):
        check_tasks([], gap_periods=0.5)
    from tfrec.errors import DescriptionError

    with pytest.raises(DescriptionError, match=r"nope\.urdf: no such file"):
        check_tasks([], robot_path=tmp_path / "nope.urdf")


def test_resume_skips_unchanged_recordings(tmp_path: Path, fleet_dir: Path) -> None:
    folder = copy_fleet(fleet_dir, tmp_path / "fleet")
    report = tmp_path / "report.parquet"
    tasks = check_tasks(find_recordings([folder]))
    with ReportWriter(report) as writer:
        run(tasks, jobs=2, on_result=lambda rows, _: writer.write(r.to_dict() for r in rows))
    first = read_report(report)

    touched = folder / "marm" / "sine.mcap"
    os.utime(touched, ns=(touched.stat().st_atime_ns, touched.stat().st_mtime_ns + 1_000_000))
    todo, kept = resume(check_tasks(find_recordings([folder])), first)
    assert sorted(Path(t.key).relative_to(folder).as_posix() for t in todo) == [
        "bad/garbage.mcap", "bad/odd.dat", "marm/sine.mcap"]  # touched, and the errors
    assert {row["file"] for row in kept} == {t.key for t in tasks} - {t.key for t in todo}
    assert tally(kept) == Progress(done=6, total=6, passed=2, failed=4)

    with ReportWriter(report, force=True) as writer:  # resuming: the report read is replaced
        writer.write(kept)
        run(todo, jobs=2, on_result=lambda rows, _: writer.write(r.to_dict() for r in rows))
    second = read_report(report)
    assert sorted((r["file"], r["check"], r["frame"]) for r in second) == sorted(
        (r["file"], r["check"], r["frame"]) for r in first)
    again, _ = resume(check_tasks(find_recordings([folder])), second)
    assert sorted(Path(t.key).name for t in again) == ["garbage.mcap", "odd.dat"]
    other, _ = resume(check_tasks(find_recordings([folder]), pos_tol=1e-3), second)
    assert len(other) == 9  # other options: every recording again
