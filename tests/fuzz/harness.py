"""Running tfrec on a mutated input and checking the contract of issue 11.

The contract, for every run: the exit code is 0 (or 1 where a command reports differences) or 2 with
exactly one line ``tfrec: error: …`` on stderr; every other line on stderr is a ``tfrec: warning: …``; no
traceback; the run uses at most :data:`RUN_TIMEOUT_S` of CPU time (and ends within :data:`WALL_BACKSTOP_S`, for
a run that waits forever) and under :data:`MEMORY_LIMIT` of memory; no line of ``/etc/passwd`` reaches stdout,
stderr or an output file. Time is CPU time, never wall-clock time: the machine is shared, and a test that
counts seconds of a clock on the wall fails when another job runs beside it.
Where a run meets files at its outputs' places (issue #20): nothing but its outputs changes, nothing at all when
it fails, and no temporary is left (:func:`untouched_violations`, over :func:`snapshot` s of the folder before and
after).; no character that drives a terminal (ESC, CR, BEL, a right-to-left override —
anything not printable but line breaks and tabs) reaches stdout or stderr (issue 20).

Two modes, chosen by the environment variable ``TFREC_FUZZ``:

- unset (``make test``): the short slice. Hypothesis is derandomized (a fixed seed: the same examples on every
  run) with a few examples per target, and tfrec runs in-process (``tfrec.cli.main``) with stdout and stderr
  captured, a CPU-time timer that interrupts a run past :data:`RUN_TIMEOUT_S` and a check of the process's peak
  memory.
- ``TFREC_FUZZ=long`` (``make fuzz``): many examples (``TFREC_FUZZ_EXAMPLES``, default 300 per target), drawn
  at random, each run in its own process under ``RLIMIT_AS`` = 1 GiB and ``RLIMIT_CPU``, so that a memory
  blow-up or a hang is a failed example instead of a crashed test run.

A run that breaks the contract saves its input (the mutated file or folder, and the command as
``command.txt``) under ``TFREC_FUZZ_FAILURES`` (default ``.fuzz-failures/`` in the repository) before it fails,
so that it can be replayed: ``cd .fuzz-failures/<test>/ && sh command.txt``.
"""

from __future__ import annotations

import contextlib
import io
import os
import resource
import shlex
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import FrameType

from hypothesis import HealthCheck, Phase, Verbosity, event, settings

from tests.conftest import REPO

__all__ = [
    "FAILURES",
    "LONG",
    "MEMORY_LIMIT",
    "MODE",
    "PASSWD_LINE",
    "RANDOM",
    "RUN_TIMEOUT_S",
    "WALL_BACKSTOP_S",
    "Outcome",
    "check_run",
    "contract_violations",
    "cpu_seconds",
    "fuzz_settings",
    "run_tfrec",
    "save_failure",
    "snapshot",
    "untouched_violations",
]

MODE = os.environ.get("TFREC_FUZZ", "") or "short"
"""``short`` (``make test``), ``long`` (``make fuzz``) or ``wide`` (random examples like ``long``, in-process:
faster, for exploring, but a hang or memory blow-up takes the test run down with it)."""

LONG = MODE == "long"
"""The long run (``make fuzz``): a process per run."""

RANDOM = MODE in ("long", "wide")
"""Examples drawn at random (else derandomized: the same examples on every run)."""

MEMORY_LIMIT = 1 << 30
"""The address space a run may use (long mode: ``RLIMIT_AS``; short mode: growth of the peak RSS)."""

RUN_TIMEOUT_S = float(os.environ.get("TFREC_FUZZ_TIMEOUT", "30"))
"""CPU seconds after which a run counts as a hang (generous: a normal run takes well under 2 s of CPU)."""

WALL_BACKSTOP_S = max(4 * RUN_TIMEOUT_S, 120.0)
"""Wall-clock seconds after which a run that uses no CPU (a deadlock, a wait on a socket) is stopped: far beyond
what a loaded machine adds, so that it only ever catches a run that waits forever."""

FAILURES = Path(os.environ.get("TFREC_FUZZ_FAILURES", REPO / ".fuzz-failures"))
"""Where the input of a run that broke the contract is saved."""

PASSWD_LINE = b"root:x:0:0:"
"""The first line of /etc/passwd on every Linux: it must never reach an output or a message."""


def fuzz_settings(short_examples: int) -> settings:
    """Hypothesis settings of one fuzz target: ``short_examples`` derandomized examples for ``make test``,
    ``TFREC_FUZZ_EXAMPLES`` (default 300) random ones for ``make fuzz``."""
    examples = int(os.environ.get("TFREC_FUZZ_EXAMPLES", "300" if RANDOM else str(short_examples)))
    return settings(
        max_examples=examples,
        derandomize=not RANDOM,
        database=None,
        deadline=None,
        # a failure is saved and reported as found; the short slice does not spend minutes shrinking it
        phases=[Phase.explicit, Phase.generate] if not RANDOM else list(Phase),
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
        verbosity=Verbosity.quiet,  # the input is saved as a file: no megabyte-long "Falsifying example" dump
    )


@dataclass(frozen=True, slots=True)
class Outcome:
    """One run of tfrec: its exit code, what it printed, and how it ended."""

    argv: tuple[str, ...]
    code: int | None
    stdout: str
    stderr: str
    seconds: float
    """CPU seconds the run used (user + system; of the child process when it ran in one)."""
    crash: str | None = None
    """A traceback (in-process: the exception that escaped ``main``; subprocess: stderr's), a signal, or a hang."""


class _Hang(BaseException):
    """Raised by the timers inside a run that uses more than :data:`RUN_TIMEOUT_S` of CPU, or waits past
    :data:`WALL_BACKSTOP_S`."""


@contextlib.contextmanager
def _alarm(cpu_s: float, wall_s: float) -> Iterator[None]:
    """Interrupt the code inside after ``cpu_s`` seconds of this process's CPU time (``ITIMER_PROF``) or
    ``wall_s`` seconds on the clock (``ITIMER_REAL``, the backstop for a run that waits)."""
    def ring(signum: int, frame: FrameType | None) -> None:
        what = f"{cpu_s:.0f} s of CPU time" if signum == signal.SIGPROF else f"{wall_s:.0f} s of waiting"
        raise _Hang(f"no result after {what}")

    previous = {sig: signal.signal(sig, ring) for sig in (signal.SIGPROF, signal.SIGALRM)}
    signal.setitimer(signal.ITIMER_PROF, cpu_s)
    signal.setitimer(signal.ITIMER_REAL, wall_s)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.setitimer(signal.ITIMER_REAL, 0)
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def cpu_seconds(who: int = resource.RUSAGE_SELF) -> float:
    """User + system CPU seconds of this process (``RUSAGE_SELF``) or of its waited-for children
    (``RUSAGE_CHILDREN``): the clock of every time bound in the tests."""
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


def _peak_rss() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB


def _run_in_process(argv: Sequence[str], cwd: Path) -> Outcome:
    import traceback

    from tfrec.cli import main

    out, err = io.StringIO(), io.StringIO()
    crash: str | None = None
    code: int | None = None
    peak = _peak_rss()
    start = cpu_seconds()
    previous = Path.cwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), _alarm(RUN_TIMEOUT_S, WALL_BACKSTOP_S):
            code = main(list(argv))
    except _Hang as hang:
        crash = f"hang: {hang}"
    except BaseException as exc:  # noqa: BLE001 — the point: anything escaping main() is a traceback
        crash = "".join(traceback.format_exception(exc))
    finally:
        os.chdir(previous)
    seconds = cpu_seconds() - start
    grown = _peak_rss() - peak
    if crash is None and grown > MEMORY_LIMIT:
        crash = f"memory: the peak resident size grew by {grown / 2**20:,.0f} MiB"
    return Outcome(tuple(argv), code, out.getvalue(), err.getvalue(), seconds, crash)


def _run_subprocess(argv: Sequence[str], cwd: Path, *, cpu_s: int | None = None) -> Outcome:
    # RLIMIT_AS counts address space, not memory used: OpenBLAS reserves buffers per thread and glibc an arena per
    # thread far beyond what they use (tfrec record --rrd: 3.5 GB of address space for 230 MB resident), and a
    # failed reservation makes OpenBLAS spin. One BLAS thread and two arenas make the limit measure tfrec.
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep),
           "TFREC_FUZZ_RLIMIT_AS": str(MEMORY_LIMIT), "TFREC_FUZZ_RLIMIT_CPU": str(RUN_TIMEOUT_S),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MALLOC_ARENA_MAX": "2"}
    command = [sys.executable, "-m", "tests.fuzz._child", *argv]  # tfrec's main_exit under RLIMIT_AS, RLIMIT_CPU
    start = cpu_seconds(resource.RUSAGE_CHILDREN)
    process = subprocess.Popen(command, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               start_new_session=True)
    try:
        stdout, stderr = process.communicate(timeout=WALL_BACKSTOP_S)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        stdout, stderr = process.communicate()
        return Outcome(tuple(argv), None, stdout.decode(errors="replace"), stderr.decode(errors="replace"),
                       cpu_seconds(resource.RUSAGE_CHILDREN) - start,
                       f"hang: no result after {WALL_BACKSTOP_S:.0f} s of waiting")
    seconds = cpu_seconds(resource.RUSAGE_CHILDREN) - start
    out, err = stdout.decode(errors="replace"), stderr.decode(errors="replace")
    crash = None
    if process.returncode == -signal.SIGXCPU:
        crash = f"hang: no result after {RUN_TIMEOUT_S:.0f} s of CPU time"
    elif process.returncode < 0:
        crash = f"killed by signal {signal.Signals(-process.returncode).name}"
    elif "Traceback (most recent call last)" in err or "MemoryError" in err:
        crash = err
    return Outcome(tuple(argv), process.returncode, out, err, seconds, crash)


def run_tfrec(argv: Sequence[str], *, cwd: Path, isolated: bool | None = None, cpu_s: int | None = None) -> Outcome:
    """Run ``tfrec argv`` in ``cwd``: in a process of its own under ``RLIMIT_AS`` (:data:`MEMORY_LIMIT`) and a
    timeout when ``isolated`` (default: in the long run), else in-process. ``cpu_s``: the isolated run's CPU time
    is limited to that many seconds too (``RLIMIT_CPU``; the timeout then only catches a run that waits)."""
    if LONG if isolated is None else isolated:
        return _run_subprocess(argv, cwd, cpu_s=cpu_s)
    return _run_in_process(argv, cwd)


def contract_violations(outcome: Outcome, *, codes: Sequence[int] = (0,), outputs: Sequence[Path] = (),
                        timed: bool = True) -> list[str]:
    """What ``outcome`` breaks of the contract (empty: it holds); ``timed=False`` for a run whose CPU time was
    limited (``run_tfrec(cpu_s=…)``): its wall-clock time is then not judged."""
    if outcome.crash is not None:
        return [outcome.crash]
    problems = []
    if outcome.code not in (*codes, 2):
        problems.append(f"exit code {outcome.code} (expected one of {sorted({*codes, 2})})")
    lines = outcome.stderr.splitlines()
    errors = [line for line in lines if line.startswith("tfrec: error: ")]
    if outcome.code == 2 and len(errors) != 1:
        problems.append(f"exit code 2 with {len(errors)} 'tfrec: error:' lines")
    if outcome.code != 2 and errors:
        problems.append(f"exit code {outcome.code} with an error line")
    strays = [line for line in lines if not line.startswith(("tfrec: error: ", "tfrec: warning: "))]
    if strays:
        problems.append(f"stderr has lines that are neither an error nor a warning: {strays[:3]!r}")
    if outcome.seconds > RUN_TIMEOUT_S:
        problems.append(f"took {outcome.seconds:.1f} s of CPU time")
    controls = sorted({c for c in outcome.stdout + outcome.stderr if not c.isprintable() and c not in "\n\t"})
    if controls:
        problems.append(f"characters that drive a terminal reached it: {controls[:5]!r}")
    if PASSWD_LINE.decode() in outcome.stdout or PASSWD_LINE.decode() in outcome.stderr:
        problems.append("a line of /etc/passwd was printed")
    for path in outputs:
        for file in ([path] if path.is_file() else sorted(path.rglob("*")) if path.is_dir() else []):
            if file.is_file() and PASSWD_LINE in file.read_bytes():
                problems.append(f"a line of /etc/passwd is in the output {file.name}")
    return problems


def snapshot(root: Path) -> dict[str, tuple[str, str]]:
    """Every entry under ``root`` (relative path → a file's SHA-256, a link's target, or a folder), nothing followed."""
    import hashlib

    found: dict[str, tuple[str, str]] = {}
    for folder, dirs, files in os.walk(root):
        for name in dirs + files:
            path = Path(folder, name)
            key = os.fsdecode(os.path.relpath(path, root))
            if path.is_symlink():
                found[key] = ("link", os.readlink(path))
            elif path.is_dir():
                found[key] = ("folder", "")
            else:
                found[key] = ("file", hashlib.sha256(path.read_bytes()).hexdigest())
    return found


def untouched_violations(before: dict[str, tuple[str, str]], after: dict[str, tuple[str, str]], *,
                         outputs: Sequence[str] = ()) -> list[str]:
    """What a run changed that it must not have: any entry (changed, added or removed) outside ``outputs`` (paths
    relative to the snapshots' folder; with none, nothing may change), and any temporary left."""
    def inside(key: str) -> bool:
        return any(key == out or key.startswith(out.rstrip("/") + "/") for out in outputs)

    problems = [f"{key} changed" for key in sorted(before.keys() | after.keys())
                if before.get(key) != after.get(key) and not inside(key)]
    problems += [f"temporary {key} left" for key in after if Path(key).name.startswith(".tfrec-")
                 and key not in before]
    return problems


def check_run(
    argv: Sequence[str],
    *,
    cwd: Path,
    inputs: Sequence[Path],
    name: str,
    codes: Sequence[int] = (0,),
    outputs: Sequence[Path] = (),
) -> Outcome:
    """Run ``tfrec argv`` and fail the test, with ``inputs`` saved under :data:`FAILURES`/``name``, when the
    contract does not hold."""
    outcome = run_tfrec(argv, cwd=cwd)
    errors = [line for line in outcome.stderr.splitlines() if line.startswith("tfrec: error: ")]
    event(f"{argv[0]}: exit {outcome.code}" + (f": {_gist(errors[0])}" if errors else ""))
    problems = contract_violations(outcome, codes=codes, outputs=outputs)
    if problems:
        saved = save_failure(name, argv, cwd=cwd, inputs=inputs, outcome=outcome)
        raise AssertionError(f"tfrec {shlex.join(argv)}: {'; '.join(problems[:1])}\n"
                             f"input saved in {saved} (replay: cd {saved} && sh command.txt)\n"
                             f"stderr:\n{outcome.stderr[-3000:]}\n{(outcome.crash or '')[-6000:]}")
    return outcome


def _gist(error: str) -> str:
    """An error line without its file names and numbers: what kind of error it is (for ``event``)."""
    import re

    words = error.removeprefix("tfrec: error: ").split(": ")
    return re.sub(r"[0-9][0-9,.e+-]*", "N", words[-1] if len(words) < 3 else ": ".join(words[1:3]))[:70]


def save_failure(name: str, argv: Sequence[str], *, cwd: Path, inputs: Sequence[Path], outcome: Outcome) -> Path:
    """Copy ``inputs`` (paths inside ``cwd``, where the command's relative paths point) and the command into
    FAILURES/name; the last failure of a test wins (hypothesis replays the smallest failing example last)."""
    target = FAILURES / name
    shutil.rmtree(target, ignore_errors=True)
    target.mkdir(parents=True)
    for item in inputs:
        try:
            relative = item.relative_to(cwd)
        except ValueError:
            relative = Path(item.name)
        destination = target / relative
        destination.parent.mkdir(parents=True, exist_ok=True)
        if item.is_dir() and not item.is_symlink():
            shutil.copytree(item, destination, symlinks=True, dirs_exist_ok=True)
        elif item.exists() or item.is_symlink():
            shutil.copy2(item, destination, follow_symlinks=False)
    (target / "command.txt").write_text(
        f"PYTHONPATH={shlex.quote(str(REPO))} {shlex.quote(sys.executable)} -m tfrec {shlex.join(argv)}\n",
        errors="surrogateescape")  # a file name that is not UTF-8: its own bytes
    (target / "outcome.txt").write_text(
        f"exit code: {outcome.code}\nCPU seconds: {outcome.seconds:.2f}\n--- stderr\n{outcome.stderr}\n"
        f"--- crash\n{outcome.crash or ''}\n", errors="backslashreplace")
    return target
