"""`tfrec diff REV:PATH PATH`: a description as it was in a git revision, its includes from the same revision, taken
with `git archive` (the work tree, index and HEAD untouched), in a repository the test makes."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from tfrec.cli import main

ARM = """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <link name="base"/>
  <link name="upper"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="2"/>
  </joint>
  <xacro:include filename="parts/fore.xacro"/>
</robot>
"""
FORE = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <link name="fore"/>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/>
    <origin xyz="0 0 {z}" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="2"/>
  </joint>
</robot>
"""


def _git(repo: Path, *args: str) -> str:
    env = {**os.environ, "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.com", "GIT_COMMITTER_NAME": "t",
           "GIT_COMMITTER_EMAIL": "t@example.com", "GIT_CONFIG_GLOBAL": os.devnull, "GIT_CONFIG_SYSTEM": os.devnull}
    return subprocess.run(["git", *args], cwd=repo, env=env, check=True, capture_output=True, text=True).stdout


@pytest.fixture
def repo(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """robots/arm.xacro including robots/parts/fore.xacro; the include's elbow moved 1 cm in the second commit."""
    root = tmp_path / "repo"
    (root / "robots" / "parts").mkdir(parents=True)
    (root / "robots" / "arm.xacro").write_text(ARM)
    (root / "robots" / "parts" / "fore.xacro").write_text(FORE.format(z="0.3"))
    _git(root, "init", "-q", "-b", "main")
    _git(root, "add", "-A")
    _git(root, "commit", "-q", "-m", "arm")
    (root / "robots" / "parts" / "fore.xacro").write_text(FORE.format(z="0.31"))
    _git(root, "commit", "-q", "-am", "elbow 1 cm higher")
    monkeypatch.chdir(root)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))
    monkeypatch.setattr("tempfile.tempdir", None)
    return root


def _state(root: Path) -> tuple[str, str, str]:
    return (_git(root, "rev-parse", "HEAD"), _git(root, "status", "--porcelain", "--untracked-files=all"),
            (root / "robots" / "parts" / "fore.xacro").read_text())


def test_an_include_changed_between_revisions(repo: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = _state(repo)
    assert main(["diff", "HEAD~1:robots/arm.xacro", "robots/arm.xacro", "--traj", "sine", "--duration", "1"]) == 1
    out = capsys.readouterr().out
    assert "joint 'elbow' changed: origin xyz (0 0 0.3) → (0 0 0.31)" in out
    assert "HEAD~1:robots/arm.xacro" in out and "tfrec-rev-" not in out
    assert _state(repo) == before  # nothing checked out, nothing added
    assert list((repo.parent / "tmp").iterdir()) == []  # the revision's files are removed
    # the same revision as the work tree: nothing moved; a path relative to the current folder, as git takes it
    assert main(["diff", "HEAD:robots/arm.xacro", "robots/arm.xacro", "--traj", "sine", "--duration", "1"]) == 0
    os.chdir(repo / "robots")
    assert main(["diff", "HEAD~1:./arm.xacro", "HEAD:robots/arm.xacro", "--traj", "sine",
                 "--duration", "1"]) == 1
    assert "joint 'elbow' changed" in capsys.readouterr().out


def test_two_revisions_and_a_recordings_joint_states(repo: Path, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    rec = tmp_path / "run.mcap"
    assert main(["record", "robots/arm.xacro", "--traj", "sweep", "--duration", "2", "-o", str(rec), "--no-rrd"]) == 0
    capsys.readouterr()
    assert main(["diff", "HEAD~1:robots/arm.xacro", "HEAD:robots/arm.xacro", "--joints", str(rec), "--json"]) == 1
    out = capsys.readouterr().out
    assert f"/joint_states of {rec}" in out or str(rec) in out
    assert "HEAD~1:robots/arm.xacro" in out and "HEAD:robots/arm.xacro" in out
    assert '"link \'fore\'"' in out


@pytest.mark.parametrize(("token", "message"), [
    ("nosuchrev:robots/arm.xacro", "nosuchrev:robots/arm.xacro: no revision 'nosuchrev' in the repository"),
    ("HEAD~1:robots/missing.xacro", "HEAD~1:robots/missing.xacro: revision HEAD~1 ("),
    ("HEAD:../../outside.xacro", "HEAD:../../outside.xacro: revision HEAD ("),
])
def test_a_bad_revision_path_is_one_line(repo: Path, token: str, message: str,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diff", token, "robots/arm.xacro", "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"tfrec: error: {message}") and err.count("\n") == 1 and "Traceback" not in err


def test_outside_a_repository_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GIT_CEILING_DIRECTORIES", str(tmp_path.parent))
    (tmp_path / "arm.urdf").write_text("<robot name='a'><link name='b'/></robot>")
    assert main(["diff", "HEAD:arm.urdf", "arm.urdf"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tfrec: error: HEAD:arm.urdf: ") and err.count("\n") == 1
