"""tfrec's pytest plugin (tfrec/pytest_plugin.py) in a scratch project run by pytester: goldens made with
--tfrec-update, a missing golden, a 1 mm change that fails with the report and artefacts, unused goldens;
and ``tfrec record --like`` remaking a golden byte for byte."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot
import numpy
import pytest
import rerun
from mcap.reader import make_reader

import tfrec.diff.motion
import tfrec.diff.overlay
import tfrec.plots
import tfrec.recorder
import tfrec.viewer.sink
from tfrec.cli import main
from tfrec.errors import ReadError

# pytester runs the scratch project in this process and forgets the modules it imported afterwards: numpy's
# (and so everything above) cannot be imported twice, so they are imported here, before
_IMPORTED = (matplotlib.pyplot, numpy, rerun, tfrec.diff.motion, tfrec.diff.overlay, tfrec.plots, tfrec.recorder,
             tfrec.viewer.sink)

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="upper"/>
  <link name="fore"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <origin xyz="0 0 {z}" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="2"/>
  </joint>
</robot>
"""

TEST = """
def test_arm(tfrec_golden):
    tfrec_golden.check("robot/arm.urdf", traj="sine", duration=0.5, seed=0)


def test_named(tfrec_golden):
    tfrec_golden.check("robot/arm.urdf", traj="random", duration=0.5, seed=3, rate=20, name="arm-random")
"""


@pytest.fixture
def project(pytester: pytest.Pytester) -> pytest.Pytester:
    (pytester.path / "robot").mkdir()
    (pytester.path / "robot" / "arm.urdf").write_text(ARM.format(z="0.1"))
    pytester.makepyfile(test_arm=TEST)
    return pytester


def _recipe(path: Path) -> dict[str, str]:
    with open(path, "rb") as stream:
        for record in make_reader(stream).iter_metadata():
            if record.name == "tfrec.recipe":
                return dict(record.metadata)
    raise AssertionError(f"{path}: no tfrec.recipe metadata")


def test_the_golden_workflow(project: pytest.Pytester) -> None:
    goldens = project.path / "test_arm"
    # no golden: one line that says how to make it, no traceback
    result = project.runpytest()
    result.assert_outcomes(failed=2)
    made_with = "pytest --tfrec-update test_arm.py::test_arm"
    result.stdout.fnmatch_lines([f"*test_arm.mcap: no golden recording yet; make it with: {made_with}"])
    assert "Traceback" not in result.stdout.str() and "def test_arm" not in result.stdout.str()
    assert not goldens.exists()
    # --tfrec-update makes them, and says so; then the tests pass
    result = project.runpytest("--tfrec-update")
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["*tfrec: goldens written (--tfrec-update)*", f"{goldens / 'test_arm.mcap'}"])
    assert sorted(path.name for path in goldens.iterdir()) == ["arm-random.mcap", "test_arm.mcap"]
    recipe = _recipe(goldens / "test_arm.mcap")
    assert recipe["description"] == "../robot/arm.urdf" and recipe["traj"] == "sine"
    assert recipe["duration_s"] == "0.5" and recipe["seed"] == "0"
    first = (goldens / "test_arm.mcap").read_bytes()
    project.runpytest().assert_outcomes(passed=2)
    # a joint origin 1 mm higher: the report, the overlay and the plot
    (project.path / "robot" / "arm.urdf").write_text(ARM.format(z="0.101"))
    result = project.runpytest(f"--tfrec-artifacts={project.path / 'out'}")
    result.assert_outcomes(failed=2)
    text = result.stdout.str()
    assert "test_arm.mcap: the recording differs from its golden" in text
    assert "shoulder" in text and "Traceback" not in text
    result.stdout.fnmatch_lines(["*artefact: *test_arm.diff.rrd", "*artefact: *test_arm.diff.png"])
    overlay = project.path / "out" / "test_arm" / "test_arm.diff.rrd"
    plot = project.path / "out" / "test_arm" / "test_arm.diff.png"
    assert overlay.read_bytes()[:4] == b"RRF2"
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the change is meant: --tfrec-update rewrites the goldens, and they pass again
    project.runpytest("--tfrec-update").assert_outcomes(passed=2)
    assert (goldens / "test_arm.mcap").read_bytes() != first
    assert _recipe(goldens / "test_arm.mcap")["description_sha256"] != recipe["description_sha256"]
    project.runpytest().assert_outcomes(passed=2)


def test_artefacts_go_to_tmp_path_by_default(project: pytest.Pytester) -> None:
    project.runpytest("--tfrec-update").assert_outcomes(passed=2)
    (project.path / "robot" / "arm.urdf").write_text(ARM.format(z="0.101"))
    result = project.runpytest("-k", "not named", f"--basetemp={project.path / 'tmp'}")
    result.assert_outcomes(failed=1, deselected=1)
    rrds = list((project.path / "tmp").rglob("test_arm.diff.rrd"))
    assert len(rrds) == 1 and rrds[0].stat().st_size > 0
    assert "goldens no test used" not in result.stdout.str()  # the deselected test's golden is not unused


def test_unused_goldens_are_listed(project: pytest.Pytester) -> None:
    project.runpytest("--tfrec-update").assert_outcomes(passed=2)
    stale = project.path / "test_arm" / "test_gone.mcap"
    stale.write_bytes((project.path / "test_arm" / "test_arm.mcap").read_bytes())
    result = project.runpytest()
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["*tfrec: goldens no test used*", f"{stale}  (delete it if no test needs it)"])
    assert "arm-random.mcap  (delete" not in result.stdout.str()


def test_a_bad_description_is_one_line(project: pytest.Pytester) -> None:
    (project.path / "robot" / "arm.urdf").write_text("<robot name='arm'><link name='a'/><joint/></robot>")
    result = project.runpytest("--tfrec-update")
    result.assert_outcomes(failed=2)
    result.stdout.fnmatch_lines(["*tfrec_golden: *arm.urdf*"])
    assert "Traceback" not in result.stdout.str()


def test_record_like_remakes_a_golden_byte_for_byte(project: pytest.Pytester, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    project.runpytest("--tfrec-update").assert_outcomes(passed=2)
    for name in ("test_arm", "arm-random"):
        golden = project.path / "test_arm" / f"{name}.mcap"
        again = tmp_path / f"{name}.mcap"
        assert main(["record", "--like", str(golden), "-o", str(again), "--no-rrd"]) == 0
        assert again.read_bytes() == golden.read_bytes()
    assert main(["info", str(project.path / "test_arm" / "test_arm.mcap")]) == 0
    out = capsys.readouterr().out
    assert "Made with:   tfrec record ../robot/arm.urdf --traj sine --duration 0.5" in out
    # a changed description gives another recording (and says so in the hash)
    (project.path / "robot" / "arm.urdf").write_text(ARM.format(z="0.2"))
    changed = tmp_path / "changed.mcap"
    assert main(["record", "--like", str(project.path / "test_arm" / "test_arm.mcap"), "-o", str(changed),
                 "--no-rrd"]) == 0
    assert changed.read_bytes() != (project.path / "test_arm" / "test_arm.mcap").read_bytes()


def test_record_like_refuses_a_robot_or_a_recording_without_recipe(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    made = tmp_path / "a.bag"
    assert main(["record", "robots/marm.xacro", "--duration", "0.2", "-o", str(made), "--no-rrd"]) == 0
    capsys.readouterr()
    assert main(["record", "--like", str(made), "-o", str(tmp_path / "b.mcap")]) == 2
    assert f"{made}: holds no recipe" in capsys.readouterr().err
    assert main(["record", "robots/marm.xacro", "--like", str(made)]) == 2
    assert "ROBOT goes with no `--like`" in capsys.readouterr().err


def test_the_plugin_imports_nothing_heavy() -> None:
    code = ("import sys, tfrec.pytest_plugin; heavy = [m for m in ('numpy', 'mcap', 'rerun', 'matplotlib', "
            "'xacro', 'tfrec.recorder') if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_a_recipe_from_another_writer_is_read_and_a_huge_or_malformed_one_is_not(tmp_path: Path,
                                                                                capsys: pytest.CaptureFixture[str]) -> None:
    """Recipes written by mcap's own writer: a good one is taken by --like; one over 1 MiB is not read; one
    without its description is one line."""
    from mcap.writer import Writer

    from tfrec.recorder import RECIPE, Recipe, read_recipe

    def write(path: Path, values: dict[str, str]) -> Path:
        with open(path, "wb") as stream:
            writer = Writer(stream)
            writer.start(profile="ros2", library="other")
            writer.add_metadata(RECIPE, values)
            writer.finish()
        return path

    arm = tmp_path / "arm.urdf"
    arm.write_text(ARM.format(z="0.1"))
    good = write(tmp_path / "good.mcap", Recipe(description="arm.urdf", traj="sweep", duration_s=1.0).metadata())
    assert read_recipe(good).traj == "sweep"
    assert main(["record", "--like", str(good), "-o", str(tmp_path / "out.mcap"), "--no-rrd"]) == 0
    assert "--traj sweep" in capsys.readouterr().out
    huge = write(tmp_path / "huge.mcap", {**Recipe(description="arm.urdf").metadata(), "pad": "x" * (1 << 20)})
    with pytest.raises(ReadError, match="holds no recipe"):
        read_recipe(huge)
    broken = write(tmp_path / "broken.mcap", {"traj": "sine"})
    assert main(["record", "--like", str(broken), "-o", str(tmp_path / "b.mcap")]) == 2
    assert capsys.readouterr().err == f"tfrec: error: {broken}: its tfrec.recipe metadata has no 'description'\n"
