"""``rerun FILE`` through ``rerun-importer-tfrec``: the real ``rerun`` of the pinned rerun-sdk opens a ROS 1 bag, a
rosbag2 sqlite3 folder and a xacro headlessly (``--save out.rrd``), and the result is read back."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REPO
from tfrec import cli
from tfrec.replay.load import load_replay

MARM = str(REPO / "robots" / "marm.xacro")
BIN = Path(sys.executable).parent


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _rerun_open(path: Path, out: Path) -> subprocess.CompletedProcess[str]:
    """``rerun PATH --save OUT`` with the importer on PATH (the venv's bin, as an installed package puts it)."""
    rerun = shutil.which("rerun", path=str(BIN))
    if rerun is None or shutil.which("rerun-importer-tfrec", path=str(BIN)) is None:
        pytest.skip("rerun or rerun-importer-tfrec is not installed beside this Python")
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}
    return subprocess.run([rerun, str(path), "--save", str(out), "--port", str(_free_port())], env=env,
                          capture_output=True, text=True, timeout=120, check=False)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("importer")
    out = {"mcap": folder / "marm.mcap", "bag": folder / "marm.bag"}
    assert cli.main(["record", MARM, "--traj", "sine", "--duration", "2", "-o", str(out["mcap"]), "--no-rrd"]) == 0
    assert cli.main(["record", MARM, "--traj", "sine", "--duration", "2", "-o", str(out["bag"]), "--no-rrd"]) == 0
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    out["db3"] = folder / "sqlite_bag"
    with AnyReader([out["mcap"]]) as reader, Writer(out["db3"], version=9,
                                                     storage_plugin=StoragePlugin.SQLITE3) as writer:
        connections = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store) for c in reader.connections}
        for connection, time_ns, raw in reader.messages():
            writer.write(connections[connection.id], time_ns, raw)
    return out


def _same_tf(rrd: Path, reference: Path) -> None:
    got, want = load_replay(rrd), load_replay(reference)
    assert got.robot_description == want.robot_description
    assert set(got.tf) == set(want.tf) and got.tf
    for pair, series in want.tf.items():
        np.testing.assert_array_equal(got.tf[pair].time_ns, series.time_ns)
        np.testing.assert_allclose(got.tf[pair].translation, series.translation, atol=1e-6)


@pytest.mark.parametrize("kind", ["bag", "db3"])
def test_rerun_opens_a_ros1_bag_and_a_rosbag2_sqlite3_folder(recorded: dict[str, Path], kind: str,
                                                              tmp_path: Path) -> None:
    source = recorded[kind]
    opened = source if kind == "bag" else next(source.glob("*.db3"))
    out = tmp_path / "out.rrd"
    run = _rerun_open(opened, out)
    assert run.returncode == 0, run.stderr
    _same_tf(out, recorded["mcap"])


def test_rerun_opens_a_xacro_at_its_center_pose(tmp_path: Path) -> None:
    from tfrec.description import load_description
    from tfrec.kinematics.fk import static_transforms

    out = tmp_path / "out.rrd"
    run = _rerun_open(Path(MARM), out)
    assert run.returncode == 0, run.stderr
    replay = load_replay(out)
    robot = load_description(MARM)
    assert replay.robot_description == robot.urdf
    static = static_transforms(robot)
    assert set(zip(static.parents, static.children)) <= set(replay.static)
    moving = {(j.parent, j.child) for j in robot.joints if j.type.moves}
    assert moving <= set(replay.tf)
    for pair in moving:  # center: every joint at 0 (its range holds 0), so the joint's origin alone
        joint = next(j for j in robot.joints if (j.parent, j.child) == pair)
        np.testing.assert_allclose(replay.tf[pair].translation[0], joint.origin.xyz, atol=1e-6)


def test_the_importer_declines_what_it_does_not_read(recorded: dict[str, Path], tmp_path: Path,
                                                     capsysbinary: pytest.CaptureFixture[bytes]) -> None:
    """Exit 66 and nothing on stdout: an .mcap (Rerun's own importer reads it), a text file, a folder without
    metadata.yaml; a broken xacro is one error line and exit 2."""
    from tfrec.cli._importer import main

    (tmp_path / "notes.txt").write_text("hello")
    for path in (recorded["mcap"], tmp_path / "notes.txt", tmp_path):
        assert main([str(path), "--recording-id", "r", "--application-id", "a"]) == 66
    assert capsysbinary.readouterr().out == b""
    bad = tmp_path / "bad.xacro"
    bad.write_text("<robot name='x'><link name='a'></robot>")
    assert main([str(bad), "--recording-id", "r", "--application-id", "a"]) == 2
    captured = capsysbinary.readouterr()
    assert captured.err.decode().startswith("tfrec: error: ") and len(captured.err.decode().splitlines()) == 1


def test_rerun_reads_an_mcap_with_its_own_importer(recorded: dict[str, Path], tmp_path: Path) -> None:
    """tfrec declines the .mcap; Rerun's MCAP importer gives its transforms (what tfrec would add is in
    docs/live.md)."""
    from rerun.chunk import RrdReader

    out = tmp_path / "out.rrd"
    run = _rerun_open(recorded["mcap"], out)
    assert run.returncode == 0, run.stderr
    paths = {chunk.entity_path for chunk in RrdReader(out).stream()}
    assert any("tf" in path for path in paths), sorted(paths)[:20]
