"""rosbag2 folders: ``metadata.yaml`` and the offered QoS profiles (:mod:`.metadata`)."""

from __future__ import annotations

__all__ = ["metadata"]
