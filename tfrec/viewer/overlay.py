"""Two robots of a diff as one Rerun recording: a ghost overlay that shows where they differ.

Both robots move together, each logged through its own :class:`~tfrec.viewer.sink.RerunSink`
under its own entity prefix and frame prefix — A at ``/a`` (frames ``a/<link>``), solid, every link
coloured by its current error (green within tolerance, through yellow, to red at the worst error of
the whole diff); B at ``/b`` (frames ``b/<link>``), a translucent ghost. B's root frame is A's root
frame (an identity transform at ``/b/tf_static/root``), so the two overlap where they agree.

Beside the 3D view: the largest link error at every instant, position (m) and orientation (rad), each
with its tolerance as a line, and the moment each link first exceeds its tolerance as a marker on
the plot and an entry of the events log (``/diff/events``, also marked on the timeline).

Entity paths (beside each robot's, as in :mod:`tfrec.formats.rrd.paths`, under ``/a`` and ``/b``):

- ``/diff/position/error`` and ``/diff/rotation/error``: ``Scalars``, the largest error of any link;
- ``/diff/position/tolerance`` and ``/diff/rotation/tolerance``: ``Scalars``, the tolerance;
- ``/diff/position/first_exceeds``: ``Scalars`` + ``SeriesPoints``, one point per link, when it first
  exceeds its tolerance (its error then);
- ``/diff/events``: ``TextLog``, the same moments in words;
- ``/diff/legend``: ``TextDocument`` (Markdown), the colour scale with the errors it stands for.

Only plain data comes in (:class:`OverlayRobot`, :class:`OverlayErrors`); the diff computes it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from tfrec.errors import WriteError
from tfrec.formats.rrd.paths import TIMELINE, visual_entity
from tfrec.model import Robot
from tfrec.recording import Transforms
from tfrec.viewer.blueprint import Reach, stable_ids
from tfrec.viewer.columns import ArrowTimeColumn, time_column
from tfrec.viewer.geometry import colour_archetype
from tfrec.viewer.sink import RerunSink

__all__ = [
    "DIFF_ROOT",
    "GHOST_COLOUR",
    "OVERLAY_APPLICATION_ID",
    "OverlayErrors",
    "OverlayRobot",
    "colour_legend",
    "error_colours",
    "overlay_blueprint",
    "write_overlay",
]

Array = NDArray[np.float64]

OVERLAY_APPLICATION_ID = "tfrec-diff"
"""The Rerun application id of overlays (a recording's layout stays the viewer's for ``tfrec``)."""
DIFF_ROOT = "diff"
GHOST_COLOUR = 0xB4C8FF66
"""B's colour: a light blue at 40 % opacity."""
_GREEN, _YELLOW, _RED = np.array([40, 180, 60]), np.array([240, 200, 30]), np.array([220, 30, 30])
_UNPLACED = 0x909090FF
"""A link the other side does not place."""
_GREEN_RGBA = (40 << 24) | (180 << 16) | (60 << 8) | 0xFF


@dataclass(frozen=True, slots=True)
class OverlayRobot:
    """One robot of the overlay.

    Attributes:
        robot: its model (geometry), or None (its TF axes alone).
        static: transforms that do not change (N = 1), parent_from_child, frames without prefix.
        dynamic: transforms at the overlay's N stamps.
        description: its URDF, kept at ``/<a or b>/robot_description``.
    """

    robot: Robot | None
    static: Transforms
    dynamic: Transforms
    description: str | None = None


@dataclass(frozen=True, slots=True)
class OverlayErrors:
    """Each link's error at each stamp (A's pose against B's, root → link).

    Attributes:
        links: the links compared.
        position, rotation: float64 (N, L): m and rad; inf where one side does not place the link.
        position_tol, rotation_tol: float64 (N, L): the tolerances in force.
    """

    links: tuple[str, ...]
    position: Array
    rotation: Array
    position_tol: Array
    rotation_tol: Array


def error_colours(errors: OverlayErrors) -> NDArray[np.uint32]:
    """0xRRGGBBAA (N, L): green within tolerance, then yellow to red as the error nears the worst
    of the whole diff (position and orientation each against its own worst; the larger counts)."""
    scores = []
    for error, tol in ((errors.position, errors.position_tol), (errors.rotation, errors.rotation_tol)):
        excess = np.where(np.isfinite(error), error - tol, np.inf)
        worst = _worst_excess(error, tol)
        score = np.where(excess > 0, np.clip(excess / worst if worst > 0 else 1.0, 0.0, 1.0), -1.0)
        scores.append(np.where(np.isinf(excess), 1.0, score))
    score = np.maximum(*scores) if scores else np.zeros((0, 0))
    t = np.clip(score, 0.0, 1.0)[..., np.newaxis]
    rgb = np.where(t < 0.5, _YELLOW * (2 * t) + _GREEN * (1 - 2 * t), _RED * (2 * t - 1) + _YELLOW * (2 - 2 * t))
    rgb = np.where(score[..., np.newaxis] < 0, _GREEN, rgb)
    r, g, b = (np.rint(rgb[..., i]).astype(np.uint32) for i in range(3))
    out: NDArray[np.uint32] = (r << 24) | (g << 16) | (b << 8) | np.uint32(0xFF)
    return out


def _worst_excess(error: Array, tol: Array) -> float:
    """The largest finite amount by which an error exceeds its tolerance (0 when none does)."""
    excess = np.where(np.isfinite(error), error - tol, np.inf)
    finite = excess[np.isfinite(excess) & (excess > 0)]
    return float(finite.max()) if finite.size else 0.0


def colour_legend(errors: OverlayErrors) -> str:
    """The scale of :func:`error_colours`, as Markdown: what green, yellow, red and grey mean in this diff, with the
    errors the colours stand for."""
    position, rotation = (_worst_excess(errors.position, errors.position_tol),
                          _worst_excess(errors.rotation, errors.rotation_tol))
    tol_p = float(errors.position_tol.max()) if errors.position_tol.size else 0.0
    tol_r = float(errors.rotation_tol.max()) if errors.rotation_tol.size else 0.0
    return "\n".join([
        "| A's link colour | its error against B |",
        "| --- | --- |",
        f"| green | within tolerance ({tol_p:.3g} m, {tol_r:.3g} rad) |",
        f"| yellow | +{position / 2:.3g} m or +{rotation / 2:.3g} rad over it |",
        f"| red | +{position:.3g} m or +{rotation:.3g} rad over it: this diff's worst |",
        "| grey | not in B |",
        "",
        ("Colours blend in between; position and orientation each count against their own worst, the larger wins. "
         "B is the translucent blue ghost."),
    ])


def write_overlay(
    path: str | os.PathLike[str],
    *,
    a: OverlayRobot,
    b: OverlayRobot,
    stamp_ns: NDArray[np.int64],
    errors: OverlayErrors,
    recording_id: str,
    name: str,
    package_paths: Sequence[str | os.PathLike[str]] = (),
) -> None:
    """Write the overlay of a diff to ``path`` (the caller writes it to a temporary name and renames it).

    Args:
        path: the ``.rrd`` file.
        a, b: the two robots.
        stamp_ns: int64 (N,) absolute stamps of the N instants.
        errors: the link errors at those instants.
        recording_id: the Rerun recording id (derive it from the inputs: the same diff, the same id).
        name: the recording's name in the viewer.
        package_paths: where meshes' packages are looked up.

    Raises:
        WriteError: the file cannot be written; it is deleted.
    """
    file = Path(path)
    stream = rr.RecordingStream(OVERLAY_APPLICATION_ID, recording_id=recording_id, send_properties=False)
    try:
        with open(file, "wb"):
            pass  # fail here with the OS's own words, not in Rerun's writer thread
        stream.save(file)
    except (OSError, RuntimeError) as err:
        raise WriteError(f"{file}: cannot write: {getattr(err, 'strerror', None) or err}") from err
    where = os.fspath(file)
    sink_a = RerunSink.from_stream(stream, target=where, robot=a.robot, package_paths=package_paths,
                                   frame_prefix="a/", entity_prefix="/a", colour=0, axis_length_m=0.0)
    sink_b = RerunSink.from_stream(stream, target=where, robot=b.robot, package_paths=package_paths,
                                   frame_prefix="b/", entity_prefix="/b", colour=GHOST_COLOUR, axis_length_m=0.0)
    try:
        start = int(stamp_ns[0]) if len(stamp_ns) else 0
        for label, sink, side in (("a", sink_a, a), ("b", sink_b, b)):
            sink.begin(static=_prefixed(side.static, f"{label}/"), start_time_ns=start,
                       robot_description=side.description, name=name, properties=label == "a",
                       root=f"{label}/{_root(side)}")
            if len(stamp_ns):
                sink.write_chunk(stamp_ns=stamp_ns, joint_names=(), positions=np.zeros((len(stamp_ns), 0)),
                                 velocities=np.zeros((len(stamp_ns), 0)), transforms=_prefixed(side.dynamic, f"{label}/"))
        _send(stream, "/b/tf_static/root", rr.Transform3D.columns(
            translation=[[0.0, 0.0, 0.0]], quaternion=[[0.0, 0.0, 0.0, 1.0]], parent_frame=[f"a/{_root(a)}"],
            child_frame=[f"b/{_root(b)}"]))
        if len(stamp_ns):
            _log_colours(stream, a.robot, stamp_ns, errors)
            _log_errors(stream, stamp_ns, errors)
        _send(stream, f"/{DIFF_ROOT}/legend", rr.TextDocument.columns(text=[colour_legend(errors)],
                                                                         media_type=["text/markdown"]))
        reaches = [r for r in (sink_a.reach, sink_b.reach) if r is not None]
        sink_a.send_blueprint(overlay_blueprint(_merged(reaches), root_frame=f"a/{_root(a)}"))
        sink_a.finish()
    except BaseException:
        sink_a.abort()
        file.unlink(missing_ok=True)
        raise


def overlay_blueprint(reach: Reach | None, *, root_frame: str) -> rrb.Blueprint:
    """The overlay's layout: the two robots in 3D, beside the error plots and the events log."""
    view3d = rrb.Spatial3DView(name="A (coloured by error) and B (ghost)", origin="/",
                               contents=["/a/robot/**", "/b/robot/**"],
                               spatial_information=rrb.SpatialInformation(target_frame=root_frame),
                               eye_controls=None if reach is None else reach.eye(fill=0.9))
    position = rrb.TimeSeriesView(name="largest link position error (m)", origin=f"/{DIFF_ROOT}/position")
    rotation = rrb.TimeSeriesView(name="largest link orientation error (rad)", origin=f"/{DIFF_ROOT}/rotation")
    events = rrb.TextLogView(name="first above tolerance", origin=f"/{DIFF_ROOT}/events")
    legend = rrb.TextDocumentView(name="colour scale", origin=f"/{DIFF_ROOT}/legend")
    return stable_ids(rrb.Blueprint(
        rrb.Horizontal(view3d, rrb.Vertical(position, rotation, events, legend, row_shares=[2, 2, 1, 2]),
                       column_shares=[5, 3]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="expanded", timeline=TIMELINE),
    ), namespace="tfrec-diff")


# -- helpers ------------------------------------------------------------------------------------


def _root(side: OverlayRobot) -> str:
    if side.robot is not None:
        return side.robot.root
    children = set(side.static.children) | set(side.dynamic.children)
    parents = [p for p in (*side.static.parents, *side.dynamic.parents) if p not in children]
    return parents[0] if parents else "world"


def _prefixed(tfs: Transforms, prefix: str) -> Transforms:
    return Transforms(tuple(prefix + p for p in tfs.parents), tuple(prefix + c for c in tfs.children),
                      tfs.translation, tfs.rotation)


def _merged(reaches: list[Reach]) -> Reach | None:
    if not reaches:
        return None
    out = Reach(reaches[0].robot)
    for reach in reaches:
        out.merge(reach)
    return out


def _send(stream: rr.RecordingStream, entity: str, columns: Any, index: list[ArrowTimeColumn] | None = None) -> None:
    rr.send_columns(entity, indexes=index or [], columns=columns, recording=stream, strict=True)


def _log_colours(stream: rr.RecordingStream, robot: Robot | None, stamp_ns: NDArray[np.int64],
                 errors: OverlayErrors) -> None:
    """A's visuals over time in the colours of their link's error (grey: B does not place the link)."""
    if robot is None:
        return
    index = [time_column(stamp_ns)]
    colours = error_colours(errors)
    column = {link: k for k, link in enumerate(errors.links)}
    for link in robot.links:
        k = column.get(link.name)
        other = _GREEN_RGBA if link.name == robot.root else _UNPLACED  # the root is where both are
        rgba = colours[:, k] if k is not None else np.full(len(stamp_ns), other, dtype=np.uint32)
        for i, visual in enumerate(link.visuals):
            kind = colour_archetype(visual)
            columns = rr.Asset3D.columns(albedo_factor=rgba) if kind == "Asset3D" else getattr(rr, kind).columns(
                colors=rgba)
            _send(stream, "/a" + visual_entity(link.name, i), columns, index)


def _log_errors(stream: rr.RecordingStream, stamp_ns: NDArray[np.int64], errors: OverlayErrors) -> None:
    """The largest error at each instant with its tolerance, and each link's first exceeding."""
    style = rr.SeriesLines.columns
    for quantity, error, tol, unit in (("position", errors.position, errors.position_tol, "m"),
                                       ("rotation", errors.rotation, errors.rotation_tol, "rad")):
        root = f"/{DIFF_ROOT}/{quantity}"
        finite = np.where(np.isfinite(error), error, np.nan)
        if error.shape[1] == 0:
            continue
        largest = np.nanmax(np.where(np.isnan(finite), -np.inf, finite), axis=1)
        keep = np.isfinite(largest)
        _send(stream, f"{root}/error", style(colors=[0xE0403AFF], names=[f"largest link {quantity} error ({unit})"],
                                             widths=[2.0]))
        _send(stream, f"{root}/tolerance", style(colors=[0x8A8A8AFF], names=[f"tolerance ({unit})"], widths=[1.0]))
        if keep.any():
            _send(stream, f"{root}/error", rr.Scalars.columns(scalars=largest[keep]), [time_column(stamp_ns[keep])])
        _send(stream, f"{root}/tolerance", rr.Scalars.columns(scalars=tol.max(axis=1)), [time_column(stamp_ns)])
    over = (errors.position > errors.position_tol) | (errors.rotation > errors.rotation_tol)
    events: list[tuple[int, str, float]] = []
    for k, link in enumerate(errors.links):
        if over[:, k].any():
            first = int(np.argmax(over[:, k]))
            events.append((first, link, float(errors.position[first, k])))
    if not events:
        return
    events.sort()
    times = np.array([stamp_ns[i] for i, _, _ in events], dtype=np.int64)
    texts = [f"{link}: first above tolerance, {value:.3g} m from B's" if np.isfinite(value)
             else f"{link}: first placed by one side only" for _, link, value in events]
    _send(stream, f"/{DIFF_ROOT}/events", rr.TextLog.columns(text=texts, level=["WARN"] * len(texts)),
          [time_column(times)])
    marker = f"/{DIFF_ROOT}/position/first_exceeds"
    _send(stream, marker, rr.SeriesPoints.columns(colors=[0xFF8C00FF], names=["first above tolerance"],
                                                  markers=["diamond"], marker_sizes=[6.0]))
    values = np.array([value if np.isfinite(value) else 0.0 for _, _, value in events])
    unique, first_of = np.unique(times, return_index=True)
    _send(stream, marker, rr.Scalars.columns(scalars=values[first_of]), [time_column(unique)])
