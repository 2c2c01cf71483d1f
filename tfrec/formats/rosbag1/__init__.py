"""ROS 1 bags (format 2.0): their records, written and read back (:mod:`.records`), their index (:mod:`.index`),
the one reader — through the index, or record by record when it cannot be used, damaged files included
(:mod:`.source`) —, the one writer, chunked and indexed with vectorized ROS 1 serialization (:mod:`.writer`), and
the sink of ``tfrec record`` over it (:mod:`.sink`)."""

from __future__ import annotations

from tfrec.formats.rosbag1.sink import Ros1BagSink
from tfrec.formats.rosbag1.writer import Ros1BagWriter

__all__ = ["Ros1BagSink", "Ros1BagWriter", "index", "records", "sink", "source", "writer"]
