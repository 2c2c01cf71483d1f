"""Reading recordings back into arrays: MCAP, rosbag2 folders, ROS 1 bags and tfrec's ``.rrd``.

:func:`read_recording` gives one :class:`Recording` whatever the format: the robot description,
the topic table, the joint states as one (N, J) array and every TF frame pair as a time series.
``diff`` compares two of them and ``replay`` plays one back.

How each format is read:

- ``.mcap`` (ROS 2 profile, CDR): :mod:`tfrec.mcap_read`, tfrec's own sequential reader; a
  file cut short is read up to the cut (complete records of a partial chunk included), a damaged
  chunk is skipped (its CRC fails) and reading goes on; :attr:`Recording.read_error` says what was lost.
- rosbag2 folders (mcap or sqlite3 storage) and ROS 1 ``.bag`` files: ``rosbags``' ``AnyReader``.
- ``.rrd``: :mod:`tfrec.rrd_read`, through Rerun's own reader. Rerun stores transforms as float32.

JointState and TFMessage messages with a fixed layout (the same names in every message) are
decoded in bulk with numpy (:mod:`tfrec.ros_decode`); anything else through rosbags'
deserializers, message by message.
"""

from __future__ import annotations

import os
from collections.abc import Collection
from pathlib import Path
from typing import Any

from .errors import RecordingError
from .mcap_read import MCAP_MAGIC, read_mcap
from .recorded import (
    DECODED_TOPICS,
    JOINT_STATES,
    ROBOT_DESCRIPTION,
    TF,
    TF_STATIC,
    Collector,
    FrameSeries,
    JointStates,
    Recording,
    TopicInfo,
    deserializer,
)
from .rrd_read import RRD_MAGIC, read_rrd

__all__ = [
    "TopicInfo",
    "JointStates",
    "FrameSeries",
    "Recording",
    "read_recording",
    "recording_format",
    "JOINT_STATES",
    "TF",
    "TF_STATIC",
    "ROBOT_DESCRIPTION",
]

_ROS1_MAGIC = b"#ROSBAG V2.0\n"
_BATCH = 32768
"""Messages of a topic decoded at once."""


def recording_format(path: str | os.PathLike[str]) -> str:
    """The format of a recording: ``mcap``, ``rosbag2``, ``rosbag1`` or ``rrd``, from its first bytes.

    Raises:
        RecordingError: a missing path, or something that is none of those.
    """
    where = os.fspath(path)
    file = Path(path)
    if file.is_dir():
        if (file / "metadata.yaml").is_file():
            return "rosbag2"
        raise RecordingError(f"{where}: a folder without metadata.yaml (not a rosbag2 bag)")
    if not file.exists():
        raise RecordingError(f"{where}: no such file or folder")
    try:
        with open(file, "rb") as stream:
            head = stream.read(16)
    except OSError as err:
        raise RecordingError(f"{where}: cannot read: {err.strerror or err}") from None
    if head.startswith(MCAP_MAGIC):
        return "mcap"
    if head.startswith(_ROS1_MAGIC):
        return "rosbag1"
    if head.startswith(RRD_MAGIC):
        return "rrd"
    if head.startswith(b"SQLite format 3\0") and (file.parent / "metadata.yaml").is_file():
        return "rosbag2"
    raise RecordingError(f"{where}: not a recording (neither MCAP, rosbag2, ROS 1 bag nor Rerun .rrd)")


def read_recording(path: str | os.PathLike[str], *, topics: Collection[str] | None = None) -> Recording:
    """Read a recording into arrays.

    Args:
        path: an ``.mcap`` file, a rosbag2 folder (or its ``.db3``), a ROS 1 ``.bag`` or an ``.rrd``.
        topics: decode only these of /robot_description, /tf_static, /joint_states and /tf
            (the topic table always lists every topic); None for all.

    Returns:
        The recording. A damaged MCAP yields what was readable, with ``read_error`` set.

    Raises:
        RecordingError: a missing or unreadable input, or one that is not a recording; one
            line naming the file.
    """
    fmt = recording_format(path)
    wanted = DECODED_TOPICS if topics is None else frozenset(topics)
    if fmt == "mcap":
        return read_mcap(Path(path), wanted)
    if fmt == "rrd":
        return read_rrd(Path(path), wanted)
    file = Path(path)
    if fmt == "rosbag2" and file.is_file():
        file = file.parent
    single = _single_mcap(file) if fmt == "rosbag2" else None
    if single is not None:  # tfrec record --bag: read the MCAP directly, much faster than rosbags
        recording = read_mcap(single, wanted)
        recording.path, recording.format = os.fspath(file), "rosbag2"
        return recording
    return _read_rosbags(file, fmt, wanted)


def _single_mcap(folder: Path) -> Path | None:
    """The one MCAP file of a rosbag2 folder with mcap storage, unsplit and uncompressed as a whole."""
    import yaml

    try:
        meta = yaml.safe_load((folder / "metadata.yaml").read_text(encoding="utf-8"))
        info = meta["rosbag2_bagfile_information"]
        files = info["relative_file_paths"]
        if info.get("storage_identifier") != "mcap" or info.get("compression_format") or len(files) != 1:
            return None
        file = folder / str(files[0])
    except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError):
        return None  # rosbags will say what is wrong
    return file if file.is_file() else None


def _read_rosbags(path: Path, fmt: str, wanted: frozenset[str]) -> Recording:
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error
    from rosbags.serde import SerdeError
    from rosbags.typesys import Stores, get_typestore

    where = os.fspath(path)
    ros1 = fmt == "rosbag1"
    recording = Recording(path=where, format=fmt)
    collector = Collector(recording, wanted, ros1=ros1)
    default = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    try:
        with AnyReader([path], default_typestore=default) as reader:
            decoded = []
            for connection in reader.connections:
                if collector.decodes(connection.topic, connection.msgtype):
                    if not ros1 and getattr(connection.ext, "serialization_format", "cdr") != "cdr":
                        raise RecordingError(f"{where}: topic {connection.topic} is not cdr-serialized")
                    decoded.append(connection)
                    collector.set_deserializer(connection.topic, deserializer(
                        reader.typestore, connection.msgtype, ros1=ros1, where=where, topic=connection.topic))
            stats: dict[str, list[Any]] = {}  # topic → [type, count, first, last]
            pending: dict[str, list[bytes]] = {}
            for connection, log_time, raw in reader.messages():
                topic = connection.topic
                entry = stats.get(topic)
                if entry is None:
                    stats[topic] = [connection.msgtype, 1, log_time, log_time]
                else:
                    entry[1] += 1
                    entry[2] = min(entry[2], log_time)
                    entry[3] = max(entry[3], log_time)
                if connection in decoded:
                    batch = pending.setdefault(topic, [])
                    batch.append(raw)
                    if len(batch) >= _BATCH:
                        collector.add(topic, batch)
                        pending[topic] = []
            for topic, batch in pending.items():
                collector.add(topic, batch)
            for topic, (msgtype, count, first, last) in stats.items():
                collector.count(topic, msgtype, count, first, last)
    except (AnyReaderError, Reader1Error, Reader2Error, SerdeError) as err:
        raise RecordingError(f"{where}: cannot read {'ROS 1 bag' if ros1 else 'rosbag2 bag'}: {err}") from None
    except OSError as err:
        raise RecordingError(f"{where}: cannot read: {err.strerror or err}") from None
    return collector.finish()
