"""Finding recordings under paths, and pairing two folders."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.fleet.helpers import EXPECTED, copy_fleet
from tfrec.fleet import FleetError, Row, find_recordings, pair_recordings
from tfrec.fleet.report import read_report


def _relative(paths: list[Path], folder: Path) -> list[str]:
    return [p.relative_to(folder).as_posix() for p in paths]


def test_a_folder_is_searched_recursively_and_bags_are_not_entered(fleet_dir: Path) -> None:
    found = find_recordings([fleet_dir])
    assert _relative(found, fleet_dir) == sorted(EXPECTED)  # notes.txt skipped, odd.dat taken, gap_bag whole
    assert found == sorted(found, key=lambda p: p.as_posix())


def test_globs_files_and_duplicates(fleet_dir: Path) -> None:
    assert _relative(find_recordings([str(fleet_dir / "marm" / "*.mcap")]), fleet_dir) == [
        "marm/random.mcap", "marm/sine.mcap"]
    recursive = find_recordings([str(fleet_dir / "**" / "sine.mcap")])
    assert _relative(recursive, fleet_dir) == ["marm/sine.mcap", "mbot/sine.mcap"]
    twice = find_recordings([fleet_dir / "marm", fleet_dir / "marm" / "sine.mcap", fleet_dir / "bad" / "gap_bag"])
    assert _relative(twice, fleet_dir) == ["bad/gap_bag", "marm/random.mcap", "marm/sine.mcap"]


def test_a_file_given_is_taken_even_when_it_is_not_a_recording(fleet_dir: Path) -> None:
    assert find_recordings([fleet_dir / "notes.txt"]) == [fleet_dir / "notes.txt"]


def test_hidden_files_and_folders_are_skipped(tmp_path: Path, fleet_dir: Path) -> None:
    (tmp_path / ".cache").mkdir()
    shutil.copy(fleet_dir / "marm" / "sine.mcap", tmp_path / ".cache" / "a.mcap")
    shutil.copy(fleet_dir / "marm" / "sine.mcap", tmp_path / ".b.mcap")
    shutil.copy(fleet_dir / "marm" / "sine.mcap", tmp_path / "no_extension")
    (tmp_path / "README").write_text("text")
    assert _relative(find_recordings([tmp_path]), tmp_path) == ["README", "no_extension"]


def test_missing_paths_and_empty_globs_are_errors(tmp_path: Path) -> None:
    with pytest.raises(FleetError, match=r"nope\.mcap: no such file or folder"):
        find_recordings([tmp_path / "nope.mcap"])
    with pytest.raises(FleetError, match=r"\*\.bag: matches no file or folder"):
        find_recordings([str(tmp_path / "*.bag")])
    assert find_recordings([tmp_path]) == []


def test_pairs_by_relative_path(tmp_path: Path, fleet_dir: Path) -> None:
    a = tmp_path / "a"
    b = tmp_path / "b"
    shutil.copytree(fleet_dir / "marm", a / "marm")
    shutil.copytree(fleet_dir / "bad" / "gap_bag", a / "gap_bag")
    shutil.copytree(fleet_dir / "marm", b / "marm")
    shutil.copytree(fleet_dir / "bad" / "gap_bag", b / "gap_bag")
    os.remove(a / "marm" / "random.mcap")
    shutil.copy(fleet_dir / "mbot" / "sine.mcap", a / "extra.mcap")
    pairs = pair_recordings(a, b)
    assert [(p.key, p.a is not None, p.b is not None) for p in pairs] == [
        ("extra.mcap", True, False), ("gap_bag", True, True), ("marm/random.mcap", False, True),
        ("marm/sine.mcap", True, True)]
    assert pairs[1].a == a / "gap_bag"


def test_two_bags_pair_as_one_recording(fleet_dir: Path) -> None:
    bag = fleet_dir / "bad" / "gap_bag"
    assert [(p.key, p.a, p.b) for p in pair_recordings(bag, bag)] == [(".", bag, bag)]


def test_pairing_needs_folders(tmp_path: Path, fleet_dir: Path) -> None:
    with pytest.raises(FleetError, match=r"sine\.mcap: not a folder \(dir_a must be a folder of recordings\)"):
        pair_recordings(fleet_dir / "marm" / "sine.mcap", tmp_path)
    with pytest.raises(FleetError, match=r"nope: no such folder \(dir_b"):
        pair_recordings(tmp_path, tmp_path / "nope")


# -- links, unreadable folders, files that vanish ---------------------------------------------------


def _link_tree(root: Path, fleet_dir: Path) -> Path:
    """Links that loop, dangle, or lead back up the tree, beside two real recordings."""
    root.mkdir()
    shutil.copy(fleet_dir / "marm" / "sine.mcap", root / "good.mcap")
    (root / "loop").symlink_to("loop")  # a link to itself
    (root / "ping.mcap").symlink_to("pong.mcap")  # two links to each other
    (root / "pong.mcap").symlink_to("ping.mcap")
    (root / "gone.mcap").symlink_to("nowhere.mcap")  # dangling
    (root / "gone.txt").symlink_to("nowhere.txt")  # dangling, and its name says it is no recording
    (root / "sub").mkdir()
    shutil.copy(fleet_dir / "mbot" / "sine.mcap", root / "sub" / "x.mcap")
    (root / "sub" / "up").symlink_to("..")  # a folder linked into itself, twice
    (root / "sub" / "here").symlink_to(".")
    (root / "bag_link").symlink_to(fleet_dir / "bad" / "gap_bag")  # a link to a rosbag2 bag: a recording
    return root


def test_links_that_loop_dangle_or_lead_back_up(tmp_path: Path, fleet_dir: Path) -> None:
    root = _link_tree(tmp_path / "tree", fleet_dir)
    with pytest.warns(UserWarning, match=r"a symbolic link to a folder, not searched \(give it as a PATH") as caught:
        found = find_recordings([root])
    assert sorted(str(w.message).split(":")[0] for w in caught) == [str(root / "sub" / "here"), str(root / "sub" / "up")]
    # what cannot be told (loops) or read (dangling) is taken: its check says why
    assert _relative(found, root) == ["bag_link", "gone.mcap", "good.mcap", "loop", "ping.mcap", "pong.mcap", "sub/x.mcap"]
    with pytest.warns(UserWarning, match="not searched"):
        assert _relative(find_recordings([root / "sub" / "up"]), root / "sub" / "up") == _relative(found, root)  # given


def test_a_glob_does_not_follow_links_round_and_round(tmp_path: Path, fleet_dir: Path) -> None:
    """Two links to '.' make glob.glob('**') run for ever (2^depth paths); tfrec's glob takes each file once."""
    import subprocess
    import sys

    root = tmp_path / "tree"
    root.mkdir()
    shutil.copy(fleet_dir / "marm" / "sine.mcap", root / "a.mcap")
    (root / "x").symlink_to(".")
    (root / "y").symlink_to(".")
    code = (f"from tfrec.fleet import find_recordings; "
            f"print([str(p) for p in find_recordings([{str(root / '**' / '*.mcap')!r}])])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str([str(root / "a.mcap")])


def test_check_a_tree_of_odd_links(tmp_path: Path, fleet_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tfrec.cli import main

    root = _link_tree(tmp_path / "tree", fleet_dir)
    report = tmp_path / "r.jsonl"
    assert main(["check", str(root), "--jobs", "1", "--report", str(report)]) == 1
    out, err = capsys.readouterr()
    assert err.count("tfrec: warning: ") == 2 and "Traceback" not in err, err
    rows = {Path(r["file"]).relative_to(root).as_posix(): r for r in read_report(report) if r["check"] == "summary"}
    assert {name: row["verdict"] for name, row in rows.items()} == {
        "bag_link": "fail", "gone.mcap": "error", "good.mcap": "pass", "loop": "error", "ping.mcap": "error",
        "pong.mcap": "error", "sub/x.mcap": "pass"}
    assert rows["loop"]["detail"].endswith("cannot read: Too many levels of symbolic links")
    assert rows["gone.mcap"]["detail"].endswith("cannot read: No such file or directory")
    assert out.splitlines()[-1].startswith("7 recordings: 2 pass, 1 fail, 4 error in ")


def _locked_tree(root: Path, fleet_dir: Path) -> dict[str, int]:
    """Folders and files this user cannot read or enter, beside readable recordings: name → its mode."""
    sine = fleet_dir / "marm" / "sine.mcap"
    modes = {"locked": 0o000, "list_only": 0o400, "enter_only": 0o100, "unreadable.mcap": 0o000}
    for name in ("locked", "list_only", "enter_only", "open"):
        (root / name).mkdir(parents=True)
        shutil.copy(sine, root / name / "inner.mcap")
    shutil.copy(sine, root / "good.mcap")
    shutil.copy(sine, root / "unreadable.mcap")
    for name, mode in modes.items():
        (root / name).chmod(mode)
    return modes


@pytest.fixture
def locked_tree(tmp_path: Path, fleet_dir: Path) -> Iterator[Path]:
    from tests.fleet.helpers import permissions_apply

    reason = permissions_apply()
    if reason is not None:
        pytest.skip(reason)
    root = tmp_path / "tree"
    modes = _locked_tree(root, fleet_dir)
    yield root
    for name in modes:
        (root / name).chmod(0o700)


def _unprivileged_tfrec(args: list[str]) -> subprocess.CompletedProcess[str]:
    from tests.conftest import REPO
    from tests.fleet.helpers import tfrec_env, unprivileged

    return subprocess.run([sys.executable, "-m", "tfrec", *args], cwd=REPO, env=tfrec_env(), capture_output=True,
                          text=True, timeout=300, check=False, preexec_fn=unprivileged())


def test_check_a_tree_with_folders_it_cannot_enter(locked_tree: Path, tmp_path: Path) -> None:
    """Run as a user that meets the permissions (root without its override): an error row each, the rest checked."""
    report = tmp_path / "r.jsonl"
    done = _unprivileged_tfrec(["check", str(locked_tree), "--jobs", "1", "--report", str(report)])
    assert done.returncode == 1, done.stderr  # errors beside passes
    assert done.stderr == "", done.stderr
    rows = {Path(r["file"]).relative_to(locked_tree).as_posix(): (r["verdict"], r["detail"])
            for r in read_report(report) if r["check"] == "summary"}
    denied = ("error", "Permission denied")
    assert {name: (verdict, detail.rsplit(": ", 1)[-1]) for name, (verdict, detail) in rows.items()} == {
        "enter_only": denied, "good.mcap": ("pass", rows["good.mcap"][1]), "list_only/inner.mcap": denied,
        "locked": denied, "open/inner.mcap": ("pass", rows["open/inner.mcap"][1]), "unreadable.mcap": denied}
    assert done.stdout.splitlines()[-1].startswith("6 recordings: 2 pass, 0 fail, 4 error in ")


def test_diff_a_tree_with_folders_it_cannot_enter(locked_tree: Path, tmp_path: Path, fleet_dir: Path) -> None:
    other = tmp_path / "other"
    _locked_tree(other, fleet_dir)
    for name in ("locked", "list_only", "enter_only", "unreadable.mcap"):
        (other / name).chmod(0o700)
    report = tmp_path / "d.jsonl"
    done = _unprivileged_tfrec(["diff", str(locked_tree), str(other), "--jobs", "1", "--report", str(report)])
    assert done.returncode == 1, done.stderr
    assert done.stderr == "", done.stderr
    rows = {r["file"]: (r["verdict"], r["detail"]) for r in read_report(report) if r["check"] == "summary"}
    assert rows["good.mcap"][0] == rows["open/inner.mcap"][0] == "pass"
    for key in ("locked", "enter_only", "list_only/inner.mcap", "unreadable.mcap"):
        assert rows[key][0] == "error" and rows[key][1].endswith("cannot read: Permission denied"), rows[key]


def test_files_that_vanish_after_the_search(tmp_path: Path, fleet_dir: Path) -> None:
    from tfrec.fleet import check_tasks, diff_tasks, run

    folder = copy_fleet(fleet_dir, tmp_path / "a")
    tasks = check_tasks(find_recordings([folder]))
    pairs = pair_recordings(folder, fleet_dir)
    (folder / "marm" / "sine.mcap").unlink()
    shutil.rmtree(folder / "bad" / "gap_bag")
    rows: list[Row] = []
    run(tasks, jobs=1, on_result=lambda result, _: rows.extend(result))
    run(diff_tasks(pairs), jobs=1, on_result=lambda result, _: rows.extend(result))
    gone = [r for r in rows if r.check == "summary" and ("sine.mcap" in r.file and "marm" in r.file or "gap_bag" in r.file)]
    assert len(gone) == 4
    assert all(r.verdict == "error" and r.detail.endswith("cannot read: No such file or directory") for r in gone), gone


@pytest.mark.parametrize("command", ["check", "diff"])
def test_the_command_line_while_files_vanish(command: str, tmp_path: Path, fleet_dir: Path,
                                            monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """The search lists a file, which is deleted before it is read: that file's error row, the rest checked."""
    import tfrec.fleet
    from tfrec.cli import main

    folder = copy_fleet(fleet_dir, tmp_path / "a")
    victim = folder / "marm" / "random.mcap"
    real = tfrec.fleet.find_recordings

    def then_delete(paths: Any) -> list[Path]:
        found = real(paths)
        if victim.exists():
            victim.unlink()
        return found

    monkeypatch.setattr(tfrec.fleet, "find_recordings", then_delete)
    monkeypatch.setattr(tfrec.fleet.discover, "find_recordings", then_delete)
    report = tmp_path / "r.jsonl"
    argv = [str(folder)] if command == "check" else [str(folder), str(fleet_dir)]
    assert main([command, *argv, "--jobs", "1", "--report", str(report)]) == 1
    assert "Traceback" not in capsys.readouterr().err
    key = str(victim) if command == "check" else "marm/random.mcap"
    [row] = [r for r in read_report(report) if r["file"] == key and r["check"] == "summary"]
    assert row["verdict"] == "error" and row["detail"].endswith("cannot read: No such file or directory")


def test_a_path_behind_a_folder_it_cannot_enter(locked_tree: Path, tmp_path: Path) -> None:
    """Given as a PATH, a file in a folder the user cannot enter is an error row saying so, not 'no such file'."""
    report = tmp_path / "r.jsonl"
    done = _unprivileged_tfrec(["check", str(locked_tree / "locked" / "inner.mcap"), "--report", str(report)])
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("tfrec: error: ") == 1 and "nothing could be read" in done.stderr
    [row] = read_report(report)
    assert row["verdict"] == "error" and row["detail"].endswith("cannot read: Permission denied")
