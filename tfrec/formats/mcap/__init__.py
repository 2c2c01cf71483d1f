"""MCAP files (ROS 2 profile): record layouts (:mod:`.records`), the summary section (:mod:`.summary`),
chunks through their message indexes (:mod:`.index`), the walk over a file's records (:mod:`.walker`),
tfrec's reader of intact and damaged files (:mod:`.reader`) and its writer (:mod:`.writer`)."""

from __future__ import annotations

__all__ = ["index", "reader", "records", "summary", "walker", "writer"]
