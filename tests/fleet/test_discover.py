"""Finding recordings under paths, and pairing two folders."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from tests.fleet.helpers import EXPECTED
from tfrec.fleet import FleetError, find_recordings, pair_recordings


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
