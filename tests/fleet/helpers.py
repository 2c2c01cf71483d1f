"""What the fleet tests share: a folder of small recordings with known verdicts, tasks that kill
their worker (importable by pool and Ray workers, as ``tests.fleet.helpers``), and the processes of a
run: its session, a child that meets file permissions even as root, a driver killed."""

from __future__ import annotations

import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import IO

import numpy as np

from tests.conftest import REPO
from tests.recording_helpers import load_robot, write_mcap, write_rosbag2
from tfrec.fleet import Row
from tfrec.formats.reader import read_recording
from tfrec.recording import FrameSeries, JointStates
from tfrec.trajectory.generators import make_trajectory

EXPECTED = {
    "marm/sine.mcap": ("pass", set()),
    "marm/random.mcap": ("pass", set()),
    "mbot/sine.mcap": ("pass", set()),
    "bad/truncated.mcap": ("fail", {"read"}),
    "bad/garbage.mcap": ("error", set()),
    "bad/mismatch.mcap": ("fail", {"resim"}),
    "bad/zero_stamps.mcap": ("fail", {"stamps"}),
    "bad/gap_bag": ("fail", {"rate"}),
    "bad/odd.dat": ("error", set()),
}
"""Each recording of :func:`make_fleet`, relative to its folder: (verdict, checks of its findings)."""


def _mismatched(urdf: str) -> str:
    """marm's URDF with joint2's origin moved by 1 cm along z."""
    at = urdf.index('name="joint2"')
    origin = urdf.index('xyz="-0.1 0 0"', at)
    return urdf[:origin] + 'xyz="-0.1 0 0.01"' + urdf[origin + len('xyz="-0.1 0 0"'):]


def _with_gap(folder: Path, source: Path, lost: slice) -> None:
    """A rosbag2 bag of ``source`` without the /joint_states and /tf samples of ``lost``."""
    rec = read_recording(source)
    js = rec.joint_states
    assert js is not None
    keep = np.ones(len(js), dtype=np.bool_)
    keep[lost] = False
    rec.joint_states = JointStates(js.time_ns[keep], js.names, js.positions[keep])
    rec.tf = {pair: FrameSeries(s.time_ns[keep], s.translation[keep], s.rotation[keep]) for pair, s in rec.tf.items()}
    write_rosbag2(rec, folder, storage="mcap")


def make_fleet(folder: Path, *, duration_s: float = 2.0, rate_hz: float = 50.0) -> Path:
    """A folder of small recordings whose verdicts are :data:`EXPECTED` (plus ``notes.txt``,
    which is not looked at)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        marm, mbot = load_robot("marm"), load_robot("mbot")
        for sub in ("marm", "mbot", "bad"):
            (folder / sub).mkdir(parents=True, exist_ok=True)
        sine = make_trajectory(marm, "sine", duration_s=duration_s, rate_hz=rate_hz)
        good = write_mcap(folder / "marm" / "sine.mcap", marm, sine)
        write_mcap(folder / "marm" / "random.mcap", marm,
                   make_trajectory(marm, "random", duration_s=duration_s, rate_hz=rate_hz, seed=1))
        write_mcap(folder / "mbot" / "sine.mcap", mbot,
                   make_trajectory(mbot, "sine", duration_s=duration_s, rate_hz=rate_hz))
        write_mcap(folder / "bad" / "mismatch.mcap", marm, sine, description=_mismatched(marm.urdf))
        write_mcap(folder / "bad" / "zero_stamps.mcap", marm, sine, start_time_ns=0)
        _with_gap(folder / "bad" / "gap_bag", good, slice(40, 60))
    data = good.read_bytes()
    (folder / "bad" / "truncated.mcap").write_bytes(data[: len(data) * 2 // 3])
    (folder / "bad" / "garbage.mcap").write_bytes(np.random.default_rng(0).bytes(5000))
    (folder / "bad" / "odd.dat").write_bytes(b"\x00\x01 not a recording" * 10)
    (folder / "notes.txt").write_text("not a recording\n")
    return folder


def copy_fleet(source: Path, target: Path) -> Path:
    """A copy of a :func:`make_fleet` folder (file times kept)."""
    shutil.copytree(source, target)
    return target


# -- tasks for the engine tests (top level: workers import them by name) ---------------------------


def ok(key: str, seconds: float = 0.0) -> list[Row]:
    """A task that passes, after ``seconds``."""
    time.sleep(seconds)
    return [Row(file=key, detail="ok")]


def die_once(key: str, marker: str) -> list[Row]:
    """A task whose worker is killed (SIGKILL) the first time, and that passes the second."""
    if not os.path.exists(marker):
        Path(marker).write_text(str(os.getpid()))
        os.kill(os.getpid(), signal.SIGKILL)
    return [Row(file=key, detail="survived")]


def die_always(key: str) -> list[Row]:
    """A task whose worker exits with code 137 (as after the OOM killer's SIGKILL in a shell) every time."""
    os._exit(137)


def buggy(key: str) -> list[Row]:
    """A task that meets a bug."""
    return [Row(file=key, detail=str(1 / 0))]


# -- processes: a run's session, a child without root's permission override -------------------------

RAY_ENV = {
    "RAY_AUTH_MODE": "disabled",
    "RAY_USAGE_STATS_ENABLED": "0",
}
"""What Ray's processes need besides tfrec: no authentication, no usage stats."""


def tfrec_env() -> dict[str, str]:
    """The environment of a ``python -m tfrec`` child: tfrec and these tests importable, Ray quiet."""
    return {**os.environ, **RAY_ENV,
            "PYTHONPATH": os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}


def session_processes(session: int) -> dict[int, str]:
    """The live processes (zombies left out) of a session: pid → command line."""
    out = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            stat = Path(f"/proc/{name}/stat").read_text()
            command = Path(f"/proc/{name}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if int(fields[3]) == session and fields[0] != "Z":
            out[int(name)] = command.strip()
    return out


def end_session(session: int) -> None:
    """SIGKILL what is left of a session a test started (by pid: never another's processes)."""
    for _ in range(3):
        for pid in session_processes(session):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        time.sleep(0.2)


_CAP_DAC_OVERRIDE, _CAP_DAC_READ_SEARCH, _PR_CAPBSET_DROP = 1, 2, 24


def _drop_file_capabilities() -> None:
    """In a child before exec: leave root's capabilities to bypass file permissions out of the bounding set,
    so that after exec even root meets ``chmod 000`` (the child is otherwise root as before)."""
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    for capability in (_CAP_DAC_OVERRIDE, _CAP_DAC_READ_SEARCH):
        if libc.prctl(_PR_CAPBSET_DROP, capability, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")


def permissions_apply() -> str | None:
    """None when a child started with :func:`unprivileged` meets file permissions; else why not (for a skip)."""
    with tempfile.TemporaryDirectory() as folder:
        locked = Path(folder) / "locked"
        locked.write_text("x")
        locked.chmod(0)
        try:
            done = subprocess.run([sys.executable, "-c", f"open({str(locked)!r}).read()"], capture_output=True,
                                  timeout=60, check=False, preexec_fn=unprivileged())
        except OSError as err:
            return f"cannot start a child without root's file permission override: {err}"
        if done.returncode == 0:
            return "a mode-000 file is readable here even without CAP_DAC_OVERRIDE (a file system that ignores modes?)"
    return None


def unprivileged() -> Callable[[], None] | None:
    """The ``preexec_fn`` of a child that meets file permissions: as root, one that leaves out the capabilities
    that override them (:func:`_drop_file_capabilities`); as another user, none is needed."""
    return _drop_file_capabilities if os.geteuid() == 0 else None


GRACE_S = 5.0
"""How long after its driver's death a run's processes may take to end (the issue's figure)."""


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
