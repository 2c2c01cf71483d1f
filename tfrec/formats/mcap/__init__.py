"""MCAP files (ROS 2 profile): record layouts (:mod:`.records`), the summary section (:mod:`.summary`),
chunks through their message indexes (:mod:`.index`), the walk over a file's records (:mod:`.walker`),
tfrec's reader of intact and damaged files (:mod:`.reader`) and its writer (:mod:`.writer`); for ``tfrec convert``,
every message raw, chunk by chunk (:mod:`.messages`), and a writer of any topics (:mod:`.raw_writer`)."""

from __future__ import annotations

__all__ = ["index", "messages", "raw_writer", "reader", "records", "summary", "walker", "writer"]
