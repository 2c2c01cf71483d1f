"""MCAP files (ROS 2 profile): record layouts (:mod:`.records`), the summary section (:mod:`.summary`), chunks
through their message indexes (:mod:`.index`), the one reader — one walk of a file's records, damaged files
included (:mod:`.source`) —, the one writer of any channels (:mod:`.writer`) and, over it, the sink of ``tfrec
record`` (:mod:`.sink`)."""

from __future__ import annotations

__all__ = ["index", "records", "sink", "source", "summary", "writer"]
