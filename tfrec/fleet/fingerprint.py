"""A recording's fingerprint for ``--resume``: its size, modification time and a hash of its summary.

Cheap, whatever the recording's length: only the part of the file that already summarizes it is
read, never the messages.

- MCAP: the summary section (schemas, channels, statistics, chunk indexes), located through the
  footer (:func:`tfrec.mcap_summary.read_summary_section`); a file without an intact one (cut
  short, or written without a summary) falls back to its first and last 64 KiB.
- rosbag2 folder: ``metadata.yaml`` and the name, size and modification time of every file in it.
- ROS 1 bag: the index section, from the bag header's ``index_pos`` to the end (connection and
  chunk info records); an unindexed bag falls back to its first and last 64 KiB.
- anything else (``.rrd``, a file that is not a recording): its first and last 64 KiB.
"""

from __future__ import annotations

import hashlib
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from tfrec.errors import FleetError, TfrecError
from tfrec.formats.mcap.records import MCAP_MAGIC
from tfrec.formats.mcap.summary import read_summary_section
from tfrec.formats.reader import recording_format
from tfrec.formats.rosbag1.records import ROS1_MAGIC

__all__ = ["EDGE_BYTES", "INDEX_LIMIT", "Fingerprint", "fingerprint"]

EDGE_BYTES = 64 * 1024
"""Bytes hashed at each end of a file without a summary."""

INDEX_LIMIT = 64 * 1024 * 1024
"""A ROS 1 index section longer than this is not hashed whole (the file's ends are)."""


@dataclass(frozen=True, slots=True)
class Fingerprint:
    """What identifies one state of a recording.

    Attributes:
        size: bytes (a rosbag2 folder: the sum of its files).
        mtime_ns: modification time (a rosbag2 folder: the latest of its files').
        digest: 32 hex digits of the SHA-256 of the summary (see the module's docstring).
    """

    size: int
    mtime_ns: int
    digest: str

    @property
    def key(self) -> str:
        """``size:mtime_ns:digest``, the report's ``fingerprint`` column."""
        return f"{self.size}:{self.mtime_ns}:{self.digest}"


def fingerprint(path: str | os.PathLike[str]) -> Fingerprint:
    """The fingerprint of a recording (file or rosbag2 folder), reading only its summary.

    Raises:
        FleetError: the path is missing or cannot be read (one line naming it).
    """
    where = os.fspath(path)
    file = Path(path)
    try:
        if file.is_dir():
            return _folder(file)
        if file.exists() and not file.is_file():  # a FIFO or device: never read (its check is an error row)
            return Fingerprint(0, 0, hashlib.sha256(b"special\0" + os.fsencode(file)).hexdigest()[:32])
        try:
            fmt = recording_format(file)
        except TfrecError:
            fmt = ""
        with open(file, "rb") as stream:
            size = os.fstat(stream.fileno()).st_size
            mtime_ns = os.fstat(stream.fileno()).st_mtime_ns
            digest = hashlib.sha256(fmt.encode() + b"\0")
            summary: bytes | memoryview | None = None
            if fmt == "mcap":
                summary = read_summary_section(stream, size, after=len(MCAP_MAGIC))
            elif fmt == "rosbag1":
                summary = _ros1_index(stream, size)
            if summary is not None:
                digest.update(summary)
            else:
                digest.update(_edges(stream, size))
    except OSError as err:
        raise FleetError(f"{where}: cannot read: {err.strerror or err}") from None
    return Fingerprint(size, mtime_ns, digest.hexdigest()[:32])


def _folder(folder: Path) -> Fingerprint:
    """A rosbag2 folder's fingerprint: metadata.yaml's bytes and each file's name, size and time."""
    digest = hashlib.sha256(b"rosbag2\0")
    size = mtime_ns = 0
    meta = folder / "metadata.yaml"
    if meta.is_file():
        digest.update(meta.read_bytes())
    for entry in sorted(os.scandir(folder), key=lambda e: e.name):
        if not entry.is_file():
            continue
        stat = entry.stat()
        size += stat.st_size
        mtime_ns = max(mtime_ns, stat.st_mtime_ns)
        digest.update(f"\0{entry.name}\0{stat.st_size}\0{stat.st_mtime_ns}".encode())
    return Fingerprint(size, mtime_ns, digest.hexdigest()[:32])


def _edges(stream: IO[bytes], size: int) -> bytes:
    """The first and last :data:`EDGE_BYTES` of a file (the whole of a small one)."""
    stream.seek(0)
    if size <= 2 * EDGE_BYTES:
        return stream.read()
    head = stream.read(EDGE_BYTES)
    stream.seek(size - EDGE_BYTES)
    return head + stream.read(EDGE_BYTES)


def _ros1_index(stream: IO[bytes], size: int) -> bytes | None:
    """A ROS 1 bag's index section (from the bag header record's ``index_pos`` to the end), or
    None when the header is damaged, the bag is unindexed or the index is too long to hash."""
    stream.seek(len(ROS1_MAGIC))
    head = stream.read(4)
    if len(head) < 4:
        return None
    (header_len,) = struct.unpack("<I", head)
    header = stream.read(min(header_len, 4096))
    index_pos = None
    pos = 0
    while pos + 4 <= len(header):
        (field_len,) = struct.unpack_from("<I", header, pos)
        name, sep, value = header[pos + 4 : pos + 4 + field_len].partition(b"=")
        if sep and name == b"index_pos" and len(value) == 8:
            (index_pos,) = struct.unpack("<Q", value)
        pos += 4 + field_len
    if index_pos is None or not 0 < index_pos < size or size - index_pos > INDEX_LIMIT:
        return None
    stream.seek(index_pos)
    return stream.read(size - index_pos)
