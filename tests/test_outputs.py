"""Nothing lost (issue #20): ``--force`` replaces only what tfrec would write there, and an input is never an output.

For every command and each of its outputs the test builds, in a folder of its own, what a user may have at the
output's place — a file of another kind with the output's extension, an empty file, a folder of their own files
that holds the input, the input itself under another name (``./x``, a symbolic link, a hard link), a link to a
tfrec output elsewhere, a tfrec output of another kind, a rosbag2 folder with something more in it — runs the
command with ``--force`` and checks: exit 2, one ``tfrec: error:`` line naming the output, every file of the
folder unchanged (hashed before and after, links and folders included), nothing new (no temporary left).

Then the other side: ``--force`` replaces a genuine output (tfrec's, and a rosbag2 folder of rosbags' own writer,
read back with rosbags), a 255-byte output name works, and names the system cannot take are one line.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.conftest import ROBOTS
from tests.fuzz.harness import snapshot
from tfrec._outputs import process_namespace
from tfrec.cli import main

SHORT = ["--duration", "0.3", "--rate", "20"]


INPUTS = {"IN": "in.mcap", "ROBOT": "marm.xacro", "A": "a", "B": "b"}
"""The inputs in each example's folder: a recording, a description, two folders of recordings."""


@dataclass(frozen=True)
class Case:
    """One output of one command: ``argv`` with ``{OUT}`` for it and ``{IN}``, ``{ROBOT}``, ``{A}``, ``{B}`` for the
    inputs (:data:`INPUTS`); ``key`` is the input the aliases stand for (A: the recording in folder A)."""

    name: str
    argv: tuple[str, ...]
    out: str
    key: str = "IN"

    @property
    def main(self) -> str:
        """The main input's path: a file."""
        return "a/in.mcap" if self.key == "A" else INPUTS[self.key]

    @property
    def folder(self) -> bool:
        return "." not in self.out


CASES = [
    Case("record -o .mcap", ("record", "{ROBOT}", *SHORT, "--no-rrd", "-o", "{OUT}"), "out.mcap", "ROBOT"),
    Case("record -o .bag", ("record", "{ROBOT}", *SHORT, "--no-rrd", "-o", "{OUT}"), "out.bag", "ROBOT"),
    Case("record --bag", ("record", "{ROBOT}", *SHORT, "--no-rrd", "--bag", "{OUT}"), "outbag", "ROBOT"),
    Case("record --rrd", ("record", "{ROBOT}", *SHORT, "--no-mcap", "--rrd", "{OUT}"), "out.rrd", "ROBOT"),
    Case("convert .mcap", ("convert", "{IN}", "{OUT}"), "out.mcap"),
    Case("convert .bag", ("convert", "{IN}", "{OUT}"), "out.bag"),
    Case("convert .rrd", ("convert", "{IN}", "{OUT}"), "out.rrd"),
    Case("convert --bag", ("convert", "{IN}", "--bag", "{OUT}"), "outbag"),
    Case("replay --save", ("replay", "{IN}", "--save", "{OUT}"), "out.rrd"),
    Case("replay --plot", ("replay", "--check", "{IN}", "--plot", "{OUT}"), "out.png"),
    Case("diff --rrd", ("diff", "{IN}", "{IN}", "--rrd", "{OUT}"), "out.rrd"),
    Case("diff --plot", ("diff", "{IN}", "{IN}", "--plot", "{OUT}"), "out.svg"),
    Case("plot -o", ("plot", "{IN}", "-o", "{OUT}"), "out.pdf"),
    Case("info --graph", ("info", "{IN}", "--graph", "{OUT}"), "out.dot"),
    Case("inspect --graph", ("inspect", "{ROBOT}", "--graph", "{OUT}"), "out.svg", "ROBOT"),
    Case("check --report .jsonl", ("check", "{IN}", "--report", "{OUT}"), "out.jsonl"),
    Case("check --report .parquet", ("check", "{IN}", "--report", "{OUT}"), "out.parquet"),
    Case("diff DIR DIR --report", ("diff", "{A}", "{B}", "--report", "{OUT}"), "out.jsonl", "A"),
]

KIND_BYTES = {
    ".mcap": b"\x89MCAP0\r\n",
    ".bag": b"#ROSBAG V2.0\n",
    ".rrd": b"RRF2",
    ".png": b"\x89PNG\r\n\x1a\n",
    ".svg": b'<?xml version="1.0"?>\n<svg xmlns="http://www.w3.org/2000/svg"></svg>\n',
    ".pdf": b"%PDF-1.4\n",
    ".dot": b"// tfrec\ndigraph g {\n}\n",
    ".jsonl": b'{"file": "a.mcap", "check": "summary", "verdict": "pass"}\n',
}
"""How a file of each output kind begins: enough for tfrec to take it for one of its own."""

OTHER_KIND = {".mcap": ".rrd", ".bag": ".mcap", ".rrd": ".mcap", ".png": ".pdf", ".svg": ".png", ".pdf": ".svg",
              ".dot": ".svg", ".jsonl": ".mcap", ".parquet": ".jsonl"}
"""A kind tfrec writes elsewhere, found at an output's place: not what tfrec writes there."""


@pytest.fixture(scope="module")
def seeds(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A recording, a rosbag2 folder and a Parquet report written by tfrec, copied into each example's folder."""
    root = tmp_path_factory.mktemp("seeds")
    robot = str(ROBOTS / "marm.xacro")
    assert main(["record", robot, *SHORT, "--no-rrd", "-o", str(root / "in.mcap")]) == 0
    assert main(["record", robot, *SHORT, "--no-rrd", "--bag", str(root / "bag")]) == 0
    assert main(["check", str(root / "in.mcap"), "--report", str(root / "report.parquet")]) == 0
    return root


def _workdir(seeds: Path, work: Path) -> None:
    shutil.copy(ROBOTS / "marm.xacro", work / "marm.xacro")
    shutil.copy(seeds / "in.mcap", work / "in.mcap")
    for side in ("a", "b"):
        (work / side).mkdir()
        shutil.copy(seeds / "in.mcap", work / side / "in.mcap")


def _argv(case: Case, out: str, **inputs: str) -> list[str]:
    names = {**INPUTS, **inputs, "OUT": out}
    return [arg.format(**names) for arg in case.argv]


tree = snapshot
"""Every entry under a folder: a file's SHA-256, a link's target, a folder; nothing is followed."""


def _refused(argv: list[str], work: Path, out: str, capsys: pytest.CaptureFixture[str]) -> str:
    """Run ``argv`` with --force in ``work``: exit 2, one error line naming ``out``, nothing changed or added."""
    before = tree(work.parent)
    code = main([*argv, "--force"])
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if line.startswith("tfrec: error: ")]
    assert code == 2 and len(errors) == 1, err
    assert not [line for line in err.splitlines() if not line.startswith(("tfrec: error: ", "tfrec: warning: "))], err
    assert str(Path(out)) in errors[0], errors[0]
    assert "Traceback" not in err and ".tfrec-" not in err
    assert tree(work.parent) == before
    return errors[0]


def _foreign_file(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    (work / case.out).write_bytes(b"my notes: tfrec did not write this\n")
    return case.out, {}


def _empty_file(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    (work / case.out).write_bytes(b"")
    return case.out, {}


def _folder_holding_the_input(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    """A project folder at the output's place: the user's files, a subfolder, and the command's input."""
    folder = work / case.out
    (folder / "sub").mkdir(parents=True)
    (folder / "notes.txt").write_text("my notes\n")
    (folder / "sub" / "thesis.tex").write_text("\\section{Results}\n")
    name = INPUTS[case.key]
    os.rename(work / name, folder / name)
    return case.out, {case.key: f"{case.out}/{name}"}


def _same_path(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    return f"./{case.main}", {}


def _symlink_to_input(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    (work / case.out).symlink_to(case.main)
    return case.out, {}


def _hard_link_of_input(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    if case.folder:  # a rosbag2 folder whose storage file is a hard link of the input
        (work / case.out).mkdir()
        os.link(work / case.main, work / case.out / f"{case.out}_0.mcap")
        shutil.copy(work.parent / "seeds" / "bag" / "metadata.yaml", work / case.out / "metadata.yaml")
        text = (work / case.out / "metadata.yaml").read_text().replace("bag_0.mcap", f"{case.out}_0.mcap")
        (work / case.out / "metadata.yaml").write_text(text)
        return case.out, {}
    os.link(work / case.main, work / case.out)
    return case.out, {}


def _link_to_a_tfrec_output(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    elsewhere = work / "elsewhere"
    elsewhere.mkdir()
    if case.folder:
        shutil.copytree(work.parent / "seeds" / "bag", elsewhere / "genuine")
    elif case.out.endswith(".parquet"):
        shutil.copy(work.parent / "seeds" / "report.parquet", elsewhere / "genuine")
    else:
        (elsewhere / "genuine").write_bytes(KIND_BYTES[Path(case.out).suffix] + b"a tfrec output elsewhere")
    (work / case.out).symlink_to(elsewhere / "genuine")
    return case.out, {}


def _another_tfrec_kind(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    """A tfrec output of another kind at a file's place; a rosbag2 folder with a user's file added at a folder's."""
    if case.folder:
        shutil.copytree(work.parent / "seeds" / "bag", work / case.out)
        (work / case.out / "bag_0.mcap").rename(work / case.out / f"{case.out}_0.mcap")
        meta = work / case.out / "metadata.yaml"
        meta.write_text(meta.read_text().replace("bag_0.mcap", f"{case.out}_0.mcap"))
        (work / case.out / "notes.txt").write_text("my notes, put in the bag folder\n")
        return case.out, {}
    other = OTHER_KIND[Path(case.out).suffix]
    data = (work.parent / "seeds" / "report.parquet").read_bytes() if other == ".parquet" else KIND_BYTES[other]
    (work / case.out).write_bytes(data + b"of another kind")
    return case.out, {}


def _bag_listing_a_user_file(case: Case, work: Path) -> tuple[str, dict[str, str]]:
    """A folder whose metadata.yaml (rosbag2's) lists the user's own file as its storage."""
    shutil.copytree(work.parent / "seeds" / "bag", work / case.out)
    (work / case.out / "bag_0.mcap").write_text("my thesis, listed as storage by a hand-written metadata.yaml\n")
    return case.out, {}


SCENARIOS: dict[str, Callable[[Case, Path], tuple[str, dict[str, str]]]] = {
    "foreign file": _foreign_file,
    "empty file": _empty_file,
    "folder holding the input": _folder_holding_the_input,
    "the input as ./x": _same_path,
    "symlink to the input": _symlink_to_input,
    "hard link of the input": _hard_link_of_input,
    "symlink to a tfrec output": _link_to_a_tfrec_output,
    "another tfrec kind": _another_tfrec_kind,
    "bag listing a user's file": _bag_listing_a_user_file,
}


EXAMPLES = [(case, scenario) for case in CASES for scenario in SCENARIOS
            if (scenario != "bag listing a user's file" or case.folder)
            and (scenario != "empty file" or not case.out.endswith(".jsonl"))]
"""Every scenario for every output; an empty .jsonl is a report tfrec writes (a run of check stopped before its first
row): it is replaced (test_the_report_of_check_needs_force_and_is_only_ever_a_report)."""


@pytest.mark.parametrize(("case", "scenario"), EXAMPLES, ids=[f"{case.name}-{scenario}" for case, scenario in EXAMPLES])
def test_force_never_replaces_what_tfrec_did_not_write(case: Case, scenario: str, seeds: Path, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copytree(seeds, tmp_path / "seeds")
    work = tmp_path / "work"
    work.mkdir()
    _workdir(seeds, work)
    out, inputs = SCENARIOS[scenario](case, work)
    monkeypatch.chdir(work)
    _refused(_argv(case, out, **inputs), work, out, capsys)


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_force_replaces_a_genuine_output(case: Case, seeds: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    _workdir(seeds, tmp_path)
    monkeypatch.chdir(tmp_path)
    argv = _argv(case, case.out)
    assert main(argv) in (0, 1), capsys.readouterr().err
    first = os.stat(case.out).st_ino
    assert main(argv) == 2 and "already exists (use --force to overwrite)" in capsys.readouterr().err
    assert main([*argv, "--force"]) in (0, 1), capsys.readouterr().err
    assert os.stat(case.out).st_ino != first  # a new file (or folder), renamed into place
    assert not [p for p in tmp_path.rglob(".tfrec-*")]
    if case.folder:
        assert sorted(p.name for p in Path(case.out).iterdir()) == ["metadata.yaml", f"{case.out}_0.mcap"]


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_force_replaces_a_rosbag2_folder_of_rosbags_writer(storage: str, seeds: Path, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / "theirs"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3) \
            as writer:
        conn = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        message = store.types["std_msgs/msg/String"](data="hello")
        writer.write(conn, 1, store.serialize_cdr(message, "std_msgs/msg/String"))
    assert len(list(bag.iterdir())) == 2
    assert main(["convert", str(seeds / "in.mcap"), "--bag", str(bag), "--force"]) == 0
    with AnyReader([bag]) as reader:
        topics = {c.topic for c in reader.connections}
    assert "/chatter" not in topics and {"/tf", "/joint_states", "/robot_description"} <= topics
    assert sorted(p.name for p in tmp_path.iterdir()) == ["theirs"]


def test_the_report_of_check_needs_force_and_is_only_ever_a_report(seeds: Path, tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """`check --report` replaces an existing report only with --force (or --resume, which reads it first), and a
    file that is not a tfrec report never."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    rec = str(seeds / "in.mcap")
    for name in ("r.jsonl", "r.parquet"):
        report = tmp_path / name
        assert main(["check", rec, "--report", str(report)]) == 0
        assert main(["check", rec, "--report", str(report)]) == 2
        assert capsys.readouterr().err.endswith(f"tfrec: error: {report}: already exists (use --force to overwrite)\n")
        assert main(["check", rec, "--report", str(report), "--resume"]) == 0
        assert "1 unchanged, from the report" in capsys.readouterr().out
        assert main(["check", rec, "--report", str(report), "--force"]) == 0
    pq.write_table(pa.table({"name": ["a"], "size": [1]}), tmp_path / "other.parquet")
    (tmp_path / "other.jsonl").write_text('{"name": "a"}\n')
    for name in ("other.parquet", "other.jsonl"):
        before = (tmp_path / name).read_bytes()
        for flag in ("--force", "--resume"):
            assert main(["check", rec, "--report", str(tmp_path / name), flag]) == 2
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and "not a tfrec report" in err
            assert ("--force replaces only" in err) == (flag == "--force")  # --resume: the report it cannot read
            assert (tmp_path / name).read_bytes() == before
    empty = tmp_path / "empty.jsonl"  # a run stopped before its first row leaves an empty report: tfrec's
    empty.write_bytes(b"")
    assert main(["check", rec, "--report", str(empty), "--force"]) == 0 and empty.stat().st_size > 0


@pytest.mark.parametrize("case", [c for c in CASES if not c.folder and c.name in (
    "record -o .mcap", "convert .bag", "replay --save", "plot -o", "inspect --graph", "check --report .jsonl",
    "diff DIR DIR --report")], ids=lambda c: c.name)
def test_a_255_byte_output_name_works(case: Case, seeds: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    _workdir(seeds, tmp_path)
    monkeypatch.chdir(tmp_path)
    suffix = Path(case.out).suffix
    out = "é" * ((255 - len(suffix)) // 2) + "x" * ((255 - len(suffix)) % 2) + suffix  # 255 bytes, not characters
    assert len(os.fsencode(out)) == 255
    argv = _argv(case, out)
    assert main(argv) in (0, 1), capsys.readouterr().err
    assert main([*argv, "--force"]) in (0, 1), capsys.readouterr().err
    assert Path(out).stat().st_size > 0 and not list(tmp_path.rglob(".tfrec-*"))


def test_a_rosbag2_folder_name_leaves_room_for_its_storage_file(seeds: Path, tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    from rosbags.highlevel import AnyReader

    fits = tmp_path / ("b" * 248)  # its storage file b…b_0.mcap has 255 bytes
    assert main(["convert", str(seeds / "in.mcap"), "--bag", str(fits)]) == 0
    with AnyReader([fits]) as reader:
        assert sum(c.msgcount for c in reader.connections) > 0
    assert main(["record", str(ROBOTS / "marm.xacro"), *SHORT, "--no-rrd", "--bag", str(fits), "--force"]) == 0
    capsys.readouterr()
    for command in (["convert", str(seeds / "in.mcap")], ["record", str(ROBOTS / "marm.xacro"), *SHORT, "--no-rrd"]):
        too_long = tmp_path / ("c" * 249)
        assert main([*command, "--bag", str(too_long)]) == 2
        err = capsys.readouterr().err
        assert err == (f"tfrec: error: {too_long}: too long a name for a rosbag2 folder: the file {'c' * 249}_0.mcap "
                       "it holds would have 256 bytes, and the file system allows 255 (the folder's name may have "
                       "248)\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == [fits.name]


@pytest.mark.parametrize("argv", [
    ["record", "{ROBOT}", "--no-rrd", "-o", "{LONG}.mcap"],
    ["record", "{ROBOT}", "--bag", "{LONG}"],
    ["convert", "{IN}", "{LONG}.bag"],
    ["replay", "{IN}", "--save", "{LONG}.rrd"],
    ["plot", "{IN}", "-o", "{LONG}.png"],
    ["check", "{IN}", "--report", "{LONG}.jsonl"],
    ["inspect", "{LONG}.urdf"],
    ["info", "{LONG}.mcap"],
    ["diff", "{LONG}.mcap", "{IN}"],
    ["replay", "--check", "{LONG}.mcap"],
    ["record", "{ROBOT}", "--traj", "{LONG}.csv", "-o", "{T}/x.mcap"],
    ["record", "{ROBOT}", "-o", "{DEEP}/x.mcap"],
    ["plot", "{IN}", "-o", "{DEEP}/x.png"],
])
def test_a_path_the_system_cannot_take_is_one_line(argv: list[str], seeds: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    names = {"ROBOT": str(ROBOTS / "marm.xacro"), "IN": str(seeds / "in.mcap"), "T": str(tmp_path),
             "LONG": str(tmp_path / ("n" * 256)),
             "DEEP": str(tmp_path / "/".join(["d" * 200] * 21))}
    before = tree(tmp_path)
    code = main([arg.format(**names) for arg in argv])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("tfrec: error: "), err
    assert tree(tmp_path) == before


def test_outputs_of_one_command_need_places_of_their_own(seeds: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    robot = str(ROBOTS / "marm.xacro")
    for argv in (["--bag", str(tmp_path / "x.rrd"), "--rrd", str(tmp_path / "x.rrd")],
                 ["--bag", str(tmp_path / "b"), "--rrd", str(tmp_path / "b" / "x.rrd")]):
        assert main(["record", robot, *SHORT, *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "each output needs its own place" in err
    assert not list(tmp_path.iterdir())


def test_an_output_is_never_written_into_an_input_bag(seeds: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / "bag"
    shutil.copytree(seeds / "bag", bag)
    before = tree(tmp_path)
    for source in (bag, bag / "metadata.yaml", bag / "bag_0.mcap"):
        for argv in (["convert", str(source), str(bag / "new.mcap")], ["plot", str(source), "-o", str(bag / "p.svg")],
                     ["convert", str(source), "--bag", str(bag), "--force"]):
            assert main(argv) == 2
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and str(source) in err, err
    assert tree(tmp_path) == before


# -- the mechanism, directly ---------------------------------------------------------------------------------------


def test_a_target_changed_after_its_check_is_refused_at_commit(seeds: Path, tmp_path: Path) -> None:
    """The check is repeated when the outputs are renamed: a file that became a user's, or a bag folder that got a
    user's file, between the check and the end of the writing is not replaced, and nothing is renamed."""
    from tfrec._atomic import AtomicOutputs
    from tfrec._outputs import check_outputs
    from tfrec.errors import WriteError
    from tfrec.formats.kinds import MCAP, ROSBAG2

    out, bag = tmp_path / "out.mcap", tmp_path / "bag"
    out.write_bytes(b"\x89MCAP0\r\nold")
    shutil.copytree(seeds / "bag", bag)
    check_outputs([(out, MCAP), (bag, ROSBAG2)], force=True)
    for changed in (out, bag):
        with pytest.raises(WriteError, match=f"{changed.name}: exists and is not .*`force` replaces only what tfrec "
                                             "writes there"), AtomicOutputs(replace=True) as outputs:
            outputs.path(out, kind=MCAP).write_bytes(b"\x89MCAP0\r\nnew")
            (outputs.path(bag, kind=ROSBAG2) / "bag_0.mcap").write_bytes(b"\x89MCAP0\r\nnew")
            if changed == out:
                out.write_bytes(b"the user's now")
            else:
                (bag / "notes.txt").write_text("mine")
            outputs.commit()
        assert not list(tmp_path.glob(".tfrec-*"))
        assert out.read_bytes() == (b"the user's now" if changed == out else b"\x89MCAP0\r\nold")
        out.write_bytes(b"\x89MCAP0\r\nold")
    assert (bag / "notes.txt").read_text() == "mine"
    assert (bag / "bag_0.mcap").read_bytes() == (seeds / "bag" / "bag_0.mcap").read_bytes()


def test_a_bag_folder_is_replaced_entry_by_entry(seeds: Path, tmp_path: Path) -> None:
    from tfrec._atomic import AtomicOutputs
    from tfrec.formats.kinds import ROSBAG2

    bag = tmp_path / "bag"
    shutil.copytree(seeds / "bag", bag)
    with AtomicOutputs(replace=True) as outputs:
        temp = outputs.path(bag, kind=ROSBAG2)
        (temp / "metadata.yaml").write_text("new")
        outputs.commit()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"] and (bag / "metadata.yaml").read_text() == "new"


@pytest.mark.parametrize("make, reason", [
    (lambda bag: (bag / "metadata.yaml").unlink(), "it has no metadata.yaml"),
    (lambda bag: (bag / "extra").mkdir(), "it holds extra, which its metadata.yaml does not list"),
    (lambda bag: (bag / "metadata.yaml").write_text("[1, 2"), "its metadata.yaml is not a rosbag2 bag's"),
    (lambda bag: (bag / "metadata.yaml").write_text("a: 1\n"), "its metadata.yaml is not a rosbag2 bag's"),
    (lambda bag: (bag / "bag_0.mcap").unlink(), ("its metadata.yaml is not a rosbag2 bag's: metadata.yaml lists "
                                                "bag_0.mcap, which is missing")),
    (lambda bag: ((bag / "bag_0.mcap").unlink(), (bag / "bag_0.mcap").symlink_to("/etc/passwd")),
     "its bag_0.mcap: it is a symbolic link"),
    (lambda bag: ((bag / "bag_0.mcap").unlink(), os.mkfifo(bag / "bag_0.mcap")),
     "its metadata.yaml is not a rosbag2 bag's"),  # rosbag2's reader finds no file there
    (lambda bag: ((bag / "metadata.yaml").rename(bag / "m"), (bag / "metadata.yaml").symlink_to("m")),
     "its metadata.yaml: it is a symbolic link"),
    (lambda bag: (bag / "bag_0.mcap").write_bytes(b"my thesis"), "its bag_0.mcap is not rosbag2 storage"),
])
def test_what_is_not_a_rosbag2_folder(make: Callable[[Path], object], reason: str, seeds: Path,
                                      tmp_path: Path) -> None:
    from tfrec._outputs import NotOurs
    from tfrec.formats.kinds import ROSBAG2

    bag = tmp_path / "bag"
    shutil.copytree(seeds / "bag", bag)
    assert ROSBAG2.owned(bag) == [bag / "metadata.yaml", bag / "bag_0.mcap"]
    make(bag)
    with pytest.raises(NotOurs, match=reason.replace("(", r"\(").replace(")", r"\)")):
        ROSBAG2.owned(bag)


def test_errors_name_the_output_never_its_temporary(tmp_path: Path) -> None:
    from tfrec._atomic import AtomicOutputs
    from tfrec.errors import ReplayError, WriteError
    from tfrec.formats.kinds import ROSBAG2, RRD

    bag, rrd = tmp_path / ("b" * 240), tmp_path / "x.rrd"
    with pytest.raises(WriteError) as raised, AtomicOutputs() as outputs:
        temp = outputs.path(bag, kind=ROSBAG2)
        open(temp / "inner_0.mcap", "rb")  # noqa: SIM115 - raises
    assert str(raised.value) == f"{bag}/inner_0.mcap: cannot write: No such file or directory"
    with pytest.raises(ReplayError) as other, AtomicOutputs() as outputs:
        temp = outputs.path(rrd, kind=RRD)
        raise ReplayError(f"{temp}: the viewer went away ({temp.name})")
    assert str(other.value) == f"{rrd}: the viewer went away (x.rrd)"
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_temporaries_have_short_names_and_stale_ones_are_removed(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    from tfrec._atomic import AtomicOutputs
    from tfrec.formats.kinds import MCAP

    target = tmp_path / ("t" * 250 + ".mcap")
    with AtomicOutputs() as outputs:
        temp = outputs.path(target, kind=MCAP)
        assert temp.name.startswith(f".tfrec-{process_namespace()}-{os.getpid()}-") and temp.name.endswith(".mcap")
        assert len(temp.name) <= 51
    dead = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                              text=True, check=True).stdout)
    stale = [tmp_path / f".tfrec-{process_namespace()}-{dead}-0123abcd.rrd",
             tmp_path / f".tfrec-{process_namespace()}-{dead}-89abcdef"]
    stale[0].write_bytes(b"RRF2 half written")
    (stale[1] / "x_0.mcap").parent.mkdir()
    (stale[1] / "x_0.mcap").write_bytes(b"\x89MCAP0\r\n half written")
    assert main(["record", str(ROBOTS / "marm.xacro"), *SHORT, "-o", str(tmp_path / "n.mcap"),
                 "--rrd", str(tmp_path / "n.rrd")]) == 0
    assert main(["record", str(ROBOTS / "marm.xacro"), *SHORT, "--no-rrd", "--bag", str(tmp_path / "b")]) == 0
    assert not any(p.exists() for p in stale)
    assert capsys.readouterr().err.count("removed 1 unfinished output of killed runs") == 2
    named_like_one = tmp_path / f".tfrec-{dead}-0123abcd.mcap"
    assert main(["record", str(ROBOTS / "marm.xacro"), *SHORT, "--no-rrd", "-o", str(named_like_one)]) == 2
    assert "named like tfrec's temporary files" in capsys.readouterr().err


def test_what_appears_in_a_bag_while_it_is_replaced_is_kept(seeds: Path, tmp_path: Path) -> None:
    """A folder is replaced by removing the entries its kind recognized, never a whole tree: a file that appeared
    after the check (here: one the check did not list) is kept in a folder of its own, with a warning."""
    from tfrec._atomic import _replace
    from tfrec.formats.kinds import ROSBAG2

    bag, new = tmp_path / "bag", tmp_path / f".tfrec-{process_namespace()}-1-0123abcd"
    shutil.copytree(seeds / "bag", bag)
    owned = ROSBAG2.owned(bag)
    (bag / "appeared.txt").write_text("written meanwhile")
    new.mkdir()
    (new / "metadata.yaml").write_text("new")
    with pytest.warns(UserWarning, match=r"bag: files that appeared in it while it was replaced are kept in .*"
                                         r"\.tfrec-kept-[0-9a-f]{8}"):
        _replace(new, bag, owned)
    kept = next(tmp_path.glob(".tfrec-kept-*"))
    assert sorted(p.name for p in kept.iterdir()) == ["appeared.txt"] and (bag / "metadata.yaml").read_text() == "new"
