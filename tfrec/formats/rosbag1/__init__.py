"""ROS 1 bags (format 2.0): their records, written and read back (:mod:`.records`), their index (:mod:`.index`),
the one reader — through the index, or record by record when it cannot be used, damaged files included
(:mod:`.source`) —, the one writer, chunked and indexed with vectorized ROS 1 serialization (:mod:`.writer`), and
the sink of ``tfrec record`` over it (:mod:`.sink`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__all__ = ["Ros1BagSink", "Ros1BagWriter", "index", "records", "sink", "source", "writer"]

if TYPE_CHECKING:
    from tfrec.formats.rosbag1.sink import Ros1BagSink
    from tfrec.formats.rosbag1.writer import Ros1BagWriter


def __getattr__(name: str) -> Any:  # lazy: reading a bag (or an MCAP, which needs ROS 1's magic) needs no writer
    if name == "Ros1BagSink":
        from tfrec.formats.rosbag1.sink import Ros1BagSink

        return Ros1BagSink
    if name == "Ros1BagWriter":
        from tfrec.formats.rosbag1.writer import Ros1BagWriter

        return Ros1BagWriter
    raise AttributeError(f"module 'tfrec.formats.rosbag1' has no attribute {name!r}")
