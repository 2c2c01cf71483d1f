"""The TF tree as a picture: DOT text, the tidy layout, SVG/PNG/PDF for repository and corpus robots,
and the tree of a real recording."""

from __future__ import annotations

import itertools
import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import ROBOTS
from tests.plots.helpers import corpus_dir, dot_graph, png_pixels
from tfrec.cli import main
from tfrec.description import load_description, parse_urdf
from tfrec.formats.reader import read_recording
from tfrec.model import Robot
from tfrec.plots import GraphEdge, PlotError, TreeGraph, graph_format, recorded_graph, render_graph, robot_graph, to_dot
from tfrec.plots._figure import DPI
from tfrec.plots._layout import tidy_layout
from tfrec.plots.tree import MAX_INCHES
from tfrec.recording import FrameSeries, Recording

MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "pdf": b"%PDF-", "svg": b"<?xml"}


def _check_every_format(robot: Robot, tmp_path: Path) -> None:
    graph = robot_graph(robot)
    links = {link.name for link in robot.links}
    joints = {joint.name for joint in robot.joints}
    for fmt in ("dot", "svg", "png", "pdf"):
        path = tmp_path / f"{robot.name}.{fmt}"
        render_graph(graph, path)
        data = path.read_bytes()
        if fmt == "dot":
            nodes, edges, labels = dot_graph(data.decode())
            assert nodes == links
            assert edges == {(j.parent, j.child) for j in robot.joints}
            assert {label.split("\n")[0] for label in labels.values()} == joints
        else:
            assert data.startswith(MAGIC[fmt]) and len(data) > 10_000, (fmt, len(data))
        if fmt == "svg":
            text = data.decode()
            missing = [name for name in links | joints if f">{name}<" not in text]
            assert not missing
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == sorted(f"{robot.name}.{f}" for f in ("dot", "svg", "png", "pdf"))  # no temporaries left


def test_marm_graph_in_every_format(marm: Robot, tmp_path: Path) -> None:
    _check_every_format(marm, tmp_path)
    label = dot_graph((tmp_path / "marm.dot").read_text())[2][("gripper_link", "gripper_finger_link2")]
    assert label == "finger_joint2\nprismatic, axis (0 1 0)\n[-0.02, 0.01] m\nmimics finger_joint1 ×-1"


@pytest.mark.parametrize(("path", "args"), [
    ("franka_description/robots/panda/panda.urdf.xacro", {"hand": "true"}),
    ("ur_description/urdf/ur5.xacro", {}),
])
def test_corpus_graph_in_every_format(path: str, args: dict[str, str], tmp_path: Path) -> None:
    corpus = corpus_dir()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # missing meshes
        robot = load_description(corpus / path, args=args, package_paths=[corpus])
    _check_every_format(robot, tmp_path)


def test_svg_is_deterministic(marm: Robot, tmp_path: Path) -> None:
    render_graph(robot_graph(marm), tmp_path / "a.svg")
    render_graph(robot_graph(marm), tmp_path / "b.svg")
    assert (tmp_path / "a.svg").read_bytes() == (tmp_path / "b.svg").read_bytes()


def test_dot_quotes_any_frame_name(tmp_path: Path) -> None:
    names = ['a "quoted" frame', "back\\slash\\n", "two\nlines", "ünïcode/frame", "-> ; { } [ ]", "node", "x" * 3]
    edges = tuple(GraphEdge(names[0], child, f'joint "{k}"\\', "fixed", ("fixed",))
                  for k, child in enumerate(names[1:]))
    graph = TreeGraph('robot "q"', "t", "s", tuple(names), edges, (names[0],), ("a note\nover two lines",))
    text = to_dot(graph)
    nodes, found, labels = dot_graph(text)
    assert nodes == set(names)
    assert found == {(names[0], child) for child in names[1:]}
    assert labels[(names[0], "node")] == 'joint "4"\\\nfixed'
    dot = shutil.which("dot")
    if dot is not None:  # Graphviz reads it too, where installed
        result = subprocess.run([dot, "-Tsvg"], input=text.encode(), capture_output=True, check=False)
        assert result.returncode == 0, result.stderr
    render_graph(graph, tmp_path / "odd.png")  # and it draws


def test_graph_format() -> None:
    assert [graph_format(f"t.{s}") for s in ("dot", "SVG", "png", "pdf")] == ["dot", "svg", "png", "pdf"]
    with pytest.raises(PlotError, match=r"tree\.jpg: a graph is written as \.dot, \.svg, \.png, \.pdf .*not '\.jpg'"):
        graph_format("tree.jpg")
    with pytest.raises(PlotError, match="not no suffix"):
        render_graph(TreeGraph("g", "t", "s", ("a",), (), ("a",)), "tree")
    empty = recorded_graph(Recording("none.mcap", "mcap"))
    with pytest.raises(PlotError, match=r"^TF tree recorded in none\.mcap: no frames to draw$"):
        render_graph(empty, "tree.dot")


def test_tidy_layout_packs_subtrees_without_overlap() -> None:
    # a chain with a leaf hanging off every link (panda's *_sc frames), and a fork at the end
    children = {f"l{i}": [f"l{i}_sc", f"l{i + 1}"] for i in range(5)}
    children["l5"] = ["f1", "f2"]
    nodes = {n for kids in children.values() for n in kids} | {"l0"}
    widths = {n: 1.0 for n in nodes}
    place = tidy_layout(["l0"], children, widths, gap=0.5)
    assert {place.x[f"l{i}"] for i in range(6)} == {place.x["l0"]}  # the chain is straight
    assert place.levels == 7 and place.depth["f2"] == 6
    by_depth: dict[int, list[float]] = {}
    for node, x in place.x.items():
        by_depth.setdefault(place.depth[node], []).append(x)
    for xs in by_depth.values():
        xs.sort()
        assert all(b - a >= 1.5 - 1e-9 for a, b in itertools.pairwise(xs))
    # the *_sc leaves share one column left of the chain, the fork spreads around it: 3.25, not 7 columns
    assert place.width == pytest.approx(0.5 + 1.5 + 0.75 + 0.5)
    assert min(x - 0.5 for x in place.x.values()) == pytest.approx(0.0)


def test_large_robot_stays_within_bounds(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    links, joints = ["base"], []
    for i in range(1, 150):
        parent = links[int(rng.integers(max(0, i - 12), i))]
        links.append(f"link_{i}")
        joints.append(f'<joint name="joint_{i}" type="{"fixed" if i % 3 else "revolute"}"><parent link="{parent}"/>'
                      f'<child link="link_{i}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    urdf = '<robot name="big">' + "".join(f'<link name="{n}"/>' for n in links) + "".join(joints) + "</robot>"
    robot = parse_urdf(urdf)
    render_graph(robot_graph(robot), tmp_path / "big.png")
    height, width, _ = png_pixels(tmp_path / "big.png").shape
    assert max(height, width) <= MAX_INCHES * DPI + 1 and min(height, width) > 600
    render_graph(robot_graph(robot), tmp_path / "big.svg")
    assert all(f">{name}<" in (tmp_path / "big.svg").read_text() for name in links)


def test_recorded_graph_of_a_real_recording(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mcap = tmp_path / "marm.mcap"
    code = main(["record", str(ROBOTS / "marm.xacro"), "--traj", "random", "-o", str(mcap), "--no-rrd",
                 "--duration", "2"])
    capsys.readouterr()
    assert code == 0
    rec = read_recording(mcap)
    graph = recorded_graph(rec)
    frames = {frame for pair in list(rec.tf) + list(rec.tf_static) for frame in pair}
    assert set(graph.nodes) == frames and graph.roots == ("link0",) and not graph.notes
    render_graph(graph, tmp_path / "tf.dot")
    render_graph(graph, tmp_path / "tf.svg")
    nodes, edges, labels = dot_graph((tmp_path / "tf.dot").read_text())
    assert nodes == frames and edges == set(rec.tf) | set(rec.tf_static)
    for pair in rec.tf:
        assert labels[pair] == "/tf\naverage 50 Hz\n101 transforms"
    assert labels[("link6", "gripper_link")] == "/tf_static\nstatic"
    svg = (tmp_path / "tf.svg").read_text()
    assert all(f">{frame}<" in svg for frame in frames) and svg.count(">average 50 Hz<") == len(rec.tf)


def test_recorded_forest_with_odd_frames(tmp_path: Path) -> None:
    stamps = np.arange(0, 1_000_000_000, 100_000_000, dtype=np.int64)  # 10 Hz for 0.9 s
    series = FrameSeries(stamps, np.zeros((10, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (10, 1)))
    static = (np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))
    rec = Recording("odd.mcap", "mcap", tf={("map", "odom"): series, ("odom", "base"): series,
                                            ("world", "base"): series, ("cam", "optical"): series},
                    tf_static={("odom", "base"): static, ("base", "cam"): static, ("robot2", "arm"): static},
                    start_ns=0, end_ns=900_000_000)
    graph = recorded_graph(rec)
    assert graph.roots == ("map", "robot2", "world")
    assert graph.notes == ("on both /tf and /tf_static: base",
                           "frame 'base' has 2 parents (odom, world): tf keeps one")
    kinds = {(e.parent, e.child): (e.kind, e.details) for e in graph.edges}
    assert kinds[("odom", "base")] == ("static+dynamic", ("average 10 Hz", "10 transforms"))
    assert kinds[("robot2", "arm")] == ("static", ("static",))
    for fmt in ("png", "svg", "dot"):
        render_graph(graph, tmp_path / f"odd.{fmt}")
    svg = (tmp_path / "odd.svg").read_text()
    assert ">on /tf and /tf_static<" in svg and ">note: frame 'base' has 2 parents (odom, world): tf keeps one<" in svg
    assert "// note: frame 'base' has 2 parents" in (tmp_path / "odd.dot").read_text()
