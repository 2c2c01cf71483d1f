"""ROS 1 bags (format 2.0): reading through the bag's index, only the chunks that hold messages to decode
(:mod:`.index`), or record by record when the index cannot be used, damaged files included (:mod:`.reader`);
and writing them chunked and indexed with vectorized ROS 1 serialization (:mod:`.writer`, :mod:`.sink`); every
message raw, chunk by chunk, for ``tfrec convert`` (:mod:`.messages`)."""

from __future__ import annotations

from tfrec.formats.rosbag1.sink import Ros1BagSink
from tfrec.formats.rosbag1.writer import Ros1BagWriter

__all__ = ["Ros1BagSink", "Ros1BagWriter", "index", "messages", "reader", "sink", "writer"]
