"""The picture options of the command line: inspect/info --graph, plot, diff --plot, replay --check --plot."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import CORPUS, ROBOTS
from tfrec.cli import main


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("rec") / "marm.mcap"
    assert main(["record", str(ROBOTS / "marm.xacro"), "--traj", "random", "--duration", "3", "--no-rrd",
                 "-o", str(out)]) == 0
    return out


@pytest.mark.parametrize("suffix", [".dot", ".svg", ".png", ".pdf"])
def test_inspect_graph_every_format(tmp_path: Path, suffix: str, capsys: pytest.CaptureFixture[str]) -> None:
    robot, args = ((CORPUS / "ur_description" / "urdf" / "ur5.xacro", ["--package-path", str(CORPUS)])
                   if CORPUS.is_dir() else (ROBOTS / "marm.xacro", []))
    out = tmp_path / f"tree{suffix}"
    assert main(["inspect", str(robot), *args, "--graph", str(out)]) == 0
    assert out.stat().st_size > 1000 and f"wrote {out}" in capsys.readouterr().out
    if suffix in (".dot", ".svg"):
        from tfrec.description import load_description

        model = load_description(robot, package_paths=[CORPUS] if CORPUS.is_dir() else [])
        text = out.read_text()
        assert all(link.name in text for link in model.links) and all(j.name in text for j in model.joints)
    assert main(["inspect", str(robot), *args, "--graph", str(out)]) == 2  # no overwrite without --force
    assert "already exists (use --force to overwrite)" in capsys.readouterr().err
    assert main(["inspect", str(robot), *args, "--graph", str(out), "--force"]) == 0


def test_info_graph_and_plot_and_check_plot(recorded: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", str(recorded), "--graph", str(tmp_path / "frames.svg")]) == 0
    svg = (tmp_path / "frames.svg").read_text()
    assert "link0" in svg and "gripper_link" in svg and "static" in svg
    assert main(["plot", str(recorded), "-o", str(tmp_path / "rec.png")]) == 0
    assert main(["replay", "--check", str(recorded), "--plot", str(tmp_path / "check.svg")]) == 0
    assert main(["diff", str(recorded), str(recorded), "--plot", str(tmp_path / "diff.pdf")]) == 0
    for name in ("rec.png", "check.svg", "diff.pdf"):
        assert (tmp_path / name).stat().st_size > 10_000
    capsys.readouterr()
    assert main(["plot", str(recorded), "-o", str(tmp_path / "rec.gif")]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert main(["replay", str(recorded), "--plot", str(tmp_path / "x.png")]) == 2
    assert capsys.readouterr().err == "tfrec: error: --plot draws a check: it goes with --check\n"


def test_plots_are_deterministic(recorded: Path, tmp_path: Path) -> None:
    for name in ("a.svg", "b.svg"):
        assert main(["plot", str(recorded), "-o", str(tmp_path / name)]) == 0
    assert (tmp_path / "a.svg").read_bytes() == (tmp_path / "b.svg").read_bytes()
