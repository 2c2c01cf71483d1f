"""Fleet reports: Parquet and JSON lines, read back by pandas and DuckDB without tfrec."""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from tests.fleet.helpers import EXPECTED
from tfrec import __version__
from tfrec.errors import TfrecError
from tfrec.fleet import Row, check_tasks, find_recordings, run
from tfrec.fleet.report import REPORT_COLUMNS, ReportError, ReportWriter, is_report, read_report, report_problem

_DUCKDB_TYPES = {"string": "VARCHAR", "int64": "BIGINT", "float64": "DOUBLE"}
_PANDAS_KINDS = {"string": "O", "int64": "if", "float64": "f"}  # an int64 column with nulls reads as float


def _query(sql: str) -> list[tuple[Any, ...]]:
    duckdb = pytest.importorskip("duckdb")
    relation = duckdb.sql(sql)
    assert relation is not None
    rows: list[tuple[Any, ...]] = relation.fetchall()
    return rows


@pytest.fixture(scope="module")
def fleet_rows(fleet_dir: Path) -> list[Row]:
    rows: list[Row] = []
    run(check_tasks(find_recordings([fleet_dir])), jobs=2, on_result=lambda result, _: rows.extend(result))
    return rows


@pytest.mark.parametrize("suffix", [".parquet", ".jsonl"])
def test_a_report_round_trips_through_pandas_and_duckdb(tmp_path: Path, fleet_rows: list[Row], suffix: str) -> None:
    pd = pytest.importorskip("pandas")
    pytest.importorskip("duckdb")

    path = tmp_path / f"fleet{suffix}"
    with ReportWriter(path, row_group_rows=5) as writer:
        for row in fleet_rows:
            writer.write([row.to_dict()])
    assert writer.rows_written == len(fleet_rows)
    names = [c.name for c in REPORT_COLUMNS]

    back = read_report(path)
    assert back == [row.to_dict() for row in fleet_rows]

    frame = pd.read_parquet(path) if suffix == ".parquet" else pd.read_json(path, lines=True, dtype=False)
    assert list(frame.columns) == names and len(frame) == len(fleet_rows)
    for column in REPORT_COLUMNS:
        if frame[column.name].notna().any():
            assert frame[column.name].dtype.kind in _PANDAS_KINDS[column.type], column.name

    source = f"'{path}'" if suffix == ".parquet" else f"read_json('{path}', format='newline_delimited')"
    described = _query(f"DESCRIBE SELECT * FROM {source}")
    assert [d[0] for d in described] == names
    if suffix == ".parquet":
        assert [d[1] for d in described] == [_DUCKDB_TYPES[c.type] for c in REPORT_COLUMNS]
    verdicts = dict(_query(f"SELECT file, verdict FROM {source} WHERE \"check\" = 'summary'"))
    assert {Path(f).relative_to(Path(fleet_rows[0].file).parents[1]).as_posix(): v for f, v in verdicts.items()} == {
        name: verdict for name, (verdict, _) in EXPECTED.items()}
    (mismatch,) = _query(f"SELECT frame, unit, max_error, first_exceed_s FROM {source} WHERE \"check\" = 'resim'")
    assert mismatch[:2] == ("link2", "m") and mismatch[2] == pytest.approx(0.01) and mismatch[3] == 0.0


def test_non_finite_errors(tmp_path: Path) -> None:
    rows = [Row(file="a", max_error=math.inf, verdict="fail").to_dict()]
    with ReportWriter(tmp_path / "r.jsonl") as writer:
        writer.write(rows)
    with ReportWriter(tmp_path / "r.parquet") as writer:
        writer.write(rows)
    assert json.loads((tmp_path / "r.jsonl").read_text())["max_error"] is None
    assert read_report(tmp_path / "r.parquet")[0]["max_error"] == math.inf


def test_the_report_appears_at_close_and_keeps_what_finished(tmp_path: Path) -> None:
    path = tmp_path / "r.parquet"
    with ReportWriter(path) as writer:
        writer.write([Row(file="old").to_dict()])
    old = path.read_bytes()
    writer = ReportWriter(path, force=True)
    writer.write([Row(file="a").to_dict()])
    assert path.read_bytes() == old and len(list(tmp_path.iterdir())) == 2
    writer.close()
    assert [r["file"] for r in read_report(path)] == ["a"] and len(list(tmp_path.iterdir())) == 1
    for stop in (KeyboardInterrupt, TfrecError):
        with pytest.raises(stop), ReportWriter(path, force=True) as writer:
            writer.write([Row(file="b").to_dict()])
            raise stop()
        assert [r["file"] for r in read_report(path)] == ["b"]


def test_a_bug_leaves_the_old_report(tmp_path: Path) -> None:
    path = tmp_path / "r.jsonl"
    with ReportWriter(path) as writer:
        writer.write([Row(file="old").to_dict()])
    with pytest.raises(ZeroDivisionError), ReportWriter(path, force=True) as writer:
        writer.write([Row(file="new").to_dict()])
        raise ZeroDivisionError("a bug")
    assert [r["file"] for r in read_report(path)] == ["old"] and len(list(tmp_path.iterdir())) == 1


def test_report_errors(tmp_path: Path) -> None:
    with pytest.raises(ReportError, match=r"r\.csv: a report's name must end in \.parquet or \.jsonl$"):
        ReportWriter(tmp_path / "r.csv")
    assert read_report(tmp_path / "none.jsonl", missing_ok=True) == []
    with pytest.raises(ReportError, match=r"none\.jsonl: cannot read: No such file or directory$"):
        read_report(tmp_path / "none.jsonl")
    (tmp_path / "bad.jsonl").write_text('{"file": "a", "check": "summary", "verdict": "pass"}\n{"file": \n')
    with pytest.raises(ReportError, match=r"bad\.jsonl: not a tfrec report: line 2 is not JSON \(Expecting value\)$"):
        read_report(tmp_path / "bad.jsonl")
    (tmp_path / "other.jsonl").write_text('{"name": "a"}\n')
    with pytest.raises(ReportError, match=r"other\.jsonl: not a tfrec report: row 1: no check, file, verdict$"):
        read_report(tmp_path / "other.jsonl")
    (tmp_path / "bad.parquet").write_text("not parquet")
    with pytest.raises(ReportError, match=r"bad\.parquet: not a tfrec report: not a Parquet file \("):
        read_report(tmp_path / "bad.parquet")


# -- what is a tfrec report: foreign and damaged files ----------------------------------------------

_GOOD = {"file": "a.mcap", "check": "summary", "verdict": "pass", "size": 10, "max_error": 0.5, "detail": "ok"}


def _parquet(path: Path, columns: dict[str, Any], metadata: dict[bytes, bytes] | None = None) -> Path:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table(columns)
    pq.write_table(table.replace_schema_metadata(metadata) if metadata else table, path)
    return path


def _real_parquet(path: Path) -> Path:
    with ReportWriter(path) as writer:
        writer.write([_GOOD, {**_GOOD, "file": "b.mcap", "verdict": "fail"}])
    return path


def _cut_short(path: Path) -> Path:
    path.write_bytes(path.read_bytes()[:-100])
    return path


FOREIGN_PARQUET: dict[str, tuple[Callable[[Path], Path], str]] = {
    "other columns": (lambda p: _parquet(p, {"name": ["a"], "value": [1.0]}),
                      "it has no check, file, verdict column"),
    "a report's names with other types": (
        lambda p: _parquet(p, {"file": ["a"], "check": ["summary"], "verdict": ["pass"], "size": [1.5]}),
        "its column size is double, not int64"),
    "verdicts as numbers": (lambda p: _parquet(p, {"file": ["a"], "check": ["summary"], "verdict": [1]}),
                            "its column verdict is int64, not string"),
    "a column more": (lambda p: _parquet(p, {"file": ["a"], "check": ["summary"], "verdict": ["pass"], "x": [1]}),
                      r"it has columns a tfrec report has not \(x\)"),
    "another report format": (
        lambda p: _parquet(p, {"file": ["a"], "check": ["summary"], "verdict": ["pass"]},
                           {b"tfrec.report": b"7", b"tfrec.version": b"9.0.0"}),
        r"a report of format '7' \(written by tfrec 9\.0\.0\); this tfrec reads format 1"),
    "cut short": (lambda p: _cut_short(_real_parquet(p)), "not a Parquet file"),
    "a verdict that is none": (lambda p: _parquet(p, {"file": ["a"], "check": ["summary"], "verdict": ["maybe"]}),
                               r"row 1: verdict is \"maybe\""),
    "a null file": (lambda p: _parquet(p, {"file": [None, "b"], "check": ["summary"] * 2, "verdict": ["pass"] * 2}),
                    "row 1: file is null"),
    "millions of rows in a few bytes": (
        lambda p: _parquet(p, {"file": ["a"] * 3_000_000, "check": ["summary"] * 3_000_000,
                               "verdict": ["pass"] * 3_000_000}), r"claim 3,000,000 rows"),
}

FOREIGN_JSONL: dict[str, tuple[str, str]] = {
    "other keys": ('{"name": "a", "value": 1}\n', "row 1: no check, file, verdict"),
    "a key more": (json.dumps({**_GOOD, "extra": 1}) + "\n", r"row 1: a column a tfrec report has not \(extra\)"),
    "a size as text": (json.dumps({**_GOOD, "size": "10 bytes"}) + "\n", r'row 1: size is "10 bytes"'),
    "a size of true": (json.dumps({**_GOOD, "size": True}) + "\n", "row 1: size is true"),
    "an error as a list": (json.dumps({**_GOOD, "max_error": [1]}) + "\n", r"row 1: max_error is \[1\]"),
    "a file as a number": (json.dumps({**_GOOD, "file": 3}) + "\n", "row 1: file is 3"),
    "a line that is a list": ("[1, 2]\n", "line 1 is not a JSON object"),
    "a second row of another kind": (json.dumps(_GOOD) + '\n{"a": 1}\n', "row 2: no check, file, verdict"),
    "nested a million deep": ("[" * 1_000_000 + "]" * 1_000_000 + "\n", "line 1 is JSON nested too deeply"),
    "not UTF-8": ('{"file": "\xff"}\n'.encode("latin-1").decode("latin-1"), "line 1 is not UTF-8 text"),
}


@pytest.mark.parametrize("case", sorted(FOREIGN_PARQUET))
def test_a_parquet_file_that_is_no_tfrec_report(case: str, tmp_path: Path) -> None:
    make, why = FOREIGN_PARQUET[case]
    path = make(tmp_path / "r.parquet")
    with pytest.raises(ReportError, match=rf"^{tmp_path / 'r.parquet'}: not a tfrec report: .*{why}"):
        read_report(path)
    if "row 1" not in why:  # the schema tells: without reading the rows
        assert re.search(why, report_problem(path) or "")
        assert not is_report(path)


@pytest.mark.parametrize("case", sorted(FOREIGN_JSONL))
def test_json_lines_that_are_no_tfrec_report(case: str, tmp_path: Path) -> None:
    text, why = FOREIGN_JSONL[case]
    path = tmp_path / "r.jsonl"
    path.write_bytes(text.encode("latin-1") if case == "not UTF-8" else text.encode())
    with pytest.raises(ReportError, match=rf"^{tmp_path / 'r.jsonl'}: not a tfrec report: {why}"):
        read_report(path)
    if "row 2" not in why:  # the first row tells
        assert not is_report(path)


def test_what_is_a_report(tmp_path: Path) -> None:
    assert is_report(_real_parquet(tmp_path / "r.parquet")) and report_problem(tmp_path / "r.parquet") is None
    import pyarrow.parquet as pq

    assert pq.read_schema(tmp_path / "r.parquet").metadata == {b"tfrec.report": b"1", b"tfrec.version": __version__.encode()}
    older = _parquet(tmp_path / "older.parquet", {"file": ["a"], "check": ["summary"], "verdict": ["pass"]})
    assert is_report(older)  # written before reports said their format: its columns tell
    (tmp_path / "empty.jsonl").write_text("")
    assert is_report(tmp_path / "empty.jsonl") and read_report(tmp_path / "empty.jsonl") == []  # stopped before a row
    (tmp_path / "folder.jsonl").mkdir()
    assert report_problem(tmp_path / "folder.jsonl") == "a folder"
    os.mkfifo(tmp_path / "fifo.jsonl")  # reading it would wait for ever
    assert report_problem(tmp_path / "fifo.jsonl") == "not a regular file (a FIFO, device or socket)"
    with pytest.raises(ReportError, match="fifo.jsonl: not a tfrec report: not a regular file"):
        read_report(tmp_path / "fifo.jsonl")
    assert not is_report(tmp_path / "none.jsonl")
