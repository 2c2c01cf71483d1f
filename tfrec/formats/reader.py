"""Reading recordings back into arrays: MCAP, rosbag2 folders, ROS 1 bags and tfrec's ``.rrd``.

:func:`read_recording` gives one :class:`Recording` whatever the format: the robot description,
the topic table, the joint states as one (N, J) array and every TF frame pair as a time series.
``diff`` compares two of them and ``replay`` plays one back.

How each format is read:

- ``.mcap`` (ROS 2 profile, CDR): :mod:`tfrec.formats.mcap.reader`, tfrec's own sequential reader; a
  file cut short is read up to the cut (complete records of a partial chunk included), a damaged
  chunk is skipped (its CRC fails) and reading goes on; :attr:`Recording.read_error` says what was lost.
- rosbag2 folders (mcap or sqlite3 storage) and ROS 1 ``.bag`` files: ``rosbags``' ``AnyReader``
  (a rosbag2 folder of one uncompressed MCAP: :mod:`tfrec.formats.mcap.reader`). What rosbags refuses is
  read as far as possible, with :attr:`Recording.read_error` saying where reading stopped: a ROS 1
  bag cut short, without an index, with a damaged chunk or with an index that rosbags trips over
  (an assertion fails, a lookup misses) record by record
  (:mod:`tfrec.formats.rosbag1.reader`); a sqlite3 ``.db3`` cut short through SQLite, from a copy whose
  header's page count is lowered to the pages the file still has, its ``messages`` table in row
  order up to the first missing page.
- ``.rrd``: :mod:`tfrec.formats.rrd.reader`, through Rerun's own reader. Rerun stores transforms as float32.

JointState and TFMessage messages with a fixed layout (the same names in every message) are
decoded in bulk with numpy (:mod:`tfrec.formats.ros.decode`); anything else through rosbags'
deserializers, message by message.
"""

from __future__ import annotations

import os
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

from tfrec.errors import ReadError
from tfrec.formats._collect import DECODED_TOPICS
from tfrec.formats._rosbags import read_rosbags
from tfrec.formats.mcap.reader import read_mcap
from tfrec.formats.mcap.records import MCAP_MAGIC
from tfrec.formats.rosbag1.reader import ROS1_MAGIC
from tfrec.formats.rosbag2.metadata import BagMetadata, read_bag_metadata
from tfrec.formats.rrd.reader import RRD_MAGIC, read_rrd
from tfrec.recording import Recording

__all__ = [
    "RecordingSource",
    "identify_recording",
    "read_recording",
    "recording_format",
]

@dataclass(frozen=True, slots=True)
class RecordingSource:
    """A recording identified, not yet read (:func:`identify_recording`).

    Attributes:
        path: the path given: a file, or a rosbag2 folder.
        format: ``mcap``, ``rosbag2``, ``rosbag1`` or ``rrd``.
        bag: a rosbag2 bag's ``metadata.yaml``; None for the other formats.
    """

    path: Path
    format: str
    bag: BagMetadata | None = None

    @property
    def files(self) -> tuple[Path, ...]:
        """The files that hold the recording: a rosbag2 bag's, else the file itself."""
        return self.bag.files if self.bag is not None else (self.path,)


def recording_format(path: str | os.PathLike[str]) -> str:
    """The format of a recording: ``mcap``, ``rosbag2``, ``rosbag1`` or ``rrd``, from its first bytes.

    Raises:
        ReadError: a missing path, or something that is none of those.
    """
    where = os.fspath(path)
    file = Path(path)
    if file.is_dir():
        if (file / "metadata.yaml").is_file():
            return "rosbag2"
        raise ReadError(f"{where}: a folder without metadata.yaml (not a rosbag2 bag)")
    if not file.exists():
        raise ReadError(f"{where}: no such file or folder")
    try:
        with open(file, "rb") as stream:
            head = stream.read(16)
    except OSError as err:
        raise ReadError(f"{where}: cannot read: {err.strerror or err}") from err
    if head.startswith(MCAP_MAGIC):
        return "mcap"
    if head.startswith(ROS1_MAGIC):
        return "rosbag1"
    if head.startswith(RRD_MAGIC):
        return "rrd"
    if head.startswith(b"SQLite format 3\0") and (file.parent / "metadata.yaml").is_file():
        return "rosbag2"
    raise ReadError(f"{where}: not a recording (neither MCAP, rosbag2, ROS 1 bag nor Rerun .rrd)")


def identify_recording(path: str | os.PathLike[str]) -> RecordingSource:
    """The format of a recording (:func:`recording_format`) and, for a rosbag2 bag, its ``metadata.yaml``.

    Raises:
        ReadError: a missing path, something that is not a recording, or a rosbag2 bag
            whose metadata.yaml is malformed or lists missing files; one line naming the file.
    """
    fmt = recording_format(path)
    file = Path(path)
    if fmt != "rosbag2":
        return RecordingSource(file, fmt)
    return RecordingSource(file, fmt, read_bag_metadata(file.parent if file.is_file() else file))


def read_recording(
    path: str | os.PathLike[str] | RecordingSource, *, topics: Collection[str] | None = None
) -> Recording:
    """Read a recording into arrays.

    Args:
        path: an ``.mcap`` file, a rosbag2 folder (or its ``.db3``), a ROS 1 ``.bag`` or an
            ``.rrd``; or what :func:`identify_recording` found of one.
        topics: decode only these of /robot_description, /tf_static, /joint_states and /tf
            (the topic table always lists every topic); None for all.

    Returns:
        The recording. A damaged MCAP, ROS 1 bag or sqlite3 bag yields what was readable,
        with ``read_error`` set.

    Raises:
        ReadError: a missing or unreadable input, or one that is not a recording; one
            line naming the file.
    """
    source = path if isinstance(path, RecordingSource) else identify_recording(path)
    wanted = DECODED_TOPICS if topics is None else frozenset(topics)
    fmt, file = source.format, source.path
    if fmt == "mcap":
        return read_mcap(file, wanted)
    if fmt == "rrd":
        return read_rrd(file, wanted)
    if fmt == "rosbag1":
        return read_rosbags(file, fmt, wanted)
    if file.is_file():
        file = file.parent
    meta = source.bag if source.bag is not None else read_bag_metadata(file)  # its errors are one line
    if meta.storage == "mcap" and not meta.compression and len(meta.files) == 1:
        recording = read_mcap(meta.files[0], wanted)  # tfrec record --bag: much faster than rosbags
        recording.path, recording.format = os.fspath(file), "rosbag2"
        recording.details["storage"] = "mcap"
        return recording
    return read_rosbags(file, fmt, wanted, meta)
