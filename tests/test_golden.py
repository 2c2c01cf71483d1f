"""Log-diff regression tests: record again with the arguments that made tests/golden/*.mcap and
compare by meaning. A change in FK, trajectories or encoding fails here with diff's readable
report; a different library version in a file header does not (the header is not compared).

To accept an intended change, re-run the commands in tests/golden/README.md and commit the files.
"""

from __future__ import annotations

import os
import shlex
import struct
from pathlib import Path

import pytest

from tfrec import cli
from tfrec.diff.asserts import assert_recordings_match
from tfrec.diff.compare import FLOAT32_TOL
from tfrec.formats.reader import read_recording

from .conftest import REPO

GOLDEN = Path(__file__).parent / "golden"

# file name → the `tfrec record` arguments that made it (run from the repository root)
COMMANDS = {
    "mbot-sine-2s.mcap": "record robots/mbot.xacro --traj sine --duration 2 --rate 50",
    "marm-random-2s.mcap": "record robots/marm.xacro --traj random --duration 2 --rate 50 --seed 7",
}
TOLERANCE = {"pos_tol": 1e-9, "rot_tol": 1e-9, "joint_tol": 1e-9}


def _record(tmp_path: Path, name: str, *extra: str) -> int:
    """The golden's command, run from the repository root as the README says (the recipe inside the recording keeps
    the description's path as given)."""
    argv = shlex.split(COMMANDS[name])
    here = os.getcwd()
    os.chdir(REPO)
    try:
        return cli.main([*argv, *extra])
    finally:
        os.chdir(here)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_record_again_matches_golden(tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]) -> None:
    fresh = tmp_path / name
    assert _record(tmp_path, name, "-o", str(fresh), "--rrd", str(fresh.with_suffix(".rrd"))) == 0
    capsys.readouterr()
    report = assert_recordings_match(GOLDEN / name, fresh, **TOLERANCE)
    assert report.a.topics == report.b.topics
    # the .rrd of the same command matches too, at float32 tolerance
    assert_recordings_match(GOLDEN / name, fresh.with_suffix(".rrd"), pos_tol=FLOAT32_TOL, rot_tol=FLOAT32_TOL,
                            joint_tol=TOLERANCE["joint_tol"])


GOLDEN_ZSTD = (1, 5, 7)
"""The libzstd version that compressed the goldens' chunks (the one python-zstandard 0.25 bundles). Another version
may compress the same records to other bytes: there the fresh file is compared record by record, uncompressed."""


def _records(path: Path) -> list[object]:
    """Every record of an MCAP, each chunk's records uncompressed, but for those that only say where compressed
    bytes lie (chunk, metadata and attachment indexes, the footer, summary offsets, the data section's CRC)."""
    from mcap.records import AttachmentIndex, ChunkIndex, DataEnd, Footer, MetadataIndex, SummaryOffset
    from mcap.stream_reader import StreamReader

    with open(path, "rb") as stream:
        return [record for record in StreamReader(stream, emit_chunks=False).records
                if not isinstance(record, (AttachmentIndex, ChunkIndex, DataEnd, Footer, MetadataIndex, SummaryOffset))]


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_record_again_is_the_golden_byte_for_byte(tmp_path: Path, name: str, monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """`cmp golden.mcap fresh.mcap`: the same command under another name and folder gives the golden's bytes
    (the header's library string, which names tfrec's version, taken from the golden) — with the libzstd that
    made the golden; with another, the same records once uncompressed (docs/recording-format.md)."""
    import zstandard
    from mcap.reader import make_reader

    from tfrec.formats.mcap import writer

    with open(GOLDEN / name, "rb") as stream:
        library = make_reader(stream).get_header().library
    monkeypatch.setattr(writer, "LIBRARY", library)
    fresh = tmp_path / "elsewhere" / "fresh.mcap"
    fresh.parent.mkdir()
    assert _record(tmp_path, name, "-o", str(fresh), "--no-rrd") == 0
    capsys.readouterr()
    assert _records(fresh) == _records(GOLDEN / name)
    if tuple(zstandard.ZSTD_VERSION) == GOLDEN_ZSTD:
        assert fresh.read_bytes() == (GOLDEN / name).read_bytes()


def test_header_is_not_compared(tmp_path: Path) -> None:
    """Rewrite the MCAP header's library string (same length): still identical by meaning."""
    golden = GOLDEN / "marm-random-2s.mcap"
    data = bytearray(golden.read_bytes())
    profile_len = struct.unpack_from("<I", data, 8 + 9)[0]
    at = 8 + 9 + 4 + profile_len
    library_len = struct.unpack_from("<I", data, at)[0]
    data[at + 4 : at + 4 + library_len] = b"x" * library_len
    other = tmp_path / "other.mcap"
    other.write_bytes(bytes(data))
    assert other.read_bytes() != golden.read_bytes()
    assert_recordings_match(golden, other, **TOLERANCE)


def test_goldens_are_small_and_documented() -> None:
    readme = (GOLDEN / "README.md").read_text()
    assert sorted(p.name for p in GOLDEN.glob("*.mcap")) == sorted(COMMANDS)
    for name, command in COMMANDS.items():
        assert f"tfrec {command} -o tests/golden/{name} --no-rrd" in readme
        assert (GOLDEN / name).stat().st_size < 200_000
        rec = read_recording(GOLDEN / name)
        assert rec.read_error is None and rec.duration_ns == 2_000_000_000


def test_a_regression_shows_as_a_readable_failure(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """What a regression looks like here: frame ids that changed (a frame prefix, as if by mistake)."""
    fresh = tmp_path / "fresh.mcap"
    assert _record(tmp_path, "marm-random-2s.mcap", "--frame-prefix", "arm/", "-o", str(fresh), "--no-rrd") == 0
    capsys.readouterr()
    with pytest.raises(AssertionError) as info:
        assert_recordings_match(GOLDEN / "marm-random-2s.mcap", fresh, **TOLERANCE)
    text = str(info.value)
    assert text.splitlines()[0] == "recordings differ: 18 differences"
    assert "link0 → link1 only in A (/tf)" in text and "arm/link0 → arm/link1 only in B (/tf)" in text
