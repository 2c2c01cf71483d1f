"""ROS 1 bags (format 2.0): reading record by record, damaged files included (:mod:`.reader`), and writing
them chunked and indexed with vectorized ROS 1 serialization (:mod:`.writer`, :mod:`.sink`)."""

from __future__ import annotations

from tfrec.formats.rosbag1.sink import Ros1BagSink
from tfrec.formats.rosbag1.writer import Ros1BagWriter

__all__ = ["Ros1BagSink", "Ros1BagWriter", "reader", "sink", "writer"]
