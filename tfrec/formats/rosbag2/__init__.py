"""rosbag2 folders: ``metadata.yaml`` and the offered QoS profiles (:mod:`.metadata`), sqlite3 databases read
with SQL (:mod:`.sqlite3`), and compressed bags and the counts of ``metadata.yaml`` (:mod:`.storage`). A
bag's MCAP files are read by :mod:`tfrec.formats.mcap`; a sqlite3 bag's every message, raw, for ``tfrec convert``
(:mod:`.messages`)."""

from __future__ import annotations

__all__ = ["messages", "metadata", "sqlite3", "storage"]
