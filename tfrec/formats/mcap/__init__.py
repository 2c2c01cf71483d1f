"""MCAP files (ROS 2 profile): record layouts (:mod:`.records`), the summary section (:mod:`.summary`),
tfrec's sequential reader of intact and damaged files (:mod:`.reader`) and its writer (:mod:`.writer`)."""

from __future__ import annotations

__all__ = ["reader", "records", "summary", "writer"]
