"""Plots of a recording, of a diff and of a replay check: written, non-trivial, deterministic."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import ROBOTS
from tests.plots.helpers import has_colour, png_pixels
from tests.recording_helpers import write_mcap
from tfrec.cli import main
from tfrec.description import parse_urdf
from tfrec.diff.compare import compare
from tfrec.formats.reader import read_recording
from tfrec.model import Robot
from tfrec.plots import (
    ErrorSeries,
    PlotError,
    assign_colours,
    default_frames,
    errors_from_check,
    errors_from_diff,
    frame_paths,
    plot_check,
    plot_diff,
    plot_errors,
    plot_format,
    plot_recording,
)
from tfrec.plots._figure import PALETTE, envelope
from tfrec.plots.errors import first_exceed
from tfrec.recording import Recording
from tfrec.replay.check import check_replay
from tfrec.replay.load import load_replay
from tfrec.trajectory.generators import make_trajectory


def _moved_joint3(robot: Robot, dy: float) -> Robot:
    """The robot with joint3's origin moved by ``dy`` m along y: link3 and what hangs below it move."""
    old = '<origin rpy="0 0 0" xyz="0 0 0.14"/>'
    assert robot.urdf.count(old) == 1
    return parse_urdf(robot.urdf.replace(old, f'<origin rpy="0 0 0" xyz="0 {dy} 0.14"/>'))


@pytest.fixture(scope="module")
def random_rec(tmp_path_factory: pytest.TempPathFactory) -> Recording:
    """robots/marm.xacro, ``--traj random`` for 3 s at 50 Hz, recorded by the CLI."""
    mcap = tmp_path_factory.mktemp("plots") / "marm.mcap"
    assert main(["record", str(ROBOTS / "marm.xacro"), "--traj", "random", "-o", str(mcap), "--no-rrd",
                 "--duration", "3"]) == 0
    return read_recording(mcap)


def test_plot_recording_png(random_rec: Recording, tmp_path: Path) -> None:
    out = tmp_path / "rec.png"
    plot_recording(random_rec, out)
    assert out.stat().st_size > 60_000
    pixels = png_pixels(out)
    height, width, _ = pixels.shape
    assert 1200 <= width <= 1600 and height > 800
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 100
    assert random_rec.joint_states is not None
    colours = assign_colours(random_rec.joint_states.names)
    missing = [name for name, (colour, _) in colours.items() if not has_colour(pixels, colour)]
    assert not missing  # every joint's line is there, in its own colour
    assert len({colour for colour, _ in colours.values()}) == len(colours)


def test_plot_recording_svg_is_deterministic(random_rec: Recording, tmp_path: Path) -> None:
    plot_recording(random_rec, tmp_path / "a.svg")
    plot_recording(random_rec, tmp_path / "b.svg")
    svg = (tmp_path / "a.svg").read_bytes()
    assert svg == (tmp_path / "b.svg").read_bytes()
    text = svg.decode()
    assert random_rec.joint_states is not None
    assert all(f">{name}<" in text for name in random_rec.joint_states.names)
    for words in ("position (rad)", "position (m)", "velocity (rad/s)", "velocity (m/s)", "top view (x–y)",
                  "side view (x–z)", "gripper_finger_link1"):
        assert words in text, words
    plot_recording(random_rec, tmp_path / "c.pdf")
    assert (tmp_path / "c.pdf").read_bytes().startswith(b"%PDF-")


def test_frame_paths_compose_tf_into_the_root(random_rec: Recording) -> None:
    assert default_frames(random_rec) == ["gripper_finger_link1", "gripper_finger_link2"]
    paths = frame_paths(random_rec, ["link1", "gripper_link"])
    assert paths.roots == {"link1": "link0", "gripper_link": "link0"}
    assert paths.t_s[0] == 0.0 and paths.t_s[-1] == pytest.approx(3.0) and len(paths.t_s) == 151
    # link1 turns about link0's x axis at link0's origin offset: it stays put; the gripper moves
    assert np.ptp(paths.positions["link1"], axis=0) == pytest.approx(np.zeros(3), abs=1e-12)
    assert np.ptp(paths.positions["gripper_link"], axis=0).max() > 0.05
    assert np.isfinite(paths.positions["gripper_link"]).all()


def test_plot_recording_options_and_errors(random_rec: Recording, tmp_path: Path) -> None:
    plot_recording(random_rec, tmp_path / "one.png", frames=["link3"])
    with pytest.raises(PlotError, match=r"marm\.mcap: frames nope, gone not in /tf or /tf_static \(its frames: "
                                        r"gripper_finger_link1, .*link6\)"):
        plot_recording(random_rec, tmp_path / "bad.png", frames=["nope", "gone"])
    with pytest.raises(PlotError, match=r"rec\.gif: a plot is written as \.png, \.svg, \.pdf"):
        plot_recording(random_rec, tmp_path / "rec.gif")
    empty = Recording("empty.mcap", "mcap")
    with pytest.raises(PlotError, match=r"empty\.mcap: nothing to plot: no /joint_states, /tf or /tf_static"):
        plot_recording(empty, tmp_path / "empty.png")
    assert not (tmp_path / "bad.png").exists() and not (tmp_path / "empty.png").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["one.png"]  # no temporary files left


def test_plot_recording_without_a_description(random_rec: Recording, tmp_path: Path) -> None:
    bare = dataclasses.replace(random_rec, robot_description=None, tf={}, tf_static={})
    plot_recording(bare, tmp_path / "bare.svg")
    text = (tmp_path / "bare.svg").read_text()
    assert ">position<" in text and "(rad)" not in text and "frame paths" not in text


def test_colours_are_stable_and_distinct() -> None:
    names = [f"joint{i}" for i in range(1, 8)]
    colours = assign_colours(names)
    assert colours == assign_colours(reversed(names))
    assert len({c for c, _ in colours.values()}) == 7
    many = assign_colours(f"j{i}" for i in range(30))
    assert len({c for c, _ in many.values()}) == len(PALETTE)
    assert len(set(many.values())) == 30  # past the palette, line styles tell them apart


def test_envelope_keeps_peaks() -> None:
    t = np.linspace(0.0, 100.0, 100_001)
    y = np.sin(t)[:, np.newaxis] * np.array([1.0, 2.0])
    y[54_321, 0] = 9.0
    tt, yy = envelope(t, y)
    assert len(tt) <= 4000 and yy.shape == (len(tt), 2)
    assert yy[:, 0].max() == 9.0 and yy[:, 1].min() == pytest.approx(-2.0, abs=1e-6)
    assert np.all(np.diff(tt) >= 0)


def _synthetic(n_frames: int) -> list[ErrorSeries]:
    t = np.linspace(0.0, 4.0, 401)
    out = []
    for k in range(n_frames):
        trans = 1e-8 * (k + 1) * (1.0 + np.sin(t + k))
        rot = np.zeros_like(t)
        if k == 3:  # one frame drifts past the tolerance at t = 1.5 s
            trans = np.where(t >= 1.5, 1e-3 * (t - 1.0), trans)
            rot = np.where(t >= 2.0, 0.01, 0.0)
        out.append(ErrorSeries(f"frame_{k}", t, trans, rot))
    out.append(ErrorSeries("latched", np.zeros(1), np.array([2e-9]), np.array([0.0]), static=True))
    return out


def test_plot_errors_synthetic(tmp_path: Path) -> None:
    series = _synthetic(12)
    assert first_exceed(series[3].t_s, series[3].translation_m, 1e-4) == pytest.approx(1.5)
    for name in ("a.svg", "b.svg", "c.png"):
        plot_errors(series, tmp_path / name, pos_tol=1e-4, rot_tol=1e-3, title="synthetic errors")
    svg = (tmp_path / "a.svg").read_bytes()
    assert svg == (tmp_path / "b.svg").read_bytes()
    text = svg.decode()
    assert "first above tolerance: frame_3 at t=1.500 s" in text  # translation
    assert "first above tolerance: frame_3 at t=2.000 s" in text  # rotation
    assert ">and 5 more frames (0 above)" in text and "1 of 13 frames above" in text
    assert text.index(">✗ frame_3<") < text.index(">✓ frame_11<")  # worst first
    pixels = png_pixels(tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 50_000 and len(np.unique(pixels.reshape(-1, 3), axis=0)) > 50
    with pytest.raises(PlotError, match=r"none\.png: no frame errors to plot"):
        plot_errors([], tmp_path / "none.png", pos_tol=1e-4, rot_tol=1e-3, title="nothing")


@pytest.fixture(scope="module")
def two_recordings(tmp_path_factory: pytest.TempPathFactory, marm: Robot) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("diff")
    moved = _moved_joint3(marm, 0.0015)
    a = write_mcap(folder / "a.mcap", marm, make_trajectory(marm, "sine", duration_s=3.0, rate_hz=50.0))
    b = write_mcap(folder / "b.mcap", moved, make_trajectory(moved, "sine", duration_s=3.0, rate_hz=50.0,
                                                               amplitude=0.801))
    return a, b


def test_diff_plot(two_recordings: tuple[Path, Path], tmp_path: Path) -> None:
    report = compare(*two_recordings, pos_tol=1e-3, rot_tol=1e-3)
    series = {s.name: s for s in errors_from_diff(report)}
    assert set(series) == {"link1", "link2", "link3", "link4", "link5", "link6", "gripper_finger_link1",
                           "gripper_finger_link2", "gripper_link"}
    assert series["gripper_link"].static and series["gripper_link"].largest() == (0.0, 0.0)
    assert series["link3"].translation_m == pytest.approx(np.full(151, 0.0015))
    assert len(series["link1"].t_s) == 151 and series["link1"].rotation_rad.max() > 1e-3
    # the largest errors agree with the report's
    assert max(s.largest()[1] for s in series.values()) == pytest.approx(report.largest["rotation"].value)
    out = tmp_path / "diff.png"
    plot_diff(report, out)
    pixels = png_pixels(out)
    assert out.stat().st_size > 50_000 and pixels.shape[1] >= 1200
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 50
    plot_diff(report, tmp_path / "diff.svg")
    assert "tfrec diff: " in (tmp_path / "diff.svg").read_text()


def test_check_plot(two_recordings: tuple[Path, Path], marm: Robot, tmp_path: Path) -> None:
    replay = load_replay(two_recordings[0], robot=_moved_joint3(marm, 0.002))
    report = check_replay(replay)
    assert [f.frame for f in report.failures] == ["link3"]
    series = {s.name: s for s in errors_from_check(report)}
    assert len(series["link3"].t_s) == report.failures[0].samples == 151
    assert series["link3"].translation_m == pytest.approx(np.full(151, 0.002))
    assert series["link3"].largest()[0] == pytest.approx(report.failures[0].translation_m)
    assert series["gripper_link"].static
    bare = dataclasses.replace(report, frames=[dataclasses.replace(f, errors=None) for f in report.frames])
    points = {s.name: s for s in errors_from_check(bare)}  # frames without their errors: the largest alone
    assert np.nanmax(points["link3"].translation_m) == report.failures[0].translation_m
    for name, checked in (("check.png", report), ("check-points.svg", bare)):
        plot_check(checked, tmp_path / name)
    assert (tmp_path / "check.png").stat().st_size > 50_000
    text = (tmp_path / "check-points.svg").read_text()
    assert "FAIL (1 of 9 frames)" in text and "largest errors only" in text


def test_plot_format() -> None:
    assert plot_format("x.PNG") == "png"
    with pytest.raises(PlotError, match=r"x\.dot: a plot is written as \.png, \.svg, \.pdf"):
        plot_format("x.dot")


def test_plot_of_a_bag_of_two_namespaced_robots(random_rec: Recording, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """/robot1/… and /robot2/…: the root namespace has nothing; --namespace chooses the robot."""
    from tests.bag_builders import Robot as BagRobot
    from tests.bag_builders import write_bag

    bag = write_bag(tmp_path / "two.bag", [BagRobot(random_rec, namespace="/robot1"),
                                           BagRobot(random_rec, namespace="/robot2")], kind="ros1")
    assert main(["plot", str(bag), "-o", str(tmp_path / "both.svg")]) == 2
    assert capsys.readouterr().err == (f"tfrec: error: {bag}: 2 robots (/robot1, /robot2): choose one with "
                                       "--namespace\n")
    assert main(["plot", str(bag), "-o", str(tmp_path / "nope.svg"), "--namespace", "/nope"]) == 2
    assert "no robot in namespace '/nope' (namespaces with robot topics: /robot1, /robot2)" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.svg"))
    assert main(["plot", str(bag), "-o", str(tmp_path / "robot2.svg"), "--namespace", "robot2"]) == 0
    text = (tmp_path / "robot2.svg").read_text()
    assert random_rec.joint_states is not None
    assert all(f">{name}<" in text for name in random_rec.joint_states.names)
    assert "position (rad)" in text and "gripper_finger_link1" in text  # limits from /robot2/robot_description
    # the only robot of a bag is drawn without --namespace
    one = write_bag(tmp_path / "one.bag", [BagRobot(random_rec, namespace="/robot1")], kind="ros1")
    assert main(["plot", str(one), "-o", str(tmp_path / "one.svg")]) == 0
    assert (tmp_path / "one.svg").read_text().count("gripper_finger_link1") == text.count("gripper_finger_link1")
