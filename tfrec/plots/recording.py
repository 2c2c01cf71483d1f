"""A recording at a glance: joint positions and velocities over time, and the paths of chosen frames.

:func:`plot_recording` draws one panel of positions per unit (rad, m) and one of velocities beside
it, each joint in the same colour in every plot (:func:`tfrec.plots._figure.assign_colours`), its
limits as shaded bands; below, the paths of frames (default: the leaves of the TF tree) composed
from /tf_static and /tf into their root frame, seen from the top (x–y) and from the side (x–z).
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import DescriptionError, TfrecWarning, display_path
from tfrec.frames import FrameTree, frame_tree, graph_problems
from tfrec.kinematics.fk import root_from_link
from tfrec.model import JointType, Robot
from tfrec.plots._figure import (
    MAX_POINTS,
    PlotError,
    assign_colours,
    envelope,
    natural_key,
    plot_format,
    refuse_existing,
)
from tfrec.recording import JointStates, Recording, Transforms
from tfrec.resample import align, data_start_ns

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["FramePaths", "default_frames", "every_frame", "frame_paths", "one_robot", "plot_recording"]

Array = NDArray[np.float64]

DRAWABLE = 1e100
"""The largest magnitude a plot's axes reach (m, rad): a description may put a frame at 1e308 m, where
matplotlib's margins overflow; what lies beyond is drawn at the edge (joints) or not at all (paths)."""

MAX_POSES = 1_000_000
"""Poses (instants × frames on the way to the drawn ones) composed for the frame paths at most (56 MB): a
deep tree is drawn at fewer instants."""

MAX_PLOTTED = 64
"""Joints, and frame paths, drawn at most (each is a line and a legend entry: matplotlib lays out 5,000 legend
entries for minutes)."""

MAX_DEFAULT_FRAMES = 6
"""Leaves drawn when no frames are chosen: the deepest ones first."""

_UNITS = {"rad": ("position (rad)", "velocity (rad/s)"), "m": ("position (m)", "velocity (m/s)"),
          "": ("position", "velocity (per s)")}


def _tree(recording: Recording) -> FrameTree:
    """The recorded TF as a forest (:func:`tfrec.frames.frame_tree`): /tf_static, then /tf; a frame with
    several parents is placed below the first that reaches it, a cycle is not followed."""
    return frame_tree([*recording.tf_static, *recording.tf])


def default_frames(recording: Recording, *, limit: int = MAX_DEFAULT_FRAMES) -> list[str]:
    """The leaves of the recorded TF tree (frames below another that are nobody's parent), deepest
    first, at most ``limit``."""
    tree = _tree(recording)
    has_children = set(tree.parent.values())
    leaves = [frame for frame in tree.parent if frame not in has_children]
    return sorted(leaves, key=lambda f: (-tree.depth[f], natural_key(f)))[:limit]


def every_frame(recording: Recording) -> list[str]:
    """Every frame of the recorded TF tree, roots first, then by depth and name."""
    tree = _tree(recording)
    return sorted(tree.order, key=lambda f: (tree.depth[f], natural_key(f)))


@dataclass(frozen=True, slots=True)
class FramePaths:
    """Where frames go over time, in the frame at the root of their tree.

    Attributes:
        t_s: float64 (N,) seconds from the recording's start.
        positions: frame → float64 (N, 3) metres in its root frame; NaN where a transform on the
            way has no sample.
        roots: frame → its root frame.
    """

    t_s: Array
    positions: dict[str, Array]
    roots: dict[str, str]


def frame_paths(recording: Recording, frames: Sequence[str], *, max_samples: int = MAX_POINTS) -> FramePaths:
    """Root → frame positions of ``frames``, from /tf_static and /tf (:func:`~tfrec.kinematics.root_from_link`).

    Times are the stamps of the longest /tf series (at most ``max_samples`` of them, evenly spread, and
    fewer for frames deep in a tree: :data:`MAX_POSES`);
    the other series are interpolated at them (linearly, slerp for rotations), NaN outside their span.

    Raises:
        PlotError: a frame that is in neither /tf_static nor /tf.
    """
    tree = _tree(recording)
    known = tree.root
    unknown = [frame for frame in frames if frame not in known]
    if unknown:
        listed = ", ".join(sorted(known, key=natural_key)[:12]) + (" …" if len(known) > 12 else "")
        raise PlotError(f"{recording.path}: frames {', '.join(unknown)} not in /tf or /tf_static "
                        f"(its frames: {listed or 'none'})")
    for problem in graph_problems(tree):
        warnings.warn(f"{recording.path}: {problem}; frame paths are drawn along the other transforms", TfrecWarning, stacklevel=3)
    needed: set[str] = set()  # the frames on the way from the roots to ``frames``, each walked up once
    for frame in frames:
        while frame not in needed and frame in tree.parent:
            needed.add(frame)
            frame = tree.parent[frame]
    max_samples = max(2, min(max_samples, MAX_POSES // max(1, len(needed))))  # a chain of 100,000: 10 instants
    origin = data_start_ns(recording) or 0
    series = [s for s in recording.tf.values() if len(s)]
    if series:
        longest = max(series, key=len).time_ns
        index = np.unique(np.linspace(0, len(longest) - 1, min(len(longest), max_samples)).astype(np.int64))
        times = longest[index]
    else:
        times = np.array([origin], dtype=np.int64)
    roots = {frame: tree.root[frame] for frame in frames}
    positions: dict[str, Array] = {}
    for root, (fixed, dynamic) in _root_transforms(recording, tree, frames, needed, times).items():
        composed = root_from_link(fixed, dynamic, root=root)
        column = {child: k for k, child in enumerate(composed.children)}
        for frame in frames:
            if roots[frame] == root:
                k = column.get(frame)
                positions[frame] = (np.full((len(times), 3), np.nan) if k is None else
                                    np.broadcast_to(composed.translation[:, k], (len(times), 3)).copy())
    return FramePaths((times - origin) / 1e9, positions, roots)


def _root_transforms(recording: Recording, tree: FrameTree, frames: Sequence[str], needed: set[str],
                     times: NDArray[np.int64]) -> dict[str, tuple[Transforms, Transforms]]:
    """Root of each of ``frames`` → the transforms on the way from it to them (static, and /tf at ``times``):
    only the edges of the tree into the ``needed`` frames."""
    static: dict[str, dict[tuple[str, str], tuple[Array, Array]]] = {}
    dynamic: dict[str, list[tuple[tuple[str, str], Array, Array]]] = {}
    for frame in sorted({tree.root[frame] for frame in frames}, key=natural_key):
        static[frame], dynamic[frame] = {}, []
    for child in (frame for frame in tree.order if frame in needed):
        pair = (tree.parent[child], child)
        moving = recording.tf.get(pair)
        if moving is not None and len(moving):
            alignment = align(times, moving.time_ns)
            translation = np.full((len(times), 3), np.nan)
            rotation = np.full((len(times), 4), np.nan)
            translation[alignment.inside] = alignment.linear(moving.translation)
            rotation[alignment.inside] = alignment.rotations(moving.rotation)
            dynamic[tree.root[child]].append((pair, translation, rotation))
        elif pair in recording.tf_static:
            static[tree.root[child]][pair] = recording.tf_static[pair]
    n = len(times)
    none = Transforms((), (), np.zeros((1, 0, 3)), np.zeros((1, 0, 4)))
    return {root: (Transforms.from_poses(static[root]) if static[root] else none,
                   Transforms(tuple(p for (p, _), _, _ in dynamic[root]), tuple(c for (_, c), _, _ in dynamic[root]),
                              np.stack([t for _, t, _ in dynamic[root]], axis=1) if dynamic[root] else np.zeros((n, 0, 3)),
                              np.stack([q for _, _, q in dynamic[root]], axis=1) if dynamic[root] else np.zeros((n, 0, 4))))
            for root in static}


def _robot(recording: Recording, robot: Robot | None) -> Robot | None:
    if robot is not None or recording.robot_description is None:
        return robot
    from tfrec.description import parse_urdf

    try:
        return parse_urdf(recording.robot_description, source=f"{recording.path}:/robot_description")
    except DescriptionError as err:
        warnings.warn(f"{err}; joints are plotted without units and limits", TfrecWarning, stacklevel=3)
        return None


def _unit(name: str, robot: Robot | None) -> str:
    joint = None if robot is None else robot.joint_by_name.get(name)
    if joint is None or not joint.type.moves:
        return ""
    return "m" if joint.type is JointType.PRISMATIC else "rad"


def _velocities(t: Array, q: Array) -> Array:
    """d q / d t by central differences (one-sided at the ends), NaN where stamps repeat or a position is missing."""
    if len(t) < 2:
        return np.full_like(q, np.nan)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # over: positions near ±1.8e308
        v: Array = np.gradient(q, t, axis=0)
    v[~np.isfinite(v)] = np.nan
    return v


def _view(ax: Axes, data: Array, bands: list[tuple[float, float]]) -> bool:
    """Y limits around the data, and the limit bands when they are not far wider than the data.

    Returns:
        Whether the bands are in view (bands far wider than the data would shade all of it: not drawn).
    """
    finite = data[np.isfinite(data)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (-1.0, 1.0)
    lo, hi = max(lo, -DRAWABLE), min(hi, DRAWABLE)
    span = max(hi - lo, 1e-9)
    shown = False
    bands = [(max(b_lo, -DRAWABLE), min(b_hi, DRAWABLE)) for b_lo, b_hi in bands]
    if bands:
        b_lo, b_hi = min(b for b, _ in bands), max(b for _, b in bands)
        if b_hi - b_lo <= 20.0 * span or lo < b_lo or hi > b_hi:
            lo, hi = min(lo, b_lo), max(hi, b_hi)
            span = hi - lo
            shown = True
    ax.set_ylim(lo - 0.06 * span, hi + 0.06 * span)
    return shown


def _bands(ax: Axes, intervals: dict[tuple[float, float], list[str]], colours: dict[str, tuple[str, str]]) -> None:
    for (lo, hi), names in sorted(intervals.items()):
        lo, hi = max(lo, -DRAWABLE), min(hi, DRAWABLE)
        colour = "#7f7f7f" if len(names) > 1 else colours[names[0]][0]
        ax.axhspan(lo, hi, facecolor=colour, alpha=0.06, linewidth=0, zorder=0)
        for y in (lo, hi):
            ax.axhline(y, color=colour, linewidth=0.8, linestyle=(0, (4, 3)), alpha=0.8, zorder=1)


def one_robot(recording: Recording, namespace: str | None = None) -> Recording:
    """The recording as the one robot a plot draws: the root namespace's robot topics when it has any
    (and no ``namespace`` is chosen), else the only robot of the recording (``/robot1/joint_states``,
    ``/robot1/tf``…, or one of several robots sharing /tf by frame prefix), else the robot of
    ``namespace`` (``/robot1``; ``""`` the root).

    Raises:
        PlotError: several robots and no ``namespace`` to choose one, or none in ``namespace``.
    """
    from tfrec.robots import find_robots

    if namespace is None and recording.robot_topics("").has_data():
        return recording
    robots = [r for r in find_robots(recording, namespace=namespace) if not r.unclaimed]
    if not robots:
        if namespace is None:
            return recording  # nothing to plot: plot_recording says so
        found = ", ".join(name or "/" for name in recording.topic_namespaces()) or "none"
        raise PlotError(f"{recording.path}: no robot in namespace '{namespace or '/'}' (namespaces with robot "
                        f"topics: {found})")
    if len(robots) > 1:
        keys = ", ".join(r.key or "/" for r in robots)
        raise PlotError(f"{recording.path}: {len(robots)} robots ({keys}): choose one with --namespace"
                        + (" (they share one namespace: plot one of them with --frames)" if namespace is not None
                           else ""))
    found_robot = robots[0]
    return dataclasses.replace(recording, robot_description=found_robot.robot_description, robot_descriptions=(),
                               joint_states=found_robot.joint_states, tf=dict(found_robot.tf),
                               tf_static=dict(found_robot.tf_static), namespaces={})


def plot_recording(recording: Recording, path: str | os.PathLike[str], *, robot: Robot | None = None,
                   frames: Sequence[str] | None = None, namespace: str | None = None, force: bool = False) -> None:
    """Plot a recording's joint states and frame paths to ``path`` (``.png``, ``.svg`` or ``.pdf``).

    Args:
        recording: from :func:`tfrec.readers.read_recording`.
        path: the picture; its suffix chooses the format.
        robot: the model for joint units and limits; default: the recording's /robot_description
            (without either, joints go in one panel without units or limits).
        frames: frames whose paths are drawn; default: the deepest leaves of the TF tree.
        namespace: the robot to draw when the recording has several (``/robot1``; ``""`` the root
            namespace's); see :func:`one_robot`.

    Raises:
        PlotError: a bad suffix, a recording with neither /joint_states nor /tf, an unknown frame,
            or several robots and no ``namespace``.
        WriteError: the file cannot be written.
    """
    fmt = plot_format(path)
    refuse_existing(path, force=force, inputs=[recording.path] if recording.path else [])
    recording = one_robot(recording, namespace)
    js = recording.joint_states
    if js is not None and not (len(js) and js.names):  # joint states that name no joint: nothing to draw
        js = None
    if js is not None and len(js.names) > MAX_PLOTTED:
        warnings.warn(f"{recording.path}: {len(js.names):,} joints in /joint_states: the first {MAX_PLOTTED} are "
                      "drawn (a plot of more is unreadable, and takes matplotlib minutes)", TfrecWarning, stacklevel=2)
        js = JointStates(js.time_ns, js.names[:MAX_PLOTTED], js.positions[:, :MAX_PLOTTED])
    model = _robot(recording, robot)
    still = js is None and not any(len(series) for series in recording.tf.values())
    chosen = list(frames) if frames is not None else (every_frame(recording) if still else default_frames(recording))
    if len(chosen) > MAX_PLOTTED:
        warnings.warn(f"{recording.path}: {len(chosen):,} frames chosen: the paths of the first {MAX_PLOTTED} are "
                      "drawn", TfrecWarning, stacklevel=2)
        chosen = chosen[:MAX_PLOTTED]
    if js is None and not chosen and not still:  # /tf holds nothing but frames that are their own parent
        raise PlotError(f"{recording.path}: nothing to plot: no /joint_states, and no frame of /tf lies below "
                        f"another ({'; '.join(graph_problems(_tree(recording), parents=False)) or 'no frames'})")
    paths = frame_paths(recording, chosen) if chosen else None
    if js is None and paths is None:
        if model is None or model.joints:
            raise PlotError(f"{recording.path}: nothing to plot: no /joint_states, /tf or /tf_static")
        paths = FramePaths(np.zeros(1), {model.root: np.zeros((1, 3))}, {model.root: model.root})  # its one link
    if paths is not None:
        far = sorted(frame for frame, xyz in paths.positions.items() if (np.abs(xyz) > DRAWABLE).any())
        if far:
            warnings.warn(f"{recording.path}: frame paths not drawn: {', '.join(far)} reach{'es' if len(far) == 1 else ''}"
                          f" more than {DRAWABLE:g} m from the root", TfrecWarning, stacklevel=2)
            paths = None
    from tfrec.plots._figure import plot_style, save_figure

    with plot_style():
        fig = _draw(recording, js, model, paths)
        save_figure(fig, path, fmt, force=force)


def _draw(recording: Recording, js: Any, robot: Robot | None, paths: FramePaths | None) -> Any:
    from tfrec.plots._figure import new_figure

    units: list[str] = []
    if js is not None:
        present = {_unit(name, robot) for name in js.names}
        units = [u for u in ("rad", "m", "") if u in present]
    rows = len(units) + (1 if paths is not None else 0)
    heights = [2.5] * len(units) + ([4.2] if paths is not None else [])
    fig = new_figure(14.0, 1.0 + sum(heights))
    fig.set_layout_engine("constrained", h_pad=0.08, w_pad=0.08)
    grid = fig.add_gridspec(rows, 2, height_ratios=heights)
    origin = data_start_ns(recording) or 0
    span = f"{recording.duration_ns / 1e9:.2f} s" if recording.start_ns is not None else "empty"
    still = js is None and not any(len(series) for series in recording.tf.values())
    shows = " and ".join(what for what, there in (("joint states", js is not None), ("frame paths", paths is not None))
                         if there)
    if still:
        shows = "frame positions; nothing moves" + (" (no moving joints)" if robot is not None and
                                                     not robot.moving_joints else "")
    fig.suptitle(f"Recording {display_path(recording.path)} ({recording.format}, {span}): {shows}", fontsize=12,
                 fontweight="bold",
                 x=0.01, ha="left")
    if js is not None:
        t = (js.time_ns - origin) / 1e9
        colours = assign_colours(js.names)
        velocities = _velocities(t, js.positions)
        first: Axes | None = None
        for row, unit in enumerate(units):
            names = [(k, name) for k, name in enumerate(js.names) if _unit(name, robot) == unit]
            cols = [k for k, _ in names]
            for side, values in ((0, js.positions), (1, velocities)):
                ax = fig.add_subplot(grid[row, side], sharex=first)
                first = first or ax
                tt, yy = envelope(t, values[:, cols])
                intervals: dict[tuple[float, float], list[str]] = {}
                for j, (_, name) in enumerate(names):
                    colour, style = colours[name]
                    ax.plot(tt, yy[:, j], color=colour, linestyle=style, linewidth=1.2, label=name)
                    joint = None if robot is None else robot.joint_by_name.get(name)
                    if joint is not None and joint.limit is not None and joint.type is not JointType.CONTINUOUS:
                        band = ((joint.limit.lower, joint.limit.upper) if side == 0
                                else (-joint.limit.velocity, joint.limit.velocity))
                        if band[1] > band[0]:
                            intervals.setdefault(band, []).append(name)
                shown = _view(ax, yy, list(intervals))
                if shown:
                    _bands(ax, intervals, colours)
                ax.set_ylabel(_UNITS[unit][side])
                ax.grid(True, linewidth=0.4, alpha=0.5)
                what = "joint positions" if side == 0 else "joint velocities (differentiated from positions)"
                limits = (" — between dashed lines: within limits" if shown
                          else " — limits far beyond the data, not drawn" if intervals else "")
                ax.set_title(f"{what}{limits}", loc="left", fontsize=9)
                if side == 1:
                    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=8,
                              ncol=1 if len(names) <= 12 else 2)
                if row == len(units) - 1:
                    ax.set_xlabel("time (s) from the recording's start")
    if paths is not None:
        _draw_paths(fig, grid[rows - 1, 0], grid[rows - 1, 1], paths, what="frame positions" if still else "frame paths")
    return fig


def _draw_paths(fig: Any, top_slot: Any, side_slot: Any, paths: FramePaths, *, what: str = "frame paths") -> None:
    colours = assign_colours(paths.positions)
    roots = sorted(set(paths.roots.values()), key=natural_key)
    where = f"in {roots[0]}" if len(roots) == 1 else "each in the root of its tree"
    for slot, (a, b, view) in ((top_slot, (0, 1, "top view (x–y)")), (side_slot, (0, 2, "side view (x–z)"))):
        ax = fig.add_subplot(slot)
        for frame in sorted(paths.positions, key=natural_key):
            xyz = paths.positions[frame]
            colour, style = colours[frame]
            width = 1.2 if len(xyz) <= 1500 else 0.6  # a long path: thinner, so its shape shows
            ax.plot(xyz[:, a], xyz[:, b], color=colour, linestyle=style, linewidth=width, label=frame)
            ok = np.flatnonzero(np.isfinite(xyz[:, a]) & np.isfinite(xyz[:, b]))
            if ok.size and what != "frame paths":  # frames that stay put: a dot and their name
                ax.plot(xyz[ok[0], a], xyz[ok[0], b], marker="o", color=colour, markersize=6)
                ax.annotate(frame, (xyz[ok[0], a], xyz[ok[0], b]), textcoords="offset points", xytext=(5, 4),
                            fontsize=8, color=colour, annotation_clip=False, parse_math=False)
            elif ok.size:
                ax.plot(xyz[ok[0], a], xyz[ok[0], b], marker="o", color=colour, markersize=5)
                ax.plot(xyz[ok[-1], a], xyz[ok[-1], b], marker="s", color=colour, markersize=5,
                        markerfacecolor="white")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(f"{'xyz'[a]} (m)")
        ax.set_ylabel(f"{'xyz'[b]} (m)")
        ax.grid(True, linewidth=0.4, alpha=0.5)
        ax.set_title(f"{what}, {view}, {where}" + (" — ● start, □ end" if what == "frame paths" else ""),
                     loc="left", fontsize=9)
        if b == 2:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=8)
