"""`tfrec check PATH…` and `tfrec diff DIR_A DIR_B` on the command line: verdicts, exit codes, the report
read back by pandas and DuckDB without tfrec, --resume."""

from __future__ import annotations

import os
import re
import shutil
import time
from pathlib import Path

import pytest

from tests.fleet.helpers import EXPECTED
from tfrec.cli import main

COLUMNS = ["file", "robot", "check", "topic", "frame", "max_error", "unit", "first_exceed_s", "verdict", "detail",
           "size", "mtime_ns", "fingerprint", "config", "elapsed_s", "cpu_s", "read_s", "peak_rss_bytes", "worker"]


def test_check_a_folder_with_a_parquet_report(fleet_dir: Path, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    pandas = pytest.importorskip("pandas")
    duckdb = pytest.importorskip("duckdb")
    report = tmp_path / "night.parquet"
    assert main(["check", str(fleet_dir), "--jobs", "2", "--report", str(report)]) == 1  # findings
    out = capsys.readouterr().out
    assert out.splitlines()[-1].startswith("9 recordings: 3 pass, 4 fail, 2 error in ")
    assert "FAIL " in out and str(fleet_dir / "bad" / "mismatch.mcap") in out
    # a failing recording's line says its first finding (the report has them all)
    [truncated] = [line for line in out.splitlines() if line.startswith(f"FAIL {fleet_dir / 'bad' / 'truncated.mcap'}")]
    assert " — first: read: " in truncated and "reading stopped at byte" in truncated, truncated
    frame = pandas.read_parquet(report)
    assert list(frame.columns) == COLUMNS
    summaries = frame[frame["check"] == "summary"]
    verdicts = {Path(f).relative_to(fleet_dir).as_posix(): v for f, v in zip(summaries["file"], summaries["verdict"])}
    assert verdicts == {name: verdict for name, (verdict, _) in EXPECTED.items()}
    worst = duckdb.sql(f"SELECT frame, max(max_error) AS worst FROM '{report}' WHERE \"check\" = 'resim' "
                       "GROUP BY frame ORDER BY worst DESC").fetchall()
    assert worst[0][0] in {"link2", "link3", "link4", "link5", "link6", "gripper_link"} and worst[0][1] >= 0.0099


def test_resume_skips_what_is_unchanged(fleet_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "fleet"
    shutil.copytree(fleet_dir, folder)
    report = tmp_path / "r.jsonl"
    assert main(["check", str(folder), "--report", str(report)]) == 1
    capsys.readouterr()
    assert main(["check", str(folder), "--report", str(report), "--resume"]) == 1
    assert "(7 unchanged, from the report)" in capsys.readouterr().out  # error rows are checked again
    touched = folder / "marm" / "sine.mcap"
    os.utime(touched, ns=(time.time_ns(), time.time_ns()))
    assert main(["check", str(folder), "--report", str(report), "--resume"]) == 1
    assert "(6 unchanged, from the report)" in capsys.readouterr().out
    assert report.read_text().count('"check": "summary"') == 9


def test_diff_two_folders_pairs_by_relative_path(fleet_dir: Path, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    b = tmp_path / "b"
    shutil.copytree(fleet_dir / "marm", b / "marm")
    shutil.copy(fleet_dir / "marm" / "random.mcap", b / "marm" / "sine.mcap")  # a changed recording
    report = tmp_path / "d.jsonl"
    a = tmp_path / "a"
    shutil.copytree(fleet_dir / "marm", a / "marm")
    shutil.copytree(fleet_dir / "mbot", a / "mbot")  # one-sided: a finding
    assert main(["diff", str(a), str(b), "--report", str(report)]) == 1
    out = capsys.readouterr().out
    assert "3 pairs: 1 pass, 2 fail, 0 error" in out
    assert "only in A" in out and "marm/sine.mcap" in out
    assert main(["diff", str(a / "marm"), str(a / "marm")]) == 0
    assert "2 pairs: 2 pass, 0 fail, 0 error" in capsys.readouterr().out


def test_nothing_to_check_and_ray_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "empty").mkdir()
    assert main(["check", str(tmp_path / "empty")]) == 2
    assert main(["check", str(tmp_path / "nothing*.mcap")]) == 2
    err = capsys.readouterr().err
    assert err.count("tfrec: error: ") == 1 or err.count("\n") <= 2
    assert main(["check", str(tmp_path), "--resume"]) == 2
    assert capsys.readouterr().err == "tfrec: error: --resume needs --report: the report of the run it resumes\n"


@pytest.mark.parametrize("case", ["other columns", "a report's names with other types", "cut short",
                                  "another report format", "a null file"])
def test_resume_refuses_a_parquet_file_that_is_no_report(case: str, fleet_dir: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    from tests.fleet.test_report import FOREIGN_PARQUET

    make, why = FOREIGN_PARQUET[case]
    report = make(tmp_path / "r.parquet")
    before = report.read_bytes()
    assert main(["check", str(fleet_dir / "marm"), "--report", str(report), "--resume"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith(f"tfrec: error: {report}: not a tfrec report: ")
    assert re.search(why, err)
    assert report.read_bytes() == before and os.listdir(tmp_path) == ["r.parquet"]  # never replaced, no temporary


@pytest.mark.parametrize("case", ["other keys", "a size as text", "a second row of another kind", "nested a million deep"])
def test_resume_refuses_json_lines_that_are_no_report(case: str, fleet_dir: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    from tests.fleet.test_report import FOREIGN_JSONL

    text, _ = FOREIGN_JSONL[case]
    report = tmp_path / "r.jsonl"
    report.write_text(text)
    assert main(["check", str(fleet_dir / "marm"), "--report", str(report), "--resume"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"tfrec: error: {report}: not a tfrec report: ")
    assert report.read_text() == text and os.listdir(tmp_path) == ["r.jsonl"]


def test_resume_a_report_of_another_tfrec_version(fleet_dir: Path, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """Same report format, another tfrec: read, and every recording checked again (the config digest holds the
    version)."""
    import pyarrow.parquet as pq

    report = tmp_path / "r.parquet"
    assert main(["check", str(fleet_dir / "marm"), "--report", str(report)]) == 0
    table = pq.read_table(report)
    metadata = {**table.schema.metadata, b"tfrec.version": b"0.0.9"}
    rows = table.to_pylist()
    for row in rows:
        row["config"] = "0123456789abcdef"  # what another version's digest looks like
    import pyarrow as pa

    pq.write_table(pa.Table.from_pylist(rows, schema=table.schema.with_metadata(metadata)), report)
    capsys.readouterr()
    assert main(["check", str(fleet_dir / "marm"), "--report", str(report), "--resume"]) == 0
    assert "2 recordings: 2 pass, 0 fail, 0 error in " in capsys.readouterr().out  # none kept from the old report
    assert pq.read_schema(report).metadata[b"tfrec.version"] != b"0.0.9"


def test_names_reach_the_terminal_escaped(fleet_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A file name found by listing a folder cannot clear the screen, move the cursor or recolour a verdict."""
    evil = "\x1b[2J\x1b[H\x1b[32mPASS\x1b[0m\r\x07\u202e"
    a, b = tmp_path / "a", tmp_path / "b"
    for folder in (a, b):
        (folder / evil).mkdir(parents=True)
        (folder / evil / f"{evil}.mcap").write_bytes(b"\x1b[31m not a recording")
        shutil.copy(fleet_dir / "marm" / "sine.mcap", folder / "sine.mcap")
    (a / f"only{evil}.mcap").write_bytes(b"")
    (a / "linked").symlink_to(f"{a}/{evil}")  # its warning names the link
    assert main(["check", str(a), "--jobs", "1"]) == 1
    assert main(["diff", str(a), str(b), "--jobs", "1"]) == 1
    assert main(["check", str(a / evil / f"{evil}.mcap")]) == 2  # the one line that says nothing could be read
    out, err = capsys.readouterr()
    for text in (out, err):
        assert not {"\x1b", "\r", "\x07", "\u202e"} & set(text), repr(text)
    assert "\\x1b[2J\\x1b[H\\x1b[32mPASS\\x1b[0m\\r\\x07\\u202e" in out
    assert err.count("tfrec: warning: ") == 2 and err.count("tfrec: error: ") == 1
