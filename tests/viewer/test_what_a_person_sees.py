"""What a person sees in the viewer (issue 26): a timeline in seconds from the recording's start, shown first."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.conftest import REPO
from tfrec import cli

MARM = str(REPO / "robots" / "marm.xacro")


def test_every_sample_is_also_on_a_timeline_of_seconds_from_the_start(tmp_path: Path) -> None:
    """record --start-time far from 0: beside ros_time (a date), the `time` timeline counts from 0 to the duration,
    as durations; the blueprint's time panel shows it."""
    from rerun.chunk import RrdReader

    rrd = tmp_path / "r.rrd"
    assert cli.main(["record", MARM, "--duration", "2", "--rate", "10", "--no-mcap", "--rrd", str(rrd),
                     "--start-time", "1800000000"]) == 0
    elapsed: list[int] = []
    stamps: list[int] = []
    types = set()
    for chunk in RrdReader(rrd).stream():
        batch = chunk.to_record_batch()
        if chunk.entity_path == "/joints/joint1" and "time" in batch.schema.names:
            elapsed += batch.column("time").cast("int64").to_pylist()
            stamps += batch.column("ros_time").cast("int64").to_pylist()
            types.add(str(batch.schema.field("time").type))
    assert elapsed == [i * 100_000_000 for i in range(21)]
    assert np.all(np.array(stamps) - np.array(elapsed) == 1_800_000_000 * 10**9)
    assert len(types) == 1 and types.pop().startswith("duration")


def test_a_replay_waits_for_the_spawned_viewer_to_answer() -> None:
    """wait_for_viewer: True once a real (headless) viewer answers as an application; False at once where no viewer
    listens (the replay then plays anyway)."""
    import os
    import shutil
    import socket
    import sys

    import pytest

    from tfrec.viewer.spawn import wait_for_viewer

    bin_dir = os.path.dirname(sys.executable)
    if shutil.which("rerun", path=bin_dir) is None:
        pytest.skip("no rerun beside this Python")
    from rerun.experimental import ViewerClient

    def free_port() -> int:
        with socket.socket() as sock:
            sock.bind(("127.0.0.1", 0))
            return int(sock.getsockname()[1])

    assert wait_for_viewer(free_port()) is False
    port = free_port()
    old = os.environ["PATH"]
    os.environ["PATH"] = f"{bin_dir}{os.pathsep}{old}"
    try:
        viewer = ViewerClient.spawn(headless=True, port=port, detach_process=False)
    except (OSError, RuntimeError) as err:
        pytest.skip(f"no headless viewer here: {err}")
    finally:
        os.environ["PATH"] = old
    try:
        assert wait_for_viewer(port) is True
    finally:
        viewer.quit()


def test_a_wheel_has_a_spoke_that_turns_with_it(tmp_path: Path) -> None:
    """A continuous joint's child link (a wheel) gets a spoke in its own frame, perpendicular to the joint's axis and
    longer than the wheel's radius (it shows through the wheel); other links get none."""
    import pytest
    from rerun.chunk import RrdReader

    urdf = tmp_path / "cart.urdf"
    urdf.write_text(
        "<robot name='cart'><link name='base'/><link name='wheel'><visual><origin rpy='1.5707963267948966 0 0'/>"
        "<geometry><cylinder radius='0.1' length='0.04'/></geometry></visual></link><link name='arm'/>"
        "<joint name='spin' type='continuous'><parent link='base'/><child link='wheel'/><axis xyz='0 1 0'/></joint>"
        "<joint name='lift' type='revolute'><parent link='base'/><child link='arm'/><axis xyz='1 0 0'/>"
        "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>")
    rrd = tmp_path / "cart.rrd"
    assert cli.main(["record", str(urdf), "--duration", "1", "--no-mcap", "--rrd", str(rrd)]) == 0
    spokes = {}
    frames = {}
    for chunk in RrdReader(rrd).stream():
        if chunk.entity_path.endswith("/spoke"):
            batch = chunk.to_record_batch()
            if "LineStrips3D:strips" in batch.schema.names:
                spokes[chunk.entity_path] = [np.array(strip) for strip in batch.column("LineStrips3D:strips").to_pylist()[0]]
            if "CoordinateFrame:frame" in batch.schema.names:
                frames[chunk.entity_path] = batch.column("CoordinateFrame:frame").to_pylist()[0]
    assert list(spokes) == ["/robot/wheel/spoke"]
    assert frames["/robot/wheel/spoke"] == ["wheel"] or frames["/robot/wheel/spoke"] == "wheel"
    faces = []
    for start, end in spokes["/robot/wheel/spoke"]:  # one on each face of the wheel, out past its rim
        direction = end - start
        assert abs(direction[1]) < 1e-6  # perpendicular to the axis (0 1 0)
        assert np.linalg.norm(direction) > 0.1
        assert start[0] == start[2] == 0.0
        faces.append(start[1])
    assert sorted(faces) == pytest.approx([-0.0204, 0.0204])  # the cylinder is 4 cm thick along the axis
