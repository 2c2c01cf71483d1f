"""Every robot of ../shared/corpus and every URDF of example-robot-data (PyPI) that urdfdom accepts loads,
records a random trajectory and re-simulates clean (`replay --check`); the ones urdfdom refuses give one line."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import pytest

from tests.conftest import CORPUS, CORPUS_ABSENT
from tfrec.description import load_description
from tfrec.errors import DescriptionError
from tfrec.recorder import plan_outputs, record
from tfrec.replay import check_replay, load_replay
from tfrec.trajectory import make_trajectory


def _example_robot_data() -> Path | None:
    for entry in sys.path:
        robots = Path(entry) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if robots.is_dir():
            return robots
    return None


ERD = _example_robot_data()
ERD_URDFS = sorted(ERD.rglob("*.urdf")) if ERD is not None else []
URDFDOM_REFUSES = {"ur_description/urdf/ur3.urdf": "<robot> has no name"}
"""What urdfdom (check_urdf) refuses among them, and why."""

CORPUS_ROBOTS = {
    "urdf_tutorial-r2d2": ("urdf_tutorial/urdf/08-macroed.urdf.xacro", {}),
    "turtlebot3-burger": ("turtlebot3_description/urdf/turtlebot3_burger.urdf.xacro", {}),
    "turtlebot3-waffle_pi": ("turtlebot3_description/urdf/turtlebot3_waffle_pi.urdf.xacro", {}),
    "ur5": ("ur_description/urdf/ur5.xacro", {}),
    "panda-hand": ("franka_description/robots/panda/panda.urdf.xacro", {"hand": "true"}),
    "robotiq-2f-85": ("robotiq_description/urdf/robotiq_2f_85_gripper.urdf.xacro", {}),
}


def _round_trip(path: Path, args: dict[str, str], package_paths: list[Path], tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # missing meshes, planar/floating joints, ignored elements…
        robot = load_description(path, args=args, package_paths=package_paths)
        trajectory = make_trajectory(robot, "random", duration_s=1.0, rate_hz=20.0, period_s=0.5)
        plan = plan_outputs(stem=robot.name, out=tmp_path / "r.mcap", no_rrd=True)
        record(robot, trajectory, plan)
        report = check_replay(load_replay(plan.mcap))
    assert report.passed, report.failures


@pytest.mark.skipif(not CORPUS.is_dir(), reason=CORPUS_ABSENT)
@pytest.mark.parametrize("name", sorted(CORPUS_ROBOTS))
def test_corpus_robot_records_and_checks(name: str, tmp_path: Path) -> None:
    rel, args = CORPUS_ROBOTS[name]
    _round_trip(CORPUS / rel, args, [CORPUS], tmp_path)


@pytest.mark.skipif(ERD is None, reason="example-robot-data is not installed (pip install example-robot-data)")
@pytest.mark.parametrize("urdf", ERD_URDFS, ids=[str(p.relative_to(ERD)) for p in ERD_URDFS] if ERD else [])
def test_example_robot_data_urdf(urdf: Path, tmp_path: Path) -> None:
    assert ERD is not None
    rel = str(urdf.relative_to(ERD))
    if rel in URDFDOM_REFUSES:
        with pytest.raises(DescriptionError, match=URDFDOM_REFUSES[rel]) as info:
            load_description(urdf, package_paths=[ERD])
        assert "\n" not in str(info.value)
        return
    _round_trip(urdf, {}, [ERD], tmp_path)


def test_example_robot_data_holds_the_pr2() -> None:
    if ERD is None:
        pytest.skip("example-robot-data is not installed")
    assert ERD / "pr2_description" / "urdf" / "pr2.urdf" in ERD_URDFS
