"""``tfrec diff A B --rrd``: the ghost overlay, read back with Rerun's own reader."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from tests.diff.test_motion import arm
from tests.formats.test_rrd import RERUN, Rrd
from tfrec import cli
from tfrec.diff import compare_motion
from tfrec.diff.overlay import write_overlay
from tfrec.errors import WriteError
from tfrec.formats.rrd.paths import TIMELINE
from tfrec.viewer.overlay import GHOST_COLOUR, OVERLAY_APPLICATION_ID, OverlayErrors, error_colours

GREEN = (40 << 24) | (180 << 16) | (60 << 8) | 0xFF
RED = (220 << 24) | (30 << 16) | (30 << 8) | 0xFF


@pytest.fixture(scope="module")
def overlay(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Rrd]:
    folder = tmp_path_factory.mktemp("overlay")
    a, b = arm(folder, "a.xacro"), arm(folder, "b.xacro", elbow_z="0.301")
    out = folder / "diff.rrd"
    assert cli.main(["diff", str(a), str(b), "--duration", "2", "--rrd", str(out)]) == 1
    return out, Rrd(out)


def test_both_robots_move_together(overlay: tuple[Path, Rrd]) -> None:
    _, rrd = overlay
    assert rrd.store.application_id == OVERLAY_APPLICATION_ID
    for side in ("a", "b"):
        stamps, parents = rrd.series(f"/{side}/tf/elbow", "Transform3D:parent_frame")
        assert len(stamps) == 101 and parents[0] == [f"{side}/upper"]
        _, children = rrd.series(f"/{side}/tf/elbow", "Transform3D:child_frame")
        assert children[0] == [f"{side}/fore"]
        assert rrd.static[f"/{side}/robot"]["CoordinateFrame:frame"] == [f"{side}/base"]
        assert rrd.static[f"/{side}/tf_static/tool_joint"]["Transform3D:parent_frame"] == [f"{side}/fore"]
    _, a_translation = rrd.series("/a/tf/elbow", "Transform3D:translation")
    _, b_translation = rrd.series("/b/tf/elbow", "Transform3D:translation")
    shift = np.array(b_translation)[:, 0] - np.array(a_translation)[:, 0]
    np.testing.assert_allclose(shift, np.broadcast_to([0.0, 0.0, 1e-3], shift.shape), atol=1e-7)
    root = rrd.static["/b/tf_static/root"]
    assert root["Transform3D:parent_frame"] == ["a/base"] and root["Transform3D:child_frame"] == ["b/base"]
    # B is a translucent ghost; A's visuals have no static colour (it would hide the error colours)
    assert rrd.static["/b/robot/upper/visual_0"]["Boxes3D:colors"] == [GHOST_COLOUR]
    assert "Boxes3D:colors" not in rrd.static["/a/robot/upper/visual_0"]


def test_links_are_coloured_by_their_error(overlay: tuple[Path, Rrd]) -> None:
    _, rrd = overlay
    _, upper = rrd.series("/a/robot/upper/visual_0", "Boxes3D:colors")
    _, fore = rrd.series("/a/robot/fore/visual_0", "Boxes3D:colors")
    _, base = rrd.series("/a/robot/base/visual_0", "Cylinders3D:colors")
    assert len(fore) == 101 and {c[0] for c in upper} == {GREEN} and {c[0] for c in base} == {GREEN}
    assert {c[0] for c in fore} == {RED}  # 1 mm all along, the worst of the diff


def test_the_error_series_with_the_tolerance_and_the_first_exceeding(overlay: tuple[Path, Rrd]) -> None:
    _, rrd = overlay
    stamps, errors = rrd.series("/diff/position/error", "Scalars:scalars")
    assert len(stamps) == 101
    np.testing.assert_allclose(np.array(errors)[:, 0], 1e-3, atol=1e-12)
    _, tolerance = rrd.series("/diff/position/tolerance", "Scalars:scalars")
    assert {t[0] for t in tolerance} == {1e-9}
    _, rotation = rrd.series("/diff/rotation/error", "Scalars:scalars")
    assert max(r[0] for r in rotation) < 1e-12
    assert rrd.static["/diff/position/error"]["SeriesLines:names"] == ["largest link position error (m)"]
    when, texts = rrd.series("/diff/events", "TextLog:text")
    assert [t[0] for t in texts] == ["fore: first above tolerance, 0.001 m from B's",
                                     "tool: first above tolerance, 0.001 m from B's"]
    assert when[0] == stamps[0]
    marks, values = rrd.series("/diff/position/first_exceeds", "Scalars:scalars")
    assert list(marks) == [stamps[0]] and values[0][0] == pytest.approx(1e-3)


def test_the_colours_have_a_legend_with_the_errors_they_stand_for(overlay: tuple[Path, Rrd]) -> None:
    """The error colouring's scale is shown: green within the tolerance, red at this diff's worst excess (1 mm)."""
    _, rrd = overlay
    legend = rrd.static["/diff/legend"]
    assert legend["TextDocument:media_type"] == ["text/markdown"]
    (text,) = legend["TextDocument:text"]
    assert "green | within tolerance (1e-09 m" in text
    assert "red | +0.001 m or +0 rad over it: this diff's worst" in text and "yellow | +0.0005 m" in text
    assert "grey" in text


def test_the_blueprint_frames_both_robots_beside_the_plots(overlay: tuple[Path, Rrd]) -> None:
    _, rrd = overlay
    rows = [row for chunk in rrd.blueprint_chunks for row in chunk]
    views = {(row["ViewBlueprint:class_identifier"][0], row["ViewBlueprint:space_origin"][0])
             for row in rows if row.get("ViewBlueprint:class_identifier")}
    assert views == {("3D", "/"), ("TimeSeries", "/diff/position"), ("TimeSeries", "/diff/rotation"),
                     ("TextLog", "/diff/events"), ("TextDocument", "/diff/legend")}
    (eye,) = [row for row in rows if row.get("EyeControls3D:position")]
    position, target = np.array(eye["EyeControls3D:position"][0]), np.array(eye["EyeControls3D:look_target"][0])
    assert eye["EyeControls3D:eye_up"][0] == [0.0, 0.0, 1.0]
    offset = position - target
    assert offset[0] == pytest.approx(offset[1]) and offset[0] > 0 and offset[2] > 0  # front-left, above
    assert any(row.get("SpatialInformation:target_frame") == ["a/base"] for row in rows)
    assert any(row.get("TimePanelBlueprint:timeline") == [TIMELINE] for row in rows)


def test_the_same_diff_gives_a_recording_rerun_finds_identical(overlay: tuple[Path, Rrd], tmp_path: Path) -> None:
    first, _ = overlay
    folder = first.parent
    second = tmp_path / "again.rrd"
    assert cli.main(["diff", str(folder / "a.xacro"), str(folder / "b.xacro"), "--duration", "2",
                     "--rrd", str(second)]) == 1
    result = subprocess.run([RERUN, "rrd", "compare", first, second], check=False, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr


def test_an_existing_output_is_refused_before_anything_is_compared(overlay: tuple[Path, Rrd],
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    out, _ = overlay
    before = out.read_bytes()
    assert cli.main(["diff", str(out.parent / "a.xacro"), str(out.parent / "nothing.xacro"), "--rrd", str(out)]) == 2
    assert "exists" in capsys.readouterr().err and out.read_bytes() == before
    comparison = compare_motion(out.parent / "a.xacro", out.parent / "a.xacro", duration_s=0.5)
    with pytest.raises(WriteError, match="not .rrd|\\.rrd"):
        write_overlay(comparison, out.with_suffix(".mcap"))
    assert not list(out.parent.glob(".tfrec-*"))


def test_two_recordings_as_an_overlay(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a = tmp_path / "a.mcap"
    assert cli.main(["record", str(arm(tmp_path)), "--duration", "1", "-o", str(a), "--no-rrd"]) == 0
    assert cli.main(["record", str(arm(tmp_path, "b.xacro", elbow_z="0.302")), "--duration", "1",
                     "-o", str(tmp_path / "b.mcap"), "--no-rrd"]) == 0
    out = tmp_path / "recordings.rrd"
    assert cli.main(["diff", str(a), str(tmp_path / "b.mcap"), "--rrd", str(out)]) == 1
    assert "4 topics)" in capsys.readouterr().out  # the recordings' report
    _, errors = Rrd(out).series("/diff/position/error", "Scalars:scalars")
    np.testing.assert_allclose(np.array(errors)[:, 0], 2e-3, atol=1e-12)


def test_error_colours_go_from_green_through_yellow_to_red() -> None:
    position = np.array([[0.0, 0.5, 1.0, np.inf]])
    errors = OverlayErrors(("a", "b", "c", "d"), position, np.zeros((1, 4)), np.full((1, 4), 1e-9),
                           np.full((1, 4), 1e-9))
    colours = error_colours(errors)[0]
    assert colours[0] == GREEN and colours[2] == RED and colours[3] == RED
    assert colours[1] == (240 << 24) | (200 << 16) | (30 << 8) | 0xFF  # half way: yellow
