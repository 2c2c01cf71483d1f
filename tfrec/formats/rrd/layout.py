"""The viewer's layout (blueprint) of a tfrec recording: per robot, a 3D view beside its joint plots.

A replay of several robots (:func:`tfrec.robots.find_robots`) shows each robot in a tab of its own,
its views rooted at its entities (``/robot1/robot``, ``/robot1/joints``).
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

from tfrec.formats.rrd.paths import JOINTS_ROOT, ROBOT_ROOT, TIMELINE, VELOCITIES_ROOT

__all__ = ["blueprint_of", "robot_views"]


def robot_views(root: str, *, eye: rrb.EyeControls3D | None, velocities: bool,
                name: str | None = None) -> rrb.Container:
    """One robot's views: a 3D view of ``<root>/robot`` (camera ``eye``) beside a plot of its joint
    positions, and in a second tab of its joint velocities when some were logged."""
    view3d = rrb.Spatial3DView(name="robot", origin=f"{root}/{ROBOT_ROOT}", eye_controls=eye)
    plots: rrb.Container | rrb.View = rrb.TimeSeriesView(name="joint positions", origin=f"{root}/{JOINTS_ROOT}")
    if velocities:
        plots = rrb.Tabs(plots, rrb.TimeSeriesView(name="joint velocities", origin=f"{root}/{VELOCITIES_ROOT}"))
    return rrb.Horizontal(view3d, plots, column_shares=[3, 2], name=name)


def blueprint_of(views: Sequence[rrb.Container]) -> rrb.Blueprint:
    """The layout of one robot's views, or of several robots' as tabs; panels collapsed."""
    layout = views[0] if len(views) == 1 else rrb.Tabs(*views)
    return rrb.Blueprint(
        layout,
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE),
    )
