"""A `tfrec check` driver killed by SIGKILL (as the OOM killer does) leaves nothing behind: its pool workers,
the forkserver and the resource tracker end within seconds and the caller's pipes reach end-of-file; a
resource tracker killed under a running check costs a warning, not tracebacks. (Ray's local cluster: in
test_ray.py.)"""

from __future__ import annotations

import os
import signal
import warnings
from pathlib import Path

import pytest

from tests.fleet.helpers import (
    end_session,
    kill_driver_and_expect_nothing_left,
    session_processes,
    start_check,
    wait_for,
)
from tests.recording_helpers import load_robot, write_mcap
from tfrec.trajectory.generators import make_trajectory


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
