"""``tfrec info`` of an MCAP file loads the code that file needs and no other: not the other formats' readers
and writers, not rosbags' distro type stores (the types tfrec reads are known without them), not xacro's
sandbox, Rerun or the recorder. Measured in a fresh interpreter (sys.modules after the command); the time it
saves is in benchmarks/bench_limits.py and docs/performance.md."""

from __future__ import annotations

import json
import resource
import subprocess
import sys
from pathlib import Path

from tfrec.formats.mcap.writer import message_definition
from tfrec.formats.ros.definitions import INTERPRETED, ROS_LAYOUTS, foreign_layout
from tfrec.formats.ros.types import ROS2_DEFINITIONS, ros1_message_definition, typestore

_LOADED = """
import contextlib, io, json, sys
from tfrec.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(["info", sys.argv[1]])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""

NOT_NEEDED = (
    "tfrec.formats.rosbag1.source", "tfrec.formats.rosbag1.index", "tfrec.formats.rosbag1.writer",
    "tfrec.formats.rosbag1.sink", "tfrec.formats.rosbag2.source", "sqlite3", "tfrec.formats.mcap.writer",
    "tfrec.formats.mcap.sink", "mcap", "tfrec.description._load", "tfrec.description.xacro", "xacro", "rerun",
    "tfrec.viewer", "tfrec.recorder", "tfrec.kinematics", "tfrec.replay", "matplotlib",
)


def _cpu_limit() -> None:  # the hang guard: 30 CPU seconds
    resource.setrlimit(resource.RLIMIT_CPU, (30, 30))


def _modules_after_info(path: Path) -> list[str]:
    done = subprocess.run([sys.executable, "-c", _LOADED, str(path)], capture_output=True, text=True, check=True,
                          preexec_fn=_cpu_limit)
    result = json.loads(done.stdout)
    assert result["code"] == 0
    return list(result["modules"])


def test_info_of_an_mcap_loads_only_what_it_reads(marm_mcap: Path) -> None:
    modules = set(_modules_after_info(marm_mcap))
    assert {"tfrec.formats.mcap.source", "tfrec.formats.ros.decode", "tfrec.description.urdf"} <= modules
    loaded = sorted(name for name in modules if name in NOT_NEEDED or name.split(".")[0] in NOT_NEEDED)
    assert loaded == []
    stores = sorted(name for name in modules if name.startswith("rosbags.typesys.stores.ros"))
    assert stores == []  # no distro store: ROS 2 Humble's alone takes longer to build than the rest of `info`


def test_the_layouts_known_without_a_store_are_rosbags() -> None:
    """The definitions, md5sums and type hashes tfrec knows by heart are those rosbags' stores give."""
    store = typestore()
    for msgtype, text in ROS2_DEFINITIONS.items():
        assert store.generate_msgdef(msgtype, ros_version=2)[0] == text == message_definition(msgtype)[0]
    assert set(ROS_LAYOUTS) == set(INTERPRETED.values()) == set(ROS2_DEFINITIONS)
    for msgtype, (md5sum, rihs01) in ROS_LAYOUTS.items():
        assert ros1_message_definition(msgtype)[1] == md5sum
        assert store.hash_rihs01(msgtype) == rihs01


def test_a_definition_known_by_heart_is_judged_as_when_parsed() -> None:
    """tfrec's own ros2msg text is taken without parsing: the verdict is the one parsing gives (a comment added
    makes the text another, parsed and compared field by field) — ROS 2's layout, and not ROS 1's (whose Header
    has a seq)."""
    for msgtype, text in ROS2_DEFINITIONS.items():
        for ros1 in (False, True):
            known = foreign_layout(msgtype, ros1=ros1, definition=text, definition_encoding="ros2msg")
            parsed = foreign_layout(msgtype, ros1=ros1, definition=text + "# a comment\n", definition_encoding="ros2msg")
            assert known == parsed, (msgtype, ros1)
            assert (known is None) == (not ros1 or msgtype == "std_msgs/msg/String")
