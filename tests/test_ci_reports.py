"""Reports for CI (tfrec/fleet/ci.py): `check` and `diff` with --junit (validated against the JUnit schema by
xmlschema, read by junitparser), --format github (workflow commands at the description's lines) and --summary
(Markdown); the outputs' --force rules; and docs/ci.md's GitHub Actions workflow and GitLab job, run as written."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import xmlschema
import yaml
from junitparser import Error, Failure, JUnitXml

from tfrec.cli import main

from .conftest import REPO

SCHEMA = xmlschema.XMLSchema(Path(__file__).parent / "data" / "junit.xsd")

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="upper"/>
  <link name="fore"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/>
    <origin xyz="0 0 {z}" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="2"/>
  </joint>
</robot>
"""
ELBOW_LINE = 11  # the line of <joint name="elbow"> in ARM


def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


@pytest.fixture
def fleet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    """bags/ with two recordings of arm.urdf, and arm-moved.urdf whose elbow is 1 cm higher."""
    arm = _write(tmp_path / "arm.urdf", ARM.format(z="0.3"))
    _write(tmp_path / "arm-moved.urdf", ARM.format(z="0.31"))
    for name, traj in (("one", "sine"), ("two", "sweep")):
        assert main(["record", str(arm), "--traj", traj, "--duration", "1", "-o", str(tmp_path / "bags" / f"{name}.mcap"),
                     "--no-rrd"]) == 0
    capsys.readouterr()
    return tmp_path


def _junit(path: Path) -> JUnitXml:
    SCHEMA.validate(path)  # raises with the schema's complaint
    return JUnitXml.fromfile(str(path))


def test_check_junit_github_and_summary(fleet: Path, capsys: pytest.CaptureFixture[str]) -> None:
    junit, summary = fleet / "check.xml", fleet / "summary.md"
    # against the recorded description: all pass
    assert main(["check", str(fleet / "bags"), "--jobs", "1", "--junit", str(junit), "--summary", str(summary),
                 "--format", "github"]) == 0
    assert "::error" not in capsys.readouterr().out
    suites = list(_junit(junit))
    assert len(suites) == 1 and suites[0].name == "check" and suites[0].tests == 2 and suites[0].hostname
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d", suites[0].timestamp)  # xs:dateTime, as Ant's schema wants
    cases = [case for suite in suites for case in suite]
    assert sorted(case.name for case in cases) == sorted(str(fleet / "bags" / f"{n}.mcap") for n in ("one", "two"))
    assert all(case.is_passed for case in cases)
    assert summary.read_text().startswith("<!-- tfrec summary -->\n## tfrec check")
    # against a description whose elbow moved: each recording fails, the findings point at the elbow's line
    assert main(["check", str(fleet / "bags"), "--robot", str(fleet / "arm-moved.urdf"), "--jobs", "1", "--junit",
                 str(junit), "--summary", str(summary), "--format", "github"]) == 2  # refused: they exist
    assert "--force" in capsys.readouterr().err
    assert main(["check", str(fleet / "bags"), "--robot", str(fleet / "arm-moved.urdf"), "--jobs", "1", "--junit",
                 str(junit), "--summary", str(summary), "--format", "github", "--force"]) == 1
    out = capsys.readouterr().out
    annotations = [line for line in out.splitlines() if line.startswith("::error ")]
    assert annotations, out
    moved = str(fleet / "arm-moved.urdf")
    fore = [line for line in annotations if line.partition("::")[2].partition("::")[0].endswith(" fore")]
    # the frame 'fore' is placed by the joint elbow: the annotation points at that joint
    assert len(fore) == 2 and all(line.startswith(f"::error file={moved},line={ELBOW_LINE},") for line in fore), fore
    report = _junit(junit)
    cases = [case for suite in report for case in suite]
    assert len(cases) == 2 and all(isinstance(case.result[0], Failure) for case in cases)
    assert "resim" in cases[0].result[0].text
    text = summary.read_text()
    assert "❌ fail" in text and "### Worst errors" in text and "### Findings" in text


def test_diff_of_descriptions_points_at_the_changed_element(fleet: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a, b = fleet / "arm.urdf", fleet / "arm-moved.urdf"
    junit, summary, overlay = fleet / "d.xml", fleet / "d.md", fleet / "d.rrd"
    assert main(["diff", str(a), str(b), "--traj", "sine", "--duration", "1", "--junit", str(junit), "--summary",
                 str(summary), "--format", "github", "--rrd", str(overlay)]) == 1
    out = capsys.readouterr().out
    assert f"::error file={b},line={ELBOW_LINE},title=tfrec%3A description joint 'elbow'::joint 'elbow' changed" in out
    (case,) = [case for suite in _junit(junit) for case in suite]
    assert case.name == f"{a} vs {b}" and isinstance(case.result[0], Failure)
    assert f"{b}:{ELBOW_LINE}: description: joint 'elbow' changed" in case.result[0].text
    text = summary.read_text()
    assert f"[{overlay}]({overlay})" in text and "❌ fail" in text
    # the same description: a passing test case, no annotation
    assert main(["diff", str(a), str(a), "--traj", "sine", "--duration", "1", "--junit", str(junit), "--force",
                 "--format", "github"]) == 0
    assert "::error" not in capsys.readouterr().out
    (case,) = [case for suite in _junit(junit) for case in suite]
    assert case.is_passed


def test_diff_of_folders_and_an_unreadable_recording_is_an_error_case(fleet: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    other = fleet / "other"
    other.mkdir()
    (other / "one.mcap").write_bytes((fleet / "bags" / "one.mcap").read_bytes())
    (other / "two.mcap").write_bytes(b"not a recording")
    junit = fleet / "pairs.xml"
    assert main(["diff", str(fleet / "bags"), str(other), "--jobs", "1", "--junit", str(junit)]) == 1
    capsys.readouterr()
    cases = {case.name: case for suite in _junit(junit) for case in suite}
    assert cases["one.mcap"].is_passed
    assert isinstance(cases["two.mcap"].result[0], Error)


def test_outputs_follow_the_force_rules(fleet: Path, capsys: pytest.CaptureFixture[str]) -> None:
    notes = _write(fleet / "notes.xml", "<notes>mine</notes>\n")
    assert main(["check", str(fleet / "bags"), "--junit", str(notes), "--force", "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert "notes.xml" in err and "JUnit" in err and notes.read_text() == "<notes>mine</notes>\n"
    mine = _write(fleet / "mine.md", "# my notes\n")
    assert main(["check", str(fleet / "bags"), "--summary", str(mine), "--force", "--jobs", "1"]) == 2
    assert mine.read_text() == "# my notes\n"
    capsys.readouterr()
    recording = fleet / "bags" / "one.mcap"
    assert main(["check", str(fleet / "bags"), "--junit", str(recording), "--force", "--jobs", "1"]) == 2
    assert recording.read_bytes()[:5] == b"\x89MCAP"


def test_names_from_inputs_are_escaped_in_annotations_and_xml(tmp_path: Path) -> None:
    from tfrec.fleet.ci import Case, CaseFinding, github_annotations, junit_xml

    case = Case(name="bags/a\x1b[2J,b:c.mcap", verdict="fail", detail="50% off\nline two",
                findings=(CaseFinding("resim", "link\x07", "over\r\ntolerance", file="x,y:z.urdf", line=3),))
    (line,) = github_annotations([case])
    assert line == "::error file=x%2Cy%3Az.urdf,line=3,title=tfrec%3A resim link\x07::over%0D%0Atolerance"
    path = tmp_path / "r.xml"
    path.write_bytes(junit_xml([case], suite="check"))
    (parsed,) = [c for suite in _junit(path) for c in suite]
    assert parsed.name == "bags/a\\x1b[2J,b:c.mcap"


def test_pytests_own_junit_report_validates_too(pytester: pytest.Pytester) -> None:
    """The schema is not tailored to tfrec: pytest's --junitxml report, which the CI reporters read, passes it."""
    pytester.makepyfile("def test_a():\n    pass\n\ndef test_b():\n    assert 0\n")
    pytester.runpytest("--junitxml=out.xml")
    SCHEMA.validate(pytester.path / "out.xml")


_RUN = re.compile(r"^\s*(?:- run: |- )?(tfrec (?:check|diff) .*)$")


def _commands(doc: str) -> list[str]:
    """The tfrec commands of the YAML blocks of docs/ci.md's "Robot regression checks" section."""
    text = (REPO / "docs" / "ci.md").read_text()
    section = text.split("## Robot regression checks", 1)[1].split("\n## ", 1)[0]
    block = section.split(f"```yaml\n# {doc}", 1)[1].split("```", 1)[0]
    return [match.group(1) for line in block.splitlines() if (match := _RUN.match(line))]


@pytest.mark.parametrize("doc", [".github/workflows/robot.yml", ".gitlab-ci.yml"])
def test_the_documented_ci_jobs_run_as_written(doc: str, tmp_path: Path) -> None:
    """docs/ci.md's jobs, in a project laid out as they expect: robots/ with the description, goldens/ with
    recordings made by `tfrec record`; the commands run in a shell, with $GITHUB_STEP_SUMMARY set."""
    commands = _commands(doc)
    assert len(commands) >= 2, commands
    text = (REPO / "docs" / "ci.md").read_text()
    job = yaml.safe_load(text.split(f"```yaml\n# {doc}", 1)[1].split("```", 1)[0])  # valid YAML, the right shape
    steps = job["jobs"]["robot"]["steps"] if doc.startswith(".github") else job["robot"]["script"]
    assert [c for step in steps for c in ([step.get("run", "")] if isinstance(step, dict) else [step])
            if c.startswith("tfrec ")] == commands
    (tmp_path / "robots").mkdir()
    shutil.copy(REPO / "robots" / "marm.xacro", tmp_path / "robots" / "marm.xacro")
    if (REPO / "robots" / "marm").is_dir():
        shutil.copytree(REPO / "robots" / "marm", tmp_path / "robots" / "marm")
    (tmp_path / "step-summary.md").touch()  # GitHub creates it empty for each step
    env = {**os.environ, "GITHUB_STEP_SUMMARY": str(tmp_path / "step-summary.md"), "CI_PROJECT_DIR": str(tmp_path)}
    tfrec = [sys.executable, "-m", "tfrec"]
    subprocess.run([*tfrec, "record", "robots/marm.xacro", "--traj", "sine", "--duration", "1", "-o",
                    "goldens/marm-sine.mcap", "--no-rrd", "--quiet-legacy"], cwd=tmp_path, env=env, check=True,
                   capture_output=True)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])  # this tfrec
    for command in commands:  # in a shell, as the runners run them; ${{ runner.temp }} is GitHub's expression
        done = subprocess.run(["bash", "-c", command.replace("${{ runner.temp }}", str(tmp_path))], cwd=tmp_path,
                              env=env, capture_output=True, text=True, timeout=300, check=False)
        assert done.returncode == 0, (command, done.stdout, done.stderr)
    reports = sorted(tmp_path.rglob("*.xml"))
    assert reports, list(tmp_path.iterdir())
    for report in reports:
        SCHEMA.validate(report)
    summary = tmp_path / ("step-summary.md" if doc.startswith(".github") else "summary.md")
    assert summary.read_text().startswith("<!-- tfrec summary -->\n## tfrec check: goldens/")


def test_a_summary_of_names_that_are_no_utf8_is_written(tmp_path: Path) -> None:
    from tfrec.fleet.ci import Case, write_ci_outputs

    case = Case(name="bags/\udcff|x.mcap", verdict="fail", detail="bad \x1b[2J", file="bags/\udcff|x.mcap")
    write_ci_outputs([case], suite="check", title="t", junit=tmp_path / "j.xml", summary=tmp_path / "s.md",
                     force=False)
    text = (tmp_path / "s.md").read_text(encoding="utf-8")
    assert "`bags/\\udcff\\|x.mcap`" in text and "\x1b" not in text
    SCHEMA.validate(tmp_path / "j.xml")
