"""Fleet reports: Parquet and JSON lines, read back by pandas and DuckDB without tfrec."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from tests.fleet.helpers import EXPECTED
from tfrec.errors import TfrecError
from tfrec.fleet import Row, check_tasks, find_recordings, run
from tfrec.formats.report import REPORT_COLUMNS, ReportError, ReportWriter, read_report

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
    with pytest.raises(ReportError, match=r"bad\.jsonl:2: not a JSON object: Expecting value$"):
        read_report(tmp_path / "bad.jsonl")
    (tmp_path / "other.jsonl").write_text('{"name": "a"}\n')
    with pytest.raises(ReportError, match=r"other\.jsonl: row 1 has no check, file, verdict \(not a tfrec report\?\)"):
        read_report(tmp_path / "other.jsonl")
    (tmp_path / "bad.parquet").write_text("not parquet")
    with pytest.raises(ReportError, match=r"bad\.parquet: not a Parquet report: "):
        read_report(tmp_path / "bad.parquet")
