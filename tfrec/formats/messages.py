"""Every message of a recording, raw: the door ``tfrec convert`` reads through.

:func:`open_messages` opens whatever :func:`tfrec.formats.read_recording` reads — an MCAP file, a
rosbag2 folder (mcap or sqlite3 storage, compressed or not), a ROS 1 bag — as a
:class:`~tfrec.formats.ros.connection.MessageSource`: its connections (type, definition, QoS or
latching) and its messages in batches, one chunk at a time, nothing decoded. Topic names are
resolved as a player publishes them (relative names global, ``remap`` rules applied).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

from tfrec.errors import ReadError
from tfrec.formats._collect import ReadOptions
from tfrec.formats.mcap import summary
from tfrec.formats.mcap.messages import McapMessages
from tfrec.formats.reader import RecordingSource, identify_recording
from tfrec.formats.ros.connection import Connection, Extra, MessageBatch, MessageSource
from tfrec.formats.rosbag1.messages import Ros1Messages
from tfrec.formats.rosbag2.messages import Sqlite3Messages
from tfrec.formats.rosbag2.metadata import read_bag_metadata
from tfrec.formats.rosbag2.storage import message_decompressor, plain_files

__all__ = ["Connection", "Extra", "MessageBatch", "MessageSource", "listed_extras", "open_messages"]


@contextlib.contextmanager
def open_messages(
    path: str | os.PathLike[str] | RecordingSource,
    *,
    remap: Iterable[str] | Mapping[str, str] | None = None,
) -> Iterator[MessageSource]:
    """A recording's raw messages (a context: a bag compressed file by file is decompressed to a
    temporary folder while it is read).

    Args:
        path: an ``.mcap`` file, a rosbag2 folder, a ROS 1 ``.bag``, or what
            :func:`tfrec.formats.identify_recording` found of one.
        remap: ``FROM:=TO`` topic remapping rules (or a mapping), applied as ROS applies them.

    Raises:
        ReadError: a missing file, one that is not such a recording (a Rerun ``.rrd`` holds no
            ROS messages), an unknown rosbag2 storage or compression, a bad `remap` rule.
    """
    resolve = ReadOptions.of(remap=remap).resolve
    source = path if isinstance(path, RecordingSource) else identify_recording(path)
    where = os.fspath(source.path)
    if source.format == "mcap":
        yield McapMessages([source.path], where=where, resolve=resolve)
        return
    if source.format == "rosbag1":
        yield Ros1Messages(source.path, where=where, resolve=resolve)
        return
    if source.format != "rosbag2":
        raise ReadError(f"{where}: a Rerun recording holds no ROS messages to copy "
                        "(MCAP files, rosbag2 folders and ROS 1 bags do)")
    folder = source.path.parent if source.path.is_file() else source.path
    meta = source.bag if source.bag is not None else read_bag_metadata(Path(folder))
    where = os.fspath(folder)
    if meta.storage not in ("mcap", "sqlite3"):
        raise ReadError(f"{where}: storage '{meta.storage}' (tfrec reads mcap and sqlite3 bags)")
    decompress = message_decompressor(meta, where)
    with plain_files(meta, where) as files:
        if meta.storage == "mcap":
            yield McapMessages(files, where=where, resolve=resolve, decompress=decompress, fmt="rosbag2")
        else:
            yield Sqlite3Messages(files, where=where, resolve=resolve, decompress=decompress)


def listed_extras(source: RecordingSource) -> list[Extra]:
    """The attachments and metadata records the summaries of a recording's MCAP files index (an MCAP file,
    a rosbag2 bag of MCAP storage whose files are not compressed whole), without reading its messages:
    what an output that cannot hold them leaves out."""
    files = [source.path] if source.format == "mcap" else list(source.files) if (
        source.format == "rosbag2" and source.bag is not None and source.bag.storage == "mcap") else []
    found: list[Extra] = []
    for file in files:
        try:
            with open(file, "rb") as stream:
                found.extend(summary.listed_extras(stream, os.fstat(stream.fileno()).st_size, Path(file)))
        except OSError:
            continue  # reading the recording says what is wrong with it
    return found
