"""The Ray engine on real clusters: a local one (``ray.init(num_cpus=2)``, once per session) and a
head plus a second node started with ``ray start`` on this machine, on loopback addresses.

The clusters are ended by the ids of the processes these tests started (``ray stop`` would end
every Ray process of the machine, other users' too).
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.conftest import REPO
from tests.fleet import helpers
from tests.fleet.helpers import EXPECTED
from tfrec.fleet import ERROR, PASS, Progress, Row, Task, check_tasks, find_recordings, run

ray = pytest.importorskip("ray")

pytestmark = pytest.mark.ray

_ENV = {
    "RAY_AUTH_MODE": "disabled",
    "RAY_USAGE_STATS_ENABLED": "0",
    "PYTHONPATH": os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])]),
}
"""What Ray's processes need: tfrec and these tests importable, no authentication or usage stats."""


@pytest.fixture(scope="session")
def local_ray() -> Iterator[None]:
    """A local Ray cluster of 2 CPUs in this process, for the session."""
    if ray.is_initialized():
        pytest.skip("Ray is already initialized in this process")
    for name in ("RAY_AUTH_MODE", "RAY_USAGE_STATS_ENABLED"):
        os.environ.setdefault(name, _ENV[name])
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="error",
             runtime_env={"env_vars": {"PYTHONPATH": _ENV["PYTHONPATH"]}})
    yield
    ray.shutdown()


def test_ray_gives_the_pools_verdicts(local_ray: None, fleet_dir: Path) -> None:
    rows: list[Row] = []
    progress = run(check_tasks(find_recordings([fleet_dir])), engine="ray",
                   on_result=lambda result, _: rows.extend(result))
    assert progress == Progress(done=9, total=9, passed=3, failed=4, errors=2)
    from tests.fleet.test_engine import _by_file

    assert _by_file(rows, fleet_dir) == EXPECTED
    assert ray.is_initialized()  # a cluster the caller started is left running


def test_ray_retries_a_task_whose_worker_died(local_ray: None, tmp_path: Path) -> None:
    tasks = [Task("once", helpers.die_once, ("once", str(tmp_path / "died"))), Task("always", helpers.die_always,
                                                                                   ("always",)),
             Task("ok", helpers.ok, ("ok",))]
    rows: dict[str, Row] = {}
    progress = run(tasks, engine="ray", on_result=lambda result, _: rows.update({result[0].file: result[0]}))
    assert progress == Progress(done=3, total=3, passed=2, errors=1)
    assert (rows["once"].verdict, rows["once"].detail) == (PASS, "survived")
    assert rows["always"].verdict == ERROR and rows["always"].detail.startswith("worker died (WorkerCrashedError: ")


# -- a head and a second node ---------------------------------------------------------------------


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _session_members(sessions: set[int]) -> list[int]:
    """The live processes of these sessions (each ``ray start`` runs in a session of its own)."""
    out = []
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            stat = Path(f"/proc/{name}/stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if int(fields[3]) in sessions and fields[0] != "Z":
            out.append(int(name))
    return out


def _end_sessions(sessions: set[int]) -> None:
    """End every process of these sessions: SIGTERM, then SIGKILL what is left after 3 s (Ray would
    drain for up to 30 s)."""
    for sig, grace in ((signal.SIGTERM, 3.0), (signal.SIGKILL, 5.0)):
        for pid in _session_members(sessions):
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + grace
        while _session_members(sessions) and time.monotonic() < deadline:
            time.sleep(0.1)
    assert not _session_members(sessions)


def _ray_start(args: list[str], node_ip: str, cpus: int, log: Path) -> subprocess.Popen[bytes]:
    ports = ["--dashboard-agent-listen-port", "--dashboard-agent-grpc-port", "--runtime-env-agent-port",
             "--metrics-export-port", "--node-manager-port", "--object-manager-port"]
    command = [str(Path(sys.executable).with_name("ray")), "start", "--block", "--disable-usage-stats",
               "--node-ip-address", node_ip, "--num-cpus", str(cpus), *args]
    for option in ports:
        command += [option, str(_free_port())]
    with open(log, "wb") as out:
        return subprocess.Popen(command, env={**os.environ, **_ENV}, stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True)


def _cluster_nodes(address: str) -> int:
    """Alive nodes, asked from another process (this one may be in another cluster)."""
    probe = (f"import ray; ray.init(address={address!r}, log_to_driver=False, logging_level='error'); "
             "print(sum(1 for n in ray.nodes() if n['Alive']))")
    done = subprocess.run([sys.executable, "-c", probe], env={**os.environ, **_ENV}, capture_output=True,
                          text=True, timeout=60, check=False)
    return int(done.stdout.strip() or 0) if done.returncode == 0 else 0


def _wait_started(process: subprocess.Popen[bytes], log: Path, deadline: float) -> None:
    """Wait for ``ray start`` to say that its node runs."""
    while b"Ray runtime started" not in log.read_bytes():
        assert process.poll() is None and time.monotonic() < deadline, log.read_text()
        time.sleep(0.2)


@pytest.fixture
def two_nodes() -> Iterator[tuple[str, tuple[int, int]]]:
    """A Ray head on 127.0.0.2 and a second node on 127.0.0.3: (address, {head's session, node's session}).

    The head has no CPU (as large clusters run it: it only schedules), the second node two, so
    every task crosses to the second node. (With a CPU on the head, Ray reuses the head's
    worker for short tasks and the second node may get none.) Ray 2.60 turns
    ``--node-ip-address 127.0.0.1`` into the machine's routable address; other loopback
    addresses it keeps (its servers still listen on every interface).
    """
    if not sys.platform.startswith("linux"):
        pytest.skip("127.0.0.2 and 127.0.0.3 are loopback addresses on Linux only")
    temp = Path(tempfile.mkdtemp(prefix="tfrec-ray-"))  # short: Ray's socket paths live under it
    port = _free_port()
    address = f"127.0.0.2:{port}"
    head = ["--head", "--port", str(port), "--include-dashboard", "false", "--temp-dir", str(temp)]
    if importlib.util.find_spec("grpc") is not None:
        # With ray[client]'s grpc present the head also serves Ray Client, on 10001 unless told otherwise;
        # without it, Ray refuses the option (and serves no client).
        head += ["--ray-client-server-port", str(_free_port())]
    processes = [_ray_start(head, "127.0.0.2", 0, temp / "head.log")]
    sessions = {processes[0].pid}
    try:
        deadline = time.monotonic() + 120
        _wait_started(processes[0], temp / "head.log", deadline)
        processes.append(_ray_start(["--address", address], "127.0.0.3", 2, temp / "node.log"))
        sessions.add(processes[1].pid)
        _wait_started(processes[1], temp / "node.log", deadline)
        while _cluster_nodes(address) < 2:
            assert time.monotonic() < deadline, "the second node did not join"
            time.sleep(0.5)
        yield address, (processes[0].pid, processes[1].pid)
    finally:
        _end_sessions(sessions)
        for process in processes:
            process.wait(timeout=10)
        shutil.rmtree(temp, ignore_errors=True)


def test_check_on_a_two_node_cluster(two_nodes: tuple[str, tuple[int, int]], fleet_dir: Path, tmp_path: Path) -> None:
    address, _ = two_nodes
    report = tmp_path / "fleet.jsonl"
    done = subprocess.run([sys.executable, "-m", "tfrec", "check", str(fleet_dir), "--engine", "ray",
                           "--address", address, "--report", str(report)],
                          cwd=REPO, env={**os.environ, **_ENV}, capture_output=True, text=True, timeout=300,
                          check=False)
    assert done.returncode == 1, done.stderr  # findings
    assert "9 recordings: 3 pass, 4 fail, 2 error" in done.stdout.splitlines()[-1]
    rows = [json.loads(line) for line in report.read_text().splitlines()]
    verdicts = {Path(r["file"]).relative_to(fleet_dir).as_posix(): r["verdict"] for r in rows if r["check"] == "summary"}
    assert verdicts == {name: verdict for name, (verdict, _) in EXPECTED.items()}
    assert any(r["check"] == "resim" and r["frame"] == "link2" for r in rows)  # the description mismatch
    assert any(r["check"] == "read" for r in rows)  # the damaged file
    # which node ran each recording: the worker column names the Ray node's address
    ran_in = [row["worker"].rsplit(":", 1)[0] for row in rows if row["check"] == "summary"]
    assert len(ran_in) == 9 and set(ran_in) == {"127.0.0.3"}  # every recording ran on the second node


# -- a local cluster started by tfrec, its driver killed --------------------------------------------


def test_a_killed_driver_takes_its_local_cluster_with_it(tmp_path: Path) -> None:
    """SIGKILL of `tfrec check --engine ray` (a local cluster of its own): GCS, raylet, agents and workers are
    gone within seconds, not the minute Ray's agents would wait for the dead GCS."""
    from tests.fleet.helpers import kill_driver_and_expect_nothing_left, start_check, wait_for
    from tests.recording_helpers import load_robot, write_mcap
    from tfrec.trajectory.generators import make_trajectory

    marm = load_robot("marm")
    first = write_mcap(tmp_path / "r00.mcap", marm, make_trajectory(marm, "sine", duration_s=30, rate_hz=200))
    for k in range(1, 16):
        os.link(first, tmp_path / f"r{k:02d}.mcap")
    process = start_check([str(tmp_path), "--engine", "ray", "--jobs", "2"])

    def working(processes: dict[int, str]) -> bool:  # Ray's workers started: the whole cluster runs
        return sum("default_worker.py" in command or command.startswith("ray::") for command in processes.values()) >= 4

    wait_for(process, working, timeout_s=180)
    kill_driver_and_expect_nothing_left(process)
