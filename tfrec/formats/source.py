"""The one door to a recording's messages: what it is (:func:`identify_recording`), and its one source
(:func:`open_messages`), whatever the format.

:func:`open_messages` opens an MCAP file, a rosbag2 folder (mcap or sqlite3 storage, compressed file by file or
message by message) or a ROS 1 bag as its format's :class:`~tfrec.formats.ros.connection.MessageSource` — the one
reader of that format (:mod:`tfrec.formats.mcap.source`, :mod:`tfrec.formats.rosbag2.source`,
:mod:`tfrec.formats.rosbag1.source`) — with topic names resolved as a player publishes them (relative names global,
``remap`` rules applied). :func:`tfrec.formats.read_recording`, ``convert``, ``replay``, ``check``, ``diff`` and
``info`` all read through it.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from tfrec.errors import ReadError, TfrecWarning, display_path
from tfrec.formats._collect import ReadOptions
from tfrec.formats.mcap.records import MCAP_MAGIC
from tfrec.formats.ros.connection import Extra, MessageSource

if TYPE_CHECKING:
    from tfrec.formats.rosbag2.metadata import BagMetadata

# Each format's source (and a rosbag2 folder's metadata.yaml reader, with YAML) is imported when a recording of
# that format is opened, and its magic when a file's first bytes are not MCAP's: `tfrec info` of an MCAP file loads
# no code of the other formats.

__all__ = ["RecordingSource", "identify_recording", "listed_extras", "open_messages", "recording_format"]


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

    @property
    def where(self) -> str:
        """The recording, for messages: the file, or a rosbag2 bag's folder."""
        if self.format == "rosbag2" and self.path.is_file():
            return os.fspath(self.path.parent)
        return os.fspath(self.path)


def recording_format(path: str | os.PathLike[str]) -> str:
    """The format of a recording: ``mcap``, ``rosbag2``, ``rosbag1`` or ``rrd``, from its first bytes.

    Raises:
        ReadError: a missing path, or something that is none of those.
    """
    where = os.fspath(path)
    file = Path(path)
    if file.is_dir():
        from tfrec.formats.rosbag2.metadata import bag_without_metadata

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
    from tfrec.formats.rosbag1.records import ROS1_MAGIC

    if head.startswith(ROS1_MAGIC):
        return "rosbag1"
    from tfrec.formats.rrd.reader import RRD_MAGIC

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
    from tfrec.formats.rosbag2.metadata import BagMetadata, bag_without_metadata, read_bag_metadata

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


@contextlib.contextmanager
def open_messages(
    path: str | os.PathLike[str] | RecordingSource,
    *,
    remap: Iterable[str] | Mapping[str, str] | None = None,
) -> Iterator[MessageSource]:
    """A recording's messages: its format's one source (a context: a bag compressed file by file is decompressed to
    a temporary folder while it is read). Its :meth:`~tfrec.formats.ros.connection.MessageSource.batches` takes
    the connections asked for (``batches(connections=…)``).

    Args:
        path: an ``.mcap`` file, a rosbag2 folder (or its ``.db3``), a ROS 1 ``.bag``, or what
            :func:`identify_recording` found of one.
        remap: ``FROM:=TO`` topic remapping rules (or a mapping), applied as ROS applies them.

    Raises:
        ReadError: a missing file, one that is not such a recording (a Rerun ``.rrd`` holds no ROS messages), an
            unknown rosbag2 storage or compression, a bad `remap` rule.
    """
    options = ReadOptions.of(remap=remap)
    with messages_of(path if isinstance(path, RecordingSource) else identify_recording(path),
                     options.resolve) as source:
        yield source


@contextlib.contextmanager
def messages_of(source: RecordingSource, resolve: Callable[[str], str]) -> Iterator[MessageSource]:
    """:func:`open_messages` of a recording identified, its topic names resolved by ``resolve``: the one dispatch
    over the formats."""
    where = source.where
    if source.format == "mcap":
        from tfrec.formats.mcap.source import McapSource

        yield McapSource([source.path], where=where, resolve=resolve)
        return
    if source.format == "rosbag1":
        from tfrec.formats.rosbag1.source import Ros1Source

        yield Ros1Source(source.path, where=where, resolve=resolve)
        return
    if source.format != "rosbag2":
        raise ReadError(f"{where}: a Rerun recording holds no ROS messages (MCAP files, rosbag2 folders and ROS 1 "
                        "bags do)")
    with _rosbag2_messages(source, resolve) as found:
        yield found


@contextlib.contextmanager
def _rosbag2_messages(source: RecordingSource, resolve: Callable[[str], str]) -> Iterator[MessageSource]:
    """A rosbag2 bag's source: its MCAP or sqlite3 files, decompressed to a temporary folder while read when the bag
    is compressed file by file."""
    from tfrec.formats.rosbag2.metadata import read_bag_metadata
    from tfrec.formats.rosbag2.storage import message_decompressor, plain_files

    where = source.where
    meta = source.bag if source.bag is not None else read_bag_metadata(Path(where))
    if meta.storage not in ("mcap", "sqlite3"):
        raise ReadError(f"{where}: storage '{meta.storage}' (tfrec reads mcap and sqlite3 bags)")
    decompress = message_decompressor(meta, where)
    with plain_files(meta, where) as files:
        found: MessageSource
        if meta.storage == "mcap":
            from tfrec.formats.mcap.source import McapSource

            found = McapSource(files, where=where, resolve=resolve, decompress=decompress, fmt="rosbag2")
        else:
            from tfrec.formats.rosbag2.source import Sqlite3Source

            found = Sqlite3Source(files, where=where, resolve=resolve, decompress=decompress)
        if meta.topic_counts is not None:
            expected: dict[str, int] = {}
            for topic, count in meta.topic_counts.items():
                expected[resolve(topic)] = expected.get(resolve(topic), 0) + count
            found.expected_counts = expected
        yield found


def listed_extras(source: RecordingSource) -> list[Extra]:
    """The attachments and metadata records the summaries of a recording's MCAP files index (an MCAP file,
    a rosbag2 bag of MCAP storage whose files are not compressed whole), without reading its messages:
    what an output that cannot hold them leaves out."""
    files = [source.path] if source.format == "mcap" else list(source.files) if (
        source.format == "rosbag2" and source.bag is not None and source.bag.storage == "mcap") else []
    from tfrec.formats.mcap import summary

    found: list[Extra] = []
    for file in files:
        try:
            with open(file, "rb") as stream:
                found.extend(summary.listed_extras(stream, os.fstat(stream.fileno()).st_size, Path(file)))
        except OSError:
            continue  # reading the recording says what is wrong with it
    return found
