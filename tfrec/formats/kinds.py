"""The recordings tfrec writes, recognized on disk: the :class:`tfrec._outputs.OutputKind` of each output.

``--force`` replaces an existing output only when it is of the kind tfrec writes there (docs/security.md):

- :data:`MCAP`, :data:`ROS1_BAG`, :data:`RRD`: a regular file that begins with MCAP's magic, ``#ROSBAG V2.0``
  or Rerun's ``RRF2``;
- :data:`ROSBAG2`: a folder holding a ``metadata.yaml`` that rosbag2 (or tfrec, or rosbags) wrote, read with the
  bounded YAML loader, and the storage files it lists (MCAP, SQLite or zstd-compressed), nothing else: no other
  file, no subfolder, no link. Replacing it removes exactly those entries.

The reports of ``tfrec check`` have their kinds in :mod:`tfrec.fleet.report`, pictures in :mod:`tfrec.plots`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import final

from tfrec._outputs import FileKind, NotOurs, read_head
from tfrec.errors import ReadError
from tfrec.formats.mcap.records import MCAP_MAGIC
from tfrec.formats.rosbag1.records import ROS1_MAGIC
from tfrec.formats.rosbag2.metadata import bag_storage_name, read_bag_metadata
from tfrec.formats.rrd.reader import RRD_MAGIC

__all__ = ["MCAP", "ROS1_BAG", "ROSBAG2", "RRD", "STORAGE_SIGNATURES", "Rosbag2Folder"]

MCAP = FileKind("an MCAP file", (MCAP_MAGIC,), suffix=".mcap")
ROS1_BAG = FileKind("a ROS 1 bag", (ROS1_MAGIC,), suffix=".bag")
RRD = FileKind("a Rerun recording", (RRD_MAGIC,), suffix=".rrd")

STORAGE_SIGNATURES = (MCAP_MAGIC, b"SQLite format 3\0", b"\x28\xb5\x2f\xfd")
"""How a rosbag2 storage file begins: MCAP, sqlite3, or either compressed whole with zstd (``bag_0.mcap.zstd``)."""


@final
@dataclass(frozen=True, slots=True)
class Rosbag2Folder:
    """A rosbag2 bag folder: ``metadata.yaml`` and the storage files it lists, nothing else."""

    name: str = "a rosbag2 folder"
    folder: bool = field(default=True, init=False)
    suffix: str | None = field(default=None, init=False)

    def owned(self, target: Path) -> list[Path]:
        """``metadata.yaml`` and the storage files of the bag ``target``.

        Raises:
            NotOurs: no (or a linked, or a malformed) metadata.yaml, a listed file missing, an entry it does not
                list, or a storage file that is a link, a folder or none of MCAP, SQLite and zstd.
        """
        meta = target / "metadata.yaml"
        if not os.path.lexists(meta):
            raise NotOurs("it has no metadata.yaml")
        try:
            read_head(meta, 0)  # a regular file, not a link
        except NotOurs as why:
            raise NotOurs(f"its metadata.yaml: {why}") from None
        try:
            files = read_bag_metadata(target).files
        except ReadError as err:
            raise NotOurs(f"its metadata.yaml is not a rosbag2 bag's: {_after_path(str(err))}") from None
        listed = {file.name for file in files}
        with os.scandir(target) as entries:
            for entry in entries:  # stops at the first entry not listed: bounded by the metadata
                if entry.name == meta.name:
                    continue
                if entry.name not in listed:
                    raise NotOurs(f"it holds {entry.name}, which its metadata.yaml does not list")
                try:
                    head = read_head(Path(entry.path), 16)
                except NotOurs as why:
                    raise NotOurs(f"its {entry.name}: {why}") from None
                if not head.startswith(STORAGE_SIGNATURES):
                    raise NotOurs(f"its {entry.name} is not rosbag2 storage (MCAP, SQLite or zstd)")
        return [meta, *files]

    def inner_names(self, target: Path) -> tuple[str, ...]:
        return ("metadata.yaml", bag_storage_name(target.name))

    def unfinished(self, path: Path) -> bool:
        """A folder of regular files only: ``metadata.yaml`` and storage files, each empty or beginning as MCAP,
        SQLite or zstd (what a bag being written holds)."""
        try:
            with os.scandir(path) as scan:
                entries = list(scan)
        except OSError:
            return False
        for entry in entries:
            if entry.name == "metadata.yaml" and entry.is_file(follow_symlinks=False):
                continue
            try:
                head = read_head(Path(entry.path), 16)
            except NotOurs:
                return False
            if head and not head.startswith(STORAGE_SIGNATURES):
                return False
        return True


def _after_path(message: str) -> str:
    """An error's message without the path it begins with."""
    return message.split(": ", 1)[-1]


ROSBAG2 = Rosbag2Folder()
