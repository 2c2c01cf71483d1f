"""Finding the recordings under paths, and pairing two folders of recordings by relative path.

A recording is a file (MCAP, ROS 1 bag, Rerun ``.rrd``) or a rosbag2 folder — a folder holding
``metadata.yaml``, which is never searched further. A path given is taken as it is: a file is a
recording (when it is not one, checking it says so), a folder is searched recursively, and a
path that does not exist is read as a glob (``**`` included). In a folder search, hidden files
and folders (``.name``) are skipped, files with a recording's extension are taken, and any
other file is taken when its first bytes are a recording's
(:func:`tfrec.readers.recording_format`); of the rest, those whose extension says they are not
recordings (text, code, images, meshes, archives…) are skipped silently, and the others are
taken too, so that checking them reports them rather than a fleet's odd file going unseen.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from tfrec.errors import FleetError, TfrecError
from tfrec.formats.reader import recording_format

__all__ = ["NOT_RECORDING_SUFFIXES", "RECORDING_SUFFIXES", "Pair", "find_recordings", "pair_recordings"]

RECORDING_SUFFIXES = frozenset({".mcap", ".bag", ".rrd", ".db3"})
"""Extensions of recording files: always taken by a folder search."""

NOT_RECORDING_SUFFIXES = frozenset({
    ".txt", ".md", ".rst", ".csv", ".tsv", ".json", ".jsonl", ".yaml", ".yml", ".xml", ".toml", ".ini",
    ".cfg", ".conf", ".log", ".urdf", ".xacro", ".sdf", ".srdf", ".launch", ".rviz", ".msg", ".srv",
    ".action", ".py", ".pyc", ".sh", ".c", ".cpp", ".h", ".hpp", ".cmake", ".html", ".pdf", ".png",
    ".jpg", ".jpeg", ".gif", ".svg", ".webp", ".mp4", ".stl", ".dae", ".obj", ".ply", ".glb", ".gltf",
    ".parquet", ".npy", ".npz", ".pkl", ".h5", ".hdf5", ".zip", ".gz", ".tgz", ".tar", ".bz2", ".xz",
    ".zst", ".lz4", ".7z", ".lock", ".tmp", ".bak", ".swp", ".db3-shm", ".db3-wal", ".mcap-journal",
})
"""Extensions of files that a folder search skips silently when they are not recordings."""

_GLOB_CHARS = frozenset("*?[")


@dataclass(frozen=True, slots=True)
class Pair:
    """Two recordings at the same relative path under two folders.

    Attributes:
        key: the relative path (``/``-separated; ``.`` when the folders are rosbag2 bags themselves).
        a, b: the recording under each folder, or None when there is none on that side.
    """

    key: str
    a: Path | None
    b: Path | None


def _is_bag_folder(path: Path) -> bool:
    """A rosbag2 bag: a folder with its metadata.yaml, or the split files of one bag without it."""
    from tfrec.formats.rosbag2.metadata import bag_without_metadata

    return (path / "metadata.yaml").is_file() or bag_without_metadata(path) is not None


def _taken(file: Path) -> bool:
    """Whether a folder search takes this file (see the module's docstring)."""
    suffix = file.suffix.lower()
    if suffix in RECORDING_SUFFIXES:
        return True
    try:
        recording_format(file)
    except TfrecError:
        return suffix not in NOT_RECORDING_SUFFIXES
    return True


def _search(folder: Path) -> Iterator[Path]:
    """The recordings under a folder, recursively (rosbag2 bags are not entered)."""
    if _is_bag_folder(folder):
        yield folder
        return
    for root, dirs, files in os.walk(folder):
        here = Path(root)
        bags = [name for name in dirs if not name.startswith(".") and _is_bag_folder(here / name)]
        yield from (here / name for name in bags)
        dirs[:] = sorted(name for name in dirs if not name.startswith(".") and name not in bags)
        for name in files:
            if not name.startswith(".") and _taken(here / name):
                yield here / name


def _expand(path: str) -> list[Path]:
    """A path as given: itself when it exists, else the matches of the glob it is.

    Raises:
        FleetError: a path that does not exist and is no glob, or a glob that matches nothing.
    """
    if os.path.lexists(path):
        return [Path(path)]
    if not _GLOB_CHARS & set(path):
        raise FleetError(f"{path}: no such file or folder")
    matches = sorted(glob.glob(path, recursive=True))
    if not matches:
        raise FleetError(f"{path}: matches no file or folder")
    return [Path(match) for match in matches]


def find_recordings(paths: Iterable[str | os.PathLike[str]]) -> list[Path]:
    """Every recording under ``paths`` (files, rosbag2 folders, folders searched recursively, globs).

    Args:
        paths: what to look at; see the module's docstring for what is taken.

    Returns:
        The recordings, sorted by path, each once (a file reached twice, by two paths or a
        symbolic link, is taken at its first path).

    Raises:
        FleetError: a path that does not exist, or a glob that matches nothing.
    """
    found: dict[str, Path] = {}
    for given in paths:
        for path in _expand(os.fspath(given)):
            candidates = _search(path) if path.is_dir() else iter([path])
            for candidate in candidates:
                found.setdefault(os.path.realpath(candidate), candidate)
    return sorted(found.values(), key=lambda p: p.as_posix())


def pair_recordings(dir_a: str | os.PathLike[str], dir_b: str | os.PathLike[str]) -> list[Pair]:
    """The recordings of two folders, paired by their path relative to each folder.

    Returns:
        One :class:`Pair` per relative path found on either side, sorted by it; a recording on
        one side only has None on the other.

    Raises:
        FleetError: ``dir_a`` or ``dir_b`` is not a folder.
    """
    sides: list[dict[str, Path]] = []
    for name, given in (("dir_a", dir_a), ("dir_b", dir_b)):
        folder = Path(given)
        if not folder.is_dir():
            what = "no such folder" if not folder.exists() else "not a folder"
            raise FleetError(f"{os.fspath(given)}: {what} ({name} must be a folder of recordings)")
        sides.append({path.relative_to(folder).as_posix(): path for path in find_recordings([folder])})
    keys = sorted(set(sides[0]) | set(sides[1]))
    return [Pair(key, sides[0].get(key), sides[1].get(key)) for key in keys]
