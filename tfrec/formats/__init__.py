"""Recordings on disk: MCAP, rosbag2 folders, ROS 1 bags and Rerun ``.rrd`` files, read and written.

Each format has one source that walks its files once (:func:`open_messages`, the one door: rosbags' ``AnyReader``
role) and one writer; :func:`read_recording` builds a :class:`~tfrec.recording.Recording` on the source, whatever
the format. The subpackages hold one format each:

- :mod:`~tfrec.formats.ros`: connections, message batches and the source every format's reader is; CDR encoding
  and bulk decoding of the messages tfrec reads and writes, rosbags' type stores, message definitions;
- :mod:`~tfrec.formats.mcap`: MCAP records, summary section, chunk indexes, the source, the writer and the sink;
- :mod:`~tfrec.formats.rosbag1`: ROS 1 bags: records, index, the source, the writer and the sink;
- :mod:`~tfrec.formats.rosbag2`: rosbag2 folders (``metadata.yaml``, QoS, compressed bags, the sqlite3 source);
- :mod:`~tfrec.formats.rrd`: Rerun recordings read back: entity paths, the reader (the writing side is
  :mod:`tfrec.viewer`).

:mod:`~tfrec.formats.translate` carries messages between ROS 1 and ROS 2 and :mod:`~tfrec.formats.output` writes
them (MCAP, rosbag2 folder, ROS 1 bag) for ``tfrec convert``; :class:`RecordSink` is what ``record`` writes through.

The only package that imports mcap, rosbags, zstandard and lz4 (each lazily or inside its format's modules, so
importing :mod:`tfrec.formats` stays cheap); it imports nothing of tfrec but the base.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__all__ = [
    "MessageSource",
    "RecordSink",
    "RecordingSource",
    "identify_recording",
    "open_messages",
    "read_recording",
    "recording_format",
]

if TYPE_CHECKING:
    from tfrec.formats.reader import read_recording
    from tfrec.formats.ros.connection import MessageSource
    from tfrec.formats.sink import RecordSink
    from tfrec.formats.source import RecordingSource, identify_recording, open_messages, recording_format


def __getattr__(name: str) -> Any:  # lazy: the readers import numpy and their format's modules
    if name == "read_recording":
        from tfrec.formats.reader import read_recording

        return read_recording
    if name == "MessageSource":
        from tfrec.formats.ros.connection import MessageSource

        return MessageSource
    if name == "RecordSink":
        from tfrec.formats.sink import RecordSink

        return RecordSink
    if name in __all__:
        from tfrec.formats import source

        return getattr(source, name)
    raise AttributeError(f"module 'tfrec.formats' has no attribute {name!r}")
