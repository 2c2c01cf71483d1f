"""`tfrec check --engine ray --address A` where no Ray cluster is: one `tfrec: error:` line within --ray-timeout,
none of Ray's own lines — for a closed port, a silent TCP server, a web server, a server that speaks HTTP/2 (as
gRPC does) but is no Ray cluster, a host name that does not resolve, and malformed addresses. No cluster is
started here (a real one answering the probe: test_ray.py)."""

from __future__ import annotations

import http.server
import resource
import socket
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.conftest import REPO
from tests.fleet.helpers import tfrec_env
from tfrec.fleet import FleetError
from tfrec.fleet.raycluster import probe, split_address

pytest.importorskip("ray")

HOST = "127.0.0.2" if sys.platform.startswith("linux") else "127.0.0.1"
"""A loopback address Ray does not replace by the machine's own (it does so for 127.0.0.1 and localhost)."""

H2_SETTINGS = b"\x00\x00\x00\x04\x00\x00\x00\x00\x00"
"""An empty HTTP/2 SETTINGS frame: what a gRPC server sends first."""


def _serve(handle: Callable[[socket.socket], None]) -> Iterator[int]:
    """A TCP server on HOST that hands each connection to ``handle``; yields its port."""
    server = socket.socket()
    server.bind((HOST, 0))
    server.listen(16)
    connections: list[socket.socket] = []

    def accept() -> None:
        while True:
            try:
                connection, _ = server.accept()
            except OSError:  # closed: the test is over
                return
            connections.append(connection)
            threading.Thread(target=handle, args=(connection,), daemon=True).start()

    threading.Thread(target=accept, daemon=True).start()
    try:
        yield server.getsockname()[1]
    finally:
        server.close()
        for connection in connections:
            connection.close()


def _silent(connection: socket.socket) -> None:
    """Accept, read, never answer."""
    try:
        while connection.recv(65536):
            pass
    except OSError:
        pass


def _grpc_like(connection: socket.socket) -> None:
    """Answer the HTTP/2 preface with a SETTINGS frame, then nothing: it looks like gRPC, it is no Ray."""
    try:
        connection.sendall(H2_SETTINGS)
        _silent(connection)
    except OSError:
        pass


@pytest.fixture
def silent_server() -> Iterator[int]:
    yield from _serve(_silent)


@pytest.fixture
def grpc_like_server() -> Iterator[int]:
    yield from _serve(_grpc_like)


@pytest.fixture
def web_server() -> Iterator[int]:
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, format: str, *args: object) -> None:
            pass

    server = http.server.ThreadingHTTPServer((HOST, 0), Quiet)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        yield server.server_address[1]
    finally:
        server.shutdown()
        server.server_close()


def _closed_port() -> int:
    with socket.socket() as probe_socket:
        probe_socket.bind(("127.0.0.1", 0))
        return int(probe_socket.getsockname()[1])  # closed again when this returns


def _check(address: str, tmp_path: Path, timeout_s: float = 5) -> tuple[str, float]:
    """``tfrec check`` of one recording on the Ray cluster at ``address``: (its stderr, its CPU seconds). It
    must fail with exit code 2 and one line; the hang guard is generous (Ray alone would retry for ~12 min)."""
    recording = tmp_path / "r.mcap"
    recording.write_bytes(b"")  # never read: the run stops at the address
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([sys.executable, "-m", "tfrec", "check", str(recording), "--engine", "ray",
                           "--address", address, "--ray-timeout", str(timeout_s)],
                          cwd=REPO, env=tfrec_env(), capture_output=True, text=True, timeout=180, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert done.returncode == 2, done.stderr
    assert done.stdout == ""
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tfrec: error: --address "), done.stderr  # Ray's own lines: none
    return lines[0], (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def test_a_closed_port(tmp_path: Path) -> None:
    line, cpu_s = _check(f"127.0.0.1:{_closed_port()}", tmp_path)
    assert "no Ray cluster there: nothing listens there (connection refused)" in line
    assert cpu_s < 30


def test_a_silent_tcp_server(silent_server: int, tmp_path: Path) -> None:
    line, cpu_s = _check(f"{HOST}:{silent_server}", tmp_path, timeout_s=2)
    assert line.endswith("no Ray cluster there: something listens there but gave no gRPC answer within 2 s")
    assert cpu_s < 30  # waiting, not spinning


def test_a_web_server(web_server: int, tmp_path: Path) -> None:
    line, _ = _check(f"{HOST}:{web_server}", tmp_path)
    assert line.endswith("no Ray cluster there: something else listens there (it does not speak gRPC)")


def test_a_server_that_speaks_http2_but_is_no_ray_cluster(grpc_like_server: int, tmp_path: Path) -> None:
    # the probe passes; Ray's own connection is then bounded by the time left
    line, cpu_s = _check(f"{HOST}:{grpc_like_server}", tmp_path, timeout_s=3)
    assert f"--address {HOST}:{grpc_like_server}: cannot connect to a Ray cluster: " in line
    assert cpu_s < 30


def test_a_host_name_that_does_not_resolve(tmp_path: Path) -> None:
    line, _ = _check("no-such-host.invalid:6379", tmp_path)  # .invalid never resolves (RFC 2606)
    assert "no Ray cluster there: " in line and "no-such-host.invalid" in line


@pytest.mark.parametrize("address", ["bad::addr", "localhost", "ray://"])
def test_malformed_addresses(address: str, tmp_path: Path) -> None:
    line, _ = _check(address, tmp_path)
    assert "is not an address of a Ray cluster (host:port, ray://host:port, auto or local)" in line


def test_ray_address_from_the_environment(tmp_path: Path) -> None:
    recording = tmp_path / "r.mcap"
    recording.write_bytes(b"")
    done = subprocess.run([sys.executable, "-m", "tfrec", "check", str(recording), "--engine", "ray"], cwd=REPO,
                          env={**tfrec_env(), "RAY_ADDRESS": "head-node"}, capture_output=True, text=True, timeout=180,
                          check=False)
    assert (done.returncode, done.stderr) == (2, ("tfrec: error: RAY_ADDRESS 'head-node' is not an address of a Ray "
                                                 "cluster (host:port, ray://host:port, auto or local)\n"))


def test_split_address() -> None:
    assert split_address("10.0.0.5:6379") == ("10.0.0.5", 6379)
    assert split_address("ray://head.example:10001") == ("head.example", 10001)
    assert split_address("[::1]:6379") == ("::1", 6379)
    for bad in ("10.0.0.5", "10.0.0.5:0", "10.0.0.5:65536", "10.0.0.5:६३७९", "[::1]", "a b:1", "ray://", ":6379",
                "10.0.0.5:6379/x", "host\x1b[2J:1"):
        with pytest.raises(FleetError, match="is not an address of a Ray cluster"):
            split_address(bad)


def test_the_probe_in_process(silent_server: int, web_server: int, grpc_like_server: int) -> None:
    assert probe(HOST, grpc_like_server, timeout_s=5) is None  # looks like gRPC: Ray is asked
    assert probe(HOST, silent_server, timeout_s=5, grpc=False) is None  # TLS (RAY_USE_TLS): a connection is enough
    assert probe(HOST, silent_server, timeout_s=0.5) == "something listens there but gave no gRPC answer within 0.5 s"
    assert probe(HOST, web_server, timeout_s=5) == "something else listens there (it does not speak gRPC)"
    assert probe("127.0.0.1", _closed_port(), timeout_s=5) == "nothing listens there (connection refused)"


def test_a_local_cluster_that_cannot_start_is_one_line(tmp_path: Path) -> None:
    """Under a 1 GiB address-space limit Ray's own processes cannot start, and ``ray.init`` raises a plain
    ``Exception`` ("The current node timed out during startup"): one line, and none of the processes it started
    is left to say "subprocess N is still running" or to outlive the run."""
    from tests.fuzz.harness import contract_violations, run_tfrec

    (tmp_path / "fleet").mkdir()
    (tmp_path / "fleet" / "a.mcap").write_bytes((REPO / "tests" / "golden" / "mbot-sine-2s.mcap").read_bytes())
    outcome = run_tfrec(["check", "fleet", "--engine", "ray", "--jobs", "1"], cwd=tmp_path, isolated=True)
    assert not contract_violations(outcome, codes=()), outcome.stderr
    assert outcome.stderr.startswith("tfrec: error: cannot start a local Ray cluster: ")
    assert outcome.stderr.count("\n") == 1, outcome.stderr
