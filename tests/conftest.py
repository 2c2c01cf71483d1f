"""Shared fixtures: the repository's robots and the real packages in ../shared/corpus, and a
recording of robots/marm.xacro (a module that defines a fixture of the same name uses its own)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from tfrec.model import Robot
    from tfrec.recording import Recording
    from tfrec.trajectory.types import JointTrajectory

REPO = Path(__file__).resolve().parents[1]
ROBOTS = REPO / "robots"
SHARED = next((folder / "shared" for folder in REPO.parents if (folder / "shared").is_dir()), REPO.parent / "shared")
"""../shared: beside the repository, or beside a folder of worktrees that holds it."""
CORPUS = SHARED / "corpus"
BAGS = SHARED / "bags"
"""Recordings written by other tools (rosbag2's and rosbag.js's test bags), read-only."""


@pytest.fixture
def robots() -> Path:
    return ROBOTS


@pytest.fixture
def corpus() -> Path:
    if not CORPUS.is_dir():
        pytest.skip("../shared/corpus is absent")
    return CORPUS


@pytest.fixture(scope="module")
def marm() -> Robot:
    from .recording_helpers import load_robot  # it imports this module

    return load_robot("marm")


@pytest.fixture(scope="module")
def traj(marm: Robot) -> JointTrajectory:
    from .recording_helpers import marm_trajectory

    return marm_trajectory(marm)


@pytest.fixture(scope="module")
def marm_mcap(tmp_path_factory: pytest.TempPathFactory, marm: Robot, traj: JointTrajectory) -> Path:
    """robots/marm.xacro's sine trajectory, 2 s at 50 Hz, as tfrec's MCAP."""
    from .recording_helpers import write_mcap

    return write_mcap(tmp_path_factory.mktemp("marm") / "marm.mcap", marm, traj)


@pytest.fixture(scope="module")
def marm_rec(marm_mcap: Path) -> Recording:
    from tfrec.formats.reader import read_recording

    return read_recording(marm_mcap)
