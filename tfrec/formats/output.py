"""Writers of raw messages on any connections, one interface over the three outputs of ``tfrec convert``.

:func:`open_output` gives a :class:`MessageWriter` of a ROS 2 MCAP file
(:class:`~tfrec.formats.mcap.writer.McapWriter`), a rosbag2 folder (that MCAP, and its
``metadata.yaml`` from what it embedded) or a ROS 1 bag
(:class:`~tfrec.formats.rosbag1.writer.Ros1BagWriter`). Connections are added as
:class:`~tfrec.formats.ros.connection.Connection` s already in the output's serialization
(:func:`tfrec.formats.translate.translation`); publishers a format cannot tell apart share one
connection: an MCAP channel per topic, type and durability, a ROS 1 connection per topic, type,
md5sum, latching and caller id. An MCAP input's attachments and metadata records go to an MCAP output
as they are (:meth:`MessageWriter.copy_extras`); a ROS 1 bag cannot hold them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from tfrec.formats.mcap.writer import McapWriter
from tfrec.formats.ros.connection import Connection, Extra
from tfrec.formats.ros.decode import RawMessages
from tfrec.formats.rosbag1.writer import Ros1BagWriter
from tfrec.formats.rosbag2.metadata import bag_storage_name, write_bag_metadata

__all__ = ["OUTPUT_KINDS", "MessageWriter", "open_output"]

OUTPUT_KINDS = {"mcap": "cdr", "rosbag2": "cdr", "rosbag1": "ros1"}
"""Each output kind and the serialization its messages have."""

Data = NDArray[np.uint8] | Sequence[bytes | memoryview]


def _rows(data: Data) -> Data:
    """Messages that lie in one buffer and all have one size, as an (n, size) view (the writers'
    fast path); anything else as it is."""
    if isinstance(data, RawMessages) and len(data):
        sizes = data.sizes()
        if bool((sizes == sizes[0]).all()):
            return data.rows(np.arange(len(data)), int(sizes[0]))
    return data


class MessageWriter:
    """A recording being written: connections, then messages, then :meth:`finish` (or :meth:`abort`).

    Attributes:
        encoding: the serialization of its messages, ``cdr`` or ``ros1``.
        counts: messages written per connection id.
    """

    encoding = ""

    def __init__(self) -> None:
        self.counts: dict[int, int] = {}
        self._ids: dict[tuple[object, ...], int] = {}

    def add(self, connection: Connection) -> int:
        """The id of a connection (in the output's serialization), added when it is new."""
        key = self._key(connection)
        found = self._ids.get(key)
        if found is None:
            found = self._ids[key] = self._add(connection)
            self.counts[found] = 0
        return found

    def write(self, conn: int, log_time: NDArray[np.int64], data: Data,
              publish_time: NDArray[np.int64] | None = None) -> None:
        """Write N messages of one connection (log times in any order).

        Raises:
            WriteError: a time the format cannot hold, or a write error.
        """
        if len(log_time):
            self._write(conn, log_time, _rows(data), publish_time)
            self.counts[conn] += len(log_time)

    def copy_extras(self, extras: Sequence[Extra]) -> list[tuple[str, str]]:
        """Copy an input's attachments and metadata records (an MCAP's) after the messages written so far.

        Returns:
            Those left out and why: (``attachment 'calibration.yaml'``, ``a ROS 1 bag cannot hold …``).

        Raises:
            WriteError: a write error.
        """
        return [(extra.shown, "a ROS 1 bag cannot hold attachments or metadata records") for extra in extras]

    def finish(self) -> None:
        """Write the index and summary, and close the file(s).

        Raises:
            WriteError: a write error.
        """
        raise NotImplementedError

    def abort(self) -> None:
        """Close the file(s) after an error (the caller deletes them)."""
        raise NotImplementedError

    def _key(self, connection: Connection) -> tuple[object, ...]:
        raise NotImplementedError

    def _add(self, connection: Connection) -> int:
        raise NotImplementedError

    def _write(self, conn: int, log_time: NDArray[np.int64], data: Data, publish_time: NDArray[np.int64] | None) -> None:
        raise NotImplementedError


class _McapOutput(MessageWriter):
    encoding = "cdr"

    def __init__(self, path: Path, *, compression: str, bag_dir: Path | None) -> None:
        super().__init__()
        self._bag_dir = bag_dir
        self._file_name = path.name
        self._stream: IO[bytes] = open(path, "wb")  # noqa: SIM115 - closed by finish() or abort()
        try:
            self._writer = McapWriter(self._stream, compression=compression)
        except BaseException:
            self._stream.close()
            raise

    def _key(self, connection: Connection) -> tuple[object, ...]:
        return connection.topic, connection.msgtype, connection.encoding, connection.latched

    def _add(self, connection: Connection) -> int:
        return self._writer.add_channel(connection)

    def _write(self, conn: int, log_time: NDArray[np.int64], data: Data, publish_time: NDArray[np.int64] | None) -> None:
        self._writer.write(conn, log_time, data, publish_time)

    def copy_extras(self, extras: Sequence[Extra]) -> list[tuple[str, str]]:
        return self._writer.copy_extras(extras)

    def finish(self) -> None:
        self._writer.finish()
        self._stream.close()
        if self._bag_dir is not None:
            write_bag_metadata(self._bag_dir, self._writer.bag_info, file_name=self._file_name)

    def abort(self) -> None:
        self._writer.abort()
        self._stream.close()


class _Ros1Output(MessageWriter):
    encoding = "ros1"

    def __init__(self, path: Path, *, compression: str) -> None:
        super().__init__()
        self._writer = Ros1BagWriter(path, compression=compression)

    def _key(self, connection: Connection) -> tuple[object, ...]:
        return connection.topic, connection.msgtype, connection.type_hash, connection.latched, connection.callerid

    def _add(self, connection: Connection) -> int:
        return self._writer.add_connection(connection.topic, connection.msgtype, msgdef=connection.definition,
                                           md5sum=connection.type_hash, latching=connection.latched,
                                           callerid=connection.callerid or None)

    def _write(self, conn: int, log_time: NDArray[np.int64], data: Data, publish_time: NDArray[np.int64] | None) -> None:
        self._writer.write_many(conn, log_time, data)

    def finish(self) -> None:
        self._writer.close()

    def abort(self) -> None:
        self._writer.abort()


def open_output(path: Path, *, kind: str, compression: str | None = None, name: str | None = None) -> MessageWriter:
    """A writer of ``path``: an MCAP file (``mcap``), a rosbag2 folder (``rosbag2``: ``path`` is
    the folder, which must exist) or a ROS 1 bag (``rosbag1``).

    Args:
        path: where to write (the caller's temporary name).
        kind: one of :data:`OUTPUT_KINDS`.
        name: a rosbag2 folder's final name: its MCAP is ``<name>_0.mcap`` (default: ``path``'s name).
        compression: chunk compression: MCAP ``zstd`` (default), ``lz4`` or ``none``; ROS 1 ``none``
            (default), ``bz2`` or ``lz4``.

    Raises:
        WriteError: an unknown compression, or a file that cannot be created.
    """
    if kind == "rosbag1":
        return _Ros1Output(path, compression=compression or "none")
    if kind == "rosbag2":
        return _McapOutput(path / bag_storage_name(name or path.name), compression=compression or "zstd", bag_dir=path)
    if kind != "mcap":
        raise ValueError(f"output kind {kind!r} is not one of {', '.join(OUTPUT_KINDS)}")
    return _McapOutput(path, compression=compression or "zstd", bag_dir=None)
