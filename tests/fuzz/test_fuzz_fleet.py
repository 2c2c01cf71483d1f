"""Fuzzing the fleet commands' inputs that are not recordings: reports that ``--resume`` reads (a real report's
JSON lines with keys, values and lines mutated; Parquet files of drawn columns and types, with the report's
schema metadata changed, or a real one's bytes mutated), and folders of odd entries (links that loop, dangle or
lead back up, FIFOs, empty and foreign files, folders it cannot enter, names with terminal escapes) whose entries
vanish while ``check`` or a folder ``diff`` runs. The contract is :mod:`tests.fuzz.harness`'s, plus: a report
that ``--resume`` refused is left as it was, one it accepted is a tfrec report afterwards, and no escape
sequence reaches the terminal."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.fuzz.conftest import RecordingSeed, workdir
from tests.fuzz.harness import check_run, fuzz_settings
from tests.fuzz.mutate import HOSTILE_TEXT, mutated_bytes
from tfrec.fleet.report import REPORT_COLUMNS, is_report

pytestmark = pytest.mark.filterwarnings("ignore:Generating overly large repr:hypothesis.errors.HypothesisWarning")

ESCAPES = "\x1b[2J\x1b[31m\r\x07"
"""What a name must not do to the terminal (clear it, recolour it, return the cursor, ring)."""

CONTROL = frozenset("\x1b\r\x07")
"""The characters of :data:`ESCAPES` that must never reach the terminal unescaped."""

_NAMES = [c.name for c in REPORT_COLUMNS]


@pytest.fixture(scope="session")
def fleet_seed(recording_seeds: list[RecordingSeed], seed_root: Path, tmp_path_factory: pytest.TempPathFactory
               ) -> tuple[Path, bytes, bytes]:
    """A small fleet (two of tfrec's recordings and a damaged one) and its reports: (folder, JSON lines, Parquet)."""
    from tfrec.cli import main

    folder = tmp_path_factory.mktemp("fuzz-fleet")
    for name in ("marm.mcap", "marm.bag"):
        shutil.copy(seed_root / "rec" / name, folder / name)
    (folder / "cut.mcap").write_bytes((seed_root / "rec" / "marm.mcap").read_bytes()[:3000])
    reports = []
    for suffix in (".jsonl", ".parquet"):
        report = tmp_path_factory.mktemp("fuzz-report") / f"r{suffix}"
        assert main(["check", str(folder), "--jobs", "1", "--report", str(report)]) == 1
        reports.append(report.read_bytes())
    return folder, reports[0], reports[1]


# -- reports for --resume ----------------------------------------------------------------------------

_HOSTILE_VALUES: list[Any] = [None, "", "pass", "maybe", 1, -1, 1.5, 2**70, -(2**70), True, [], {}, [[1]], {"a": 1},
                              "x" * 5000, ESCAPES, "\udcff", float("inf")]


def _object(line: bytes) -> dict[str, Any] | None:
    """A line's JSON object, or None when an earlier mutation made it something else."""
    try:
        row = json.loads(line)
    except (ValueError, RecursionError):
        return None
    return row if isinstance(row, dict) else None


@st.composite
def jsonl_report(draw: st.DrawFn, text: bytes) -> bytes:
    """A real report's lines with keys deleted, added or renamed, values replaced, lines duplicated, replaced by
    garbage, nested deep or cut short."""
    lines = [json.loads(line) for line in text.splitlines() if line.strip()]
    out: list[bytes] = [json.dumps(row).encode() for row in lines]
    for _ in range(draw(st.integers(1, 4))):
        k = draw(st.integers(0, max(len(out) - 1, 0)))
        kind = draw(st.sampled_from(["value", "value", "valid", "valid", "delete", "add", "rename", "duplicate",
                                     "garbage", "nest", "raw"]))
        row = _object(out[k]) if out and kind in ("value", "valid", "delete", "add", "rename") else None
        if isinstance(row, dict) and kind == "valid":  # still a report: another verdict, fingerprint or config
            name = draw(st.sampled_from(["verdict", "fingerprint", "config", "detail", "robot"]))
            row[name] = draw(st.sampled_from(["pass", "fail", "error"] if name == "verdict" else ["", "x", ESCAPES]))
        elif isinstance(row, dict) and kind == "value":
            row[draw(st.sampled_from(_NAMES))] = draw(st.sampled_from(_HOSTILE_VALUES))
        elif isinstance(row, dict) and kind == "delete" and row:
            row.pop(draw(st.sampled_from(sorted(row))))
        elif isinstance(row, dict) and kind == "add":
            row[draw(st.sampled_from(["name", "value", "File", "", "file ", ESCAPES]))] = draw(st.sampled_from([1, "a"]))
        elif isinstance(row, dict) and kind == "rename" and row:
            old = draw(st.sampled_from(sorted(row)))
            row[old.upper() + "_"] = row.pop(old)
        elif kind == "duplicate" and out:
            out.insert(k, out[k])
        elif kind == "garbage" and out:
            out[k] = draw(mutated_bytes(out[k], max_ops=2))
        elif kind == "nest":
            depth = draw(st.sampled_from([10, 1000, 200_000]))
            out.insert(k, b"[" * depth + b"]" * depth)
        elif kind == "raw" and out:
            out[k] = out[k].replace(b'"max_error": null', b'"max_error": NaN').replace(b'"size": ', b'"size": 1e999 , "x": ')
        if row is not None:
            out[k] = json.dumps(row, allow_nan=True).encode(errors="surrogatepass")
    data = b"\n".join(out) + b"\n"
    if draw(st.integers(0, 4)) == 0:  # cut short
        data = data[: draw(st.integers(0, len(data)))]
    return data


_ARROW_TYPES = ["string", "large_string", "int64", "int32", "double", "float", "bool", "null", "timestamp",
                "list", "binary"]


def _column(kind: str, rows: int, value: Any) -> Any:
    """A column of ``rows`` values of an Arrow type (``value`` for a text column, when given)."""
    import pyarrow as pa

    if kind == "timestamp":
        return pa.array([0] * rows, pa.timestamp("ns"))
    if kind == "list":
        return pa.array([[1]] * rows, pa.list_(pa.int64()))
    if kind == "null":
        return pa.nulls(rows)
    types = {"string": pa.string(), "large_string": pa.large_string(), "int64": pa.int64(), "int32": pa.int32(),
             "double": pa.float64(), "float": pa.float32(), "bool": pa.bool_(), "binary": pa.binary()}
    samples = {"string": "pass", "large_string": "summary", "int64": 3, "int32": 3, "double": 0.5, "float": 0.5,
               "bool": True, "binary": b"x"}
    text = kind in ("string", "large_string") and value is not None
    return pa.array([value if text else samples[kind]] * rows, types[kind])


@st.composite
def parquet_report(draw: st.DrawFn, data: bytes) -> bytes:
    """A Parquet file: drawn columns (a report's names and others) of drawn types, a real report with its schema
    metadata changed, or a real report's bytes mutated (footer, pages, cut short)."""
    import io

    import pyarrow as pa
    import pyarrow.parquet as pq

    kind = draw(st.sampled_from(["columns", "columns", "metadata", "bytes"]))
    if kind == "bytes":
        return draw(mutated_bytes(data, max_ops=3))
    if kind == "metadata":
        table = pq.read_table(io.BytesIO(data))
        metadata = {b"tfrec.report": draw(st.sampled_from([b"1", b"2", b"", b"\xff", b"1" * 100])),
                    b"tfrec.version": draw(st.binary(max_size=40))}
        table = table.replace_schema_metadata(metadata)
    else:
        names = draw(st.lists(st.sampled_from([*_NAMES, "name", "value", "File", ESCAPES]), min_size=1, max_size=8,
                              unique=True))
        rows = draw(st.sampled_from([0, 1, 3]))
        value = draw(st.sampled_from([None, None, "error", "fail"]))
        table = pa.table({name: _column(draw(st.sampled_from(_ARROW_TYPES)), rows, value if name == "verdict" else None)
                          for name in names})
    out = io.BytesIO()
    pq.write_table(table, out)
    return out.getvalue()


@fuzz_settings(short_examples=16)
@given(data=st.data())
def test_foreign_reports_for_resume(data: st.DataObject, fleet_seed: tuple[Path, bytes, bytes], runs: Path) -> None:
    folder, jsonl, parquet = fleet_seed
    suffix = data.draw(st.sampled_from([".jsonl", ".parquet"]), label="format")
    report = data.draw(jsonl_report(jsonl) if suffix == ".jsonl" else parquet_report(parquet), label="report")
    with workdir(runs) as cwd:
        target = cwd / f"r{suffix}"
        target.write_bytes(report)
        outcome = check_run(["check", str(folder), "--jobs", "1", "--report", target.name, "--resume"], cwd=cwd,
                            inputs=[target], name=f"resume{suffix}", codes=(0, 1))
        if outcome.code == 2:
            assert target.read_bytes() == report, "a report --resume refused was changed"
            assert sorted(os.listdir(cwd)) == [target.name], "a temporary was left"
        else:
            assert is_report(target)
        assert not CONTROL & set(outcome.stdout + outcome.stderr)


# -- folders of odd entries, vanishing while the command runs -----------------------------------------

_ENTRIES = ["recording", "recording", "foreign", "empty", "dangling", "loop", "up", "here", "fifo", "folder",
            "locked", "bag", "hidden", "escapes"]


def _entry(folder: Path, kind: str, index: int, recording: Path) -> Path:
    """Make one entry of ``kind`` in ``folder``; its path."""
    name = {"escapes": f"{ESCAPES}{index}.mcap", "hidden": f".h{index}.mcap", "fifo": f"f{index}.mcap",
            "foreign": f"x{index}.bag", "empty": f"e{index}.db3"}.get(kind, f"{kind}{index}")
    path = folder / name
    if kind in ("recording", "hidden", "escapes"):
        os.link(recording, path)
    elif kind == "foreign":
        path.write_bytes(b"#ROSBAG V2.0\n" + HOSTILE_TEXT[index % len(HOSTILE_TEXT)].encode(errors="replace"))
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "dangling":
        path.symlink_to(f"nowhere{index}.mcap")
    elif kind == "loop":
        path.symlink_to(name)
    elif kind == "up":
        path.symlink_to("..")
    elif kind == "here":
        path.symlink_to(".")
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "bag":
        path.mkdir()
        (path / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 9, relative_file_paths: [x.db3]}\n")
    else:  # folder, locked: a recording inside; locked cannot be entered (as root it can: root overrides modes)
        path.mkdir()
        os.link(recording, path / "inner.mcap")
        if kind == "locked":
            path.chmod(0)
    return path


@st.composite
def odd_tree(draw: st.DrawFn) -> list[tuple[int, str]]:
    """Entries to make: (depth, kind) in order; a ``folder`` opens the next depth."""
    return draw(st.lists(st.tuples(st.integers(0, 2), st.sampled_from(_ENTRIES)), min_size=1, max_size=10))


def _build(root: Path, plan: list[tuple[int, str]], recording: Path) -> list[Path]:
    folders = [root]
    made = []
    for index, (depth, kind) in enumerate(plan):
        parent = folders[min(depth, len(folders) - 1)]
        path = _entry(parent, kind, index, recording)
        made.append(path)
        if kind == "folder":
            folders.append(path)
    return made


@contextlib.contextmanager
def _vanishing(paths: list[Path], delay_s: float) -> Iterator[None]:
    """Delete ``paths`` (files, links, folders) from another thread ``delay_s`` after the command starts."""

    def delete() -> None:
        time.sleep(delay_s)
        for path in paths:
            try:
                if path.is_dir() and not path.is_symlink():
                    path.chmod(0o700)
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    path.unlink()
            except OSError:
                pass

    thread = threading.Thread(target=delete, daemon=True)
    thread.start()
    try:
        yield
    finally:
        thread.join()


def _unlock(root: Path) -> None:
    """Make every folder under ``root`` enterable again, so that the example's folder can be removed."""
    for folder, dirs, _ in os.walk(root):
        for name in dirs:
            path = Path(folder) / name
            if not path.is_symlink() and not stat.S_IMODE(path.lstat().st_mode) & 0o100:
                path.chmod(0o700)


def _special(folder: str, names: list[str]) -> list[str]:
    """The entries ``shutil.copytree`` cannot copy: FIFOs, folders it cannot enter."""
    out = []
    for name in names:
        mode = os.lstat(os.path.join(folder, name)).st_mode
        if stat.S_ISFIFO(mode) or (stat.S_ISDIR(mode) and not stat.S_IMODE(mode) & 0o100):
            out.append(name)
    return out


@fuzz_settings(short_examples=12)
@given(data=st.data())
def test_odd_folders_whose_entries_vanish(data: st.DataObject, fleet_seed: tuple[Path, bytes, bytes],
                                         runs: Path) -> None:
    folder, _, _ = fleet_seed
    plan = data.draw(odd_tree(), label="tree")
    command = data.draw(st.sampled_from(["check", "check-report", "glob", "diff"]), label="command")
    with workdir(runs) as cwd:
        tree = cwd / "tree"
        tree.mkdir()
        made = _build(tree, plan, folder / "marm.mcap")
        other = cwd / "other"
        shutil.copytree(tree, other, symlinks=True, ignore=_special)
        gone = [path for path in made if data.draw(st.booleans(), label=f"vanish {path.name!r}")]
        delay_s = data.draw(st.sampled_from([0.0, 0.05, 0.2, 0.5]), label="delay")
        argv = {"check": ["check", "tree"], "check-report": ["check", "tree", "--report", "out.jsonl"],
                "glob": ["check", "tree/**/*.mcap"], "diff": ["diff", "tree", "other"]}[command]
        try:
            with _vanishing(gone, delay_s):
                outcome = check_run([*argv, "--jobs", "1"], cwd=cwd, inputs=[tree, other], name=f"folder-{command}",
                                    codes=(0, 1))
        finally:
            _unlock(cwd)
        assert not CONTROL & set(outcome.stdout + outcome.stderr), "an escape sequence reached the terminal"
