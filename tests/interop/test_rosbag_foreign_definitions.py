"""Real ``rosbag check`` on what ``tfrec convert`` writes from a ROS 1 bag another tool wrote (issue 22): the input
carries rosbags' generated definitions (no comments: ``rosbag check`` asks for migrations on it), tfrec's output
carries genmsg's text of each of Noetic's types, and ``rosbag check`` finds nothing to migrate."""

from __future__ import annotations

from pathlib import Path

from tests.convert.test_ros1_definitions import KNOWN, _other_tools_bag, _ros1_mcap
from tests.interop.ros import Ros
from tfrec.convert import convert

NOTHING = "Bag file does not need any migrations."


def test_rosbag_check_finds_nothing_to_migrate_in_a_converted_foreign_bag(ros: Ros, tmp_path: Path) -> None:
    source = tmp_path / "foreign.bag"
    given = _other_tools_bag(source, types=KNOWN)
    assert given  # the input: rosbags' texts, which real rosbag check flags
    assert ros.run("rosbag", "check", source).stdout.strip() != NOTHING
    convert(source, tmp_path / "out.bag")
    assert ros.run("rosbag", "check", tmp_path / "out.bag").stdout.strip() == NOTHING


def test_rosbag_check_finds_nothing_to_migrate_in_a_bag_from_ros1_mcap(ros: Ros, tmp_path: Path) -> None:
    _ros1_mcap(tmp_path / "in.mcap", types=KNOWN)
    convert(tmp_path / "in.mcap", tmp_path / "out.bag")
    assert ros.run("rosbag", "check", tmp_path / "out.bag").stdout.strip() == NOTHING
