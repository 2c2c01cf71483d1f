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
"""Real robot description packages written by others (urdf_tutorial, turtlebot3, ur_description, franka_description,
robotiq), read-only; kept outside the repository."""
BAGS = SHARED / "bags"
"""Recordings written by other tools (rosbag2's and rosbag.js's test bags), read-only; kept outside the repository."""

CORPUS_ABSENT = ("../shared/corpus is not here: it holds real robot packages by others (urdf_tutorial, turtlebot3, "
                 "ur_description, franka_description, robotiq), kept outside this repository; the tests that compare "
                 "tfrec with them run where it exists — skipping them is fine")
"""The skip reason of every test that needs :data:`CORPUS` (pytest -ra shows it once, with a count)."""
BAGS_ABSENT = ("../shared/bags is not here: it holds real bags written by other tools (rosbag2's and rosbag.js's own "
               "test bags), kept outside this repository; the tests that read them run where it exists — skipping "
               "them is fine")
"""The skip reason of every test that needs :data:`BAGS`."""


SLOW_TIER = (
    # Ray clusters; Ray imported in child processes that find no cluster; drivers killed with what they started
    "tests/fleet/test_ray.py",
    "tests/fleet/test_ray_address.py",
    "tests/fleet/test_lifetime.py",
    "tests/fleet/test_engine.py::test_a_dead_worker_costs_its_task_only",
    # the README tour, command by command
    "tests/test_docs.py::test_readme_tour_works_as_typed",
    # pictures: matplotlib plots and graphs in every format
    "tests/plots/test_plots.py",
    "tests/cli/test_pictures_cli.py",
    "tests/plots/test_tree.py::test_large_robot_stays_within_bounds",
    "tests/plots/test_tree.py::test_corpus_graph_in_every_format",
    # Rerun recordings written and read back in a child process
    "tests/diff/test_diff.py::test_mcap_against_its_own_rrd",
    "tests/test_real_bags.py::test_an_rrd_of_a_multi_robot_replay_is_read_back_robot_by_robot",
    "tests/test_real_bags.py::test_an_rrd_of_another_application_is_refused",
    "tests/replay/test_replay.py::test_an_rrd_not_written_by_tfrec_is_refused",
    "tests/convert/test_convert.py::test_rerun_output",
    "tests/test_without_joints.py::test_info_replay_check_and_plot_work[cube-rrd]",
    "tests/test_without_joints.py::test_info_replay_check_and_plot_work[statue-rrd]",
    "tests/formats/test_rrd.py::test_a_write_that_fails_midway_is_a_recording_error",
    # peak memory of a check of ten minutes against one minute's, each in a process of its own
    "tests/replay/test_pieces.py::test_check_memory_does_not_grow_with_the_recordings_length",
    # bombs and floods, each in a process of its own under memory limits
    "tests/faults/test_hostile_recordings.py::test_an_rrd_that_aborts_reruns_reader_is_one_line",
    "tests/faults/test_hostile_recordings.py::test_a_ros1_bz2_chunk_inflating_to_4_gib_is_skipped",
    "tests/faults/test_hostile_recordings.py::test_a_zstd_bomb_as_a_message_of_a_compressed_rosbag2_bag_is_one_line",
    "tests/faults/test_hostile_recordings.py::test_check_of_a_folder_with_a_fifo_and_a_device_is_error_rows",
    "tests/faults/test_writing_faults.py::test_record_and_replay_save_onto_a_full_disk_give_one_line",
    "tests/faults/test_hostile_descriptions.py::test_millions_of_short_csv_rows_are_one_line_in_bounded_memory",
    "tests/faults/test_hostile_descriptions.py::test_hostile_meshes_are_skipped_with_a_warning_naming_the_link",
    "tests/formats/test_decompress_limits.py::test_the_bombs_are_small",
    "tests/description/test_sandbox.py::test_deep_xml_is_nested_too_deeply_not_recursion",
    "tests/description/test_sandbox.py::test_exponential_macros_side_by_side_are_refused",
    "tests/trajectory/test_keyframes.py::test_many_rows_in_seconds",
    "tests/faults/test_deep_chains.py",
    # tfrec serve --connect into the real rerun, started and stopped
    "tests/live/test_serve.py::test_connect_streams_the_same_to_a_rerun_viewer",
    "tests/live/test_serve.py::test_a_whole_served_trajectory_leaves_the_files_record_writes",
    "tests/live/test_serve.py::test_a_recording_served_with_connect_reaches_the_rerun_viewer_too",
    "tests/faults/test_many_channels.py",
    "tests/faults/test_many_schemas.py::test_65000_",
    "tests/faults/test_address_space.py",
    # a scratch pytest project run again and again: goldens made, compared, failed with artefacts, remade
    "tests/test_pytest_plugin.py::test_the_golden_workflow",
)
"""The slow tier (``make test-slow``, run by CI; ``make test`` leaves it out): test files, or test names
(a prefix: every parametrization, and every test whose name starts so), kept in this one list."""


INTEROP_TIER = "tests/interop/"
"""The interop tier (``make interop``, run by CI): tfrec against Debian's ROS 1 (check_urdf, roscore,
robot_state_publisher, rosbag, view_frames, roslaunch); ``make test`` and ``make test-slow`` leave it out."""


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if item.nodeid.startswith(SLOW_TIER):
            item.add_marker(pytest.mark.slow)
        if item.nodeid.startswith(INTEROP_TIER):
            item.add_marker(pytest.mark.interop)


@pytest.fixture
def robots() -> Path:
    return ROBOTS


@pytest.fixture
def corpus() -> Path:
    if not CORPUS.is_dir():
        pytest.skip(CORPUS_ABSENT)
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
