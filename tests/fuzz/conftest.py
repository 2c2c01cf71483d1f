"""Seeds of the fuzz targets: real descriptions (robots/, ../shared/corpus, small inline URDFs), a CSV
trajectory, recordings made by tfrec itself (MCAP with each compression, rosbag2 with mcap and sqlite3 storage,
ROS 1 bags with each compression, an .rrd) and the real bags in ../shared/bags. They are made once per session;
every example works on a copy in its own folder (:func:`workdir`)."""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import tempfile
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from tests.conftest import CORPUS, ROBOTS

BAGS = CORPUS.parent / "bags"


@dataclass(frozen=True, slots=True)
class DescriptionSeed:
    """A description to mutate: ``mutate`` (one of its files) is replaced by its mutation, ``entry`` is loaded.

    Paths are relative to the seed folder; ``tree`` is the folder copied into each example's working folder.
    """

    name: str
    tree: str
    entry: str
    mutate: str
    args: tuple[str, ...] = ()
    rrd: bool = True
    """Whether ``record --rrd`` is among its commands (meshes read: slower)."""


@dataclass(frozen=True, slots=True)
class RecordingSeed:
    """A recording to mutate: a file or a rosbag2 folder under the seed folder."""

    name: str
    path: str
    real: bool = False
    """Written by another tool (../shared/bags), not by tfrec."""
    tags: tuple[str, ...] = field(default=())


INLINE_URDF = """<?xml version="1.0"?>
<robot name="inline">
  <material name="blue"><color rgba="0 0 1 1"/></material>
  <link name="base"><visual><geometry><box size="0.1 0.2 0.3"/></geometry><material name="blue"/></visual></link>
  <link name="upper"><visual><origin xyz="0 0 0.1" rpy="0 0 0"/><geometry><cylinder radius="0.02" length="0.2"/></geometry></visual></link>
  <link name="fore"><visual><geometry><mesh filename="package://inline_robot/meshes/part.stl" scale="1 1 1"/></geometry></visual></link>
  <link name="finger_a"><visual><geometry><sphere radius="0.01"/></geometry></visual></link>
  <link name="finger_b"/>
  <link name="wheel"/>
  <link name="tool"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.3" rpy="0 0 1.5707963"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="10" velocity="1"/>
    <safety_controller soft_lower_limit="-1.4" soft_upper_limit="1.4" k_position="10" k_velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/><origin xyz="0 0 0.2"/><axis xyz="1 1 0"/>
    <limit lower="0" upper="2" effort="10" velocity="1"/>
  </joint>
  <joint name="finger_a_joint" type="prismatic">
    <parent link="fore"/><child link="finger_a"/><axis xyz="0 0 1"/><limit lower="-0.01" upper="0.02" effort="1" velocity="1"/>
  </joint>
  <joint name="finger_b_joint" type="prismatic">
    <parent link="fore"/><child link="finger_b"/><axis xyz="0 0 -1"/><limit lower="-0.01" upper="0.02" effort="1" velocity="1"/>
    <mimic joint="finger_a_joint" multiplier="-1" offset="0.001"/>
  </joint>
  <joint name="wheel_joint" type="continuous"><parent link="base"/><child link="wheel"/><axis xyz="0 0 1"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="fore"/><child link="tool"/><origin xyz="0.1 0 0" rpy="3.14159 0 0"/></joint>
</robot>
"""

INLINE_XACRO = """<?xml version="1.0"?>
<robot name="inline_xacro" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="hand" default="true"/>
  <xacro:property name="length" value="0.3"/>
  <xacro:property name="limits" value="${xacro.load_yaml('$(find inline_robot)/config/limits.yaml')}"/>
  <xacro:include filename="$(find inline_robot)/urdf/parts.xacro"/>
  <xacro:macro name="segment" params="name parent length:=0.2 *origin">
    <link name="${name}"><visual><geometry><cylinder radius="0.02" length="${length}"/></geometry></visual></link>
    <joint name="${name}_joint" type="revolute">
      <parent link="${parent}"/><child link="${name}"/><xacro:insert_block name="origin"/>
      <axis xyz="0 0 1"/><limit lower="${limits['lower']}" upper="${limits['upper']}" effort="1" velocity="1"/>
    </joint>
  </xacro:macro>
  <link name="base"/>
  <xacro:segment name="a" parent="base" length="${length}"><origin xyz="0 0 ${length / 2}"/></xacro:segment>
  <xacro:segment name="b" parent="a"><origin xyz="0 0 ${length}" rpy="${pi / 2} 0 0"/></xacro:segment>
  <xacro:if value="$(arg hand)">
    <xacro:part name="hand" parent="b"/>
  </xacro:if>
  <xacro:unless value="$(arg hand)"><link name="no_hand"/></xacro:unless>
</robot>
"""

INLINE_PARTS = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="part" params="name parent">
    <link name="${name}"><visual><geometry><mesh filename="package://inline_robot/meshes/part.stl"/></geometry></visual></link>
    <joint name="${name}_joint" type="fixed"><parent link="${parent}"/><child link="${name}"/></joint>
  </xacro:macro>
</robot>
"""

ASCII_STL = """solid part
facet normal 0 0 1
 outer loop
  vertex 0 0 0
  vertex 0.05 0 0
  vertex 0 0.05 0
 endloop
endfacet
endsolid part
"""


def _description_seeds(root: Path) -> list[DescriptionSeed]:
    shutil.copytree(ROBOTS, root / "robots")
    inline = root / "inline_robot"
    (inline / "urdf").mkdir(parents=True)
    (inline / "meshes").mkdir()
    (inline / "config").mkdir()
    (inline / "package.xml").write_text("<package><name>inline_robot</name></package>\n")
    (inline / "urdf" / "inline.urdf").write_text(INLINE_URDF)
    (inline / "urdf" / "inline.urdf.xacro").write_text(INLINE_XACRO)
    (inline / "urdf" / "parts.xacro").write_text(INLINE_PARTS)
    (inline / "config" / "limits.yaml").write_text("lower: -1.0\nupper: 1.0\n")
    (inline / "meshes" / "part.stl").write_text(ASCII_STL)
    seeds = [
        DescriptionSeed("marm", "robots", "robots/marm.xacro", "robots/marm.xacro"),
        DescriptionSeed("mbot", "robots", "robots/mbot.xacro", "robots/mbot.xacro"),
        DescriptionSeed("mbot_base", "robots", "robots/mbot.xacro", "robots/mbot/mbot_base.xacro"),
        DescriptionSeed("simple_cube", "robots", "robots/simple_cube.xacro", "robots/simple_cube_params.xacro"),
        DescriptionSeed("inline_urdf", "inline_robot", "inline_robot/urdf/inline.urdf", "inline_robot/urdf/inline.urdf"),
        DescriptionSeed("inline_xacro", "inline_robot", "inline_robot/urdf/inline.urdf.xacro",
                        "inline_robot/urdf/inline.urdf.xacro"),
        DescriptionSeed("inline_parts", "inline_robot", "inline_robot/urdf/inline.urdf.xacro",
                        "inline_robot/urdf/parts.xacro", ("hand:=true",)),
    ]
    if CORPUS.is_dir():
        shutil.copytree(CORPUS, root / "corpus", ignore=shutil.ignore_patterns("README.md"))
        seeds += [
            DescriptionSeed("tutorial_06", "corpus/urdf_tutorial", "corpus/urdf_tutorial/urdf/06-flexible.urdf",
                            "corpus/urdf_tutorial/urdf/06-flexible.urdf"),
            DescriptionSeed("tutorial_08", "corpus/urdf_tutorial", "corpus/urdf_tutorial/urdf/08-macroed.urdf.xacro",
                            "corpus/urdf_tutorial/urdf/08-macroed.urdf.xacro"),
            DescriptionSeed("burger", "corpus/turtlebot3_description",
                            "corpus/turtlebot3_description/urdf/turtlebot3_burger.urdf.xacro",
                            "corpus/turtlebot3_description/urdf/turtlebot3_burger.urdf.xacro", rrd=False),
            DescriptionSeed("ur5", "corpus/ur_description", "corpus/ur_description/urdf/ur5.xacro",
                            "corpus/ur_description/urdf/inc/ur_macro.xacro", rrd=False),
            DescriptionSeed("panda", "corpus/franka_description", "corpus/franka_description/robots/panda/panda.urdf.xacro",
                            "corpus/franka_description/robots/common/franka_robot.xacro", ("hand:=true",), rrd=False),
            DescriptionSeed("panda_arm", "corpus/franka_description",
                            "corpus/franka_description/robots/panda/panda.urdf.xacro",
                            "corpus/franka_description/robots/common/franka_arm.xacro", rrd=False),
            DescriptionSeed("robotiq", "corpus/robotiq_description",
                            "corpus/robotiq_description/urdf/robotiq_2f_85_gripper.urdf.xacro",
                            "corpus/robotiq_description/urdf/robotiq_2f_85_macro.urdf.xacro", rrd=False),
        ]
    return [seed for seed in seeds if (root / seed.mutate).is_file()]


MARM_CSV = "time,joint1,joint2,joint3,joint4,joint5,joint6,finger_joint1\n" + "".join(
    f"{t / 10:.1f},{0.1 * t:.2f},{-0.05 * t:.3f},0.2,0,{0.01 * t:.2f},-0.3,{0.001 * t:.3f}\n" for t in range(12))


def _quiet_main(argv: list[str], cwd: Path) -> None:
    from tfrec.cli import main

    previous = Path.cwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err, \
                warnings.catch_warnings():
            warnings.simplefilter("ignore")
            code = main(argv)
    finally:
        os.chdir(previous)
    assert code == 0, err.getvalue()


def _recording_seeds(root: Path) -> list[RecordingSeed]:
    from tests.recording_helpers import write_rosbag2
    from tfrec.formats import read_recording

    rec = root / "rec"
    rec.mkdir()
    robots = str(ROBOTS)
    short = ["--duration", "1", "--rate", "20", "--no-rrd"]
    _quiet_main(["record", f"{robots}/marm.xacro", "-o", "marm.mcap", *short], rec)
    _quiet_main(["record", f"{robots}/marm.xacro", "-o", "marm-none.mcap", "--compression", "none", *short], rec)
    _quiet_main(["record", f"{robots}/mbot.xacro", "-o", "mbot-lz4.mcap", "--compression", "lz4", *short], rec)
    _quiet_main(["record", f"{robots}/simple_cube.xacro", "-o", "cube.mcap", "--compression", "none", *short], rec)
    _quiet_main(["record", f"{robots}/marm.xacro", "-o", "marm.bag", *short], rec)
    _quiet_main(["record", f"{robots}/marm.xacro", "-o", "marm-lz4.bag", "--compression", "lz4", *short], rec)
    _quiet_main(["record", f"{robots}/mbot.xacro", "-o", "mbot-bz2.bag", "--compression", "bz2", *short], rec)
    _quiet_main(["record", f"{robots}/marm.xacro", "--bag", "marm-bag", *short], rec)
    _quiet_main(["record", f"{robots}/marm.xacro", "-o", "marm-rrd.mcap", "--rrd", "marm.rrd", "--duration", "1",
                 "--rate", "10"], rec)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        write_rosbag2(read_recording(rec / "marm.mcap"), rec / "marm-sqlite")
    seeds = [
        RecordingSeed("marm.mcap", "rec/marm.mcap", tags=("mcap",)),
        RecordingSeed("marm-none.mcap", "rec/marm-none.mcap", tags=("mcap",)),
        RecordingSeed("mbot-lz4.mcap", "rec/mbot-lz4.mcap", tags=("mcap",)),
        RecordingSeed("cube.mcap", "rec/cube.mcap", tags=("mcap",)),
        RecordingSeed("marm.bag", "rec/marm.bag", tags=("ros1",)),
        RecordingSeed("marm-lz4.bag", "rec/marm-lz4.bag", tags=("ros1",)),
        RecordingSeed("mbot-bz2.bag", "rec/mbot-bz2.bag", tags=("ros1",)),
        RecordingSeed("marm-bag", "rec/marm-bag", tags=("rosbag2", "mcap-storage")),
        RecordingSeed("marm-sqlite", "rec/marm-sqlite", tags=("rosbag2", "sqlite3")),
        RecordingSeed("marm.rrd", "rec/marm.rrd", tags=("rrd",)),
    ]
    if BAGS.is_dir():
        shutil.copytree(BAGS, root / "bags", ignore=shutil.ignore_patterns("README.md"))
        for path in sorted((root / "bags" / "rosbag2").iterdir()):
            relative = path.relative_to(root).as_posix()
            if path.suffix == ".mcap":
                seeds.append(RecordingSeed(path.name, relative, real=True, tags=("mcap",)))
            elif (path / "metadata.yaml").is_file():
                storage = "sqlite3" if any(path.glob("*.db3")) else "mcap-storage"
                seeds.append(RecordingSeed(path.name, relative, real=True, tags=("rosbag2", storage)))
        for path in sorted((root / "bags" / "rosbagjs").glob("*.bag")):
            seeds.append(RecordingSeed(path.name, path.relative_to(root).as_posix(), real=True, tags=("ros1",)))
    return seeds


@pytest.fixture(scope="session")
def seed_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz-seeds")


@pytest.fixture(scope="session")
def description_seeds(seed_root: Path) -> list[DescriptionSeed]:
    return _description_seeds(seed_root)


@pytest.fixture(scope="session")
def recording_seeds(seed_root: Path) -> list[RecordingSeed]:
    return _recording_seeds(seed_root)


@pytest.fixture(scope="session")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder under which each example gets its own working folder."""
    return tmp_path_factory.mktemp("fuzz-runs")


@contextlib.contextmanager
def workdir(runs: Path) -> Iterator[Path]:
    """A fresh working folder for one example, removed afterwards."""
    path = Path(tempfile.mkdtemp(dir=runs))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


def _link_or_copy(source: str, target: str) -> None:
    if ".db3" in Path(source).name:  # SQLite writes into a database it reads (its -wal, -shm): a real copy
        shutil.copy2(source, target)
    else:
        os.link(source, target)


def link_tree(source: Path, target: Path) -> None:
    """``source`` copied to ``target`` as hard links (instant; SQLite files copied); replace a file with
    :func:`replace_file`, which leaves the seed alone."""
    if source.is_dir():
        shutil.copytree(source, target, copy_function=_link_or_copy, symlinks=True)
    else:
        target.parent.mkdir(parents=True, exist_ok=True)
        _link_or_copy(str(source), str(target))


def replace_file(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` without touching the file it was a hard link of."""
    if path.exists() or path.is_symlink():
        path.unlink()
    path.write_bytes(data)


@pytest.fixture(scope="session")
def output_seeds(seed_root: Path, recording_seeds: list[RecordingSeed]) -> dict[str, Path]:
    """A genuine tfrec output of each kind, by extension ("" for a rosbag2 folder): what ``--force`` may replace."""
    rec, out = seed_root / "rec", seed_root / "outputs"
    out.mkdir(exist_ok=True)
    _quiet_main(["plot", "rec/marm.mcap", "-o", "outputs/out.png"], seed_root)
    _quiet_main(["plot", "rec/marm.mcap", "-o", "outputs/out.pdf"], seed_root)
    _quiet_main(["diff", "rec/marm.mcap", "rec/marm.mcap", "--plot", "outputs/out.svg"], seed_root)
    _quiet_main(["info", "rec/marm.mcap", "--graph", "outputs/out.dot"], seed_root)
    for report in ("out.jsonl", "out.parquet"):
        _quiet_main(["check", "rec/marm.mcap", "--report", f"outputs/{report}"], seed_root)
    return {".mcap": rec / "marm.mcap", ".bag": rec / "marm.bag", ".rrd": rec / "marm.rrd", "": rec / "marm-bag",
            **{path.suffix: path for path in out.iterdir()}}
