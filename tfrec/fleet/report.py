"""Fleet reports: one row per recording and per finding, as Parquet or JSON lines.

The columns (:data:`REPORT_COLUMNS`) have fixed names and types, so that a report is read
without tfrec — ``duckdb.sql("SELECT file, frame, max_error FROM 'report.parquet' WHERE verdict
= 'fail'")``, ``pandas.read_parquet``, ``polars.read_ndjson``. Every column may be null except
``file``, ``check`` and ``verdict``. A Parquet report's schema also says what wrote it
(:data:`REPORT_METADATA`: the report format, :data:`REPORT_FORMAT_VERSION`, and tfrec's version).

What is a tfrec report is decided in one place, :func:`report_problem` (why a file is not one, or
None): ``--resume`` reads a report only when it is one (:func:`read_report` checks every row), and
a file that is not one is never replaced.

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
import stat
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Literal, final

from tfrec._atomic import AtomicOutputs
from tfrec._outputs import FileKind, check_target
from tfrec.errors import ReadError, RecordingError, TfrecError, WriteError, one_line

__all__ = [
    "REPORT_COLUMNS",
    "REPORT_FORMATS",
    "REPORT_FORMAT_VERSION",
    "REPORT_METADATA",
    "ROW_GROUP_ROWS",
    "Column",
    "ReportError",
    "ReportWriter",
    "check_report",
    "is_report",
    "read_report",
    "report_format",
    "report_kind",
    "report_problem",
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

_VERDICTS = frozenset({"pass", "fail", "error"})

REPORT_FORMAT_VERSION = 1
"""The version of the report's columns; a Parquet report of another version is refused by ``--resume``."""


def _metadata() -> dict[bytes, bytes]:
    from tfrec._version import __version__

    return {b"tfrec.report": str(REPORT_FORMAT_VERSION).encode(), b"tfrec.version": __version__.encode()}


REPORT_METADATA = ("tfrec.report", "tfrec.version")
"""The keys of a Parquet report's schema metadata: its format version and the tfrec that wrote it."""

_ARROW_TYPES = {"string": ("string", "large_string", "string_view"), "int64": ("int64",), "float64": ("double",)}
"""The Arrow types a report's column may have (other tools write text as large_string)."""


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


def _kind_test(path: Path, head: bytes) -> str | None:
    """Why an existing file is not a tfrec report (:func:`report_problem`), for ``--force``'s check."""
    try:
        return _problem(path, report_format(path))
    except OSError as err:
        return f"it cannot be read: {err.strerror or err}"


_FIRST_ROW_BYTES = 1 << 20
"""The longest line a report's reader takes (a row is a few hundred bytes; a traceback in ``detail`` a few kB)."""


PARQUET_REPORT = FileKind("a tfrec report", (b"PAR1",), test=_kind_test)
JSONL_REPORT = FileKind("a tfrec report", empty=True, test=_kind_test)
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
    return pa.schema([pa.field(c.name, types[c.type], nullable=c.name not in _REQUIRED) for c in columns],
                     metadata=_metadata())


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


def _value_problem(column: Column, value: Any) -> str | None:
    """Why a value cannot be in a column of a report (None: it can)."""
    if value is None:
        return f"{column.name} is null" if column.name in _REQUIRED else None
    if column.type == "string":
        ok = isinstance(value, str) and (column.name != "verdict" or value in _VERDICTS)
    elif column.type == "int64":
        ok = isinstance(value, int) and not isinstance(value, bool) and -(2**63) <= value < 2**63
    else:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    return None if ok else f"{column.name} is {_shown(value)}"


def _shown(value: Any) -> str:
    text = json.dumps(value, ensure_ascii=True, default=repr) if not isinstance(value, (bytes, bytearray)) else "bytes"
    return text if len(text) <= 40 else text[:37] + "..."


_BY_NAME = {c.name: c for c in REPORT_COLUMNS}


def _row_problem(record: Mapping[str, Any]) -> str | None:
    """Why a row (a mapping of column name to value) is not a row of a tfrec report (None: it is one)."""
    missing = _REQUIRED - record.keys()
    if missing:
        return f"no {', '.join(sorted(missing))}"
    extra = [name for name in record if name not in _BY_NAME]
    if extra:
        return f"a column a tfrec report has not ({', '.join(sorted(map(str, extra))[:3])})"
    for name, value in record.items():
        problem = _value_problem(_BY_NAME[name], value)
        if problem is not None:
            return problem
    return None


def _schema_problem(schema: Any) -> str | None:
    """Why a Parquet file's schema is not a report's (None: it is one)."""
    metadata = schema.metadata or {}
    version = metadata.get(b"tfrec.report")
    if version is not None and version != str(REPORT_FORMAT_VERSION).encode():
        wrote = metadata.get(b"tfrec.version", b"?")[:20].decode("ascii", "backslashreplace")
        return (f"a report of format '{version[:20].decode('ascii', 'backslashreplace')}' (written by tfrec {wrote}); "
                f"this tfrec reads format {REPORT_FORMAT_VERSION}")
    names = set(schema.names)
    missing = _REQUIRED - names
    if missing:
        return f"it has no {', '.join(sorted(missing))} column"
    extra = sorted(names - _BY_NAME.keys())
    if extra:
        return f"it has columns a tfrec report has not ({', '.join(extra[:3])})"
    for field in schema:
        column = _BY_NAME[field.name]
        if str(field.type) not in _ARROW_TYPES[column.type]:
            return f"its column {field.name} is {field.type}, not {column.type}"
    return None


def _file_problem(file: Path) -> str | None:
    """Why ``file`` cannot be a report as a file: a folder, a FIFO (reading one would wait for ever)...

    Raises:
        OSError: it cannot be looked at.
    """
    mode = os.stat(file).st_mode
    if stat.S_ISDIR(mode):
        return "a folder"
    return None if stat.S_ISREG(mode) else "not a regular file (a FIFO, device or socket)"


def _parquet_problem(file: Path) -> str | None:
    """Why a Parquet file is not a report, from its footer (its schema)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        metadata = pq.read_metadata(file)
        schema = metadata.schema.to_arrow_schema()
    except (pa.ArrowException, ValueError) as err:
        return f"not a Parquet file ({one_line(str(err))[:200]})"
    problem = _schema_problem(schema)
    if problem is not None:
        return problem
    size = os.path.getsize(file)
    unpacked = sum(metadata.row_group(k).total_byte_size for k in range(metadata.num_row_groups))
    if metadata.num_rows > size // 8 + 1 or unpacked > 64 * size + (64 << 20):  # a row packs to tens of bytes
        return (f"its {size:,} bytes claim {metadata.num_rows:,} rows of {unpacked:,} bytes (a tfrec report packs its "
                "rows far less)")
    return None


def _lines(stream: IO[bytes]) -> Iterator[tuple[int, bytes]]:
    """The lines of a JSON-lines file that are not blank, numbered; a line longer than :data:`_FIRST_ROW_BYTES`
    is given cut there (it is then no JSON: no report row is that long)."""
    number = 0
    while line := stream.readline(_FIRST_ROW_BYTES):
        number += 1
        if len(line) == _FIRST_ROW_BYTES and not line.endswith(b"\n"):
            yield number, line
            return
        if line.strip():
            yield number, line


def _first_row_problem(file: Path) -> str | None:
    with open(file, "rb") as stream:
        for number, line in _lines(stream):
            return _line_record(line, number)[1]
    return None


def report_problem(path: str | os.PathLike[str]) -> str | None:
    """Why the existing file at ``path`` is not a tfrec report, or None when it is one.

    A Parquet file is judged by its schema (its footer: names and types of the columns, the format
    version when it says one), a JSON-lines file by its first row (an empty file is a report: the
    report of a run stopped before its first row). :func:`read_report` checks every row besides.

    Raises:
        ReportError: another extension, or a file that cannot be read (no permission…).
    """
    fmt = report_format(path)
    file = Path(path)
    try:
        return _problem(file, fmt)
    except OSError as err:
        raise ReadError(f"{file}: cannot read: {err.strerror or err}") from None


def _problem(file: Path, fmt: str) -> str | None:
    """:func:`report_problem` of a report of format ``fmt``.

    Raises:
        OSError: the file cannot be read.
    """
    return _file_problem(file) or (_parquet_problem(file) if fmt == ".parquet" else _first_row_problem(file))


def check_report(path: str | os.PathLike[str]) -> None:
    """Raise unless the existing file at ``path`` is a tfrec report (:func:`report_problem`).

    Raises:
        ReportError: ``FILE: not a tfrec report: why``, or a file that cannot be read.
    """
    problem = report_problem(path)
    if problem is not None:
        raise ReadError(f"{os.fspath(path)}: not a tfrec report: {problem}")


def is_report(path: str | os.PathLike[str]) -> bool:
    """Whether the existing file at ``path`` is a tfrec report (:func:`report_problem`)."""
    try:
        return report_problem(path) is None
    except ReadError:
        return False


def _line_record(line: bytes, number: int) -> tuple[dict[str, Any], str | None]:
    """A JSON line's row, and why it is not a report's row (None: it is one)."""
    try:
        record = json.loads(line)
    except UnicodeDecodeError:
        return {}, f"line {number} is not UTF-8 text"
    except json.JSONDecodeError as err:
        return {}, f"line {number} is not JSON ({err.msg})"
    except RecursionError:
        return {}, f"line {number} is JSON nested too deeply for a report's row"
    if not isinstance(record, dict):
        return {}, f"line {number} is not a JSON object"
    problem = _row_problem(record)
    return record, None if problem is None else f"row {number}: {problem}"


def read_report(path: str | os.PathLike[str], *, missing_ok: bool = False) -> list[dict[str, Any]]:
    """The rows of a report (``.parquet`` or ``.jsonl``), each a dict of :data:`REPORT_COLUMNS`
    (a column the file lacks is None).

    Args:
        path: the report.
        missing_ok: a report that does not exist has no rows (``--resume`` on a first run).

    Raises:
        ReportError: another extension, a file that cannot be read, or one that is not a tfrec report
            (``FILE: not a tfrec report: …``: a Parquet file of other columns or types, cut short, of
            another report format; JSON lines of other keys or value types).
    """
    fmt = report_format(path)
    file = Path(path)
    if missing_ok and not os.path.lexists(file):
        return []
    names = [c.name for c in REPORT_COLUMNS]
    try:
        problem = _file_problem(file) or (_parquet_problem(file) if fmt == ".parquet" else None)
        if problem is not None:
            raise ReadError(f"{file}: not a tfrec report: {problem}")
        records = _parquet_rows(file) if fmt == ".parquet" else _jsonl_rows(file)
    except OSError as err:
        raise ReadError(f"{file}: cannot read: {err.strerror or err}") from None
    for number, record in enumerate(records, 1):
        problem = _row_problem(record)
        if problem is not None:
            raise ReadError(f"{file}: not a tfrec report: row {number}: {problem}")
    return [{name: record.get(name) for name in names} for record in records]


def _parquet_rows(file: Path) -> list[dict[str, Any]]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        rows: list[dict[str, Any]] = pq.read_table(file).to_pylist()
    except (pa.ArrowException, ValueError, OSError) as err:  # OSError: Arrow's for damaged pages too
        raise ReadError(f"{file}: not a tfrec report: its data cannot be read ({one_line(str(err))[:200]})") from None
    return rows


def _jsonl_rows(file: Path) -> list[dict[str, Any]]:
    records = []
    with open(file, "rb") as stream:
        for number, line in _lines(stream):
            record, problem = _line_record(line, number)
            if problem is not None:
                raise ReadError(f"{file}: not a tfrec report: {problem}")
            records.append(record)
    return records
