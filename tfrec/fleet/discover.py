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

Nothing found is lost silently, and nothing makes the search run away:

- A folder that cannot be listed (no permission, or gone since its parent was listed) and an entry
  whose kind cannot be told (a symbolic link that loops) are taken as they are: checking them gives
  an ``error`` row saying why (``cannot read: Permission denied``), and the rest is searched.
- A symbolic link to a folder is not followed (it could lead to ``/``, or back up the tree): it is
  taken when it is a rosbag2 bag, else a warning names it (give it as a PATH to search it). A
  folder reached twice in one search (a bind mount of an ancestor) is searched once.
- A file that vanishes between the search and its check is that file's ``error`` row.
"""

from __future__ import annotations

import fnmatch
import os
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from tfrec.errors import FleetError, TfrecError, TfrecWarning
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
    except (TfrecError, OSError):  # not a recording, or cannot be told: its name decides
        return suffix not in NOT_RECORDING_SUFFIXES
    return True


def _bag_or_none(path: Path) -> bool | None:
    """Whether a folder is a rosbag2 bag; None when that cannot be told (it cannot be entered)."""
    try:
        return _is_bag_folder(path)
    except OSError:
        return None


def _kind(entry: os.DirEntry[str]) -> str:
    """``folder``, ``linked folder`` (a symbolic link to one), ``file`` (anything else, a dangling link
    too), or ``unknown`` (a link that loops, an entry gone)."""
    try:
        folder = entry.is_dir()
        link = entry.is_symlink()
    except OSError:
        return "unknown"
    if folder:
        return "linked folder" if link else "folder"
    return "file"


def _listing(folder: Path, seen: set[tuple[int, int]]) -> list[os.DirEntry[str]] | None:
    """A folder's entries by name, [] when it was searched already, None when it cannot be listed.

    Raises:
        OSError: it cannot be listed.
    """
    info = folder.stat()
    if (info.st_dev, info.st_ino) in seen:
        return []
    seen.add((info.st_dev, info.st_ino))
    with os.scandir(folder) as listing:
        return sorted(listing, key=lambda entry: entry.name)


def _search(folder: Path) -> Iterator[Path]:
    """The recordings under a folder, recursively (see the module's docstring)."""
    if _bag_or_none(folder) is not False:  # a bag, or a folder that cannot be entered: its check says which
        yield folder
        return
    seen: set[tuple[int, int]] = set()
    todo = [folder]
    while todo:
        here = todo.pop()
        try:
            entries = _listing(here, seen)
        except OSError:
            yield here
            continue
        for entry in entries or ():
            if entry.name.startswith("."):
                continue
            path = here / entry.name
            kind = _kind(entry)
            if kind in ("folder", "linked folder"):
                bag = _bag_or_none(path)
                if bag or (bag is None and kind == "linked folder"):
                    yield path
                elif kind == "folder":
                    todo.append(path)
                else:
                    warnings.warn(f"{path}: a symbolic link to a folder, not searched (give it as a PATH to search "
                                  "it)", TfrecWarning, stacklevel=2)
            elif kind == "unknown" or _taken(path):
                yield path


def _is_dir(path: Path) -> bool:
    """Whether a path given is a folder (one that cannot even be looked at is taken as a file: its check
    says why)."""
    try:
        return path.is_dir()
    except OSError:
        return False


def _expand(path: str) -> list[Path]:
    """A path as given: itself when it exists, else the matches of the glob it is.

    Raises:
        FleetError: a path that does not exist and is no glob, or a glob that matches nothing.
    """
    try:
        os.lstat(path)
        return [Path(path)]
    except (FileNotFoundError, NotADirectoryError, ValueError):  # ValueError: a NUL in the path
        pass
    except OSError:  # there, but it cannot be looked at (a folder on the way it cannot enter): taken, its check says why
        return [Path(path)]
    if not _GLOB_CHARS & set(path):
        raise FleetError(f"{path}: no such file or folder")
    matches = sorted(set(_glob(path)), key=lambda p: p.as_posix())
    if not matches:
        raise FleetError(f"{path}: matches no file or folder")
    return matches


def _glob(pattern: str) -> list[Path]:
    """The paths a glob matches, as :func:`glob.glob` with ``recursive=True`` (``*``, ``?``, ``[…]``
    within a name, hidden names only when the pattern's name starts with ``.``, ``**`` for any depth of
    folders) — except that ``**`` does not follow symbolic links to folders (two links to ``.`` make
    :func:`glob.glob` run for ever), and that a folder it cannot list is a match (its check says why)."""
    parts = Path(pattern).parts
    first = next(i for i, part in enumerate(parts) if _GLOB_CHARS & set(part))
    out: list[Path] = []
    seen: set[tuple[int, int, int]] = set()
    todo: list[tuple[Path, tuple[str, ...]]] = [(Path(*parts[:first]), parts[first:])]
    while todo:
        folder, rest = todo.pop()
        if not rest:
            out.append(folder)
            continue
        part = rest[0]
        if part != "**" and not _GLOB_CHARS & set(part):
            if os.path.lexists(folder / part):
                todo.append((folder / part, rest[1:]))
            continue
        try:
            info = folder.stat()
            key = (info.st_dev, info.st_ino, len(rest))
            if key in seen:
                continue
            seen.add(key)
            with os.scandir(folder) as listing:
                entries = sorted(listing, key=lambda entry: entry.name)
        except (FileNotFoundError, NotADirectoryError):
            continue
        except OSError:
            out.append(folder)
            continue
        todo.extend(_glob_step(folder, rest, entries))
    return out


def _glob_step(folder: Path, rest: tuple[str, ...], entries: list[os.DirEntry[str]]) -> list[tuple[Path, tuple[str, ...]]]:
    """What one part of a glob (``rest[0]``) leads to from a folder's entries: (path, the parts left)."""
    part, tail = rest[0], rest[1:]
    if part == "**":
        if not tail:
            return [(folder, ())]  # the folder itself: it is searched recursively
        deeper = [(folder / entry.name, rest) for entry in entries
                  if not entry.name.startswith(".") and _kind(entry) == "folder"]
        return [(folder, tail), *deeper]
    out = []
    for entry in entries:
        if entry.name.startswith(".") and not part.startswith("."):
            continue
        if fnmatch.fnmatchcase(entry.name, part) and (not tail or _kind(entry) in ("folder", "linked folder")):
            out.append((folder / entry.name, tail))
    return out


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
            candidates = _search(path) if _is_dir(path) else iter([path])
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
        try:
            if not folder.is_dir():
                what = "no such folder" if not folder.exists() else "not a folder"
                raise FleetError(f"{os.fspath(given)}: {what} ({name} must be a folder of recordings)")
        except OSError as err:
            raise FleetError(f"{os.fspath(given)}: cannot read: {err.strerror or err}") from None
        sides.append({path.relative_to(folder).as_posix(): path for path in find_recordings([folder])})
    keys = sorted(set(sides[0]) | set(sides[1]))
    return [Pair(key, sides[0].get(key), sides[1].get(key)) for key in keys]
