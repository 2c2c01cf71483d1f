"""Issue 21, part 2: `tfrec diff a.xacro b.xacro --plot` draws the world displacement of each link over the
shared motion — readable for a 30-link robot (the worst links drawn and named, the rest counted) — and the
same for a recording against a description."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from tfrec.cli import main
from tfrec.diff.motion import compare_motion
from tfrec.plots import errors_from_motion


def _chain(links: int, *, shifted: int | None = None) -> str:
    """A 30-link tree: chains of 7 revolute joints from the root; joint ``shifted``'s origin 1 cm aside."""
    parts = ['<robot name="snake"><link name="l0"/>']
    for i in range(1, links + 1):
        parent = f"l{i - 1}" if i % 7 else "l0"
        y = 0.01 if i == shifted else 0.0
        parts.append(f'<link name="l{i}"/><joint name="j{i}" type="revolute"><parent link="{parent}"/>'
                     f'<child link="l{i}"/><origin xyz="0 {y} 0.1"/><axis xyz="0 1 0"/>'
                     '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    return "".join(parts) + "</robot>"


@pytest.fixture
def snakes(tmp_path: Path) -> tuple[Path, Path]:
    a, b = tmp_path / "snake.urdf", tmp_path / "snake-shifted.urdf"
    a.write_text(_chain(30))
    b.write_text(_chain(30, shifted=10))
    return a, b


def test_the_displacement_of_each_link_is_the_reports(snakes: tuple[Path, Path]) -> None:
    comparison = compare_motion(*snakes, duration_s=2.0, rate_hz=20.0)
    series = {s.name: s for s in errors_from_motion(comparison)}
    assert len(series) == 30
    for delta in comparison.report.links:
        assert np.nanmax(series[delta.link].translation_m) == pytest.approx(delta.position_m, abs=0)
    moved = sorted(name for name, s in series.items() if np.nanmax(s.translation_m) > 1e-9)
    assert moved == ["l10", "l11", "l12", "l13"]  # the shifted joint's child and the chain below it
    assert np.allclose(series["l12"].translation_m, 0.01)


def test_diff_plot_of_a_30_link_robot(snakes: tuple[Path, Path], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    picture = tmp_path / "snake.svg"
    code = main(["diff", str(snakes[0]), str(snakes[1]), "--plot", str(picture), "--duration", "2"])
    out = capsys.readouterr().out
    assert code == 1 and f"wrote {picture}" in out
    text = picture.read_text()
    lines = re.findall(r"<text [^>]*>([^<]*)</text>", text)  # the heading wraps: its lines are texts of their own
    heading = " ".join(lines)
    assert "4 of 30 links above (l10, l11, l12, l13)" in heading
    assert "and 22 more links (0 above)" in text  # 8 drawn, the others counted
    assert "note: joint 'j10' changed: origin xyz (0 0 0.1) → (0 0.01 0.1)" in text
    assert "time (s) from the motion's start" in text


def test_diff_plot_of_a_recording_against_a_description(snakes: tuple[Path, Path], tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    recording = tmp_path / "snake.mcap"
    assert main(["record", str(snakes[0]), "--duration", "1", "-o", str(recording), "--no-rrd"]) == 0
    picture = tmp_path / "against.png"
    code = main(["diff", str(recording), str(snakes[1]), "--plot", str(picture)])
    capsys.readouterr()
    assert code == 1 and picture.read_bytes().startswith(b"\x89PNG")
