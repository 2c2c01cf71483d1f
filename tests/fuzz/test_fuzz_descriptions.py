"""Fuzzing robot descriptions and CSV trajectories: real xacro/URDF files (robots/, ../shared/corpus, inline ones)
with elements and attributes mutated, loaded by ``inspect``, ``record`` (MCAP, ROS 1 bag, with and without an
.rrd) and ``diff``; CSV trajectories mutated and recorded. The contract is :mod:`tests.fuzz.harness`'s, and a
recording that comes out has no NaN and no line of /etc/passwd."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import ROBOTS
from tests.fuzz.conftest import MARM_CSV, DescriptionSeed, link_tree, replace_file, workdir
from tests.fuzz.harness import check_run, fuzz_settings
from tests.fuzz.mutate import csv_text, xml_text

SHORT = ["--duration", "0.3", "--rate", "10"]

# hypothesis warns when it would quote a strategy's arguments (a seed file) in a message: they are saved as files
pytestmark = pytest.mark.filterwarnings("ignore:Generating overly large repr:hypothesis.errors.HypothesisWarning")



def _commands(seed: DescriptionSeed) -> list[tuple[list[str], tuple[int, ...], list[str]]]:
    """(argv, exit codes besides 2, outputs) of each command run on a mutated description."""
    entry, args = seed.entry, list(seed.args)
    commands = [
        (["inspect", entry, *args], (0,), []),
        (["inspect", entry, *args, "--json"], (0,), []),
        (["record", entry, *args, "-o", "out.mcap", "--no-rrd", "--compression", "none", *SHORT], (0,), ["out.mcap"]),
        (["record", entry, *args, "-o", "out.bag", "--no-rrd", *SHORT], (0,), ["out.bag"]),
        *[(["record", entry, *args, "-o", "out.mcap", "--no-rrd", "--traj", traj, "--compression", "none", *SHORT],
           (0,), ["out.mcap"]) for traj in ("center", "random", "sweep")],
        (["diff", entry, *args, entry, *args, *SHORT], (0, 1), []),
    ]
    if seed.rrd:
        commands.append((["record", entry, *args, "-o", "out.mcap", "--rrd", "out.rrd", "--compression", "none",
                          *SHORT], (0,), ["out.mcap", "out.rrd"]))
    return commands


def _assert_finite(recording: Path) -> None:
    """No NaN or infinity reaches a recording from a description (issue 11)."""
    from tfrec.formats import read_recording

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = read_recording(recording)
    if rec.joint_states is not None:
        assert np.isfinite(rec.joint_states.positions).all(), f"{recording.name}: a joint position is not finite"
    arrays = [a for series in rec.tf.values() for a in (series.translation, series.rotation)]
    arrays += [a for pair in rec.tf_static.values() for a in pair]
    assert all(np.isfinite(a).all() for a in arrays), f"{recording.name}: a transform is not finite"


@fuzz_settings(short_examples=40)
@given(data=st.data())
def test_mutated_descriptions(data: st.DataObject, description_seeds: list[DescriptionSeed], seed_root: Path,
                              runs: Path) -> None:
    seed = data.draw(st.sampled_from(description_seeds), label="seed")
    original = (seed_root / seed.mutate).read_text(encoding="utf-8")
    mutated = data.draw(xml_text(original), label="mutated file")
    argv, codes, outputs = data.draw(st.sampled_from(_commands(seed)), label="command")
    with workdir(runs) as cwd:
        link_tree(seed_root / seed.tree, cwd / seed.tree)
        replace_file(cwd / seed.mutate, mutated)
        outcome = check_run(argv, cwd=cwd, inputs=[cwd / seed.tree], name=f"description-{seed.name}", codes=codes,
                            outputs=[cwd / out for out in outputs])
        if outcome.code == 0 and argv[0] == "record":
            _assert_finite(cwd / outputs[0])


@fuzz_settings(short_examples=20)
@given(data=st.data())
def test_mutated_csv_trajectories(data: st.DataObject, runs: Path) -> None:
    mutated = data.draw(csv_text(MARM_CSV), label="mutated csv")
    options = data.draw(st.sampled_from([[], ["--rate", "20"], ["--rate", "20", "--interp", "cubic"],
                                         ["--rate", "7", "--interp", "hold"], ["--set", "joint1=0.1"]]), label="options")
    with workdir(runs) as cwd:
        link_tree(ROBOTS / "marm.xacro", cwd / "robots" / "marm.xacro")
        (cwd / "traj.csv").write_bytes(mutated)
        argv = ["record", "robots/marm.xacro", "--traj", "traj.csv", "-o", "out.mcap", "--no-rrd", *options]
        outcome = check_run(argv, cwd=cwd, inputs=[cwd / "traj.csv", cwd / "robots"], name="csv", codes=(0,),
                            outputs=[cwd / "out.mcap"])
        if outcome.code == 0:
            _assert_finite(cwd / "out.mcap")
