"""Which files a robot description may read: its workspace, its packages, the folders named.

xacro reads what a description names — ``<xacro:include filename="…">``, ``xacro.load_yaml('…')``
— wherever it is: ``/etc/passwd``, ``../../../.ssh/id_rsa``, a link to either. What it reads can
end up in the URDF and so in a recording others receive. :class:`ReadRoots` decides, by the
file's *real* path (every link resolved: that is what the system opens), whether it lies in

1. the input file itself, or its workspace: the ``src`` folder of the colcon or catkin
   workspace holding its package, else the folder holding its package, else the input's
   own folder — never a home folder or the file system's root, which are too broad (then
   only the package, or only the input);
2. a ``package_paths`` folder, or an ``allow_paths`` entry (a folder or a file);
3. a package the :class:`~tfrec.description.packages.PackageFinder` resolves — the package
   enclosing the real path must be what ``$(find <its name>)`` gives, or an installed copy of
   it whose ``package.xml`` is a link to it (colcon ``--symlink-install``: ``install/…/share/
   <pkg>`` holds links into ``src/<pkg>``).

A link inside an allowed package that points outside (``urdf/evil.yaml -> /etc/passwd``) is
refused: only where it leads counts.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from tfrec.description.packages import PackageFinder, package_name
from tfrec.errors import DescriptionError

__all__ = ["ReadRoots", "read_capped"]


class ReadRoots:
    """The places a description may read files from (see the module's docstring).

    Args:
        input_path: the description file given by the user.
        finder: resolves ``$(find pkg)``; the packages it resolves may be read.
        package_paths: the ``package_paths`` folders (``--package-path``).
        allow_paths: more folders or files that may be read.
    """

    def __init__(
        self,
        input_path: str | os.PathLike[str],
        *,
        finder: PackageFinder,
        package_paths: Sequence[str | os.PathLike[str]] = (),
        allow_paths: Sequence[str | os.PathLike[str]] = (),
    ) -> None:
        given = Path(os.path.abspath(input_path))
        real = _real(given)
        self._files = {given, real}
        folders = [*_workspace(given), *_workspace(real), *(Path(p) for p in package_paths)]
        for extra in map(Path, allow_paths):
            if extra.is_file():
                self._files.add(_real(extra))
            else:
                folders.append(extra)
        self._folders = sorted({_real(f.expanduser()) for f in folders})
        self._finder = finder
        self._packages: dict[Path, bool] = {}

    @property
    def folders(self) -> list[Path]:
        """The folders always allowed (real paths), for messages and tests."""
        return list(self._folders)

    def allows(self, path: str | os.PathLike[str]) -> bool:
        """Whether the file at ``path`` may be read: judged by its real path (links resolved)."""
        real = _real(Path(os.path.abspath(path)))
        if real in self._files or any(real.is_relative_to(folder) for folder in self._folders):
            return True
        return self._in_resolved_package(real)

    def _in_resolved_package(self, real: Path) -> bool:
        for folder in real.parents:
            if (folder / "package.xml").is_file():
                if folder not in self._packages:
                    self._packages[folder] = self._resolves_to(folder)
                return self._packages[folder]
        return False

    def _resolves_to(self, folder: Path) -> bool:
        name = package_name(folder)
        if name is None:
            return False
        try:
            found = self._finder.find(name)
        except DescriptionError:
            return False
        if _real(found) == folder:
            return True
        manifest = found / "package.xml"  # colcon --symlink-install: the installed manifest links to the source
        return manifest.is_symlink() and _real(manifest).parent == folder

    def refusal(self, path: str | os.PathLike[str]) -> str:
        """Why ``path`` may not be read, for a message (names no file content)."""
        given = Path(os.path.abspath(path))
        real = _real(given)
        shown = str(path) if real == given else f"{path} (a link to {real})"
        return (f"{shown} is outside the folders a description may read (its workspace, `package_paths`, "
                "the packages $(find) resolves, `allow_paths`)")


def read_capped(path: str | os.PathLike[str], max_bytes: int) -> bytes:
    """The bytes of a file, refusing one larger than ``max_bytes`` without reading it all.

    Raises:
        OSError: the file cannot be read.
        DescriptionError: it is larger than ``max_bytes``.
    """
    with open(path, "rb") as file:
        data = file.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise DescriptionError(f"{path}: larger than the {max_bytes:,} bytes a description file may have")
    return data


def _real(path: Path) -> Path:
    return Path(os.path.realpath(path))


def _too_broad(folder: Path) -> bool:
    """A home folder or the file system's root: never a workspace."""
    try:
        home = _real(Path.home())
    except RuntimeError:  # no home folder known
        home = None
    real = _real(folder)
    return real == Path(real.anchor) or real == home


def _workspace(file: Path) -> list[Path]:
    """The folders a description file's own workspace gives (see the module's docstring)."""
    package = next((f for f in file.parents if (f / "package.xml").is_file() and package_name(f)), None)
    if package is None or _too_broad(package):
        return [] if package is not None or _too_broad(file.parent) else [file.parent]
    holder = next((f for f in package.parents if f.name == "src"), package.parent)
    return [package] if _too_broad(holder) else [package, holder]
