"""Fleet reports: one row per recording and per finding, as Parquet or JSON lines.

The columns (:data:`REPORT_COLUMNS`) have fixed names and types, so that a report is read
without tfrec — ``duckdb.sql("SELECT file, frame, max_error FROM 'report.parquet' WHERE verdict
= 'fail'")``, ``pandas.read_parquet``, ``polars.read_ndjson``. Every column may be null except
``file``, ``check`` and ``verdict``.

:class:`ReportWriter` writes rows as they arrive to a temporary file beside the report — Parquet
in row groups of :data:`ROW_GROUP_ROWS` rows, JSON lines flushed at every :meth:`~ReportWriter.write`
— and renames it to the report when closed: on success, and on Ctrl-C or a
:class:`~tfrec.errors.TfrecError`, so that the report keeps what finished. A bug deletes it. In
JSON lines a float that is not finite (an infinite error: NaN in the data) is written as null.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Literal, final

from tfrec._atomic import AtomicOutputs
from tfrec._outputs import FileKind, check_target
from tfrec.errors import ReadError, RecordingError, TfrecError, WriteError

__all__ = [
    "REPORT_COLUMNS",
    "REPORT_FORMATS",
    "ROW_GROUP_ROWS",
    "Column",
    "ReportError",
    "ReportWriter",
    "read_report",
    "report_format",
    "report_kind",
]

ColumnType = Literal["string", "int64", "float64"]


@dataclass(frozen=True, slots=True)
class Column:
    """One column of a report: its name, type (``string``, ``int64``, ``float64``) and meaning."""

    name: str
    type: ColumnType
    doc: str


REPORT_COLUMNS: tuple[Column, ...] = (
    Column("file", "string", "the recording as found, or the relative path of a pair"),
    Column("robot", "string", "the robot's name, '' when unknown"),
    Column("check", "string", "'summary' (one per recording: its verdict), or what found the finding: read, "
                              "description, resim, frames, stamps, rate; for pairs: missing, description, topic, "
                              "joint_states, tf, tf_static, frame"),
    Column("topic", "string", "the topic concerned, or ''"),
    Column("frame", "string", "the frame (or joint, or 'parent → child') concerned, or ''"),
    Column("max_error", "float64", "the largest error, in unit"),
    Column("unit", "string", "m, rad, s, stamps, joint (rad or m), or ''"),
    Column("first_exceed_s", "float64", "seconds since the recording's start when the finding starts"),
    Column("verdict", "string", "pass, fail or error"),
    Column("detail", "string", "one readable line"),
    Column("size", "int64", "the recording's bytes (a pair: both sides')"),
    Column("mtime_ns", "int64", "its modification time, ns since the epoch (a pair: the later)"),
    Column("fingerprint", "string", "size:mtime_ns:digest of its summary section (a pair: both, '|'-joined)"),
    Column("config", "string", "digest of the options it was checked with"),
    Column("elapsed_s", "float64", "wall time of its task (summary rows)"),
    Column("cpu_s", "float64", "CPU time of its task (elapsed_s - cpu_s: waiting for the disk or a core)"),
    Column("read_s", "float64", "the part of elapsed_s spent reading and decoding"),
    Column("peak_rss_bytes", "int64", "the worker's peak resident memory so far"),
    Column("worker", "string", "host:pid of the worker that ran it"),
)
"""The columns of a report, in order."""

REPORT_FORMATS = (".parquet", ".jsonl")
"""The report formats, by extension."""

ROW_GROUP_ROWS = 4096
"""Rows per Parquet row group (rows are buffered until then, or until the report is closed)."""

_REQUIRED = frozenset({"file", "check", "verdict"})


ReportError = RecordingError
"""A report that cannot be written (:class:`~tfrec.errors.WriteError`) or read (:class:`~tfrec.errors.ReadError`)."""


def report_format(path: str | os.PathLike[str]) -> str:
    """``.parquet`` or ``.jsonl``, from the report's name.

    Raises:
        ReportError: another extension.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in REPORT_FORMATS:
        raise WriteError(f"{os.fspath(path)}: a report's name must end in .parquet or .jsonl")
    return suffix


def _parquet_report(path: Path, head: bytes) -> str | None:
    """Why a Parquet file is not a tfrec report (its schema lacks the required columns), or None."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        names = set(pq.read_schema(path).names)
    except (pa.ArrowException, ValueError, OSError):
        return "it is not a readable Parquet file"
    return None if _REQUIRED <= names else "it has no file, check and verdict columns"


_FIRST_ROW_BYTES = 1 << 20
"""The most read of an existing JSON-lines report's first row to recognize it (a row is a few hundred bytes)."""


def _jsonl_report(path: Path, head: bytes) -> str | None:
    """Why a file is not a JSON-lines tfrec report (its first row lacks the required keys), or None."""
    try:
        with open(path, "rb") as stream:
            start = stream.read(_FIRST_ROW_BYTES)
        line = next((line for line in start.splitlines() if line.strip()), b"")
    except OSError as err:
        return f"it cannot be read: {err.strerror or err}"
    try:
        row = json.loads(line)
    except (ValueError, UnicodeDecodeError):
        return "its first line is not JSON"
    return None if isinstance(row, dict) and _REQUIRED <= row.keys() else "its first line is not a row of a tfrec report"


PARQUET_REPORT = FileKind("a tfrec report", (b"PAR1",), test=_parquet_report)
JSONL_REPORT = FileKind("a tfrec report", empty=True, test=_jsonl_report)
"""An empty file is a JSON-lines report too: the report of a run stopped before its first row."""


def report_kind(path: str | os.PathLike[str]) -> FileKind:
    """The kind of the report ``path`` (:class:`tfrec._outputs.OutputKind`: how an existing one is recognized).

    Raises:
        ReportError: a name that ends in neither .parquet nor .jsonl.
    """
    return PARQUET_REPORT if report_format(path) == ".parquet" else JSONL_REPORT


def _arrow_schema(columns: tuple[Column, ...]) -> Any:
    import pyarrow as pa

    types = {"string": pa.string(), "int64": pa.int64(), "float64": pa.float64()}
    return pa.schema([pa.field(c.name, types[c.type], nullable=c.name not in _REQUIRED) for c in columns])


def _json_value(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _utf8(value: Any) -> Any:
    """A value for Parquet, whose strings are UTF-8: the bytes of a file name that are not UTF-8 (lone surrogates in
    Python) are written as their escapes (``\\udcff``), as JSON lines write them; everything else as it is."""
    if isinstance(value, str) and not value.isprintable():
        return value.encode("utf-8", "backslashreplace").decode("utf-8")
    return value


@final
class ReportWriter:
    """Writes a report row by row; the report appears, complete, when it is closed.

    Use it as a context manager (or call :meth:`close`, or :meth:`abort`)::

        with ReportWriter("fleet.parquet") as report:
            report.write(row.to_dict() for row in rows)
    """

    def __init__(self, path: str | os.PathLike[str], *, columns: tuple[Column, ...] = REPORT_COLUMNS,
                 row_group_rows: int = ROW_GROUP_ROWS, force: bool = False) -> None:
        """Start a report at ``path`` (``.parquet`` or ``.jsonl``); with ``force`` an existing report is replaced
        at close (``--resume`` passes it: it read that report first), a file that is not a report never.

        Raises:
            ReportError: another extension, an existing report without ``force``, an existing file that is no
                tfrec report, or the temporary file cannot be created.
        """
        self.path = Path(path)
        self.format = report_format(path)
        kind = report_kind(path)
        check_target(self.path, kind, force=force)
        self.columns = columns
        self.names = tuple(c.name for c in columns)
        self.rows_written = 0
        self._group = max(1, row_group_rows)
        self._buffer: list[dict[str, Any]] = []
        self._outputs = AtomicOutputs(replace=force)
        self._text: IO[str] | None = None
        self._parquet: Any = None
        try:
            self._temp = self._outputs.path(self.path, kind=kind)
            if self.format == ".jsonl":
                # a file name with bytes that are not UTF-8 (a lone surrogate in Python) is written as its JSON
                # escape, "\\udcff", which JSON readers decode back to the same name
                self._text = open(self._temp, "w", encoding="utf-8", errors="backslashreplace")  # noqa: SIM115
            else:
                import pyarrow.parquet as pq

                self._schema = _arrow_schema(columns)
                self._parquet = pq.ParquetWriter(self._temp, self._schema)
        except OSError as err:
            self._outputs.abort()
            raise WriteError(f"{self.path}: cannot write: {err.strerror or err}") from None

    def write(self, rows: Iterable[Mapping[str, Any]]) -> None:
        """Add rows (column name → value; a missing column is null).

        Raises:
            ReportError: the file cannot be written (disk full…).
        """
        records = [{name: row.get(name) for name in self.names} for row in rows]
        if not records:
            return
        self.rows_written += len(records)
        try:
            if self._text is not None:
                self._text.writelines(json.dumps({k: _json_value(v) for k, v in record.items()}, ensure_ascii=False,
                                                 allow_nan=False) + "\n" for record in records)
                self._text.flush()
            else:
                self._buffer.extend(records)
                if len(self._buffer) >= self._group:
                    self._flush()
        except OSError as err:
            raise WriteError(f"{self.path}: cannot write: {err.strerror or err}") from None

    def _flush(self) -> None:
        if self._buffer and self._parquet is not None:
            import pyarrow as pa

            self._parquet.write_table(pa.Table.from_pylist([{k: _utf8(v) for k, v in row.items()} for row in self._buffer],
                                                           schema=self._schema))
            self._buffer = []

    def close(self) -> None:
        """Finish the file and rename it to the report.

        Raises:
            ReportError: it cannot be written or renamed.
        """
        try:
            self._flush()
            self._finish()
            self._outputs.commit()
        except OSError as err:
            self.abort()
            raise WriteError(f"{self.path}: cannot write: {err.strerror or err}") from None

    def _finish(self) -> None:
        if self._text is not None:
            self._text.close()
            self._text = None
        if self._parquet is not None:
            self._parquet.close()
            self._parquet = None

    def abort(self) -> None:
        """Delete the temporary file; an existing report is left as it was."""
        try:
            self._finish()
        except OSError:
            pass
        self._outputs.abort()

    def __enter__(self) -> ReportWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        if error is None or isinstance(error, (KeyboardInterrupt, TfrecError)):
            self.close()  # Ctrl-C, or a run stopped by an error: the report keeps what finished
        else:
            self.abort()


def read_report(path: str | os.PathLike[str], *, missing_ok: bool = False) -> list[dict[str, Any]]:
    """The rows of a report (``.parquet`` or ``.jsonl``), each a dict of :data:`REPORT_COLUMNS`
    (a column the file lacks is None; columns it has besides are kept).

    Args:
        path: the report.
        missing_ok: a report that does not exist has no rows (``--resume`` on a first run).

    Raises:
        ReportError: another extension, a file that cannot be read, or one that is not a report.
    """
    fmt = report_format(path)
    file = Path(path)
    if missing_ok and not file.exists():
        return []
    names = [c.name for c in REPORT_COLUMNS]
    try:
        if fmt == ".parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            try:
                records: list[dict[str, Any]] = pq.read_table(file).to_pylist()
            except (pa.ArrowException, ValueError) as err:
                raise ReadError(f"{file}: not a Parquet report: {' '.join(str(err).split())}") from None
        else:
            records = []
            with open(file, encoding="utf-8") as stream:
                for number, line in enumerate(stream, 1):
                    if not line.strip():
                        continue
                    try:
                        record = json.loads(line)
                    except json.JSONDecodeError as err:
                        raise ReadError(f"{file}:{number}: not a JSON object: {err.msg}") from None
                    if not isinstance(record, dict):
                        raise ReadError(f"{file}:{number}: not a JSON object")
                    records.append(record)
    except OSError as err:
        raise ReadError(f"{file}: cannot read: {err.strerror or err}") from None
    except UnicodeDecodeError as err:
        raise ReadError(f"{file}: not UTF-8 text (byte {err.start:,})") from None
    for number, record in enumerate(records, 1):
        if not _REQUIRED <= record.keys():
            missing = ", ".join(sorted(_REQUIRED - record.keys()))
            raise ReadError(f"{file}: row {number} has no {missing} (not a tfrec report?)")
    return [{**{name: record.get(name) for name in names}, **record} for record in records]
