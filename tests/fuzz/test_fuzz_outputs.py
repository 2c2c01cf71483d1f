"""Fuzzing where outputs go (issue #20): each command's output meets what a user may have at its place — their files
and folders (holding the command's input, or not), an empty file, a tfrec output of another kind, a rosbag2 folder
with something more in it or a mutated ``metadata.yaml``, the input itself under another name (``./x``, an absolute
path, a symbolic or a hard link), a link elsewhere or to nowhere, a place inside the input's rosbag2 folder, names
near and over the file system's limits — with and without ``--force``.

The contract is :mod:`tests.fuzz.harness`'s, and: a run that must be refused (anything at the output's place but
nothing, or a genuine output of its kind with ``--force``) exits 2; nothing but the output changes; nothing at all
when the run fails; no temporary is left."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from tests.conftest import ROBOTS
from tests.fuzz.conftest import RecordingSeed, link_tree, replace_file, workdir
from tests.fuzz.harness import check_run, fuzz_settings, save_failure, snapshot, untouched_violations
from tests.fuzz.mutate import foreign_bytes, foreign_tree, long_name, write_tree, yaml_text

# hypothesis warns when it would quote a strategy's arguments (a seed file) in a message: they are saved as files
pytestmark = pytest.mark.filterwarnings("ignore:Generating overly large repr:hypothesis.errors.HypothesisWarning")

SHORT = ("--duration", "0.3", "--rate", "10")

COMMANDS: list[tuple[tuple[str, ...], str, tuple[int, ...]]] = [
    (("record", "{ROBOT}", *SHORT, "--no-rrd", "-o", "{OUT}"), ".mcap", (0,)),
    (("record", "{ROBOT}", *SHORT, "--no-rrd", "-o", "{OUT}"), ".bag", (0,)),
    (("record", "{ROBOT}", *SHORT, "--no-rrd", "--bag", "{OUT}"), "", (0,)),
    (("record", "{ROBOT}", *SHORT, "--no-mcap", "--rrd", "{OUT}"), ".rrd", (0,)),
    (("convert", "{IN}", "{OUT}"), ".mcap", (0,)),
    (("convert", "{IN}", "{OUT}"), ".bag", (0,)),
    (("convert", "{IN}", "{OUT}"), ".rrd", (0,)),
    (("convert", "{IN}", "--bag", "{OUT}"), "", (0,)),
    (("replay", "{IN}", "--save", "{OUT}"), ".rrd", (0,)),
    (("replay", "--check", "{IN}", "--plot", "{OUT}"), ".png", (0, 1)),
    (("diff", "{IN}", "{IN}", "--plot", "{OUT}"), ".svg", (0, 1)),
    (("diff", "{IN}", "{IN}", "--rrd", "{OUT}"), ".rrd", (0, 1)),
    (("plot", "{IN}", "-o", "{OUT}"), ".pdf", (0,)),
    (("info", "{IN}", "--graph", "{OUT}"), ".dot", (0,)),
    (("inspect", "{ROBOT}", "--graph", "{OUT}"), ".svg", (0,)),
    (("check", "{IN}", "--report", "{OUT}"), ".jsonl", (0, 1)),
    (("check", "{IN}", "--report", "{OUT}"), ".parquet", (0, 1)),
]
"""(argv, the output's extension ("" for a rosbag2 folder), exit codes besides 2) of every output of every command."""

PLACES = ["absent", "long name", "deep path", "foreign file", "empty file", "foreign folder", "folder holding the input",
          "genuine", "genuine", "another kind", "bag with more", "bag with mutated metadata", "symlink to the input",
          "symlink elsewhere", "dangling symlink", "hard link of the input", "the input by another path",
          "inside the input's bag"]
"""What is at the output's place."""

INPUTS = ["marm.mcap", "marm.bag", "marm-bag", "marm-sqlite"]
"""The recordings read (tfrec's: MCAP, ROS 1 bag, rosbag2 folders with mcap and sqlite3 storage)."""


def _input_name(seed: RecordingSeed) -> str:
    return "inbag" if seed.path.endswith(("-bag", "-sqlite")) else "in" + Path(seed.path).suffix


def _main_input(argv: tuple[str, ...], inputs: dict[str, str]) -> str:
    """The input an alias stands for: the description of record and inspect, else the recording."""
    return inputs["ROBOT"] if "{ROBOT}" in argv else inputs["IN"]


def _a_file_of(path: str, cwd: Path) -> Path:
    """``path`` if a file, else a storage file of the rosbag2 folder ``path``."""
    full = cwd / path
    return full if full.is_file() else min(p for p in full.iterdir() if p.name != "metadata.yaml")


def _make_place(data: st.DataObject, place: str, *, cwd: Path, ext: str, force: bool, main: str,
                outputs: dict[str, Path], inputs: dict[str, str]) -> tuple[str, bool | None]:
    """Build ``place`` at the output's path; returns the output (relative to ``cwd``) and whether the run must be
    refused (None: either way, within the contract)."""
    out = "outbag" if not ext else f"out{ext}"
    target = cwd / out
    refused: bool | None = True
    if place == "absent":
        refused = False
    elif place == "long name":
        out = data.draw(long_name(ext or ""), label="long name")
        size = len(out.encode())
        refused = size > 255 or (not ext and size > 248)  # a bag's storage file: <name>_0.mcap
    elif place == "deep path":  # over PATH_MAX
        out = "/".join(["d" * 250] * 17) + f"/out{ext}"
    elif place == "foreign file":
        target.write_bytes(data.draw(foreign_bytes(), label="file"))
    elif place == "empty file":
        target.write_bytes(b"")
        refused = not (force and ext == ".jsonl")  # an empty report: a run of check stopped before its first row
    elif place == "foreign folder":
        write_tree(target, data.draw(foreign_tree(), label="folder"))
    elif place == "folder holding the input":
        write_tree(target, data.draw(foreign_tree(), label="folder"))
        moved = f"{out}/{Path(main).name}"
        os.rename(cwd / main, cwd / moved)
        inputs.update({key: moved for key, value in inputs.items() if value == main})
    elif place == "genuine":
        _copy(outputs[ext], target)
        refused = not force
    elif place == "another kind":
        other = data.draw(st.sampled_from(sorted(kind for kind in outputs if kind != ext)), label="other kind")
        _copy(outputs[other], target)
    elif place == "bag with more":
        _copy(outputs[""], target)
        write_tree(target, data.draw(foreign_tree().filter(lambda tree: set(tree) - {"metadata.yaml"}), label="more"))
    elif place == "bag with mutated metadata":
        _copy(outputs[""], target)
        replace_file(target / "metadata.yaml", data.draw(yaml_text((target / "metadata.yaml").read_text()), label="yaml"))
        refused = None if force and not ext else True
    elif place == "symlink to the input":
        target.symlink_to(main)
    elif place == "symlink elsewhere":
        _copy(outputs[ext], cwd / "elsewhere" / "precious")
        target.symlink_to(cwd / "elsewhere" / "precious")
    elif place == "dangling symlink":
        target.symlink_to("nowhere")
    elif place == "hard link of the input":
        if ext:
            os.link(_a_file_of(main, cwd), target)
        else:  # a bag of tfrec's whose storage file is the input
            _copy(outputs[""], target)
            storage = next(p for p in target.iterdir() if p.name != "metadata.yaml")
            storage.unlink()
            os.link(_a_file_of(main, cwd), storage)
    elif place == "the input by another path":
        out = data.draw(st.sampled_from([f"./{main}", str(cwd / main), f"{main}/../{main}" if (cwd / main).is_dir()
                                         else f"./{main}"]), label="alias")
    else:  # inside the input's bag
        assume((cwd / inputs["IN"]).is_dir() and main == inputs["IN"])
        out = f"{inputs['IN']}/{out}"
    return out, refused


def _copy(source: Path, target: Path) -> None:
    """A real copy (not a hard link: a hard link of a seed that is also an input would be that input)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    if source.is_dir():
        shutil.copytree(source, target)
    else:
        shutil.copy(source, target)


@fuzz_settings(short_examples=40)
@given(data=st.data())
def test_outputs_where_something_is(data: st.DataObject, recording_seeds: list[RecordingSeed],
                                    output_seeds: dict[str, Path], seed_root: Path, runs: Path) -> None:
    argv, ext, codes = data.draw(st.sampled_from(COMMANDS), label="command")
    seed = data.draw(st.sampled_from([s for s in recording_seeds if s.name in INPUTS]), label="input")
    place = data.draw(st.sampled_from(PLACES), label="place")
    force = data.draw(st.sampled_from([True, True, True, False]), label="force")
    with workdir(runs) as cwd:
        link_tree(ROBOTS / "marm.xacro", cwd / "marm.xacro")
        link_tree(seed_root / seed.path, cwd / _input_name(seed))
        inputs = {"ROBOT": "marm.xacro", "IN": _input_name(seed)}
        main = _main_input(argv, inputs)
        out, refused = _make_place(data, place, cwd=cwd, ext=ext, force=force, main=main, outputs=output_seeds,
                                   inputs=inputs)
        command = [arg.format(OUT=out, **inputs) for arg in argv] + (["--force"] if force else [])
        before = snapshot(cwd)
        outcome = check_run(command, cwd=cwd, inputs=sorted(cwd.iterdir()), name=f"outputs-{place}", codes=codes)
        problems = untouched_violations(before, snapshot(cwd), outputs=[] if outcome.code == 2 else
                                        [os.path.normpath(os.path.relpath(cwd / out, cwd))])
        if refused and outcome.code != 2:
            problems.insert(0, f"exit {outcome.code}: the output's place holds what tfrec must not replace ({place})")
        if problems:
            saved = save_failure(f"outputs-{place}", command, cwd=cwd, inputs=sorted(cwd.iterdir()), outcome=outcome)
            raise AssertionError(f"tfrec {' '.join(command)}: {'; '.join(problems[:3])}\ninput saved in {saved}\n"
                                 f"stderr:\n{outcome.stderr[-2000:]}")
