"""CSV keyframes resampled onto --rate: linear, monotone cubic (checked against scipy's PCHIP), hold;
the file's own stamps without --rate; a million rows in seconds."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from tfrec.cli import main
from tfrec.description import parse_urdf
from tfrec.errors import TrajectoryError
from tfrec.trajectory import make_trajectory

ARM = parse_urdf('''<robot name="arm"><link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="b"/><child link="c"/><limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
</robot>''')

KEYFRAMES = "time,j1,j2\n0,0,0\n1,1.5,0.1\n2,-0.5,0.5\n4,0.5,0.5\n"


def _csv(tmp_path: Path, text: str = KEYFRAMES) -> Path:
    f = tmp_path / "keys.csv"
    f.write_text(text)
    return f


def test_without_rate_the_files_own_stamps(tmp_path: Path) -> None:
    traj = make_trajectory(ARM, _csv(tmp_path))
    np.testing.assert_array_equal(traj.time_ns, np.array([0, 1, 2, 4]) * 1_000_000_000)


def test_linear_resampling(tmp_path: Path) -> None:
    traj = make_trajectory(ARM, _csv(tmp_path), rate_hz=10.0)
    assert len(traj) == 41 and traj.time_ns[-1] == 4_000_000_000
    np.testing.assert_allclose(traj.positions[5], [0.75, 0.05])  # halfway to the second keyframe
    np.testing.assert_allclose(traj.positions[::10], [[0, 0], [1.5, 0.1], [-0.5, 0.5], [0.0, 0.5], [0.5, 0.5]])
    np.testing.assert_allclose(traj.velocities[3], [1.5, 0.1])
    np.testing.assert_allclose(traj.velocities[25], [0.5, 0.0])


def test_hold_resampling_keeps_the_steps(tmp_path: Path) -> None:
    traj = make_trajectory(ARM, _csv(tmp_path), rate_hz=10.0, interp="hold")
    np.testing.assert_allclose(traj.positions[9], [0, 0])
    np.testing.assert_allclose(traj.positions[10], [1.5, 0.1])
    assert not traj.velocities.any()


def test_cubic_is_scipys_pchip_smooth_and_never_overshoots(tmp_path: Path) -> None:
    interpolate = pytest.importorskip("scipy.interpolate")
    traj = make_trajectory(ARM, _csv(tmp_path), rate_hz=100.0, interp="cubic")
    knots = np.array([[0, 0, 0], [1, 1.5, 0.1], [2, -0.5, 0.5], [4, 0.5, 0.5]], dtype=float)
    reference = interpolate.PchipInterpolator(knots[:, 0], knots[:, 1:], axis=0)
    t = traj.time_ns / 1e9
    np.testing.assert_allclose(traj.positions, reference(t), atol=1e-12)
    np.testing.assert_allclose(traj.velocities, reference.derivative()(t), atol=1e-9)
    assert traj.positions[:, 1].max() <= 0.5 and traj.positions[:, 0].min() >= -0.5  # between its keyframes
    assert np.abs(np.diff(traj.velocities, axis=0)).max() < 0.2  # no velocity jumps at the keyframes


def test_record_csv_with_rate_and_interp(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tfrec.formats import read_recording

    robot = tmp_path / "arm.urdf"
    robot.write_text(ARM.urdf)
    out = tmp_path / "k.mcap"
    assert main(["record", str(robot), "--traj", str(_csv(tmp_path)), "--rate", "50", "--interp", "cubic",
                 "--no-rrd", "-o", str(out)]) == 0
    assert "201 samples over 4 s" in capsys.readouterr().out
    states = read_recording(out).joint_states
    assert states is not None and len(states) == 201


def test_unknown_interpolation(tmp_path: Path) -> None:
    with pytest.raises(TrajectoryError, match="interpolation 'spline' is not one of linear, cubic, hold"):
        make_trajectory(ARM, _csv(tmp_path), rate_hz=10.0, interp="spline")


def test_many_rows_in_seconds(tmp_path: Path) -> None:
    """A million rows took 43 s and 1.1 GB before; numpy parses a file of plain numbers block by block now
    (docs/performance.md: a million rows of marm in about 5 s, 0.46 GB)."""
    n = 200_000
    f = tmp_path / "big.csv"
    t = np.arange(n) * 0.001
    with open(f, "w") as stream:
        stream.write("time,j1,j2\n")
        np.savetxt(stream, np.column_stack([t, np.sin(t), 0.25 + 0.2 * np.cos(t)]), delimiter=",", fmt="%.6f")
    start = time.process_time()
    traj = make_trajectory(ARM, f)
    assert len(traj) == n and time.process_time() - start < 30  # a hang guard in CPU seconds (~1 s here)
    with open(f, "a") as stream:
        stream.write("1000.5,nan,0.1\n")
    with pytest.raises(TrajectoryError, match=rf"big\.csv:{n + 2}: 'nan' in column 'j1' is not a finite number"):
        make_trajectory(ARM, f)


def test_an_endless_line_and_a_device_are_refused(tmp_path: Path) -> None:
    f = tmp_path / "endless.csv"
    with open(f, "w") as stream:
        stream.write("time,j1\n0," + "1" * (1 << 20))
    with pytest.raises(TrajectoryError, match=r"endless\.csv:2: cannot read CSV: field larger than field limit"):
        make_trajectory(ARM, f)
    with pytest.raises(TrajectoryError, match=r"/dev/zero: not a regular file"):
        make_trajectory(ARM, "/dev/zero")
