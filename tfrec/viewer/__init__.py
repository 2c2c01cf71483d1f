"""Rerun output: what ``record``, ``replay`` and ``diff --rrd`` show, the only writing side that imports rerun.

- :mod:`~tfrec.viewer.sink`: :class:`~tfrec.viewer.sink.RerunSink`, a robot's TF, joint states and geometry
  as Rerun data, for record and replay (a :class:`tfrec.formats.RecordSink`);
- :mod:`~tfrec.viewer.blueprint`: the layout — camera, plots, TF tree, one tab per robot;
- :mod:`~tfrec.viewer.geometry`: a robot's visuals (meshes found through the description's packages);
- :mod:`~tfrec.viewer.overlay`: two robots of a diff as one ghost overlay;
- :mod:`~tfrec.viewer.spawn`: replaying into a spawned viewer, a running one, or an ``.rrd`` file;
- :mod:`~tfrec.viewer.columns` and :mod:`~tfrec.viewer._flush`: Rerun's columns, and waiting for its writer.

The entity paths are the format's (:mod:`tfrec.formats.rrd.paths`), shared with the ``.rrd`` reader. A stage
above kinematics and description (it draws links where forward kinematics puts them, with the meshes of the
description's packages), beside replay, which plays into it.
"""

from __future__ import annotations

__all__ = ["blueprint", "columns", "geometry", "overlay", "sink", "spawn"]
