"""The Ray cluster of a run: one at an address, reached within a time limit and quietly, or a local one
started for the run that ends with its driver.

Ray's own ``ray.init(address=…)`` retries for minutes when nothing Ray answers there (about 35 s per
attempt, 20 attempts, each with warning lines from its C++ core on stderr). So before Ray is asked,
the address is probed within ``timeout_s`` (:func:`probe`): the host name resolved, a TCP
connection opened, and the HTTP/2 preface of gRPC answered with a SETTINGS frame, as Ray's GCS
does. An address that is malformed, does not resolve, where nothing listens, or where something
else listens (a web server, a silent TCP server) is one :class:`~tfrec.errors.FleetError` line.
What passes the probe but is still no Ray cluster (another gRPC server) fails within about
``timeout_s`` more: ``ray.init`` is then told to try once (``RAY_gcs_server_port_wait_time_s``),
and, when Ray is imported here for the first time, to give up each connection after ``timeout_s``
(``RAY_py_gcs_connect_timeout_s``, read when Ray is imported).

Ray's own output is silenced: its Python loggers at ERROR, workers' output not sent to the driver,
and the driver's stderr (file descriptor 2) on ``/dev/null`` while Ray connects, starts or shuts
down (its C++ core writes there before its log files exist).

A local cluster (no address, no ``RAY_ADDRESS``) is started with a :class:`~tfrec.fleet.lifetime.Reaper`
beside it, which kills what is left of it when the driver ends, even by SIGKILL.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import socket
import sys
import threading
import time
import warnings
from collections.abc import Iterator
from typing import Any

from tfrec.errors import FleetError, one_line
from tfrec.fleet.lifetime import Reaper, quiet_stderr

__all__ = ["DEFAULT_RAY_TIMEOUT_S", "RAY_MISSING", "cluster", "import_ray", "probe", "split_address", "target_of"]

DEFAULT_RAY_TIMEOUT_S = 20.0
"""How long connecting to a Ray cluster at an address may take (``--ray-timeout``): a cluster answers in
a few seconds, and a command that cannot reach one ends within half a minute, start-up included."""

RAY_MISSING = "engine='ray' needs Ray: pip install 'tfrec-robotics[ray]'"
"""The message of the :class:`FleetError` raised when Ray is not installed."""

_H2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + b"\x00\x00\x00\x04\x00\x00\x00\x00\x00"
"""What a gRPC client sends first: the HTTP/2 connection preface and an empty SETTINGS frame."""

_SETTINGS = 0x04
"""The type of an HTTP/2 SETTINGS frame (the fourth byte of a frame's header), a server's first frame."""

_USAGE = "host:port, ray://host:port, auto or local"


def target_of(address: str | None) -> str:
    """The cluster a run uses: ``address``, else ``RAY_ADDRESS``, else ``local`` (never another user's
    cluster by chance)."""
    return address or os.environ.get("RAY_ADDRESS") or "local"


def split_address(address: str, *, name: str = "`address`") -> tuple[str, int]:
    """``(host, port)`` of ``host:port``, ``[v6]:port`` or ``ray://host:port``.

    Args:
        address: the address.
        name: what the message calls it (``RAY_ADDRESS`` when it came from the environment).

    Raises:
        FleetError: anything else.
    """
    text = address.removeprefix("ray://")
    host, sep, port_text = text.rpartition(":")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    port = int(port_text) if port_text.isdigit() and port_text.isascii() else -1
    odd = not host.isprintable() or any(c.isspace() or c in "/[]" for c in host)
    if not sep or not host or odd or not 0 < port < 65536:
        raise FleetError(f"{name} {address!r} is not an address of a Ray cluster ({_USAGE})")
    return host, port


def import_ray(address: str | None, *, timeout_s: float = DEFAULT_RAY_TIMEOUT_S) -> Any:
    """Ray, imported (for an address, with its connection timeout set to ``timeout_s`` first, unless
    the environment sets it, as Ray reads it when imported).

    Raises:
        FleetError: a malformed address (before Ray is imported), or Ray is not installed.
    """
    target = target_of(address)
    if target not in ("local", "auto"):
        split_address(target, name="`address`" if address else "RAY_ADDRESS")
    if target != "local" and "ray" not in sys.modules:
        os.environ.setdefault("RAY_py_gcs_connect_timeout_s", str(max(1, math.ceil(timeout_s))))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Ray's own deprecation notices are not the user's business
            import ray
    except ImportError:
        raise FleetError(RAY_MISSING) from None
    return ray


@contextlib.contextmanager
def cluster(ray: Any, *, jobs: int, address: str | None, timeout_s: float = DEFAULT_RAY_TIMEOUT_S) -> Iterator[None]:
    """Connected to the cluster at ``address`` (or ``RAY_ADDRESS``), or to a local one of ``jobs`` CPUs
    started for the run, for the duration; shut down (and the local one ended) after.

    Raises:
        FleetError: a malformed address, or no Ray cluster there within ``timeout_s``.
    """
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")  # else Ray 2.60 warns about token authentication
    target = target_of(address)
    options: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False, "logging_level": logging.ERROR}
    reaper = None
    if target == "local":
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
        options["num_cpus"] = jobs
        reaper = Reaper()  # before the cluster: it must see each of its processes start
    try:
        if reaper is None:
            _connect(ray, target, options, timeout_s=timeout_s, name="`address`" if address else "RAY_ADDRESS")
        else:
            with reaper.marking():
                _init(ray, target, options, failed="cannot start a local Ray cluster")
        try:
            yield
        finally:
            with quiet_stderr(), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ray.shutdown()
    finally:
        if reaper is not None:
            reaper.close()


def _connect(ray: Any, target: str, options: dict[str, Any], *, timeout_s: float, name: str) -> None:
    """Connect to the cluster at ``target`` (``name`` says where it came from): probed, then one attempt of
    Ray's connection loop (each waits up to ``RAY_py_gcs_connect_timeout_s``, read by ``ray.init`` itself)."""
    where = _bootstrap(ray, target, name)
    if where is not None:
        host, port = split_address(where, name=name)
        tls = os.environ.get("RAY_USE_TLS", "").lower() in ("1", "true")  # a TLS handshake first: no HTTP/2 seen
        problem = probe(host, port, timeout_s=timeout_s, grpc=not tls)
        if problem is not None:
            shown = "" if target.removeprefix("ray://") == f"{host}:{port}" else f" ({host}:{port})"
            raise FleetError(f"{name} {target}{shown}: no Ray cluster there: {problem}")
    with _environment({"RAY_gcs_server_port_wait_time_s": "1"}):
        _init(ray, target, options, failed=f"{name} {target}: cannot connect to a Ray cluster")


def _init(ray: Any, target: str, options: dict[str, Any], *, failed: str) -> None:
    """``ray.init`` with its output silenced; ``failed`` starts the message of a failure."""
    with quiet_stderr(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        message = None
        try:
            ray.init(address=target, **options)
        except Exception as err:
            # Ray raises these, and a plain Exception for a node that does not start (under a memory limit, say);
            # anything else is a bug and keeps its traceback
            if not isinstance(err, (ConnectionError, TimeoutError, RuntimeError, ValueError)) and type(err) is not Exception:
                raise
            message = _ray_says(err)
        if message is not None:  # out of the except clause: the error's frames, which hold Ray's processes, are gone
            _stop_what_started(ray)
            raise FleetError(f"{failed}: {message}")


def _stop_what_started(ray: Any) -> None:
    """After a failed ``ray.init``: stop the processes it started, and let their handles go while warnings are
    silenced (each would say "subprocess N is still running")."""
    import gc

    try:
        ray.shutdown()
    except (RuntimeError, OSError, ValueError):
        pass
    gc.collect()


def _ray_says(err: BaseException) -> str:
    """Ray's message, on one line and short, its backquotes made quotes (in tfrec's messages they name a
    parameter, which the command line shows as its flag)."""
    return one_line(str(err))[:300].replace("`", "'")


@contextlib.contextmanager
def _environment(values: dict[str, str]) -> Iterator[None]:
    """Environment variables set for the duration (those the environment sets already are left alone)."""
    added = [name for name in values if name not in os.environ]
    for name in added:
        os.environ[name] = values[name]
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


def _bootstrap(ray: Any, target: str, name: str) -> str | None:
    """The ``host:port`` Ray connects to for ``target``: ``auto`` read where Ray reads it, ``localhost``
    and ``127.0.0.1`` replaced by this machine's address as Ray replaces them; None when that cannot be
    told (``auto`` with a Ray whose reading of addresses moved: Ray alone is asked then)."""
    if target.startswith("ray://"):
        return target
    if target != "auto":
        split_address(target, name=name)  # a malformed address: our message, not Ray's
    try:
        from ray._private import services  # Ray's own reading of an address (not public API)

        canonical = services.canonicalize_bootstrap_address
    except (ImportError, AttributeError):
        return None if target == "auto" else target
    try:
        with quiet_stderr(), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found = canonical(target)
    except (ConnectionError, ValueError, RuntimeError) as err:
        raise FleetError(f"{name} {target}: {_ray_says(err)}") from None
    return str(found) if found else None


def probe(host: str, port: int, *, timeout_s: float, grpc: bool = True) -> str | None:
    """Why no Ray cluster answers at ``host:port`` within ``timeout_s`` — the name does not resolve,
    nothing listens, or what listens does not answer gRPC's HTTP/2 preface with a SETTINGS frame —
    or None when something that speaks gRPC answers (with ``grpc=False``: when a connection opens)."""
    deadline = time.monotonic() + timeout_s
    resolved = _resolve(host, port, timeout_s)
    if isinstance(resolved, str):
        return resolved
    problem = f"no answer within {timeout_s:g} s (a firewall, or a host that is down?)"
    for family, kind, proto, _, sockaddr in resolved:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            break
        with socket.socket(family, kind, proto) as sock:
            sock.settimeout(remaining)
            try:
                sock.connect(sockaddr)
            except ConnectionRefusedError:
                problem = "nothing listens there (connection refused)"
                continue
            except TimeoutError:
                continue
            except OSError as err:
                problem = f"cannot connect ({err.strerror or err})"
                continue
            return _answers_grpc(sock, deadline, timeout_s) if grpc else None
    return problem


def _resolve(host: str, port: int, timeout_s: float) -> list[Any] | str:
    """The socket addresses of ``host:port``, or why there are none. The resolver cannot be interrupted:
    it runs in a daemon thread, given up after ``timeout_s``."""
    result: list[Any] = []

    def resolve() -> None:
        try:
            result.append(socket.getaddrinfo(host, port, type=socket.SOCK_STREAM))
        except (OSError, UnicodeError) as err:
            result.append(f"cannot resolve the host name {host!r} ({getattr(err, 'strerror', None) or err})")

    worker = threading.Thread(target=resolve, name="tfrec-resolve", daemon=True)
    worker.start()
    worker.join(timeout_s)
    if not result:
        return f"the host name {host!r} did not resolve within {timeout_s:g} s"
    found: list[Any] | str = result[0]
    return found if found else f"the host name {host!r} has no address"


def _answers_grpc(sock: socket.socket, deadline: float, timeout_s: float) -> str | None:
    head = b""
    try:
        sock.sendall(_H2_PREFACE)
        while len(head) < 9:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError
            sock.settimeout(remaining)
            data = sock.recv(9 - len(head))
            if not data:
                return "something listens there but closed the connection (it does not speak gRPC)"
            head += data
    except TimeoutError:
        return f"something listens there but gave no gRPC answer within {timeout_s:g} s"
    except OSError as err:
        return f"something listens there but the connection failed ({err.strerror or err})"
    if head[3] != _SETTINGS:
        return "something else listens there (it does not speak gRPC)"
    return None
