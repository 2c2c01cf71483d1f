"""Terminal safety (issue 20): names found by listing a folder, and topic, frame, joint and robot names from a recording
or a description, reach the terminal escaped in every report — results on stdout as well as errors and warnings — so
that a file named with ESC, CR or BEL sequences cannot clear the screen, recolour a verdict or set the window title.
Report files keep the names exactly: they are data."""

from __future__ import annotations

import json
import shutil
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tests.bag_builders import Robot as Publisher
from tests.bag_builders import write_bag
from tests.fuzz.harness import Outcome, contract_violations, run_tfrec
from tests.recording_helpers import _typestore
from tfrec.recording import FrameSeries, JointStates

HOSTILE = ["\x1b[2J", "\r", "\x07", "\x1b]0;title\x07", "\u202e"]
"""Clear the screen, return to the line's start, ring, set the window title, reverse the text."""
RLO = "\u202e"
"""The only one of them a URDF (XML) can hold in a name."""

URDF = f"""<?xml version="1.0"?>
<robot name="bot{RLO}evil">
  <link name="base"/><link name="arm{RLO}"/><link name="tip"/>
  <joint name="elbow{RLO}" type="revolute"><parent link="base"/><child link="arm{RLO}"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="fixed"><parent link="arm{RLO}"/><child link="tip"/><origin xyz="0.1 0 0"/></joint>
</robot>
"""


def unsafe(text: str) -> list[str]:
    """The characters of ``text`` that could drive a terminal (all but printable ones, line breaks and tabs)."""
    return sorted({c for c in text if not c.isprintable() and c not in "\n\t"})


def run(argv: list[str], cwd: Path, *, codes: tuple[int, ...] = (0,), isolated: bool = False) -> Outcome:
    outcome = run_tfrec(argv, cwd=cwd, isolated=isolated)
    problems = contract_violations(outcome, codes=codes)
    assert not problems, f"tfrec {argv}: {problems[0]}\n{outcome.stderr[-2000:]}"
    assert not unsafe(outcome.stdout), f"tfrec {argv} printed {unsafe(outcome.stdout)} on stdout:\n{outcome.stdout}"
    assert not unsafe(outcome.stderr), f"tfrec {argv} printed {unsafe(outcome.stderr)} on stderr:\n{outcome.stderr}"
    return outcome


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """bot.urdf (names with a right-to-left override), rec.mcap recorded from it, and bags whose topics, frames,
    joints and a namespace are named with each hostile sequence: ``a`` (rosbag2, two robots), ``a.bag`` (ROS 1), ``b``
    (rosbag2, one frame moved), written by rosbags."""
    from tfrec.cli import main
    from tfrec.formats import read_recording

    root = tmp_path_factory.mktemp("hostile-names")
    (root / "bot.urdf").write_text(URDF)
    (root / "bot2.urdf").write_text(URDF.replace('xyz="0.1 0 0"', 'xyz="0.2 0 0"'))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["record", str(root / "bot.urdf"), "-o", str(root / "rec.mcap"), "--no-rrd", "--duration", "1",
                     "--rate", "10"]) == 0
        rec = read_recording(root / "rec.mcap")
    js = rec.joint_states
    assert js is not None
    series = next(iter(rec.tf.values()))
    hostile = replace(
        rec, joint_states=JointStates(js.time_ns, js.names + tuple(f"j{n}" for n in HOSTILE),
                                      np.hstack([js.positions, np.zeros((len(js), len(HOSTILE)))])),
        tf={**rec.tf, **{("base", f"f{n}"): series for n in HOSTILE}})
    start = int(rec.start_ns or 0)
    for kind, name in (("mcap", "a"), ("ros1", "a.bag")):
        string = _typestore(kind == "ros1").types["std_msgs/msg/String"]
        extra = [(f"/t{n}", "std_msgs/msg/String", start, string(data=n)) for n in HOSTILE]
        robots = [Publisher(hostile)] + ([Publisher(hostile, namespace="/ns\x1b[2J")] if kind == "mcap" else [])
        write_bag(root / name, robots, kind=kind, extra=extra)
    moved = FrameSeries(series.time_ns, series.translation + 0.5, series.rotation)
    write_bag(root / "b", [Publisher(replace(hostile, tf={**hostile.tf, ("base", f"f{HOSTILE[0]}"): moved}))], kind="mcap")
    write_bag(root / "tf-only.bag", [Publisher(rec, topics=("/tf",))], kind="ros1")  # no description: no robot name
    return root


COMMANDS = [  # (argv, exit codes, whether its output names something hostile)
    (["record", "bot.urdf", "-o", "out.mcap", "--rrd", "out.rrd", "--duration", "0.3"], (0,), True),
    (["inspect", "bot.urdf"], (0,), True),
    (["inspect", "bot.urdf", "--json"], (0,), True),
    (["inspect", "bot.urdf", "--graph", "tree.dot"], (0,), False),
    (["info", "a"], (0,), True),
    (["info", "a.bag"], (0,), True),
    (["info", "a", "--json"], (0,), True),
    (["info", "a", "--graph", "frames.dot"], (0,), True),
    (["replay", "--check", "a"], (0,), True),
    (["replay", "--check", "a.bag", "--plot", "check.svg"], (0,), True),
    (["replay", "--check", "b", "--json"], (0,), True),
    (["replay", "a", "--save", "out.rrd"], (0,), True),
    (["diff", "a", "b"], (1,), True),
    (["diff", "a.bag", "b", "--plot", "diff.svg"], (1,), True),
    (["diff", "bot.urdf", "bot2.urdf", "--duration", "1"], (1,), True),
    (["diff", "a", "b", "--json"], (1,), True),
    (["convert", "a", "out.bag", "--start", "0.5"], (0,), True),
    (["convert", "a.bag", "out.mcap", "--exclude", "/t\x07", "/nope\x07"], (0,), True),
    (["convert", "a.bag", "out.rrd"], (0,), False),
    (["plot", "a.bag", "-o", "plot.svg"], (0,), False),
    (["check", "a", "a.bag", "b"], (0, 1), False),
    (["info", "a", "--namespace", "/\x1b[2J"], (0,), True),  # an unknown namespace: an error that names it
    (["record", "bot.urdf", "--interp", "\x1b]0;title\x07"], (0,), True),  # argparse's own usage error
    (["info", "no\x1b[31m-such.mcap"], (0,), True),
]


@pytest.mark.parametrize("argv, codes, names", COMMANDS,
                         ids=[" ".join(a[:2]) + f"-{i}" for i, (a, _, _) in enumerate(COMMANDS)])
def test_names_from_inputs_reach_the_terminal_escaped(folder: Path, tmp_path: Path, argv: list[str],
                                                       codes: tuple[int, ...], names: bool) -> None:
    for item in folder.iterdir():
        (shutil.copytree if item.is_dir() else shutil.copy)(item, tmp_path / item.name)
    outcome = run(argv, tmp_path, codes=codes)
    shown = outcome.stdout + outcome.stderr
    if names:  # the names are there, escaped
        assert any(escaped in shown for escaped in ("\\u202e", "\\x1b", "\\x07", "\\u001b", "\\u202E")), shown


def _aligned(header: str, rows: list[str], columns: list[str]) -> bool:
    """Whether each of ``columns`` (titles in ``header``) starts at the same place in every row."""
    places = [header.index(title) for title in columns]
    return all(row[at - 1] == " " and row[at] != " " for row in rows for at in places)


def test_tables_stay_aligned_with_escaped_names(folder: Path) -> None:
    info = run(["info", "a"], folder).stdout.splitlines()
    start = info.index(next(line for line in info if line.startswith("Topics (")))
    rows = info[start + 1 : start + 14]
    assert any("\\x1b[2J" in row for row in rows)
    types = {row.index(kind) for row in rows for kind in ("std_msgs/", "tf2_msgs/", "sensor_msgs/") if kind in row}
    assert len(types) == 1, "\n".join(rows)
    check = run(["replay", "--check", "a"], folder).stdout.splitlines()
    header = next(line for line in check if line.startswith("robot "))
    table = check[check.index(header) + 1 : next(i for i, line in enumerate(check) if line.startswith("note:"))]
    assert any("\\x1b[2J" in row for row in table) and any("\\u202e" in row for row in table)
    assert _aligned(header, table, ["frame", "parent", "topic", "samples"]), "\n".join(check)


@pytest.fixture(scope="module")
def named_files(tmp_path_factory: pytest.TempPathFactory, folder: Path) -> Path:
    """Two folders of recordings named with each hostile sequence and with bytes that are not UTF-8, some of them
    not recordings at all (error rows), B lacking one of A's."""
    import os

    root = tmp_path_factory.mktemp("named")
    for side in ("A", "B"):
        (root / side).mkdir()
    names = [f"x{n}.mcap" for n in HOSTILE]
    for name in names:
        for side in ("A", "B"):
            shutil.copy(folder / "rec.mcap", root / side / name)
        (root / "A" / f"bad{name}").write_bytes(b"not a recording")
    raw = os.fsencode(root / "A") + b"/\xff\xfe.mcap"  # a name that is not UTF-8: '\udcff\udcfe.mcap' in Python
    shutil.copy(folder / "rec.mcap", raw)
    (root / "A" / "bad\udcff\udcfe.mcap").write_bytes(b"not a recording")
    return root


def test_a_folder_of_hostile_file_names_is_checked_and_reported_escaped(named_files: Path, tmp_path: Path) -> None:
    outcome = run(["check", str(named_files / "A"), "--report", str(tmp_path / "r.jsonl")], tmp_path, codes=(1,))
    assert "\\x1b[2J" in outcome.stdout and "\\udcff\\udcfe" in outcome.stdout  # the error rows name them, escaped
    rows = [json.loads(line) for line in (tmp_path / "r.jsonl").read_text(encoding="utf-8").splitlines()]
    found = {Path(row["file"]).name for row in rows}
    assert {f"x{n}.mcap" for n in HOSTILE} | {f"badx{n}.mcap" for n in HOSTILE} | {"\udcff\udcfe.mcap"} <= found
    assert "bad\udcff\udcfe.mcap" in found  # JSON's escape of the undecodable bytes reads back as the same name


def test_a_parquet_report_keeps_the_names(named_files: Path, tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    run(["check", str(named_files / "A"), "--report", str(tmp_path / "r.parquet")], tmp_path, codes=(1,))
    found = {Path(row["file"]).name for row in pq.read_table(tmp_path / "r.parquet").to_pylist()}
    assert {f"x{n}.mcap" for n in HOSTILE} | {f"badx{n}.mcap" for n in HOSTILE} <= found
    assert "\\udcff\\udcfe.mcap" in found  # Parquet strings are UTF-8: undecodable bytes as their escapes


def test_a_folder_diff_of_hostile_file_names_is_escaped(named_files: Path, tmp_path: Path) -> None:
    outcome = run(["diff", str(named_files / "A"), str(named_files / "B")], tmp_path, codes=(1,))
    assert "only in A" in outcome.stdout and "\\x07" in outcome.stdout


def test_a_real_terminal_gets_bytes_it_can_encode(named_files: Path, tmp_path: Path) -> None:
    """In a process of its own, stdout is a UTF-8 stream: a file name that is not UTF-8 must not end the run with
    a UnicodeEncodeError (the in-process runs above write to a StringIO, which takes anything)."""
    outcome = run(["check", str(named_files / "A")], tmp_path, codes=(1,), isolated=True)
    assert "bad\\udcff\\udcfe.mcap" in outcome.stdout
    info = run(["info", str(named_files / "A" / "\udcff\udcfe.mcap")], tmp_path, isolated=True)
    assert "\\udcff\\udcfe.mcap" in info.stdout


def test_inspect_urdf_writes_the_same_document_without_terminal_controls(folder: Path, tmp_path: Path) -> None:
    """``inspect --urdf > robot.urdf`` is data: characters a terminal would act on are XML character references, and
    the document means what the file means."""
    import xml.etree.ElementTree as ET

    crlf = tmp_path / "crlf.urdf"
    crlf.write_bytes(URDF.replace("\n", "\r\n").encode())
    for path in (folder / "bot.urdf", crlf):
        outcome = run(["inspect", str(path), "--urdf"], tmp_path)
        assert "&#x202E;" in outcome.stdout and "\r" not in outcome.stdout
        shown, original = ET.fromstring(outcome.stdout.encode()), ET.fromstring(path.read_bytes())
        assert [(e.tag, e.attrib) for e in shown.iter()] == [(e.tag, e.attrib) for e in original.iter()]


@pytest.mark.parametrize("source", ["rec.mcap", "tf-only.bag"])
@pytest.mark.parametrize("argv", [
    ["replay", "IN", "--save", "out.rrd"],
    ["convert", "IN", "out.rrd"],
    ["diff", "IN", "IN", "--rrd", "out.rrd"],
    ["plot", "IN", "-o", "out.png"],
    ["info", "IN", "--graph", "out.dot"],
    ["info", "IN", "--graph", "out.svg"],
    ["replay", "--check", "IN", "--plot", "out.svg"],
    ["diff", "IN", "IN", "--plot", "out.png"],
])
def test_a_file_name_that_is_not_utf8_reaches_pictures_and_rerun_escaped(folder: Path, tmp_path: Path,
                                                                          argv: list[str], source: str) -> None:
    """Titles, graph names and Rerun's recording names are UTF-8 text: the name's bytes that are not UTF-8 are shown
    as their escapes (a UnicodeEncodeError traceback before)."""
    import os

    name = os.fsdecode(b"\xff\xfe" + Path(source).suffix.encode())
    shutil.copy(folder / source, tmp_path / name)
    outcome = run([name if a == "IN" else a for a in argv], tmp_path, codes=(0, 1))
    if source == "rec.mcap" or (argv[0] in ("replay", "convert") and argv[-1].endswith(".rrd")):
        assert (tmp_path / argv[-1]).is_file(), outcome.stderr
    else:  # a TF-only bag has no joints to plot, no description to check against: one error line
        assert outcome.code == 2 or (tmp_path / argv[-1]).is_file()


def test_the_command_line_prints_only_through_show() -> None:
    """One printer (tfrec.cli._common.show): a print(), sys.stdout.write() or json.dump(…, sys.stdout) elsewhere in
    tfrec/cli would print names unescaped."""
    import ast

    from tests.conftest import REPO

    found = []
    for path in sorted((REPO / "tfrec" / "cli").glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for function in [node for node in ast.walk(tree) if isinstance(node, ast.FunctionDef) and node.name != "show"]:
            for call in [node for node in ast.walk(function) if isinstance(node, ast.Call)]:
                text = ast.unparse(call.func)
                streams = [ast.unparse(arg) for arg in [*call.args, *(k.value for k in call.keywords)]]
                if text == "print" or text in ("sys.stdout.write", "sys.stderr.write") or (
                        text in ("json.dump", "sys.stdout.writelines") and any(s.startswith("sys.std") for s in streams)):
                    found.append(f"{path.name}:{call.lineno}: {ast.unparse(call)[:80]}")
    assert not found, "\n".join(found)
