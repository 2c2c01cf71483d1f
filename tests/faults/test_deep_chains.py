"""Deep trees (issue 20): a URDF chain of 600+ links made the .rrd blueprint recurse past Python's limit, and a
chain of 100,000 links took quadratic work in several walks (printing the tree, matching frame prefixes, the
camera's reach, mimic chains). Every walk over a description's tree or a frame tree is iterative now; each chain
is built here, and each command ends within the guard of :mod:`tests.faults.guarded` (1 GiB, 30 s of CPU)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from tests.faults.guarded import guarded, warnings_of
from tfrec.description import parse_urdf
from tfrec.formats import read_recording
from tfrec.formats.rrd.paths import MAX_LINKS
from tfrec.plots.tree import MAX_DRAWN_FRAMES
from tfrec.viewer.blueprint import tf_tree_layout


def chain_urdf(links: int, *, mimic: bool = False) -> str:
    """A chain of ``links`` + 1 links, every other joint revolute (each revolute joint after the first mimics the
    one before when ``mimic``), the others fixed."""
    parts = ['<robot name="chain">', '<link name="l0"/>']
    previous = ""
    for i in range(1, links + 1):
        kind = "revolute" if i % 2 else "fixed"
        extra = ('<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
                 if kind == "revolute" else "")
        if kind == "revolute" and mimic and previous:
            extra += f'<mimic joint="{previous}"/>'
        if kind == "revolute":
            previous = f"j{i}"
        parts.append(f'<link name="l{i}"/><joint name="j{i}" type="{kind}"><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><origin xyz="0 0 0.001"/>{extra}</joint>')
    parts.append("</robot>")
    return "\n".join(parts)


SHORT = ["--duration", "0.2", "--rate", "10"]


@pytest.fixture(scope="module")
def chain_100k(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("chain")
    (folder / "chain.urdf").write_text(chain_urdf(100_000))
    return folder


def test_a_100k_chain_is_inspected_recorded_and_read(chain_100k: Path) -> None:
    cwd = chain_100k
    tree = guarded(["inspect", "chain.urdf"], cwd)
    lines = tree.stdout.splitlines()
    assert lines[-1].endswith("l100000  (j100000: fixed)") and "[100000]" in lines[-1]
    assert max(len(line) for line in lines) < 400  # indentation stops growing: not 20 GB of spaces
    guarded(["record", "chain.urdf", "-o", "chain.mcap", "--no-rrd", *SHORT], cwd)
    with open(cwd / "chain.mcap", "rb") as stream:  # mcap's own reader, independent of tfrec
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics is not None and summary.statistics.message_count == 8
    info = guarded(["info", "chain.mcap", "--json"], cwd)
    (robot,) = json.loads(info.stdout)["robots"]
    assert len(robot["tf_frames"]) == 100_000 and len(robot["joints"]) == 50_000
    check = guarded(["replay", "--check", "chain.mcap"], cwd, codes=(0, 1))
    assert check.code == 0 and "PASS: all 100000 frames match the description" in check.stdout
    assert guarded(["diff", "chain.mcap", "chain.mcap"], cwd, codes=(0, 1)).code == 0  # joints matched by dict


def test_an_rrd_past_its_bound_is_one_line(tmp_path: Path) -> None:
    # an .rrd of more than 10,000 links is refused in one line before anything is written (Rerun: ~1 ms and
    # 60 kB a link: 100,000 links would take minutes and gigabytes)
    (tmp_path / "chain.urdf").write_text(chain_urdf(MAX_LINKS))
    refused = guarded(["record", "chain.urdf", "-o", "rrd.mcap", "--rrd", "chain.rrd", *SHORT], tmp_path,
                      isolated=False)
    assert refused.code == 2 and "at most 10,000" in refused.stderr and "--no-rrd" in refused.stderr
    assert not (tmp_path / "chain.rrd").exists() and not (tmp_path / "rrd.mcap").exists()


def test_a_tree_picture_past_its_bound_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "chain.urdf").write_text(chain_urdf(MAX_DRAWN_FRAMES))
    picture = guarded(["inspect", "chain.urdf", "--graph", "tree.svg"], tmp_path, isolated=False)
    assert picture.code == 2 and f"at most {MAX_DRAWN_FRAMES:,}" in picture.stderr and ".dot" in picture.stderr
    guarded(["inspect", "chain.urdf", "--graph", "tree.dot"], tmp_path, isolated=False)
    assert (tmp_path / "tree.dot").read_text().count(" -> ") == MAX_DRAWN_FRAMES


def test_a_plot_of_thousands_of_joints_draws_the_first(tmp_path: Path) -> None:
    (tmp_path / "chain.urdf").write_text(chain_urdf(4_000))
    guarded(["record", "chain.urdf", "-o", "chain.mcap", "--no-rrd", *SHORT], tmp_path, isolated=False)
    plot = guarded(["plot", "chain.mcap", "-o", "plot.svg"], tmp_path)
    assert any("2,000 joints" in line and "first 64" in line for line in warnings_of(plot))


def test_a_chain_past_the_recursion_limit_records_and_replays_an_rrd(tmp_path: Path) -> None:
    links = 1_500  # the .rrd's TF tree graph was laid out recursively: a RecursionError past ~1,000 links
    (tmp_path / "chain.urdf").write_text(chain_urdf(links))
    guarded(["record", "chain.urdf", "-o", "chain.mcap", "--rrd", "chain.rrd", *SHORT], tmp_path)
    rrd = read_recording(tmp_path / "chain.rrd")
    assert len(rrd.tf) + len(rrd.tf_static) == links
    guarded(["replay", "chain.mcap", "--save", "replayed.rrd"], tmp_path)
    replayed = read_recording(tmp_path / "replayed.rrd")
    assert set(replayed.tf) | set(replayed.tf_static) == set(rrd.tf) | set(rrd.tf_static)


def test_a_chain_of_100k_mimic_joints_is_linear() -> None:
    robot = parse_urdf(chain_urdf(100_000, mimic=True))
    order = robot.mimic_order
    assert len(order) == 49_999 and order[0].name == "j3" and order[-1].name == "j99999"


def test_the_tf_tree_graph_of_a_deep_chain_is_laid_out_without_recursion() -> None:
    pairs = [(f"l{i}", f"l{i + 1}") for i in range(100_000)]
    layout = tf_tree_layout(pairs)
    assert len(layout) == 100_001 and layout["l100000"][1] == 100_000 * 30.0
