"""Processes of a fleet run that end with its driver, and helpers that keep quiet.

A driver killed by SIGKILL (the kernel's OOM killer) runs no clean-up code, so what it started must
notice on its own:

- Pool workers (:func:`watch_parent`): each runs a thread that waits for the end of the pipe only its
  driver holds (``multiprocessing.parent_process().sentinel``: the forkserver keeps no copy) and ends
  the worker when it closes. The forkserver then ends (its workers gone, its "alive" pipe closes), and
  the resource tracker after it (its pipe closes too; it unlinks the semaphores the driver left).
- A local Ray cluster (:class:`Reaper`): Ray shares the fate of the GCS and the raylet with the driver,
  but the raylet's agents wait up to a minute for the dead GCS, and workers may linger. A reaper
  process (``tfrec/fleet/_reaper.py``, standard library only) started before the cluster lists the
  driver's descendants every :data:`REAPER_POLL_S` and, when the pipe from the driver closes (its
  death, or the run's end after ``ray.shutdown()``), kills those still running, and those that
  carry its mark in their environment (set while the cluster starts: Ray's workers inherit it).

Helpers that would otherwise write to the terminal — the pool's resource tracker, Ray while it
connects — are started or run with their stderr on ``/dev/null`` (:func:`quiet_stderr`).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import multiprocessing.connection
import os
import secrets
import subprocess
import sys
import threading
import warnings
from collections.abc import Iterator
from pathlib import Path

from tfrec.errors import FleetError

__all__ = ["REAPER_POLL_S", "Reaper", "quiet_resource_tracker", "quiet_stderr", "watch_parent"]

REAPER_POLL_S = 0.5
"""How often the reaper lists the driver's descendants (it kills those it has seen)."""

_ORPHAN_EXIT = 70
"""A pool worker's exit code when its driver died (EX_SOFTWARE; nobody reads it)."""


@contextlib.contextmanager
def quiet_stderr() -> Iterator[None]:
    """File descriptor 2 on ``/dev/null`` for the duration: what native code (Ray's C++ core) and
    processes started meanwhile write there is dropped. Python's ``sys.stderr`` is flushed first."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, OSError, ValueError):
            stream.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no fd 2 at all: nothing to keep quiet
        yield
        return
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 2)
        finally:
            os.close(null)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker (or start it again, if it was killed) with its stderr on
    ``/dev/null``: a tracker started again is told to forget semaphores it never saw, and says so with
    a traceback each. Starting it again warns (``resource_tracker: process died unexpectedly``)."""
    from multiprocessing import resource_tracker

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with quiet_stderr():
            resource_tracker.ensure_running()
    for warning in caught:  # shown once stderr is back
        warnings.warn(str(warning.message), warning.category, stacklevel=2)


# -- pool workers -----------------------------------------------------------------------------


def watch_parent() -> None:
    """In a pool worker: end this process as soon as the driver that started it is gone.

    ``multiprocessing.parent_process().sentinel`` is the read end of a pipe whose write end only the
    driver holds; it reads end-of-file when the driver exits or is killed.
    """
    parent = multiprocessing.parent_process()
    if parent is None:
        return
    sentinel = parent.sentinel
    threading.Thread(target=_exit_with, args=(sentinel,), name="tfrec-watch-driver", daemon=True).start()


def _exit_with(sentinel: int) -> None:
    multiprocessing.connection.wait([sentinel])
    os._exit(_ORPHAN_EXIT)  # no clean-up: the driver that would read our results is gone


# -- a local Ray cluster ------------------------------------------------------------------------

_REAPER = Path(__file__).with_name("_reaper.py")
_MARK = "TFREC_REAPER"


class Reaper:
    """A process that kills this process's descendants left running when this process ends.

    Start it before the processes it must end (a local Ray cluster), :meth:`close` it after they were
    shut down normally (it then kills what is left, if anything, and exits). When this process dies
    without closing it, the pipe closes all the same and the reaper does its work.
    """

    def __init__(self) -> None:
        # -I -S: the standard library only, whatever the environment; stderr on /dev/null and stdout a pipe of
        # ours, closed once it said it is ready, so that it never holds the caller's pipes; stdin: the pipe whose
        # end-of-file means "this process is gone".
        self.token = secrets.token_hex(8)
        try:
            self._process = subprocess.Popen(
                [sys.executable, "-I", "-S", str(_REAPER), str(os.getpid()), str(REAPER_POLL_S), self.token],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, close_fds=True,
            )
        except OSError as err:
            raise FleetError(f"cannot start the process that ends a local Ray cluster with its driver: "
                             f"{err.strerror or err}") from None
        if self._process.stdout is not None:
            with self._process.stdout:
                self._process.stdout.readline()  # "ready": it knows which processes were here before it

    @property
    def pid(self) -> int:
        return self._process.pid

    @contextlib.contextmanager
    def marking(self) -> Iterator[None]:
        """``TFREC_REAPER=token`` in this process's environment for the duration, so that the processes
        started meanwhile (and theirs) carry it: the reaper finds those it was too slow to see."""
        os.environ[_MARK] = self.token
        try:
            yield
        finally:
            os.environ.pop(_MARK, None)

    def close(self, timeout_s: float = 10.0) -> None:
        """Tell the reaper this process is done, and wait for it."""
        if self._process.stdin is not None:
            with contextlib.suppress(OSError):
                self._process.stdin.close()
        try:
            self._process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
