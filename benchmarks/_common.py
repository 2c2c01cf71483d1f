"""What the benchmarks share: the ``machine:`` line of their reports and timing."""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable
from importlib.metadata import version
from typing import TypeVar

T = TypeVar("T")


def machine(*distributions: str) -> str:
    """The ``machine:`` line of a report: CPU, cores, Python, and the versions of numpy and of
    ``distributions`` (installed distribution names, e.g. ``mcap-ros2-support``)."""
    parts = [platform.processor() or platform.machine(), f"{os.cpu_count()} CPUs", f"Python {platform.python_version()}"]
    parts += [f"{name} {version(name)}" for name in ("numpy", *distributions)]
    return "machine: " + ", ".join(parts)


def best_of(repeat: int, run: Callable[[], object]) -> float:
    """Seconds of the fastest of ``repeat`` calls of ``run``."""
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


def timed(label: str, run: Callable[[], T]) -> tuple[float, T]:
    """Call ``run`` once and print ``label: <seconds> s``; returns the seconds and what ``run`` returned."""
    start = time.perf_counter()
    result = run()
    elapsed = time.perf_counter() - start
    print(f"{label}: {elapsed:.2f} s")
    return elapsed, result
