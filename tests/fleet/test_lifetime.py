"""A `tfrec check` driver killed by SIGKILL (as the OOM killer does) leaves nothing behind: its pool workers,
the forkserver and the resource tracker end within seconds and the caller's pipes reach end-of-file; a
resource tracker killed under a running check costs a warning, not tracebacks. (Ray's local cluster: in
test_ray.py.)"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import IO

import pytest

from tests.conftest import REPO
from tests.fleet.helpers import end_session, session_processes, tfrec_env
from tests.recording_helpers import load_robot, write_mcap
from tfrec.trajectory.generators import make_trajectory

GRACE_S = 5.0
"""How long after its driver's death a run's processes may take to end (the issue's figure)."""


@pytest.fixture(scope="module")
def slow_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """16 recordings of 30 s at 200 Hz (each takes a worker about a second): a run that is busy when killed."""
    folder = tmp_path_factory.mktemp("slow")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        marm = load_robot("marm")
        first = write_mcap(folder / "r00.mcap", marm, make_trajectory(marm, "sine", duration_s=30, rate_hz=200))
    for k in range(1, 16):
        os.link(first, folder / f"r{k:02d}.mcap")  # another path: another recording for the run
    return folder


def start_check(args: list[str]) -> subprocess.Popen[bytes]:
    """``python -m tfrec check ARGS`` in a session of its own, its output on pipes of this test."""
    return subprocess.Popen([sys.executable, "-m", "tfrec", "check", *args], cwd=REPO, env=tfrec_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)


def wait_for(process: subprocess.Popen[bytes], ready: Callable[[dict[int, str]], bool], *, timeout_s: float) -> None:
    """Wait until the run's processes satisfy ``ready`` (a hang guard, not a measure: the run must be busy)."""
    deadline = time.monotonic() + timeout_s
    while not ready(session_processes(process.pid)):
        assert process.poll() is None, f"the run ended first: {process.communicate()}"
        assert time.monotonic() < deadline, f"not ready after {timeout_s:.0f} s: {session_processes(process.pid)}"
        time.sleep(0.1)


def kill_driver_and_expect_nothing_left(process: subprocess.Popen[bytes]) -> None:
    """SIGKILL the driver; within :data:`GRACE_S` no process of its session runs and its pipes are at end-of-file."""
    session = process.pid
    try:
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=60)
        deadline = time.monotonic() + GRACE_S
        while session_processes(session) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = session_processes(session)
        assert not left, f"still running {GRACE_S:.0f} s after the driver died: {left}"
        assert process.stdout is not None and process.stderr is not None
        pipes: list[IO[bytes]] = [process.stdout, process.stderr]
        readable, _, _ = select.select(pipes, [], [], GRACE_S)  # nobody holds their write ends: end-of-file
        assert len(readable) == 2
        for stream in pipes:
            os.set_blocking(stream.fileno(), False)
            while os.read(stream.fileno(), 65536):  # BlockingIOError: someone still holds the pipe
                pass
    finally:
        end_session(session)
        for end in (process.stdout, process.stderr):
            if end is not None:
                end.close()


def test_a_killed_driver_takes_its_pool_with_it(slow_fleet: Path) -> None:
    process = start_check([str(slow_fleet), "--jobs", "2"])

    def busy(processes: dict[int, str]) -> bool:  # the driver, the tracker, the forkserver and both workers
        return len(processes) >= 5

    wait_for(process, busy, timeout_s=120)
    kill_driver_and_expect_nothing_left(process)


def test_a_killed_resource_tracker_is_a_warning(slow_fleet: Path, tmp_path: Path) -> None:
    report = tmp_path / "r.jsonl"
    process = start_check([str(slow_fleet), "--jobs", "2", "--report", str(report)])
    try:
        wait_for(process, lambda processes: len(processes) >= 5, timeout_s=120)
        tracker = [pid for pid, command in session_processes(process.pid).items() if "multiprocessing.resource_tracker" in command]
        assert len(tracker) == 1, session_processes(process.pid)
        os.kill(tracker[0], signal.SIGKILL)
        out, err = process.communicate(timeout=300)
    finally:
        end_session(process.pid)
    assert process.returncode == 0, err
    assert out.decode().splitlines()[-1].startswith("16 recordings: 16 pass, 0 fail, 0 error in ")
    lines = err.decode().splitlines()
    assert all(line.startswith("tfrec: warning: ") for line in lines), lines  # no tracker's tracebacks
    assert report.read_text().count('"check": "summary"') == 16
