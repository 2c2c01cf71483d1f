"""Runs of tfrec on inputs that once made unbounded work (issue 20): each in a process of its own under
``RLIMIT_AS`` = 1 GiB and ``RLIMIT_CPU`` = 30 s (:func:`tests.fuzz.harness.run_tfrec`), judged by the fuzz contract —
a result, warnings, or one ``tfrec: error:`` line; no traceback, no MemoryError, no SIGXCPU. No wall-clock
time is asserted: the CPU limit is the hang guard (generous: 30 s)."""

from __future__ import annotations

from pathlib import Path

from tests.fuzz.harness import Outcome, contract_violations, run_tfrec


def guarded(argv: list[str], cwd: Path, *, codes: tuple[int, ...] = (0,), isolated: bool = True) -> Outcome:
    """``tfrec argv`` in ``cwd`` (its own process unless ``isolated`` is False): the contract holds."""
    outcome = run_tfrec(argv, cwd=cwd, isolated=isolated)
    problems = contract_violations(outcome, codes=codes)
    assert not problems, f"tfrec {' '.join(argv)}: {problems[0]}\n{outcome.stderr[-3000:]}"
    return outcome


def warnings_of(outcome: Outcome) -> list[str]:
    """The run's ``tfrec: warning:`` lines, without the prefix."""
    return [line.removeprefix("tfrec: warning: ") for line in outcome.stderr.splitlines()
            if line.startswith("tfrec: warning: ")]
