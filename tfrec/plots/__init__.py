"""Pictures of robots and recordings: the TF tree, joint states and frame paths, per-frame errors.

- :mod:`~tfrec.plots.tree`: the TF tree of a robot (links and joints, like ``urdf_to_graphiz``) or
  of a recording (frames, rates, static or dynamic, like ``view_frames``), as Graphviz DOT or drawn
  as SVG, PNG or PDF with a tidy-tree layout of its own (no Graphviz needed).
- :mod:`~tfrec.plots.recording`: joint positions and velocities over time, one panel per unit,
  limits shaded, and the paths of chosen frames from the top and the side.
- :mod:`~tfrec.plots.errors`: per-frame translation and rotation errors over time with the
  tolerance and the first time it is exceeded, for ``tfrec diff`` and ``tfrec replay --check``.

Output formats follow the file's suffix; SVG output is byte-identical for the same input.
matplotlib is imported only when a picture is drawn (Agg canvas, never pyplot).
"""

from __future__ import annotations

from tfrec.plots._figure import (
    GRAPH_FORMATS,
    PLOT_FORMATS,
    PlotError,
    assign_colours,
    graph_format,
    picture_kind,
    plot_format,
    refuse_existing,
)
from tfrec.plots.errors import (
    ErrorSeries,
    errors_from_check,
    errors_from_diff,
    errors_from_motion,
    plot_check,
    plot_diff,
    plot_errors,
    plot_motion,
)
from tfrec.plots.recording import FramePaths, default_frames, frame_paths, plot_recording
from tfrec.plots.tree import GraphEdge, TreeGraph, recorded_graph, render_graph, robot_graph, to_dot

__all__ = [
    "GRAPH_FORMATS",
    "PLOT_FORMATS",
    "ErrorSeries",
    "FramePaths",
    "GraphEdge",
    "PlotError",
    "TreeGraph",
    "assign_colours",
    "default_frames",
    "errors_from_check",
    "errors_from_diff",
    "errors_from_motion",
    "frame_paths",
    "graph_format",
    "picture_kind",
    "plot_check",
    "plot_diff",
    "plot_errors",
    "plot_format",
    "plot_motion",
    "plot_recording",
    "recorded_graph",
    "refuse_existing",
    "render_graph",
    "robot_graph",
    "to_dot",
]
