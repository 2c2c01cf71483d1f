"""rosbag2 folders: ``metadata.yaml`` and the offered QoS profiles (:mod:`.metadata`), compressed bags
(:mod:`.storage`), and the one reader of sqlite3 storage, with SQL (:mod:`.source`). A bag's MCAP files are read by
:mod:`tfrec.formats.mcap.source`."""

from __future__ import annotations

__all__ = ["metadata", "source", "storage"]
