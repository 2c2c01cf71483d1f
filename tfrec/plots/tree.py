"""The TF tree as a picture: a robot's links and joints (like ``urdf_to_graphiz``), or the frames of
a recording (like ``rosrun tf view_frames``).

:func:`robot_graph` and :func:`recorded_graph` turn a model or a recording into a
:class:`TreeGraph`: frames as nodes, transforms as labelled edges. :func:`to_dot` writes it as
Graphviz DOT (which needs nothing installed to write); :func:`render_graph` writes DOT, SVG, PNG or
PDF by the file's suffix, laid out by a tidy-tree layout of our own (:mod:`tfrec.plots._layout`) and
drawn with matplotlib — no Graphviz needed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from tfrec.errors import TfrecError, display_path, one_line, printable
from tfrec.frames import FrameTree, frame_tree, graph_problems
from tfrec.model import Joint, JointType, Robot
from tfrec.plots._figure import PlotError, graph_format, natural_key, refuse_existing, write_text
from tfrec.plots._layout import tidy_layout
from tfrec.recording import Recording

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["GraphEdge", "TreeGraph", "described_roots", "recorded_graph", "render_graph", "robot_graph", "to_dot"]

STATIC, DYNAMIC, BOTH = "static", "dynamic", "static+dynamic"

EDGE_STYLES: dict[str, tuple[str, Any, str]] = {
    # kind: (colour, line style, legend label)
    JointType.REVOLUTE.value: ("#1f77b4", "solid", "revolute"),
    JointType.CONTINUOUS.value: ("#17becf", "solid", "continuous"),
    JointType.PRISMATIC.value: ("#e6700b", "solid", "prismatic"),
    JointType.FIXED.value: ("#7f7f7f", "dashed", "fixed"),
    JointType.FLOATING.value: ("#9467bd", "dotted", "floating (no TF)"),
    JointType.PLANAR.value: ("#8c564b", "dotted", "planar (TF of its origin)"),
    DYNAMIC: ("#1f77b4", "solid", "/tf (dynamic)"),
    STATIC: ("#7f7f7f", "dashed", "/tf_static (static)"),
    BOTH: ("#d62728", "solid", "on /tf and /tf_static"),
}
"""How an edge of each kind is drawn: a joint type, or static/dynamic for recorded transforms."""

NODE_FILL, ROOT_FILL, NODE_EDGE = "#eef3fb", "#fde9c9", "#4a6fa5"


@dataclass(frozen=True, slots=True)
class GraphEdge:
    """One transform parent → child.

    Attributes:
        parent, child: the frames (link names, or frame ids as recorded).
        name: the first line of the label: the joint's name, or the topic.
        kind: a joint type (``revolute``…) or ``static``/``dynamic``/``static+dynamic``: how it is drawn.
        details: the further lines of the label (type and axis, limits; rate and samples).
    """

    parent: str
    child: str
    name: str
    kind: str
    details: tuple[str, ...] = ()

    @property
    def label(self) -> tuple[str, ...]:
        return (self.name, *self.details)


@dataclass(frozen=True, slots=True)
class TreeGraph:
    """A TF tree (or forest) to draw.

    Attributes:
        name: the graph's name in DOT (the robot's name, or the recording's file name).
        title, subtitle: what the picture shows and of which file.
        nodes: every frame, in drawing order.
        edges: every transform, parents before children where there is a tree.
        roots: frames with no parent, left to right.
        notes: remarks drawn under the tree (frames with two parents, on both topics…).
    """

    name: str
    title: str
    subtitle: str
    nodes: tuple[str, ...]
    edges: tuple[GraphEdge, ...]
    roots: tuple[str, ...]
    notes: tuple[str, ...] = ()


def _num(value: float) -> str:
    return f"{value:.4g}" if value else "0"


def _joint_details(joint: Joint) -> tuple[str, ...]:
    if not joint.type.moves:
        return (joint.type.value,)
    axis = " ".join(_num(v) for v in joint.axis)
    lines = [f"{joint.type.value}, axis ({axis})"]
    unit = "m" if joint.type is JointType.PRISMATIC else "rad"
    if joint.limit is not None and joint.type is not JointType.CONTINUOUS:
        lines.append(f"[{_num(joint.limit.lower)}, {_num(joint.limit.upper)}] {unit}")
    if joint.mimic is not None:
        lines.append(f"mimics {joint.mimic.joint} ×{_num(joint.mimic.multiplier)}"
                     + (f" {'+' if joint.mimic.offset >= 0 else '-'}{_num(abs(joint.mimic.offset))}"
                        if joint.mimic.offset else ""))
    return tuple(lines)


def robot_graph(robot: Robot) -> TreeGraph:
    """The kinematic tree of a robot: links as nodes, joints as edges labelled with name, type, axis, limits."""
    edges = tuple(GraphEdge(j.parent, j.child, j.name, j.type.value, _joint_details(j)) for j in robot.tree_order)
    actuated = len(robot.actuated_joints)
    source = display_path(robot.source) if robot.source else "URDF text"
    return TreeGraph(
        name=robot.name,
        title=f"TF tree of robot '{robot.name}' ({source})",
        subtitle=f"{len(robot.links)} links, {len(robot.joints)} joints ({actuated} actuated)",
        nodes=tuple(link.name for link in robot.links),
        edges=edges,
        roots=(robot.root,),
    )


def _rate(time_ns: np.ndarray[Any, np.dtype[np.int64]]) -> tuple[str, ...]:
    """``("average 50 Hz", "251 transforms")``: the rate from the first and last stamp."""
    n = len(time_ns)
    count = f"{n:,} transform{'s' if n != 1 else ''}"
    if n < 2 or time_ns[-1] <= time_ns[0]:
        return (count,)
    rate_hz = (n - 1) / ((int(time_ns[-1]) - int(time_ns[0])) / 1e9)
    return (f"average {rate_hz:.4g} Hz", count)


def _tree_order(nodes: list[str], edges: list[GraphEdge]) -> tuple[FrameTree, list[str], list[GraphEdge]]:
    """The forest (:func:`tfrec.frames.frame_tree`), nodes breadth-first from the roots (then any left in a
    cycle), edges in the order of their child."""
    has_parent = {edge.child for edge in edges}
    tree = frame_tree([(edge.parent, edge.child) for edge in edges], roots=[*(n for n in nodes if n not in has_parent),
                                                                             *nodes])
    order = list(dict.fromkeys([*tree.order, *nodes]))
    rank = {node: k for k, node in enumerate(order)}
    return tree, order, sorted(edges, key=lambda edge: (rank[edge.child], rank[edge.parent]))


def recorded_graph(recording: Recording) -> TreeGraph:
    """The frames of a recording's /tf_static and /tf: parent → child, average rate, static or dynamic, topic.

    A pair on both topics is one edge of kind ``static+dynamic``; a frame with several parents (which
    tf rejects) gets all of its edges; both are noted.
    """
    pairs = sorted(set(recording.tf_static) | set(recording.tf), key=lambda p: (natural_key(p[1]), natural_key(p[0])))
    edges: list[GraphEdge] = []
    both: list[str] = []
    for parent, child in pairs:
        series = recording.tf.get((parent, child))
        static = (parent, child) in recording.tf_static
        if series is None:
            edges.append(GraphEdge(parent, child, "/tf_static", STATIC, ("static",)))
        elif not static:
            edges.append(GraphEdge(parent, child, "/tf", DYNAMIC, _rate(series.time_ns)))
        else:
            both.append(child)
            edges.append(GraphEdge(parent, child, "/tf + /tf_static", BOTH, _rate(series.time_ns)))
    tree, frames, edges = _tree_order(sorted({frame for pair in pairs for frame in pair}, key=natural_key), edges)
    parents: dict[str, list[str]] = {}
    for edge in edges:
        parents.setdefault(edge.child, []).append(edge.parent)
    notes = []
    if both:
        notes.append(f"on both /tf and /tf_static: {', '.join(both)}")
    for child, of in parents.items():
        if len(of) > 1:
            notes.append(f"frame '{child}' has {len(of)} parents ({', '.join(of)}): tf keeps one")
    notes += graph_problems(tree, parents=False)
    roots = tuple(frame for frame in frames if frame not in parents)
    if not frames:  # a robot without joints has no TF: its tree is its root link alone
        frames = described_roots(recording)
        roots = tuple(frames)
        notes.extend(f"no TF recorded: '{frame}' is the root link of the recorded /robot_description" for frame in frames)
    n_static = sum(edge.kind != DYNAMIC for edge in edges)
    span = f", {recording.duration_ns / 1e9:.2f} s" if recording.start_ns is not None else ""
    return TreeGraph(
        name=printable(os.path.basename(os.path.normpath(recording.path))) or "tf",
        title=f"TF tree recorded in {display_path(recording.path)}",
        subtitle=f"{len(frames)} frame{'s' if len(frames) != 1 else ''}, {n_static} on /tf_static, {len(edges) - n_static + len(both)} on /tf"
                 f" ({recording.format}{span})",
        nodes=tuple(frames),
        edges=tuple(edges),
        roots=roots,
        notes=tuple(notes),
    )


def described_roots(recording: Recording) -> list[str]:
    """The root link of every robot description a recording holds (descriptions that do not parse are
    left out): the frames of a TF tree that recorded no transform."""
    from tfrec.description.urdf import parse_urdf

    roots: dict[str, None] = {}
    for namespace in [""] + sorted(recording.namespaces):
        for text in recording.robot_topics(namespace).descriptions:
            try:
                roots.setdefault(parse_urdf(text, source=None, user_lines=False).root)
            except TfrecError:
                continue
    return list(roots)


# -- DOT ------------------------------------------------------------------------------------------


def _quote(text: str) -> str:
    """A DOT quoted string of any text: backslashes and quotes escaped, line breaks as ``\\n``."""
    out = text.replace("\\", "\\\\").replace('"', '\\"').replace("\r\n", "\n").replace("\r", "\n")
    out = out.replace("\n", "\\n")
    return '"' + "".join(c if c >= " " else "?" for c in out) + '"'


def to_dot(graph: TreeGraph) -> str:
    """The graph as Graphviz DOT text (``dot -Tsvg``), the same text for the same graph."""
    lines = [f"// {one_line(graph.title)}: {one_line(graph.subtitle)} (written by tfrec)"]
    lines.extend(f"// note: {one_line(note)}" for note in graph.notes)
    lines.append(f"digraph {_quote(graph.name)} {{")
    lines.append(f"  graph [label={_quote(graph.title + chr(10) + graph.subtitle)}, labelloc=t, rankdir=TB, "
                 'fontname="Helvetica", nodesep=0.3, ranksep=0.4];')
    lines.append(f'  node [shape=box, style="rounded,filled", fillcolor="{NODE_FILL}", color="{NODE_EDGE}", '
                 'fontname="Helvetica", fontsize=11];')
    lines.append('  edge [fontname="Helvetica", fontsize=9, arrowsize=0.7];')
    roots = set(graph.roots)
    for node in graph.nodes:
        lines.append(f"  {_quote(node)}" + (f' [fillcolor="{ROOT_FILL}"]' if node in roots else "") + ";")
    for edge in graph.edges:
        colour, style, _ = EDGE_STYLES[edge.kind]
        lines.append(f"  {_quote(edge.parent)} -> {_quote(edge.child)} [label={_quote(chr(10).join(edge.label))}, "
                     f'color="{colour}", fontcolor="#333333", style={style}];')
    lines.append("}")
    return "\n".join(lines) + "\n"


# -- drawing --------------------------------------------------------------------------------------

_NODE_PT, _NAME_PT, _DETAIL_PT = 9.0, 7.5, 7.0
_PAD_X, _PAD_Y, _LINE = 7.0, 3.5, 1.3  # points; line height as a multiple of the font size
_GAP_X, _GAP_Y = 0.22, 0.16  # inches between columns, between a box and a label
_MARGIN, _TITLE_H = 0.3, 0.62
MAX_INCHES = 60.0
"""The longest side of a graph picture; larger trees are drawn smaller."""
MAX_DRAWN_FRAMES = 1_000
"""Frames a picture (SVG, PNG, PDF) is drawn of at most: 1,000 frames in a chain take ~9 s to draw and are
unreadable at :data:`MAX_INCHES` already; larger trees are written as DOT (linear, any size)."""


class _Measure:
    """Text extents in points, from matplotlib's own font metrics (no figure needed)."""

    def __init__(self) -> None:
        from matplotlib.backends.backend_agg import RendererAgg

        self._renderer = RendererAgg(8, 8, 72)  # type: ignore[no-untyped-call]  # at 72 dpi a pixel is a point
        self._props: dict[tuple[float, str], Any] = {}

    def width(self, text: str, size: float, weight: str = "normal") -> float:
        from matplotlib.font_manager import FontProperties

        props = self._props.get((size, weight))
        if props is None:
            props = self._props[(size, weight)] = FontProperties(family="sans-serif", size=size, weight=weight)
        measure = self._renderer.get_text_width_height_descent
        w, _, _ = measure(text, props, ismath=False)  # type: ignore[no-untyped-call]
        return float(w)


@dataclass(frozen=True, slots=True)
class _Box:
    w: float  # inches
    h: float


def _shown(text: str) -> str:
    """Text as drawn: control characters (a line break in a frame name) spelled out."""
    return "".join(c if c >= " " else ("\\n" if c == "\n" else f"\\x{ord(c):02x}") for c in text)


def _put(ax: Axes, x: float, y: float, text: str, **style: Any) -> None:
    """Draw text as it is: control characters spelled out, no mathtext (a frame may be named ``a$b$``)."""
    ax.text(x, y, _shown(text), parse_math=False, **style)


def _spanning_forest(graph: TreeGraph) -> tuple[list[str], dict[str, list[str]], dict[str, GraphEdge], list[GraphEdge]]:
    """Roots, tree children, each tree child's edge, and the edges left over (a second parent, a cycle):
    :func:`tfrec.frames.frame_tree` from the graph's roots, nodes in a cycle starting trees of their own."""
    tree = frame_tree([(edge.parent, edge.child) for edge in graph.edges], roots=[*graph.roots, *graph.nodes])
    children: dict[str, list[str]] = {}
    incoming: dict[str, GraphEdge] = {}
    for edge in graph.edges:
        if tree.parent.get(edge.child) == edge.parent and edge.child not in incoming:
            incoming[edge.child] = edge
            children.setdefault(edge.parent, []).append(edge.child)
    extra = [edge for edge in graph.edges if incoming.get(edge.child) is not edge]
    return tree.roots, children, incoming, extra


def render_graph(graph: TreeGraph, path: str | os.PathLike[str], *, force: bool = False) -> None:
    """Write the graph to ``path`` as DOT, SVG, PNG or PDF, chosen by the suffix.

    Frames are boxes (roots shaded), transforms arrows from parent to child with their label in a
    box of the edge's colour; the tree is laid out top-down, and the picture grows with the tree up
    to :data:`MAX_INCHES` a side, beyond which it is drawn smaller. SVG output is the same bytes for
    the same graph.

    Raises:
        PlotError: a suffix other than ``.dot``, ``.svg``, ``.png`` or ``.pdf``, a graph without frames, or
            a picture of more than :data:`MAX_DRAWN_FRAMES` frames.
        WriteError: the file cannot be written.
    """
    fmt = graph_format(path)
    refuse_existing(path, force=force)
    if not graph.nodes:
        raise PlotError(f"{graph.title}: no frames to draw")
    if fmt != "dot" and len(graph.nodes) > MAX_DRAWN_FRAMES:
        raise PlotError(f"{graph.title}: {len(graph.nodes):,} frames are more than a picture is drawn of (at most "
                        f"{MAX_DRAWN_FRAMES:,}): write a .dot file instead (Graphviz lays it out: dot -Tsvg)")
    if fmt == "dot":
        write_text(path, to_dot(graph), force=force)
        return
    from tfrec.plots._figure import plot_style, save_figure

    with plot_style():
        fig = _draw(graph)
        save_figure(fig, path, fmt, force=force)


def _draw(graph: TreeGraph) -> Any:  # noqa: PLR0915 - one figure, drawn in order: labels, edges, nodes, legend
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

    from tfrec.plots._figure import new_figure

    measure = _Measure()
    node_h = (_NODE_PT * _LINE + 2 * _PAD_Y) / 72.0
    nodes = {n: _Box((measure.width(_shown(n), _NODE_PT) + 2 * _PAD_X) / 72.0, node_h) for n in graph.nodes}
    roots, children, incoming, extra = _spanning_forest(graph)
    labels: dict[str, _Box] = {}
    for child, edge in incoming.items():
        width = max([measure.width(_shown(edge.name), _NAME_PT, "bold")]
                    + [measure.width(_shown(d), _DETAIL_PT) for d in edge.details])
        height = (_NAME_PT + _DETAIL_PT * len(edge.details)) * _LINE + 2 * _PAD_Y
        labels[child] = _Box((width + 2 * _PAD_X) / 72.0, height / 72.0)
    widths = {n: max(nodes[n].w, labels[n].w if n in labels else 0.0) for n in graph.nodes}
    place = tidy_layout(roots, children, widths, gap=_GAP_X)
    # rows: a label band above every depth but the first
    band = [0.0] * max(place.levels, 1)
    for child, box in labels.items():
        band[place.depth[child]] = max(band[place.depth[child]], box.h)
    y_node: list[float] = []
    y = _MARGIN + _TITLE_H + node_h / 2.0
    for d in range(place.levels):
        if d:
            y += node_h / 2.0 + 2 * _GAP_Y + band[d] + node_h / 2.0
        y_node.append(y)
    kinds = sorted({edge.kind for edge in graph.edges}, key=list(EDGE_STYLES).index)
    notes = list(graph.notes)
    bottom = (0.35 if kinds else 0.0) + 0.2 * len(notes) + _MARGIN
    width = max(place.width + 2 * _MARGIN, 6.0,
                measure.width(_shown(graph.title), 12.0, "bold") / 72.0 + 2 * _MARGIN)
    height = (y_node[-1] if y_node else _MARGIN + _TITLE_H) + node_h / 2.0 + bottom
    scale = min(1.0, MAX_INCHES / max(width, height))
    fig = new_figure(width * scale, height * scale)
    ax: Axes = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.set_xlim(0.0, width)
    ax.set_ylim(height, 0.0)
    ax.set_axis_off()
    left = (width - place.width) / 2.0
    x = {n: left + place.x[n] for n in place.x}
    ydepth = {n: y_node[place.depth[n]] for n in place.x}
    _put(ax, _MARGIN, _MARGIN, graph.title, fontsize=12 * scale, fontweight="bold", va="top", ha="left")
    _put(ax, _MARGIN, _MARGIN + 0.27, graph.subtitle, fontsize=9 * scale, color="#444444", va="top", ha="left")
    roots_set = set(graph.roots)
    for child, edge in incoming.items():
        colour, style, _ = EDGE_STYLES[edge.kind]
        box = labels[child]
        d = place.depth[child]
        ly = y_node[d - 1] + node_h / 2.0 + _GAP_Y + band[d] / 2.0
        top, bot = ly - box.h / 2.0, ly + box.h / 2.0
        px, py = x[edge.parent], ydepth[edge.parent] + node_h / 2.0
        ax.plot([px, x[child]], [py, top], color=colour, linestyle=style, linewidth=1.0 * scale, zorder=1)
        ax.add_patch(FancyArrowPatch((x[child], bot), (x[child], ydepth[child] - node_h / 2.0),
                                     arrowstyle="-|>", mutation_scale=8 * scale, color=colour,
                                     linewidth=1.0 * scale, shrinkA=0.0, shrinkB=0.0, zorder=1))
        ax.add_patch(FancyBboxPatch((x[child] - box.w / 2.0, top), box.w, box.h,
                                    boxstyle="round,pad=0,rounding_size=0.05", facecolor="white",
                                    edgecolor=colour, linestyle=style, linewidth=0.8 * scale, zorder=2))
        line_y = top + (_PAD_Y + _NAME_PT * _LINE / 2.0) / 72.0
        _put(ax, x[child], line_y, edge.name, fontsize=_NAME_PT * scale, fontweight="bold", color="#222222",
                ha="center", va="center", zorder=3)
        line_y += (_NAME_PT + _DETAIL_PT) * _LINE / 2.0 / 72.0
        for detail in edge.details:
            _put(ax, x[child], line_y, detail, fontsize=_DETAIL_PT * scale, color="#444444", ha="center",
                    va="center", zorder=3)
            line_y += _DETAIL_PT * _LINE / 72.0
    for edge in extra:  # a second parent or a cycle: drawn across the tree
        colour = EDGE_STYLES[BOTH][0]
        start = (x[edge.parent], ydepth[edge.parent])
        end = (x[edge.child], ydepth[edge.child])
        ax.add_patch(FancyArrowPatch(start, end, arrowstyle="-|>", connectionstyle="arc3,rad=0.25",
                                     mutation_scale=8 * scale, color=colour, linestyle="dashed",
                                     linewidth=1.0 * scale, shrinkA=8 * scale, shrinkB=8 * scale, zorder=1))
        _put(ax, (start[0] + end[0]) / 2.0, (start[1] + end[1]) / 2.0, " · ".join(edge.label),
                fontsize=_DETAIL_PT * scale,
                color=colour, ha="center", va="center", zorder=3,
                bbox={"boxstyle": "round,pad=0.2", "facecolor": "white", "edgecolor": colour, "linewidth": 0.6 * scale})
    for node in graph.nodes:
        box = nodes[node]
        ax.add_patch(FancyBboxPatch((x[node] - box.w / 2.0, ydepth[node] - box.h / 2.0), box.w, box.h,
                                    boxstyle="round,pad=0,rounding_size=0.06",
                                    facecolor=ROOT_FILL if node in roots_set else NODE_FILL, edgecolor=NODE_EDGE,
                                    linewidth=1.0 * scale, zorder=2))
        _put(ax, x[node], ydepth[node], node, fontsize=_NODE_PT * scale, ha="center", va="center_baseline", zorder=3)
    y = height - bottom + 0.15
    if kinds:
        handles = [Line2D([], [], color=EDGE_STYLES[k][0], linestyle=EDGE_STYLES[k][1], linewidth=1.5 * scale)
                   for k in kinds]
        fig.legend(handles, [EDGE_STYLES[k][2] for k in kinds], loc="lower left", ncol=len(kinds), frameon=False,
                   fontsize=8 * scale, bbox_to_anchor=(_MARGIN / width, (bottom - 0.4) / height),
                   handlelength=2.5, columnspacing=1.5)
        y += 0.35
    for note in notes:
        _put(ax, _MARGIN, y - 0.15, "note: " + note, fontsize=8 * scale, color="#8a1c1c", ha="left", va="top")
        y += 0.2
    return fig
