"""Reading recordings back into arrays: MCAP, rosbag2 folders, ROS 1 bags and tfrec's ``.rrd``.

:func:`read_recording` gives one :class:`Recording` whatever the format: the robot descriptions,
the topic table, the joint states as one (N, J) array and every TF frame pair as a time series —
for the root namespace and for every other namespace that holds robot topics (``/robot1/tf``).
``diff`` compares two of them and ``replay`` plays one back.

How each format is read (each reader reads only what it decodes; the topic table comes from the
file's own index where it has one):

- ``.mcap`` (ROS 2 profile, CDR): :mod:`tfrec.formats.mcap.reader`, tfrec's own reader, chunks
  found through their message indexes; a file cut short is read up to the cut (complete records
  of a partial chunk included), a damaged chunk is skipped (its CRC fails) and reading goes on;
  :attr:`Recording.read_error` says what was lost.
- rosbag2 folders (:mod:`tfrec.formats.rosbag2`): MCAP storage through the MCAP reader,
  file by file; sqlite3 storage through SQL (every message the database holds, whatever the QoS
  in ``metadata.yaml``), a ``.db3`` cut short read up to the first missing page. Counts that differ
  from ``metadata.yaml`` warn. A folder of ``.mcap`` files without ``metadata.yaml`` is read as one bag,
  and a ``.db3`` given without its ``metadata.yaml`` as a bag of that database (with a warning).
- ROS 1 ``.bag`` files: :mod:`tfrec.formats.rosbag1.index`, through the bag's index; a bag
  without an index (cut short), with a damaged chunk or an index that does not describe its chunks
  is read record by record (:mod:`tfrec.formats.rosbag1.reader`).
- ``.rrd``: :mod:`tfrec.formats.rrd.reader`, through Rerun's own reader. Rerun stores transforms as float32.

JointState and TFMessage messages with a fixed layout (the same names in every message) are
decoded in bulk with numpy (:mod:`tfrec.formats.ros.decode`); anything else through rosbags'
deserializers, message by message.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from tfrec.errors import ReadError, TfrecWarning, display_path
from tfrec.formats._collect import Collector, ReadOptions
from tfrec.formats.mcap.reader import read_mcap, read_mcap_into
from tfrec.formats.mcap.records import MCAP_MAGIC
from tfrec.formats.rosbag1.index import read_rosbag1
from tfrec.formats.rosbag1.reader import ROS1_MAGIC
from tfrec.formats.rosbag2.metadata import BagMetadata, bag_without_metadata, read_bag_metadata
from tfrec.formats.rosbag2.sqlite3 import Damaged, read_sqlite3_into, salvage_sqlite3_into
from tfrec.formats.rosbag2.storage import check_metadata_counts, message_decompressor, plain_files
from tfrec.formats.rrd.reader import RRD_MAGIC, read_rrd
from tfrec.recording import Recording

__all__ = [
    "ReadOptions",
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
        if (file / "metadata.yaml").is_file() or bag_without_metadata(file) is not None:
            return "rosbag2"
        raise ReadError(f"{where}: a folder without metadata.yaml and without the split files of one bag "
                        "(name_0.mcap, name_1.mcap… or .db3): not a rosbag2 bag")
    if not file.exists():
        raise ReadError(f"{where}: no such file or folder")
    if not file.is_file():  # reading a FIFO would wait forever, a device never end
        raise ReadError(f"{where}: not a regular file (a FIFO, device or socket), not a recording")
    if file.name == "metadata.yaml":  # a rosbag2 bag named by its metadata: the bag (as its .db3 files name it)
        return "rosbag2"
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
    if head.startswith(b"SQLite format 3\0") and ((file.parent / "metadata.yaml").is_file() or file.suffix == ".db3"):
        return "rosbag2"  # a .db3 on its own: rosbag2's database, read as rosbags and `ros2 bag` read it
    if not head:
        raise ReadError(f"{where}: an empty file (0 bytes), not a recording")
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
    folder = file.parent if file.is_file() else file
    if not (folder / "metadata.yaml").is_file():
        if file.is_file():  # a .db3 given on its own
            warnings.warn(f"{display_path(file)}: no metadata.yaml beside it: read as a rosbag2 database on its own "
                          "(as rosbags and `ros2 bag` read it), topics and QoS from its own tables", TfrecWarning, stacklevel=2)
            return RecordingSource(file, fmt, BagMetadata("sqlite3", (file,), ""))
        meta = bag_without_metadata(folder)
        assert meta is not None  # recording_format found its files
        return RecordingSource(file, fmt, meta)
    return RecordingSource(file, fmt, read_bag_metadata(folder))


def read_recording(
    path: str | os.PathLike[str] | RecordingSource,
    *,
    topics: Collection[str] | None = None,
    namespace: str | None = None,
    remap: Iterable[str] | Mapping[str, str] | None = None,
    use_log_time: bool = False,
    summary: bool = False,
) -> Recording:
    """Read a recording into arrays.

    Args:
        path: an ``.mcap`` file, a rosbag2 folder (or its ``.db3``), a ROS 1 ``.bag`` or an
            ``.rrd``; or what :func:`identify_recording` found of one.
        topics: decode only these of /robot_description, /tf_static, /joint_states and /tf —
            in every namespace (``/tf`` is robot1's ``/robot1/tf`` too), or one namespace's
            (``/robot1/tf``); the topic table always lists every topic. None for all.
        namespace: decode only the robot topics of this namespace (``/robot1``, ``"/"`` for the
            root) and of the root namespace, whose /tf and /joint_states its robots may share.
        remap: ``FROM:=TO`` rules (or a mapping) that rename topics as ROS remapping does,
            before anything else: ``["/robot1/tf:=/tf"]``.
        use_log_time: take each message's log time for the stamps of /joint_states and /tf
            (:attr:`Recording.time_base` ``log``): for a driver that stamps 0, say.
        summary: decode only what a summary needs: every description and /tf_static message,
            the first /joint_states message and the first thousand /tf messages of each namespace.

    Returns:
        The recording. A damaged MCAP, ROS 1 bag or sqlite3 bag yields what was readable,
        with ``read_error`` set.

    Raises:
        ReadError: a missing or unreadable input, one that is not a recording, or a bad `remap` rule;
            one line naming the file.
    """
    options = ReadOptions.of(topics=topics, namespace=namespace, remap=remap, use_log_time=use_log_time,
                             summary=summary)
    source = path if isinstance(path, RecordingSource) else identify_recording(path)
    fmt, file = source.format, source.path
    if fmt == "mcap":
        return read_mcap(file, options)
    if fmt == "rrd":
        return read_rrd(file, options)
    if fmt == "rosbag1":
        return read_rosbag1(file, options)
    if file.is_file():
        file = file.parent
    meta = source.bag if source.bag is not None else read_bag_metadata(file)  # its errors are one line
    return _read_rosbag2(file, meta, options)


def _read_rosbag2(folder: Path, meta: BagMetadata, options: ReadOptions) -> Recording:
    """A rosbag2 bag's files as one recording: MCAP storage file by file through the MCAP reader,
    sqlite3 storage through SQL (read again row by row, as far as SQLite goes, when a database is damaged).

    Raises:
        ReadError: an unknown storage or compression, a file that cannot be read, or nothing readable.
    """
    where = os.fspath(folder)
    if meta.storage not in ("mcap", "sqlite3"):
        raise ReadError(f"{where}: storage '{meta.storage}' (tfrec reads mcap and sqlite3 bags)")
    decompress = message_decompressor(meta, where)
    recording = Recording(path=where, format="rosbag2")
    collector = Collector(recording, options, ros1=False, decompress=decompress)
    with plain_files(meta, where) as files:
        if meta.storage == "mcap":
            true_starts = [lost[1] for file in files
                           if (lost := read_mcap_into(file, collector, where=where)) is not None and lost[1] is not None]
        else:
            true_starts = []
            try:
                read_sqlite3_into(files, collector, where=where)
            except Damaged as err:
                recording = Recording(path=where, format="rosbag2")
                collector = Collector(recording, options, ros1=False, decompress=decompress)
                salvage_sqlite3_into(files, collector, where=where, refused=str(err))
    collector.finish()
    if true_starts and (recording.start_ns is None or min(true_starts) < recording.start_ns):
        recording.start_ns = min(true_starts)  # messages before the first one read were lost
    recording.details["storage"] = meta.storage
    if meta.compression:
        recording.details["bag_compression"] = f"{meta.compression} {meta.compression_mode or 'file'}"
    if meta.topic_counts is not None and recording.read_error is None:
        check_metadata_counts(recording, meta, options, where)
    return recording
