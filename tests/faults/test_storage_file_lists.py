"""A rosbag2 ``metadata.yaml`` whose ``relative_file_paths`` lists one storage file 100,000 times (1.4 MB) cost a
minute per command and hung ``check`` (issue 20): every name of one file is read once now, with a warning — the
same name repeated, spelled ``./x.mcap`` or ``sub/../x.mcap``, or another name (a hard link) of the same file —
and the list is bounded. A name never leaves the bag's folder: ``../x.mcap`` is the folder's own ``x.mcap``."""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import pytest
import yaml

from tests.conftest import ROBOTS
from tests.faults.guarded import guarded, warnings_of
from tfrec.cli import main
from tfrec.formats.rosbag2.metadata import MAX_STORAGE_FILES


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A rosbag2 folder of one MCAP file, recorded by tfrec."""
    folder = tmp_path_factory.mktemp("bag")
    assert main(["record", str(ROBOTS / "marm.xacro"), "--bag", str(folder / "bag"), "--duration", "1", "--rate",
                 "20", "--no-rrd"]) == 0
    return folder / "bag"


def _listing(bag: Path, tmp_path: Path, names: list[str]) -> Path:
    """A copy of ``bag`` whose metadata.yaml lists ``names`` as its storage files."""
    copy = tmp_path / "bag"
    shutil.copytree(bag, copy)
    text = (copy / "metadata.yaml").read_text()
    listed = "\n".join(f"    - {name}" for name in names)
    text, count = re.subn(r"relative_file_paths:\n(    - .*\n)+", lambda _: f"relative_file_paths:\n{listed}\n", text)
    assert count == 1
    (copy / "metadata.yaml").write_text(text)
    return copy


def _file(bag: Path) -> str:
    (name,) = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]["relative_file_paths"]
    return str(name)


def test_one_file_listed_100_000_times_is_read_once(bag: Path, tmp_path: Path) -> None:
    name = _file(bag)
    spellings = [name, f"./{name}", f"sub/../{name}", f"../{name}"]
    copy = _listing(bag, tmp_path, [spellings[i % len(spellings)] for i in range(100_000)])
    assert (copy / "metadata.yaml").stat().st_size > 1_000_000
    for argv, codes in [(["info", "bag"], (0,)), (["replay", "--check", "bag"], (0,)), (["check", "bag"], (0,)),
                        (["convert", "bag", "out.mcap"], (0,)), (["diff", "bag", "bag"], (0,)),
                        (["replay", "bag", "--save", "out.rrd"], (0,))]:
        outcome = guarded(argv, tmp_path, codes=codes)
        assert outcome.code == 0, f"{argv}: {outcome.stderr}"
        if argv[0] != "check":  # check reports per recording, in its table
            assert any("100,000 times" in line and "read once" in line for line in warnings_of(outcome)), argv
    info = guarded(["info", "bag", "--json"], tmp_path, isolated=False)
    original = guarded(["info", str(bag), "--json"], tmp_path, isolated=False)
    counted, expected = json.loads(info.stdout), json.loads(original.stdout)
    assert counted["topics"] == expected["topics"]  # each message counted once


def test_two_names_of_one_file_are_read_once(bag: Path, tmp_path: Path) -> None:
    name = _file(bag)
    copy = _listing(bag, tmp_path, [name, "again.mcap"])
    os.link(copy / name, copy / "again.mcap")
    outcome = guarded(["info", "bag"], tmp_path, isolated=False)
    assert any("2 times" in line for line in warnings_of(outcome))
    assert "/joint_states" in outcome.stdout and " 21 msgs" in outcome.stdout


def test_a_name_outside_the_folder_stays_inside(bag: Path, tmp_path: Path) -> None:
    name = _file(bag)
    (tmp_path / "elsewhere").mkdir()
    shutil.copy(bag / name, tmp_path / "elsewhere" / name)
    copy = _listing(bag, tmp_path, [f"../elsewhere/{name}", "/etc/passwd"])
    outcome = guarded(["info", "bag"], tmp_path, isolated=False)
    # ../elsewhere/x.mcap is the folder's own x.mcap; /etc/passwd is a 'passwd' the folder does not have
    assert outcome.code == 2 and "lists passwd, which is missing" in outcome.stderr
    assert "root:" not in outcome.stderr and copy.is_dir()


def test_the_list_is_bounded(bag: Path, tmp_path: Path) -> None:
    _listing(bag, tmp_path, [f"bag_{i}.mcap" for i in range(MAX_STORAGE_FILES + 1)])
    outcome = guarded(["info", "bag"], tmp_path)
    assert outcome.code == 2 and f"at most {MAX_STORAGE_FILES:,}" in outcome.stderr
