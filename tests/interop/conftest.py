"""The interop tier (``make interop``): Debian's ROS 1 as the oracle. One master per session, on a free loopback
port; every process a test starts is stopped (its process group). Skipped, with the reason, where the tools are not
installed. The figures the comparisons measure are shown at the end of the run (and written as JSON to
``$TFREC_INTEROP_FIGURES`` when set): docs/ros-parity.md quotes them."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.interop.ros import DEBIAN_PYTHON, Ros, free_port, missing, skip_reason

FIGURES: dict[str, Any] = {}
"""What the comparisons measured, by name (counts, largest differences)."""


def figure(name: str, value: Any) -> None:
    """Record one figure of the run."""
    FIGURES[name] = value


def add_to_figure(name: str, value: float) -> None:
    FIGURES[name] = FIGURES.get(name, 0) + value


def max_figure(name: str, value: float) -> None:
    FIGURES[name] = max(FIGURES.get(name, value), value)


def pytest_terminal_summary(terminalreporter: Any) -> None:
    if not FIGURES:
        return
    terminalreporter.section("interop figures (docs/ros-parity.md)")
    for name in sorted(FIGURES):
        terminalreporter.write_line(f"{name}: {FIGURES[name]}")
    target = os.environ.get("TFREC_INTEROP_FIGURES")
    if target:
        Path(target).write_text(json.dumps(FIGURES, indent=1, sort_keys=True) + "\n")


def needs(*tools: str) -> None:
    gone = missing(*tools)
    if gone:
        pytest.skip(skip_reason(gone))


@pytest.fixture(scope="session")
def ros(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Ros]:
    """Debian's ROS 1 with a master (roscore) on a free loopback port, for the whole session."""
    needs("roscore", "rosbag", DEBIAN_PYTHON)
    home = tmp_path_factory.mktemp("ros_home")
    (home / "log").mkdir()
    session = Ros(home, free_port())
    core = session.start("roscore", "-p", str(session.port), name="roscore")
    try:
        session.wait_master()
        yield session
    finally:
        session.stop_all()
        session.stop(core)
