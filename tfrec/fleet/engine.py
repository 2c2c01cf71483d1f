"""Running per-file tasks on a local process pool or a Ray cluster, streaming their rows back.

The unit of work is one recording (or one pair): a :class:`Task` calls a per-file function of
:mod:`tfrec.fleet.tasks` in a worker process and returns its report rows. :func:`run` hands the
rows of each task to ``on_result`` as soon as it finishes, with the running counts
(:class:`Progress`), in the order tasks finish.

- ``engine="pool"``: a :class:`concurrent.futures.ProcessPoolExecutor` of ``jobs`` workers
  (forkserver start method where available, else spawn; workers ignore Ctrl-C, the driver
  stops them). A worker that dies (killed by the kernel's OOM killer, a crash in native code,
  ``os._exit``) breaks the pool: the pool is rebuilt and the tasks it lost run again. The task
  that was running in the dead process is charged with the death (each worker says which task
  it starts, and the dead worker's exit code tells it from the workers the pool then
  terminates); after ``retries`` more deaths it becomes an ``error`` row ``worker died (signal
  SIGKILL)``. The other lost tasks run again uncharged. A driver that dies (SIGKILL) takes its
  workers with it (:func:`tfrec.fleet.lifetime.watch_parent`), and the forkserver and the resource
  tracker follow; the tracker writes to ``/dev/null``, and is started again quietly if it was killed.
- ``engine="ray"``: the same function as a Ray task (``max_retries=retries``: Ray reruns a task
  whose worker died) on the cluster at ``address`` (or ``RAY_ADDRESS``), reached within
  ``ray_timeout_s``, or on a local cluster of ``jobs`` CPUs started for the run (and shut down
  after it, or killed by a reaper when the driver dies): :mod:`tfrec.fleet.raycluster`. Tasks
  are spread over the nodes (``SPREAD``: Ray's default packs short tasks on the driver's node)
  and submitted in a window of twice the cluster's CPUs, so that the driver holds a bounded
  number of results.

Ctrl-C (KeyboardInterrupt) cancels what has not finished — the pool's workers are terminated,
Ray tasks cancelled — and is raised again once the workers are gone; the rows already handed to
``on_result`` are the run's result so far.

A task that raises :class:`tfrec.errors.TfrecError` gives an ``error`` row with its message; one
that raises any other exception (a bug met on that recording) gives an ``error`` row holding the
traceback, and the run goes on with the other recordings.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import signal
import socket
import sys
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ALL_COMPLETED, FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field, replace
from multiprocessing.context import BaseContext
from multiprocessing.queues import SimpleQueue
from typing import Any, Literal

from tfrec.errors import FleetError, TfrecError, one_line
from tfrec.fleet.lifetime import quiet_resource_tracker, watch_parent
from tfrec.fleet.raycluster import DEFAULT_RAY_TIMEOUT_S, RAY_MISSING, cluster, import_ray
from tfrec.fleet.row import ERROR, FAIL, PASS, SUMMARY, Row

__all__ = [
    "ENGINES",
    "RAY_MISSING",
    "Progress",
    "ResultCallback",
    "Task",
    "default_jobs",
    "execute",
    "run",
    "tally",
]

Engine = Literal["pool", "ray"]
ENGINES: tuple[Engine, ...] = ("pool", "ray")


@dataclass(frozen=True, slots=True)
class Task:
    """One unit of work: a per-file function and its arguments, picklable.

    Attributes:
        key: the report's ``file`` of the task's rows; names the task in the rows the engine
            makes itself (a dead worker's).
        func: a top-level function returning report rows, summary first
            (:func:`tfrec.fleet.tasks.check_recording`, :func:`~tfrec.fleet.tasks.diff_pair`).
        args, kwargs: its arguments.
        inputs: the recordings it reads (None: a side of a pair without one), fingerprinted by
            :func:`tfrec.fleet.plan.resume`.
        config: the digest of its options, the rows' ``config`` column.
    """

    key: str
    func: Callable[..., list[Row]]
    args: tuple[Any, ...] = ()
    kwargs: Mapping[str, Any] = field(default_factory=dict)
    inputs: tuple[str | None, ...] = ()
    config: str = ""

    def __call__(self) -> list[Row]:
        return self.func(*self.args, **self.kwargs)


@dataclass(frozen=True, slots=True)
class Progress:
    """Counts of a run, by the verdict of each finished task's summary row.

    Attributes:
        done: tasks finished (``passed + failed + errors``).
        total: tasks of the run.
        passed, failed, errors: tasks whose verdict is ``pass``, ``fail``, ``error``.
    """

    done: int = 0
    total: int = 0
    passed: int = 0
    failed: int = 0
    errors: int = 0

    def add(self, verdict: str) -> Progress:
        """The counts with one more task of that verdict."""
        return replace(self, done=self.done + 1, passed=self.passed + (verdict == PASS),
                       failed=self.failed + (verdict == FAIL), errors=self.errors + (verdict == ERROR))


ResultCallback = Callable[[list[Row], Progress], None]
"""Called in the driver with each finished task's rows and the counts including it."""


def tally(rows: Iterable[Row | Mapping[str, Any]]) -> Progress:
    """The counts of rows already known (a report's, kept by ``resume``): one per summary row."""
    progress = Progress()
    for row in rows:
        check, verdict = (row.check, row.verdict) if isinstance(row, Row) else (row.get("check"), row.get("verdict"))
        if check == SUMMARY:
            progress = progress.add(str(verdict))
    return replace(progress, total=progress.done)


def default_jobs() -> int:
    """All the cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _node() -> str:
    """Where a task runs: the Ray node's address inside a Ray worker (nodes may share a host), else the host."""
    ray = sys.modules.get("ray")
    if ray is not None:
        try:
            if ray.is_initialized():
                return str(ray.util.get_node_ip_address())
        except (AttributeError, RuntimeError):  # Ray's state inside a worker varies: the host still says where
            pass
    return socket.gethostname()


def _peak_rss_bytes() -> int | None:
    """This process's peak resident memory (``VmHWM``), or None where /proc does not say."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _error_row(task: Task, detail: str) -> Row:
    return Row(file=task.key, verdict=ERROR, detail=detail, config=task.config)


def execute(task: Task) -> list[Row]:
    """Run one task in a worker: its rows, the summary's ``elapsed_s``, ``cpu_s``, ``peak_rss_bytes``
    and ``worker`` filled in."""
    started, cpu = time.perf_counter(), time.process_time()
    try:
        rows = task()
    except TfrecError as err:
        rows = [_error_row(task, one_line(str(err)))]
    except Exception:  # noqa: BLE001 - a bug met on this recording: its row keeps the traceback, the others go on
        rows = [_error_row(task, "internal error (a tfrec bug: please report it): " + traceback.format_exc())]
    if not rows:
        rows = [_error_row(task, f"internal error: {getattr(task.func, '__name__', task.func)} returned no rows")]
    head = replace(rows[0], elapsed_s=time.perf_counter() - started, cpu_s=time.process_time() - cpu,
                   peak_rss_bytes=_peak_rss_bytes(),
                   worker=f"{_node()}:{os.getpid()}")
    return [head, *rows[1:]]


def _check_options(jobs: int | None, engine: str, retries: int, ray_timeout_s: float) -> int:
    if not (isinstance(ray_timeout_s, (int, float)) and 0 < ray_timeout_s < math.inf):
        raise FleetError(f"`ray_timeout_s` {ray_timeout_s!r} is not a number of seconds > 0")
    if engine not in ENGINES:
        raise FleetError(f"engine '{engine}' is not one of {', '.join(ENGINES)}")
    if jobs is not None and jobs < 1:
        raise FleetError(f"jobs {jobs} is not a number of processes >= 1")
    if retries < 0:
        raise FleetError(f"retries {retries} is not a number >= 0")
    return default_jobs() if jobs is None else jobs


def run(
    tasks: Sequence[Task],
    *,
    jobs: int | None = None,
    engine: str = "pool",
    address: str | None = None,
    on_result: ResultCallback | None = None,
    retries: int = 1,
    ray_timeout_s: float = DEFAULT_RAY_TIMEOUT_S,
) -> Progress:
    """Run tasks in parallel; each finished task's rows go to ``on_result`` as they come.

    Args:
        tasks: the work, one task per recording (or pair).
        jobs: worker processes of the pool, or CPUs of a local Ray cluster (default: all cores
            of this machine); a Ray cluster at ``address`` uses all of its CPUs.
        engine: ``pool`` or ``ray``.
        address: the Ray cluster to run on (``host:port``, ``ray://host:port`` (needs ray[client]), ``auto``);
            default ``RAY_ADDRESS``, else a local cluster for the run. Ray only.
        on_result: called in this process with each task's rows and the counts so far.
        retries: how many times a task whose worker died runs again before it is an ``error`` row.
        ray_timeout_s: how long connecting to the Ray cluster at ``address`` may take.

    Returns:
        The final counts.

    Raises:
        FleetError: bad options, Ray not installed, or no Ray cluster at ``address`` within ``ray_timeout_s``.
        KeyboardInterrupt: Ctrl-C, once the workers are stopped.
    """
    jobs = _check_options(jobs, engine, retries, ray_timeout_s)
    if address is not None and engine != "ray":
        raise FleetError("address is for engine='ray' only")
    state = _Tally(Progress(total=len(tasks)), on_result)
    if not tasks:
        return state.progress
    if engine == "ray":
        _run_ray(tasks, jobs=jobs, address=address, retries=retries, timeout_s=ray_timeout_s, emit=state.emit)
    else:
        _run_pool(tasks, jobs=jobs, retries=retries, emit=state.emit)
    return state.progress


class _Tally:
    """The driver's side of a run: counts, and the callback."""

    def __init__(self, progress: Progress, on_result: ResultCallback | None) -> None:
        self.progress = progress
        self.on_result = on_result

    def emit(self, rows: list[Row]) -> None:
        self.progress = self.progress.add(rows[0].verdict)
        if self.on_result is not None:
            self.on_result(rows, self.progress)


# -- the process pool ----------------------------------------------------------------------------

_started: SimpleQueue[tuple[int, int]] | None = None
"""In a pool worker: where it says (pid, task number) as it starts a task."""


def _init_worker(started: SimpleQueue[tuple[int, int]]) -> None:
    global _started
    _started = started
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's: it stops the workers
    watch_parent()  # a driver killed (SIGKILL: the OOM killer) takes its workers with it


def _pool_execute(number: int, task: Task) -> list[Row]:
    if _started is not None:
        _started.put((os.getpid(), number))
    return execute(task)


_PRELOAD = ("tfrec.fleet.tasks", "tfrec.replay", "tfrec.replay_check", "tfrec.diff")
"""Modules the forkserver imports once, before it forks the workers."""


def _context() -> BaseContext:
    if "forkserver" in multiprocessing.get_all_start_methods():
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(list(_PRELOAD))  # each worker starts with them imported
        return context
    return multiprocessing.get_context("spawn")


def _death(code: int | None) -> str:
    """``exit code 137`` or ``signal SIGKILL`` (with the likely cause), from a process's exit code."""
    if code is None:
        return "worker died"
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = str(-code)
        oom = " (out of memory?)" if -code == signal.SIGKILL else ""
        return f"worker died (signal {name}){oom}"
    oom = " (out of memory?)" if code == 137 else ""
    return f"worker died (exit code {code}){oom}"


class _Pool:
    """A process pool whose workers report the task they start, so that a death is attributed."""

    def __init__(self, context: BaseContext, jobs: int) -> None:
        quiet_resource_tracker()  # before the pool's semaphores: a tracker killed is started again quietly
        self.started: SimpleQueue[tuple[int, int]] = context.SimpleQueue()
        self.executor = ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=_init_worker,
                                            initargs=(self.started,))

    def submit(self, number: int, task: Task) -> Future[list[Row]]:
        return self.executor.submit(_pool_execute, number, task)

    def _processes(self) -> dict[int, multiprocessing.process.BaseProcess]:
        # The executor's workers by pid: not public API, read for the exit codes of a broken pool
        # (CPython 3.10-3.13 keep them there); without it, deaths are not attributed.
        processes = getattr(self.executor, "_processes", None)
        return dict(processes) if isinstance(processes, dict) else {}

    def deaths(self) -> tuple[dict[int, str] | None, str]:
        """After the pool broke: (task number → how its worker died, for the tasks whose worker
        died on its own rather than being terminated by the pool, or None when that cannot be
        told; how the workers died, in general)."""
        processes = self._processes()
        quiet_resource_tracker()  # shutting down unlinks the pool's semaphores: through a quiet tracker
        self.executor.shutdown(wait=True)  # the workers are joined: exit codes are known
        last: dict[int, int] = {}
        while not self.started.empty():
            pid, number = self.started.get()
            last[pid] = number
        self.started.close()
        dead = {pid: p.exitcode for pid, p in processes.items() if p.exitcode not in (None, -signal.SIGTERM)}
        how = "; ".join(dict.fromkeys(_death(code) for code in dead.values())) or "worker died"
        if not dead or any(pid not in last for pid in dead):
            return None, how
        return {last[pid]: _death(code) for pid, code in dead.items()}, how

    def terminate(self) -> None:
        """Stop now: cancel what waits, end the workers (Ctrl-C)."""
        processes = self._processes()
        quiet_resource_tracker()
        self.executor.shutdown(wait=False, cancel_futures=True)
        for process in processes.values():
            if process.is_alive():
                process.terminate()
        for process in processes.values():
            process.join(timeout=5)
            if process.is_alive():
                process.kill()
                process.join()
        self.started.close()
        quiet_resource_tracker()  # the semaphores are unlinked when this pool is dropped: by a quiet tracker

    def close(self) -> None:
        quiet_resource_tracker()
        self.executor.shutdown(wait=True)
        self.started.close()
        quiet_resource_tracker()


def _run_pool(tasks: Sequence[Task], *, jobs: int, retries: int, emit: Callable[[list[Row]], None]) -> None:
    context = _context()
    waiting = deque(range(len(tasks)))
    deaths: dict[int, list[str]] = {}
    running: dict[Future[list[Row]], int] = {}
    window = 2 * jobs
    pool = _Pool(context, jobs)
    try:
        while waiting or running:
            broken = False
            while waiting and len(running) < window:
                number = waiting.popleft()
                try:
                    running[pool.submit(number, tasks[number])] = number
                except BrokenProcessPool:
                    waiting.appendleft(number)
                    broken = True
                    break
            finished, _ = wait(running, return_when=ALL_COMPLETED if broken else FIRST_COMPLETED)
            lost: list[int] = []
            for future in finished:
                number = running.pop(future)
                if isinstance(future.exception(), BrokenProcessPool):
                    lost.append(number)
                    broken = True
                else:
                    emit(_with_deaths(future.result(), deaths.get(number)))
            if not broken:
                continue
            settled, _ = wait(running)  # a broken pool fails every task it holds
            for future in settled:
                number = running.pop(future)
                if isinstance(future.exception(), BrokenProcessPool):
                    lost.append(number)
                else:
                    emit(_with_deaths(future.result(), deaths.get(number)))
            charged, how = pool.deaths()
            pool = _Pool(context, jobs)
            _charge(lost, charged, how, deaths=deaths, waiting=waiting, tasks=tasks, retries=retries, emit=emit)
    except BaseException:
        pool.terminate()
        raise
    pool.close()


def _charge(lost: list[int], charged: dict[int, str] | None, how: str, *, deaths: dict[int, list[str]],
            waiting: deque[int], tasks: Sequence[Task], retries: int, emit: Callable[[list[Row]], None]) -> None:
    """The tasks ``lost`` with a broken pool: those whose worker died (``charged``: task → how; None: unknown, every
    one) are charged the death, and run again or given up past ``retries``; the others run again, uncharged."""
    if charged is not None and not charged.keys() & set(lost):
        charged = None  # a worker died between tasks: charge every lost task, so that the run ends
    for number in sorted(lost, reverse=True):
        if charged is not None and number not in charged:
            waiting.appendleft(number)  # lost with the pool, not its cause: runs again, uncharged
            continue
        deaths.setdefault(number, []).append(how if charged is None else charged[number])
        if len(deaths[number]) > retries:
            emit([_error_row(tasks[number], _died_detail(deaths[number]))])
        else:
            waiting.appendleft(number)


def _died_detail(deaths: list[str]) -> str:
    if len(set(deaths)) == 1:
        return deaths[0] + (f", {len(deaths)} times" if len(deaths) > 1 else "")
    return "; ".join(deaths)


def _with_deaths(rows: list[Row], deaths: list[str] | None) -> list[Row]:
    """A task's rows, its summary noting the workers that died running it before."""
    if not deaths:
        return rows
    note = f"run again after {'; '.join(deaths)}"
    return [replace(rows[0], detail=f"{rows[0].detail}; {note}" if rows[0].detail else note), *rows[1:]]


# -- Ray -----------------------------------------------------------------------------------------


def _ray_error(err: BaseException) -> str:
    """One line for a Ray task that failed after its retries."""
    name = type(err).__name__
    text = one_line(str(err).split("\n\n")[0])[:300]
    if name == "OutOfMemoryError":
        return f"worker killed: out of memory ({text})"
    if name in ("WorkerCrashedError", "NodeDiedError", "LocalRayletDiedError", "ActorDiedError"):
        return f"worker died ({name}: {text})"
    return f"Ray: {name}: {text}"


def _run_ray(tasks: Sequence[Task], *, jobs: int, address: str | None, retries: int, timeout_s: float,
             emit: Callable[[list[Row]], None]) -> None:
    ray = import_ray(address, timeout_s=timeout_s)
    with contextlib.nullcontext() if ray.is_initialized() else cluster(ray, jobs=jobs, address=address,
                                                                        timeout_s=timeout_s):
        remote = ray.remote(num_cpus=1, max_retries=retries, retry_exceptions=False,
                            scheduling_strategy="SPREAD")(execute)
        cpus = int(ray.cluster_resources().get("CPU", jobs)) or jobs
        window = max(2 * cpus, 2)
        pending: dict[Any, int] = {}
        submitted = 0
        try:
            while submitted < len(tasks) or pending:
                while submitted < len(tasks) and len(pending) < window:
                    pending[remote.remote(tasks[submitted])] = submitted
                    submitted += 1
                ready, _ = ray.wait(list(pending), num_returns=1, timeout=0.5)
                for ref in ready:
                    number = pending.pop(ref)
                    try:
                        rows = ray.get(ref)
                    except ray.exceptions.RayError as err:
                        rows = [_error_row(tasks[number], _ray_error(err))]
                    emit(rows)
        except BaseException:
            for ref in pending:
                ray.cancel(ref)
            raise
