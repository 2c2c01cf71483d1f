"""Issue 21, part 3: deterministic means comparable. The same command written under two names, in two
folders, gives the same bytes — an MCAP (alone or in a rosbag2 folder), a ROS 1 bag, every convert output —
and ``.rrd`` files Rerun's own ``rerun rrd compare`` finds equal (Rerun's row ids are time-based, so its
bytes differ from run to run whatever the name). A rosbag2 folder's metadata.yaml names its file, as
rosbag2 needs; nothing else does."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.conftest import ROBOTS
from tfrec.cli import main

MARM = str(ROBOTS / "marm.xacro")
RECORD = ["record", MARM, "--traj", "random", "--duration", "1", "--seed", "5"]


def _twice(tmp_path: Path, capsys: pytest.CaptureFixture[str], make: list[str], first: str, second: str) -> tuple[Path, Path]:
    """Run ``make`` + the output twice: ``one/<first>`` and ``elsewhere/deeper/<second>``."""
    a, b = tmp_path / "one" / first, tmp_path / "elsewhere" / "deeper" / second
    for target in (a, b):
        target.parent.mkdir(parents=True, exist_ok=True)
        argv = [arg for arg in make if arg != "--bag"]
        if "--bag" in make:
            argv += ["--bag", str(target)]
        elif make[0] == "convert":
            argv.insert(2, str(target))  # convert IN OUT
        else:
            argv += ["-o", str(target)]
        assert main(argv) == 0
    capsys.readouterr()
    return a, b


def test_an_mcap_does_not_depend_on_its_name(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a, b = _twice(tmp_path, capsys, [*RECORD, "--no-rrd"], "golden.mcap", "fresh.mcap")
    assert a.read_bytes() == b.read_bytes()
    assert b"golden" not in a.read_bytes()


def test_a_ros1_bag_does_not_depend_on_its_name(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a, b = _twice(tmp_path, capsys, [*RECORD, "--no-rrd"], "golden.bag", "fresh.bag")
    assert a.read_bytes() == b.read_bytes()


def test_a_rosbag2_folder_names_its_file_in_metadata_yaml_only(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """rosbag2's convention: DIR/DIR_0.mcap, named in DIR/metadata.yaml. The MCAP inside is the same bytes
    whatever DIR is — and the same as the standalone MCAP of the same command."""
    from rosbags.rosbag2 import Reader

    a, b = _twice(tmp_path, capsys, [*RECORD, "--no-rrd", "--bag"], "golden", "fresh")
    assert (a / "golden_0.mcap").read_bytes() == (b / "fresh_0.mcap").read_bytes()
    meta_a = yaml.safe_load((a / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    meta_b = yaml.safe_load((b / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta_a["relative_file_paths"] == ["golden_0.mcap"] and meta_a["files"][0]["path"] == "golden_0.mcap"
    assert {**meta_a, "relative_file_paths": [], "files": []} == {**meta_b, "relative_file_paths": [], "files": []}
    alone = tmp_path / "alone.mcap"
    assert main([*RECORD, "--no-rrd", "-o", str(alone)]) == 0
    assert alone.read_bytes() == (a / "golden_0.mcap").read_bytes()
    with Reader(a) as reader:  # rosbags reads the folder through its metadata.yaml
        assert reader.message_count == 2 + 2 * 51


@pytest.mark.parametrize("target", ["c.mcap", "c.bag", "c"])
def test_convert_outputs_do_not_depend_on_their_names(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                      target: str) -> None:
    source = tmp_path / "source.bag"
    assert main([*RECORD, "--no-rrd", "-o", str(source)]) == 0
    folder = target == "c"
    make = ["convert", str(source), "--start", "0.2"] + (["--bag"] if folder else [])
    suffix = Path(target).suffix
    a, b = _twice(tmp_path, capsys, make, "golden" + suffix, "fresh" + suffix)
    if folder:
        a, b = a / "golden_0.mcap", b / "fresh_0.mcap"
    assert a.read_bytes() == b.read_bytes()


def _rerun() -> str:
    rerun = Path(sys.executable).parent / "rerun"
    if not rerun.exists():
        pytest.skip("the rerun command is not installed beside this Python")
    return str(rerun)


@pytest.mark.parametrize("how", ["record", "replay", "convert"])
def test_rrd_files_of_two_names_compare_equal(tmp_path: Path, capsys: pytest.CaptureFixture[str], how: str) -> None:
    """Rerun's own comparison (its row ids are time-based: not the bytes) finds the .rrd of the same
    command under two names equal — and finds a changed recording different, so the check can fail."""
    rerun = _rerun()
    source = tmp_path / "source.mcap"
    if how == "record":
        a, b = tmp_path / "one" / "golden.rrd", tmp_path / "two" / "fresh.rrd"
        for target in (a, b):
            assert main([*RECORD, "--no-mcap", "--rrd", str(target)]) == 0
    else:
        assert main([*RECORD, "--no-rrd", "-o", str(source)]) == 0
        a, b = tmp_path / "one" / "golden.rrd", tmp_path / "two" / "fresh.rrd"
        for target in (a, b):
            target.parent.mkdir(parents=True, exist_ok=True)
            argv = ["replay", str(source), "--save", str(target)] if how == "replay" else ["convert", str(source), str(target)]
            assert main(argv) == 0
    capsys.readouterr()
    same = subprocess.run([rerun, "rrd", "compare", str(a), str(b)], capture_output=True, check=False)
    assert same.returncode == 0, same.stderr.decode(errors="replace")
    other = tmp_path / "other.rrd"
    assert main(["record", MARM, "--traj", "random", "--duration", "1", "--seed", "6", "--no-mcap", "--rrd",
                 str(other)]) == 0
    differs = subprocess.run([rerun, "rrd", "compare", str(a), str(other)], capture_output=True, check=False)
    assert differs.returncode != 0
