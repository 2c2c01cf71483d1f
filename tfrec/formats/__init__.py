"""Recordings on disk: MCAP, rosbag2 folders, ROS 1 bags and Rerun ``.rrd`` files, read and written.

:func:`read_recording` is the one door over every reader (the role of rosbags' ``AnyReader``):
whatever the format, it gives a :class:`~tfrec.recording.Recording`. The subpackages hold one
format each:

- :mod:`~tfrec.formats.ros`: CDR encoding and bulk decoding of the messages tfrec reads and
  writes, rosbags' type stores;
- :mod:`~tfrec.formats.mcap`: MCAP records, summary section, reader and writer;
- :mod:`~tfrec.formats.rosbag1`: ROS 1 bags;
- :mod:`~tfrec.formats.rosbag2`: rosbag2 folders (``metadata.yaml``, QoS, sqlite3);
- :mod:`~tfrec.formats.rrd`: Rerun recordings read back: entity paths, the reader (the writing side is
  :mod:`tfrec.viewer`).

For ``tfrec convert``, :mod:`~tfrec.formats.messages` opens any recording's messages raw, chunk by chunk,
:mod:`~tfrec.formats.translate` carries them between ROS 1 and ROS 2, and :mod:`~tfrec.formats.output`
writes them (MCAP, rosbag2 folder, ROS 1 bag).

The only package that imports mcap, rosbags, rerun, pyarrow, yaml, zstandard and lz4 (each
lazily or inside its format's modules, so importing :mod:`tfrec.formats` stays cheap).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__all__ = ["RecordingSource", "identify_recording", "read_recording", "recording_format"]

if TYPE_CHECKING:
    from tfrec.formats.reader import RecordingSource, identify_recording, read_recording, recording_format


def __getattr__(name: str) -> Any:  # lazy: the readers import numpy and their format's modules
    if name in __all__:
        from tfrec.formats import reader

        return getattr(reader, name)
    raise AttributeError(f"module 'tfrec.formats' has no attribute {name!r}")
