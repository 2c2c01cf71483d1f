"""Per-frame errors over time: ``tfrec diff A B --plot`` and ``tfrec replay --check --plot``.

:func:`plot_errors` draws the translation and the rotation error of each frame over time, with the
tolerance as a line and the first time each frame exceeds it marked, worst frames first. The
adapters build its :class:`ErrorSeries` from a :class:`tfrec.diff_report.DiffReport` (which holds
both recordings: the errors are recomputed exactly as :func:`tfrec.diff.compare` computes them) and
from a :class:`tfrec.replay_check.CheckReport` (which holds only each frame's largest errors: with
the :class:`tfrec.replay.Replay` that was checked, the series are recomputed as the check does).
"""

from __future__ import annotations

import math
import os
import re
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import display_path
from tfrec.kinematics.rotations import rotation_error
from tfrec.plots._figure import PlotError, assign_colours, envelope, plot_format, refuse_existing
from tfrec.resample import align, data_start_ns

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from tfrec.diff.motion import MotionComparison
    from tfrec.diff.report import DiffReport
    from tfrec.replay.check import CheckReport

__all__ = ["MAX_SHOWN", "ErrorSeries", "errors_from_check", "errors_from_diff", "errors_from_motion", "plot_check",
           "plot_diff", "plot_errors", "plot_motion"]

Array = NDArray[np.float64]

MAX_SHOWN = 8
"""Frames drawn at most, the worst; the others are counted in the legend."""

_TOL_COLOUR = "#000000"


@dataclass(frozen=True, slots=True)
class ErrorSeries:
    """One frame's errors over time.

    Attributes:
        name: the frame (or ``parent → child``).
        t_s: float64 (n,) seconds from the recording's start.
        translation_m: float64 (n,) distance between the translations; NaN where unknown.
        rotation_rad: float64 (n,) angle of the relative rotation; NaN where unknown.
        static: a latched transform: one value (n = 1) for the whole recording, drawn as a level line.
    """

    name: str
    t_s: Array
    translation_m: Array
    rotation_rad: Array
    static: bool = False

    def largest(self) -> tuple[float, float]:
        """The largest translation and rotation error (0 where there is none)."""
        return _nanmax(self.translation_m), _nanmax(self.rotation_rad)

    def badness(self, pos_tol: float, rot_tol: float) -> float:
        """The largest error as a multiple of its tolerance: > 1 fails."""
        trans, rot = self.largest()
        return max(_ratio(trans, pos_tol), _ratio(rot, rot_tol))


def _nanmax(values: Array) -> float:
    finite = values[np.isfinite(values)]
    return float(finite.max()) if finite.size else 0.0


def _ratio(value: float, tol: float) -> float:
    if value <= tol:
        return value / tol if tol > 0 else 0.0
    return value / tol if tol > 0 else math.inf


def first_exceed(t_s: Array, values: Array, tol: float) -> float | None:
    """The first time ``values`` exceed ``tol``, or None."""
    over = np.flatnonzero(values > tol)
    return float(t_s[over[0]]) if over.size else None


def _floor(values: list[Array], tol: float) -> float | None:
    """The bottom of a log scale for errors spanning decades, or None for a linear scale.

    Errors below it (zeros, float rounding) are drawn at it: 4 decades below the tolerance (6 below
    the largest error without one), or just below the smallest error when that is larger, but always
    a decade below the tolerance.
    """
    finite = np.concatenate([v[np.isfinite(v)] for v in values]) if values else np.zeros(0)
    top = float(finite.max()) if finite.size else 0.0
    if top <= 0.0:
        return None
    positive = finite[finite > 0.0]
    small = float(positive.min())
    if not bool((finite == 0.0).any()) and max(top, tol) / min(small, tol if tol > 0 else small) < 100.0:
        return None
    lower = max(small, tol * 1e-4 if tol > 0 else top * 1e-6)
    return (min(lower, tol / 10.0) if tol > 0 else lower) / 2.0


def _panel(ax: Axes, shown: Sequence[ErrorSeries], which: str, tol: float, unit: str,
           colours: dict[str, tuple[str, str]], span: tuple[float, float], item: str = "frame") -> None:
    values = [getattr(s, which) for s in shown]
    floor = _floor(values, tol)
    earliest: tuple[float, str] | None = None
    for series, value in zip(shown, values):
        colour, style = colours[series.name]
        drawn = value if floor is None else np.maximum(value, floor)
        if series.static:
            level = float(drawn[0]) if drawn.size else math.nan
            ax.plot(span, [level, level], color=colour, linestyle=(0, (6, 2)), linewidth=1.4)
        else:
            tt, yy = envelope(series.t_s, drawn)
            ax.plot(tt, yy, color=colour, linestyle=style, linewidth=1.2,
                    marker="o" if len(tt) <= 2 else None, markersize=4)
        at = first_exceed(series.t_s, value, tol) if not series.static else None
        if at is not None:
            ax.axvline(at, color=colour, linestyle=":", linewidth=1.0, alpha=0.9)
            y = float(value[series.t_s == at][0]) if floor is None else max(float(value[series.t_s == at][0]), floor)
            ax.plot([at], [y], marker="v", color=colour, markersize=7, markeredgecolor="white", zorder=5)
            if earliest is None or at < earliest[0]:
                earliest = (at, series.name)
    if tol > 0 or floor is None:
        ax.axhline(tol, color=_TOL_COLOUR, linestyle="--", linewidth=1.2, zorder=4)
        ax.annotate(f"tolerance {tol:g} {unit}", xy=(1.0, tol), xycoords=("axes fraction", "data"),
                    xytext=(-4, 3), textcoords="offset points", ha="right", va="bottom", color=_TOL_COLOUR,
                    fontsize=8)
    if floor is not None:
        ax.set_yscale("log")
        ax.set_ylim(floor / 1.5, max(_nanmax(np.concatenate(values)), tol) * 3.0)
        ax.set_ylabel(f"{which.split('_')[0]} error ({unit}, log scale)")
        ax.annotate(f"≤ {floor:.1g} {unit} drawn here", xy=(0.0, floor), xycoords=("axes fraction", "data"),
                    xytext=(4, 2), textcoords="offset points", ha="left", va="bottom", fontsize=7, color="#666666")
    else:
        top = _nanmax(np.concatenate(values))
        ax.set_ylim(0.0, max(top, tol) * 1.15 or 1.0)
        if top == 0.0:
            ax.text(0.5, 0.5, f"no {which.split('_')[0]} error in the {item}s drawn", transform=ax.transAxes,
                    ha="center", va="center", color="#666666", fontsize=9)
        ax.set_ylabel(f"{which.split('_')[0]} error ({unit})")
    quantity = f"translation error per {item}" if which == "translation_m" else \
        f"rotation error per {item} (angle of the relative rotation)"
    first = "" if earliest is None else f" — first above tolerance: {earliest[1]} at t={earliest[0]:.3f} s"
    ax.set_title(quantity + first, loc="left", fontsize=9)
    ax.grid(True, which="major", linewidth=0.4, alpha=0.5)


def plot_errors(series: Sequence[ErrorSeries], path: str | os.PathLike[str], *, pos_tol: float, rot_tol: float,
                title: str, subtitle: str = "", notes: Sequence[str] = (), force: bool = False, item: str = "frame",
                time_origin: str = "the recording's start") -> None:
    """Plot per-frame translation and rotation errors over time to ``path`` (``.png``, ``.svg``, ``.pdf``).

    The :data:`MAX_SHOWN` worst frames (largest error relative to its tolerance) are drawn, worst
    first in the legend; the others are counted. Errors spanning several decades go on a log scale
    (zeros at its bottom). The tolerance is a dashed line; where a frame first exceeds it, a dotted
    vertical line and a triangle, and the earliest is named.

    Args:
        series: one per frame.
        path: the picture; its suffix chooses the format.
        pos_tol, rot_tol: the tolerances, m and rad.
        title: what is compared, with which files.
        subtitle: a second line (default: the tolerances and how many frames exceed them).
        notes: lines drawn under the plot (frames not compared, and why).
        item: what a series is (``frame``; ``link`` for a description diff), for the labels.
        time_origin: what times count from, for the time axis.

    Raises:
        PlotError: a bad suffix, or no series.
        WriteError: the file cannot be written.
    """
    fmt = plot_format(path)
    refuse_existing(path, force=force)
    if not series:
        raise PlotError(f"{os.fspath(path)}: no frame errors to plot")
    ordered = sorted(series, key=lambda s: (-s.badness(pos_tol, rot_tol), s.name))
    shown, rest = ordered[:MAX_SHOWN], ordered[MAX_SHOWN:]
    failing = sum(s.badness(pos_tol, rot_tol) > 1.0 for s in ordered)
    if not subtitle:
        subtitle = (f"tolerances {pos_tol:g} m, {rot_tol:g} rad: {failing} of {len(ordered)} {item}"
                    f"{'s' if len(ordered) != 1 else ''} above")
    from tfrec.plots._figure import plot_style, save_figure

    with plot_style():
        fig = _draw(shown, rest, pos_tol, rot_tol, title, subtitle, notes, item=item, time_origin=time_origin)
        save_figure(fig, path, fmt, force=force)


_HEADING_WIDTH = 125
"""Characters of a heading line: what 11-point text holds beside the legend of a 14-inch figure."""


def _draw(shown: Sequence[ErrorSeries], rest: Sequence[ErrorSeries], pos_tol: float, rot_tol: float, title: str,
          subtitle: str, notes: Sequence[str], *, item: str, time_origin: str) -> Any:
    from matplotlib.lines import Line2D

    from tfrec.plots._figure import new_figure

    heading = [line for text in (title, subtitle) for line in textwrap.wrap(text, _HEADING_WIDTH)]
    height = 7.6 + 0.2 * len(notes) + 0.2 * max(0, len(heading) - 2)
    fig = new_figure(14.0, height)
    fig.set_layout_engine("constrained", h_pad=0.08, w_pad=0.08)
    ax_t = fig.add_subplot(2, 1, 1)
    ax_r = fig.add_subplot(2, 1, 2, sharex=ax_t)
    fig.suptitle("\n".join(heading), x=0.01, ha="left", fontsize=11)
    colours = assign_colours(s.name for s in shown)
    times = [s.t_s for s in shown if not s.static and s.t_s.size]
    lo = min((float(np.nanmin(t)) for t in times), default=0.0)
    hi = max((float(np.nanmax(t)) for t in times), default=1.0)
    span = (lo, hi if hi > lo else lo + 1.0)
    _panel(ax_t, shown, "translation_m", pos_tol, "m", colours, span, item)
    _panel(ax_r, shown, "rotation_rad", rot_tol, "rad", colours, span, item)
    ax_r.set_xlabel(f"time (s) from {time_origin}")
    ax_t.tick_params(labelbottom=False)
    handles: list[Any] = []
    labels: list[str] = []
    for s in shown:
        colour, style = colours[s.name]
        trans, rot = s.largest()
        linestyle: Any = (0, (6, 2)) if s.static else style
        handles.append(Line2D([], [], color=colour, linestyle=linestyle, linewidth=1.6))
        mark = "✗" if s.badness(pos_tol, rot_tol) > 1.0 else "✓"
        label = f"{mark} {s.name}{' (static)' if s.static else ''}\n    max {trans:.2g} m, {rot:.2g} rad"
        firsts = [t for t in (first_exceed(s.t_s, s.translation_m, pos_tol),
                              first_exceed(s.t_s, s.rotation_rad, rot_tol)) if t is not None]
        if firsts and not s.static:
            label += f"\n    above from t={min(firsts):.3f} s"
        labels.append(label)
    if rest:
        trans = max(s.largest()[0] for s in rest)
        rot = max(s.largest()[1] for s in rest)
        failing = sum(s.badness(pos_tol, rot_tol) > 1.0 for s in rest)
        handles.append(Line2D([], [], linestyle="none"))
        labels.append(f"and {len(rest)} more {item}{'s' if len(rest) != 1 else ''} ({failing} above)\n"
                      f"    max {trans:.2g} m, {rot:.2g} rad")
    handles.append(Line2D([], [], color=_TOL_COLOUR, linestyle="--", linewidth=1.2))
    labels.append("tolerance")
    handles.append(Line2D([], [], color="#555555", linestyle=":", marker="v", markersize=6))
    labels.append("first above tolerance")
    fig.legend(handles, labels, loc="outside right upper", frameon=False, fontsize=8, title=f"{item}s, worst first",
               title_fontsize=8, alignment="left")
    if notes:  # under the time axis, in the space the layout keeps for it
        fig.supxlabel("\n".join(f"note: {note}" for note in notes), x=0.01, ha="left", fontsize=8, color="#8a1c1c")
    return fig


# -- adapters -------------------------------------------------------------------------------------


def _names(pairs: Sequence[tuple[str, str]]) -> dict[tuple[str, str], str]:
    """Each pair's name in the legend: the child frame, or ``parent → child`` when children repeat."""
    children = [child for _, child in pairs]
    return {(p, c): c if children.count(c) == 1 else f"{p} → {c}" for p, c in pairs}


def errors_from_diff(report: DiffReport) -> list[ErrorSeries]:
    """Per-frame errors of B against A for every frame pair both recordings hold, as :func:`tfrec.diff.compare`
    computes them: times since each recording's start (A's stamps; B interpolated at them, linearly for
    translations, by slerp for rotations); a /tf_static pair is one static value.

    Raises:
        PlotError: a report of recordings compared piece by piece (``report.whole`` False: they do not hold their
            samples); ``compare(..., whole=True)`` keeps them.
    """
    if not report.whole:
        raise PlotError(f"{display_path(report.a.path)} and {display_path(report.b.path)} were compared piece by "
                        "piece, without their samples: compare them with `whole=True` to plot their errors")
    a, b = report.a, report.b
    origin_a, origin_b = report.origins
    if origin_a is None or origin_b is None:  # absolute: stamps aligned; drawn from A's start
        origin_a = origin_b = data_start_ns(a) or 0
    dynamic = [pair for pair in a.tf if pair in b.tf and len(a.tf[pair]) and len(b.tf[pair])]
    static = [pair for pair in a.tf_static if pair in b.tf_static]
    names = _names(dynamic + static)
    out: list[ErrorSeries] = []
    for pair in dynamic:
        sa, sb = a.tf[pair], b.tf[pair]
        ta, tb = sa.time_ns - origin_a, sb.time_ns - origin_b
        alignment = align(ta, tb)
        if not alignment.inside.any():
            continue
        trans = np.linalg.norm(sa.translation[alignment.inside] - alignment.linear(sb.translation), axis=1)
        rot = rotation_error(sa.rotation[alignment.inside], alignment.rotations(sb.rotation))
        out.append(ErrorSeries(names[pair], ta[alignment.inside] / 1e9, trans, rot))
    for pair in static:
        (ta_, qa), (tb_, qb) = a.tf_static[pair], b.tf_static[pair]
        out.append(ErrorSeries(names[pair], np.zeros(1), np.array([np.linalg.norm(ta_ - tb_)]),
                               np.atleast_1d(rotation_error(qa, qb)), static=True))
    return out


def errors_from_check(report: CheckReport) -> list[ErrorSeries]:
    """Per-frame errors of a ``replay --check``: the recorded TF against the re-simulated one.

    Each frame's :class:`~tfrec.replay.check.FrameErrors` (the errors at every compared stamp) gives
    its series; a frame check without them (one built by hand) gives its largest errors alone, as
    points at the times they occur. Times count from the recording's start (``report.origin_ns``).

    Frames that could not be compared (``problem`` set) are left out.
    """
    out: list[ErrorSeries] = []
    for frame in report.frames:
        if frame.problem is not None or frame.samples == 0:
            continue
        given = frame.errors
        if given is not None:
            t_s = (np.asarray(given.time_ns) - report.origin_ns) / 1e9
            out.append(ErrorSeries(frame.frame, t_s, np.asarray(given.translation_m, dtype=np.float64),
                                   np.asarray(given.rotation_rad, dtype=np.float64),
                                   static=frame.topic == "/tf_static"))
            continue
        if frame.translation_time_s is None and frame.rotation_time_s is None:
            out.append(ErrorSeries(frame.frame, np.zeros(1), np.array([frame.translation_m]),
                                   np.array([frame.rotation_rad]), static=True))
        else:
            t_tr = frame.translation_time_s if frame.translation_time_s is not None else frame.rotation_time_s
            t_rot = frame.rotation_time_s if frame.rotation_time_s is not None else t_tr
            assert t_tr is not None and t_rot is not None
            out.append(ErrorSeries(frame.frame, np.array([t_tr, t_rot]), np.array([frame.translation_m, np.nan]),
                                   np.array([np.nan, frame.rotation_rad])))
    return out


def plot_diff(report: DiffReport, path: str | os.PathLike[str], *, force: bool = False) -> None:
    """``tfrec diff A B --plot PATH``: per-frame errors of B against A (:func:`errors_from_diff`).

    Raises:
        PlotError: a bad suffix, or no frame pair in both recordings.
        WriteError: the file cannot be written.
    """
    plot_format(path)
    refuse_existing(path, force=force, inputs=[p for p in (report.a.path, report.b.path) if p])
    series = errors_from_diff(report)
    notes = [f"{d.detail}" for d in report.differences if d.kind == "frame"][:4]
    if not series:  # robots of one link: their root, which nothing moves
        from tfrec.plots.tree import described_roots

        roots = [root for root in described_roots(report.a) if root in described_roots(report.b)]
        if not roots:
            raise PlotError(f"{display_path(report.a.path)} and {display_path(report.b.path)}: no TF frame pair in "
                            "both recordings, no frame errors to plot")
        series = [ErrorSeries(root, np.zeros(1), np.zeros(1), np.zeros(1), static=True) for root in roots]
        notes.append("no TF frame pair in either recording: their robots have one link each, at the root")
    tol = report.tolerances
    plot_errors(series, path, pos_tol=tol["pos_tol"], rot_tol=tol["rot_tol"],
                title=f"tfrec diff: {display_path(report.b.path)} (B) against {display_path(report.a.path)} (A) "
                      f"— {report.verdict}",
                notes=notes, force=force)


def errors_from_motion(comparison: MotionComparison) -> list[ErrorSeries]:
    """The world displacement of each link of a description diff over the shared motion: the distance
    between its origins in A and in B (root → link) and the angle between its orientations, as
    :func:`tfrec.diff.compare_descriptions` computes them (NaN where a side does not place it). A robot
    whose only link is the root gets the root's (none)."""
    t_s = comparison.time_ns / 1e9
    position = np.where(np.isinf(comparison.position_error), np.nan, comparison.position_error)
    rotation = np.where(np.isinf(comparison.rotation_error), np.nan, comparison.rotation_error)
    if not comparison.links:
        zeros = np.zeros(len(t_s))
        return [ErrorSeries(comparison.report.root, t_s, zeros, zeros)]
    return [ErrorSeries(link, t_s, position[:, j], rotation[:, j]) for j, link in enumerate(comparison.links)]


def plot_motion(comparison: MotionComparison, path: str | os.PathLike[str], *, force: bool = False) -> None:
    """``tfrec diff A.xacro B.xacro --plot PATH`` (or a recording against a description): the world
    displacement of each link over the shared motion (:func:`errors_from_motion`), the worst links drawn,
    the others counted; the description's changes as notes.

    Raises:
        PlotError: a bad suffix.
        WriteError: the file cannot be written.
    """
    plot_format(path)
    refuse_existing(path, force=force)
    report = comparison.report
    changes = [d.detail for d in report.differences if d.kind in ("description", "frame")]
    notes = changes[:4] + ([f"and {len(changes) - 4} more changes (see the text report)"] if len(changes) > 4 else [])
    tol = report.tolerances
    series = errors_from_motion(comparison)
    above = [s.name for s in series if s.badness(tol["pos_tol"], tol["rot_tol"]) > 1.0]
    named = ", ".join(above[:8]) + (", …" if len(above) > 8 else "")
    motion = re.sub(r"`([^`]*)`", r"\1", report.motion)  # the report's option names, as plain words
    plot_errors(series, path, pos_tol=tol["pos_tol"], rot_tol=tol["rot_tol"],
                title=f"tfrec diff: where each link of {display_path(report.b.path)} (B) is, against "
                      f"{display_path(report.a.path)} (A), in the frame of the root link '{report.root}' — "
                      f"{report.verdict}",
                subtitle=f"over {motion}; tolerances {tol['pos_tol']:g} m, {tol['rot_tol']:g} rad: {len(above)} of "
                         f"{len(series)} link{'s' if len(series) != 1 else ''} above" + (f" ({named})" if above else ""),
                notes=notes, force=force, item="link", time_origin="the motion's start")


def plot_check(report: CheckReport, path: str | os.PathLike[str], *, force: bool = False) -> None:
    """``tfrec replay --check --plot PATH``: recorded TF against the re-simulation (:func:`errors_from_check`).

    Raises:
        PlotError: a bad suffix, or no frame compared.
        WriteError: the file cannot be written.
    """
    plot_format(path)
    refuse_existing(path, force=force, inputs=[report.path] if report.path else [])
    series = errors_from_check(report)
    if not series:
        raise PlotError(f"{display_path(report.path)}: no frame was compared, no frame errors to plot")
    problems = [f"{f.frame}: {f.problem}" for f in report.frames if f.problem is not None]
    notes = problems[:4] + ([f"and {len(problems) - 4} more frames not compared"] if len(problems) > 4 else [])
    if not any(f.errors is not None for f in report.frames):
        notes.append("largest errors only (the check kept no errors over time)")
    verdict = "PASS" if report.passed else f"FAIL ({len(report.failures)} of {len(report.frames)} frames)"
    plot_errors(series, path, pos_tol=report.pos_tol, rot_tol=report.rot_tol,
                title=f"tfrec replay --check {display_path(report.path)}: recorded TF against the description "
                      f"re-simulated from /joint_states — {verdict}",
                notes=notes, force=force)
