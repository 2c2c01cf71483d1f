"""Fuzzing the classes of small inputs that once made unbounded work (issue 20): recordings whose TF is no tree
(a frame its own parent, cycles through the root or apart from it, second parents; on /tf, /tf_static or both;
with and without /joint_states and /robot_description), descriptions of deep chains, rosbag2 metadata that lists
its storage file again and again, and MCAP files of very many channels. The contract is
:mod:`tests.fuzz.harness`'s: a result, warnings, or one error line, within 30 s and 1 GiB."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.bag_builders import Robot, write_bag
from tests.fuzz.conftest import RecordingSeed, link_tree, replace_file, workdir
from tests.fuzz.harness import LONG, check_run, fuzz_settings
from tests.fuzz.mutate import chain_urdf, many_channels_mcap, relisted_files, tf_graph
from tfrec.recording import FrameSeries, JointStates, Recording

pytestmark = pytest.mark.filterwarnings("ignore:Generating overly large repr:hypothesis.errors.HypothesisWarning")

START_NS = 1_700_000_000_000_000_000
URDF = """<robot name="r"><link name="world"/><link name="base"/><link name="a"/><link name="b"/><link name="c"/>
<joint name="j0" type="fixed"><parent link="world"/><child link="base"/></joint>
<joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
  <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.1 0 0"/><axis xyz="0 0 1"/>
  <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<joint name="j3" type="fixed"><parent link="b"/><child link="c"/><origin xyz="0.1 0 0"/></joint>
</robot>"""


def _tf_recording(static: list[tuple[str, str]], tf: list[tuple[str, str]], *, joints: bool,
                  description: bool) -> Recording:
    n = 10
    time_ns = START_NS + np.arange(n, dtype=np.int64) * 100_000_000
    rec = Recording(path="fuzz", format="mcap", start_ns=START_NS)
    rec.tf_static = {pair: (np.array([0.1, 0.0, 0.0]), np.array([0.0, 0.0, 0.0, 1.0])) for pair in static}
    rec.tf = {pair: FrameSeries(time_ns, np.tile([0.1, 0.0, 0.0], (n, 1)), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)))
              for pair in tf}
    if joints:
        rec.joint_states = JointStates(time_ns, ("j1", "j2"), np.zeros((n, 2)))
    if description:
        rec.robot_description = URDF
    return rec


TF_COMMANDS = [
    (["info", "{}"], (0,), []), (["info", "{}", "--graph", "tree.svg"], (0,), ["tree.svg"]),
    (["replay", "--check", "{}"], (0, 1), []), (["diff", "{}", "{}"], (0, 1), []),
    (["replay", "{}", "--save", "out.rrd"], (0,), ["out.rrd"]), (["plot", "{}", "-o", "out.svg"], (0,), ["out.svg"]),
    (["convert", "{}", "out.rrd"], (0,), ["out.rrd"]), (["convert", "{}", "out.mcap"], (0,), ["out.mcap"]),
]


@fuzz_settings(short_examples=12)
@given(data=st.data())
def test_tf_that_is_no_tree(data: st.DataObject, runs: Path) -> None:
    static, tf = data.draw(tf_graph(), label="tf")
    joints, description = data.draw(st.booleans(), label="joints"), data.draw(st.booleans(), label="description")
    kind = data.draw(st.sampled_from(["mcap", "sqlite3", "ros1"]), label="kind")
    argv, codes, outputs = data.draw(st.sampled_from(TF_COMMANDS), label="command")
    with workdir(runs) as cwd:
        if not tf:  # bag_builders writes /tf from its first pair's stamps
            tf, static = static[-1:], static[:-1]
        target = write_bag(cwd / ("in.bag" if kind == "ros1" else "in"),
                           [Robot(_tf_recording(static, tf, joints=joints, description=description))], kind=kind)
        argv = [arg.replace("{}", target.name) for arg in argv]
        check_run(argv, cwd=cwd, inputs=[target], name="tf-graph", codes=codes, outputs=[cwd / o for o in outputs])


@fuzz_settings(short_examples=6)
@given(data=st.data())
def test_deep_chains(data: st.DataObject, runs: Path) -> None:
    links = data.draw(st.sampled_from([600, 1_500, 20_000] + ([100_000] if LONG else [])), label="links")
    branches = data.draw(st.sampled_from([0, 0, 50]), label="branches")
    short = ["--duration", "0.2", "--rate", "10"]
    argv, codes = data.draw(st.sampled_from([
        (["inspect", "chain.urdf"], (0,)), (["inspect", "chain.urdf", "--graph", "tree.dot"], (0,)),
        (["inspect", "chain.urdf", "--graph", "tree.png"], (0,)),
        (["record", "chain.urdf", "-o", "out.mcap", "--no-rrd", *short], (0,)),
        (["record", "chain.urdf", "-o", "out.mcap", "--rrd", "out.rrd", *short], (0,)),
    ]), label="command")
    with workdir(runs) as cwd:
        (cwd / "chain.urdf").write_text(chain_urdf(links, branches=branches))
        check_run(argv, cwd=cwd, inputs=[cwd / "chain.urdf"], name="deep-chain", codes=codes)


@fuzz_settings(short_examples=4)
@given(data=st.data())
def test_storage_files_listed_again_and_again(data: st.DataObject, recording_seeds: list[RecordingSeed],
                                              seed_root: Path, runs: Path) -> None:
    seeds = [seed for seed in recording_seeds if "rosbag2" in seed.tags]
    seed = data.draw(st.sampled_from(seeds), label="seed")
    original = (seed_root / seed.path / "metadata.yaml").read_text(encoding="utf-8")
    mutated = data.draw(relisted_files(original), label="metadata.yaml")
    argv, codes = data.draw(st.sampled_from([(["info", "bag"], (0,)), (["replay", "--check", "bag"], (0, 1)),
                                             (["check", "bag"], (0, 1)), (["convert", "bag", "out.mcap"], (0,)),
                                             (["diff", "bag", "bag"], (0, 1))]), label="command")
    with workdir(runs) as cwd:
        link_tree(seed_root / seed.path, cwd / "bag")
        replace_file(cwd / "bag" / "metadata.yaml", mutated)
        check_run(argv, cwd=cwd, inputs=[cwd / "bag"], name=f"storage-files-{seed.name}", codes=codes)


@fuzz_settings(short_examples=3)
@given(data=st.data())
def test_many_channels(data: st.DataObject, runs: Path) -> None:
    channels = data.draw(st.sampled_from([1_000, 20_000, 60_000]), label="channels")
    schemas = data.draw(st.sampled_from([1, 1, max(1, channels // 10)]), label="schemas")
    argv, codes = data.draw(st.sampled_from([
        (["info", "in.mcap"], (0,)), (["convert", "in.mcap", "out.mcap"], (0,)), (["convert", "in.mcap", "out.bag"], (0,)),
        (["convert", "in.mcap", "--bag", "bag"], (0,)), (["diff", "in.mcap", "in.mcap"], (0, 1)),
        (["replay", "--check", "in.mcap"], (0,)), (["check", "in.mcap"], (0, 1)),
    ]), label="command")
    with workdir(runs) as cwd:
        (cwd / "in.mcap").write_bytes(many_channels_mcap(channels, schemas=schemas))
        check_run(argv, cwd=cwd, inputs=[cwd / "in.mcap"], name="many-channels", codes=codes)
