"""Fuzzing recordings: MCAP files (tfrec's, with each compression, and the real ones of ../shared/bags) mutated
byte by byte and record by record, ROS 1 bags (tfrec's and rosbag.js's) with mutated header fields, rosbag2
folders with a mutated ``metadata.yaml``, damaged sqlite3 tables or a mutated MCAP, and tfrec's ``.rrd``. Each is
read by ``info``, ``replay --check``, ``replay --save``, ``diff A A`` and ``plot``; the contract is
:mod:`tests.fuzz.harness`'s. Odd but well-formed recordings (issue 20: a joint named twice, names with terminal
escape sequences, robot topics defined with another layout, recursive or deeply nested types) go through those
commands, ``convert`` and ``check`` of their folder too."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.fuzz.conftest import RecordingSeed, link_tree, replace_file, workdir
from tests.fuzz.harness import check_run, fuzz_settings
from tests.fuzz.mutate import (
    apply_sql,
    mutated_bytes,
    mutated_mcap,
    mutated_ros1_bag,
    mutated_sqlite_bag,
    odd_recording,
    write_odd_recording,
    yaml_text,
)
from tfrec.recording import Recording

# hypothesis warns when it would quote a strategy's arguments (a seed file) in a message: they are saved as files
pytestmark = pytest.mark.filterwarnings("ignore:Generating overly large repr:hypothesis.errors.HypothesisWarning")



def _commands(target: str) -> list[tuple[list[str], tuple[int, ...], list[str]]]:
    """(argv, exit codes besides 2, outputs) of the commands that read a recording."""
    return [
        (["info", target], (0,), []),
        (["info", target, "--json"], (0,), []),
        (["replay", "--check", target], (0, 1), []),
        (["replay", "--check", target, "--json"], (0, 1), []),
        (["diff", target, target], (0, 1), []),
        (["replay", target, "--save", "out.rrd"], (0,), ["out.rrd"]),
        (["plot", target, "-o", "out.svg"], (0,), ["out.svg"]),
    ]


def _draw_command(data: st.DataObject, target: str) -> tuple[list[str], tuple[int, ...], list[str]]:
    # the cheap readers most of the time; --save and plot (Rerun, matplotlib) now and then
    commands = _commands(target)
    return data.draw(st.sampled_from(commands[:5] * 3 + commands[5:]), label="command")


def _seeds(seeds: list[RecordingSeed], tag: str) -> list[RecordingSeed]:
    return [seed for seed in seeds if tag in seed.tags]


def _run(data: st.DataObject, seed: RecordingSeed, cwd: Path, target: Path, name: str) -> None:
    argv, codes, outputs = _draw_command(data, target.relative_to(cwd).as_posix())
    check_run(argv, cwd=cwd, inputs=[target], name=name, codes=codes, outputs=[cwd / out for out in outputs])


@fuzz_settings(short_examples=40)
@given(data=st.data())
def test_mutated_mcap(data: st.DataObject, recording_seeds: list[RecordingSeed], seed_root: Path, runs: Path) -> None:
    seed = data.draw(st.sampled_from(_seeds(recording_seeds, "mcap")), label="seed")
    original = (seed_root / seed.path).read_bytes()
    mutation = data.draw(st.sampled_from(["records", "records", "bytes"]), label="mutation")
    mutated = data.draw(mutated_mcap(original) if mutation == "records" else mutated_bytes(original), label="mcap")
    with workdir(runs) as cwd:
        target = cwd / "in.mcap"
        target.write_bytes(mutated)
        _run(data, seed, cwd, target, f"mcap-{seed.name}")


@fuzz_settings(short_examples=25)
@given(data=st.data())
def test_mutated_ros1_bags(data: st.DataObject, recording_seeds: list[RecordingSeed], seed_root: Path,
                           runs: Path) -> None:
    seed = data.draw(st.sampled_from(_seeds(recording_seeds, "ros1")), label="seed")
    mutated = data.draw(mutated_ros1_bag((seed_root / seed.path).read_bytes()), label="bag")
    with workdir(runs) as cwd:
        target = cwd / "in.bag"
        target.write_bytes(mutated)
        _run(data, seed, cwd, target, f"ros1-{seed.name}")


@fuzz_settings(short_examples=25)
@given(data=st.data())
def test_mutated_rosbag2_metadata(data: st.DataObject, recording_seeds: list[RecordingSeed], seed_root: Path,
                                  runs: Path) -> None:
    seed = data.draw(st.sampled_from(_seeds(recording_seeds, "rosbag2")), label="seed")
    original = (seed_root / seed.path / "metadata.yaml").read_text(encoding="utf-8")
    mutated = data.draw(yaml_text(original), label="metadata.yaml")
    with workdir(runs) as cwd:
        target = cwd / "bag"
        link_tree(seed_root / seed.path, target)
        replace_file(target / "metadata.yaml", mutated)
        _run(data, seed, cwd, target, f"rosbag2-metadata-{seed.name}")


@fuzz_settings(short_examples=25)
@given(data=st.data())
def test_mutated_rosbag2_storage(data: st.DataObject, recording_seeds: list[RecordingSeed], seed_root: Path,
                                 runs: Path) -> None:
    seed = data.draw(st.sampled_from(_seeds(recording_seeds, "rosbag2")), label="seed")
    files = sorted(p.name for p in (seed_root / seed.path).iterdir() if p.suffix in (".db3", ".mcap"))
    if not files:
        return
    name = data.draw(st.sampled_from(files), label="file")
    original = seed_root / seed.path / name
    with workdir(runs) as cwd:
        target = cwd / "bag"
        link_tree(seed_root / seed.path, target)
        copy = target / name
        if original.suffix == ".db3" and data.draw(st.booleans(), label="tables"):
            apply_sql(copy, data.draw(mutated_sqlite_bag(original), label="sql"))
        elif original.suffix == ".mcap":
            replace_file(copy, data.draw(mutated_mcap(original.read_bytes()), label="mcap"))
        else:
            replace_file(copy, data.draw(mutated_bytes(original.read_bytes()), label="bytes"))
        _run(data, seed, cwd, target, f"rosbag2-storage-{seed.name}")


@fuzz_settings(short_examples=4)
@given(data=st.data())
def test_mutated_rrd(data: st.DataObject, recording_seeds: list[RecordingSeed], seed_root: Path, runs: Path) -> None:
    seed = data.draw(st.sampled_from(_seeds(recording_seeds, "rrd")), label="seed")
    mutated = data.draw(mutated_bytes((seed_root / seed.path).read_bytes()), label="rrd")
    with workdir(runs) as cwd:
        target = cwd / "in.rrd"
        target.write_bytes(mutated)
        _run(data, seed, cwd, target, f"rrd-{seed.name}")


def _odd_commands(target: str) -> list[tuple[list[str], tuple[int, ...], list[str]]]:
    """What reads an odd recording: the commands of :func:`_commands`, convert (each format, TF from the joint
    states) and a check of its folder (whose listing holds its name)."""
    return _commands(target) + [
        (["convert", target, "out.mcap"], (0,), ["out.mcap"]),
        (["convert", target, "out.bag"], (0,), ["out.bag"]),
        (["convert", target, "out.rrd"], (0,), ["out.rrd"]),
        (["convert", target, "out.mcap", "--tf-from-joints"], (0,), ["out.mcap"]),
        (["check", "."], (0, 1), []),
        (["replay", "--check", target, "--use-log-time"], (0, 1), []),
    ]


@fuzz_settings(short_examples=30)
@given(data=st.data())
def test_odd_recordings(data: st.DataObject, odd_seed: Recording, runs: Path) -> None:
    plan = data.draw(odd_recording(), label="odd recording")
    with workdir(runs) as cwd:
        target = write_odd_recording(plan, odd_seed, cwd)
        argv, codes, outputs = data.draw(st.sampled_from(_odd_commands(target.name)), label="command")
        check_run(argv, cwd=cwd, inputs=[target], name=f"odd-{plan.kind}", codes=codes,
                  outputs=[cwd / out for out in outputs])
