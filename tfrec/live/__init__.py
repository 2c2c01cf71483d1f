"""Serving live, without ROS: ``tfrec serve``.

- :mod:`~tfrec.live.server`: :class:`~tfrec.live.server.FoxgloveServer`, a Foxglove WebSocket server through the
  official SDK (the only importer of ``foxglove``): the four topics, joint parameters, Center and Randomize, meshes;
- :mod:`~tfrec.live.joints`: :class:`~tfrec.live.joints.JointControl`, the joints clients move, within limits;
- :mod:`~tfrec.live.serve`: the real-time loop — a trajectory, the clients' joints, or a recording — feeding the
  server and any :class:`tfrec.formats.RecordSink` (``--record``, a Rerun viewer).

The top stage under the command line: it plays what record, replay and the viewer make.
"""

from __future__ import annotations

__all__ = ["joints", "serve", "server"]
