"""Finding ROS packages without ROS: what ``$(find pkg)`` and ``package://pkg/`` name.

A package is a folder whose ``package.xml`` has that ``<name>``. Packages are searched in
this order (first match wins):

1. the ``--package-path`` folders (each a package or a folder of packages);
2. ``ROS_PACKAGE_PATH`` (folders crawled like rospack does) and ``AMENT_PREFIX_PATH``
   (``<prefix>/share/<pkg>``);
3. the package enclosing the input file, and its sibling packages (the folder holding it,
   and the ``src/`` folder of a catkin or colcon workspace above it).

:func:`find_in_package` is roslaunch's ``PKG FILE`` form: the file of that name anywhere in the package.
"""

from __future__ import annotations

import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from urllib.parse import unquote, urlparse

from tfrec.errors import DescriptionError, TfrecWarning

__all__ = ["PackageFinder", "find_in_package", "package_name"]

_MAX_DEPTH = 6  # how deep a folder of packages is crawled
_SKIP_DIRS = {"node_modules", "__pycache__", "build", "install", "log", "devel"}


def package_name(folder: Path) -> str | None:
    """The ``<name>`` in ``folder/package.xml``, or None when it has none (or no such file)."""
    manifest = folder / "package.xml"
    if not manifest.is_file():
        return None
    try:
        root = ET.parse(manifest).getroot()
    except (ET.ParseError, OSError):
        return None
    name = root.findtext("name")
    return name.strip() if name and name.strip() else None


def _crawl(folder: Path) -> Iterator[tuple[str, Path, int]]:
    """Yield (name, path, depth) of the packages in folder: folder itself, or those below it,
    breadth first (shallower packages first, then in sorted order)."""
    level = [folder] if folder.is_dir() else []
    for depth in range(_MAX_DEPTH + 1):
        deeper: list[Path] = []
        for current in level:
            name = package_name(current)
            if name is not None:
                yield name, current, depth
                continue
            try:
                entries = sorted(current.iterdir())
            except OSError:
                continue
            for entry in entries:
                if entry.name.startswith(".") or entry.name in _SKIP_DIRS:
                    continue
                if entry.is_dir() and not (entry / "CATKIN_IGNORE").exists() and not (entry / "COLCON_IGNORE").exists():
                    deeper.append(entry)
        level = deeper
        if not level:
            return


def _enclosing_package(path: Path) -> Path | None:
    for folder in path.parents:
        if package_name(folder) is not None:
            return folder
    return None


class PackageFinder:
    """Resolves package names to folders, from explicit paths, the environment and the input's place.

    Args:
        package_paths: ``--package-path`` folders, searched first.
        near: the input file; its enclosing package and siblings are searched last.
        environ: environment to read ``ROS_PACKAGE_PATH`` and ``AMENT_PREFIX_PATH`` from
            (default ``os.environ``).
        also: folders of packages searched last, only when no other place has the package (the working
            folder, for ``PKG FILE``).
    """

    def __init__(
        self,
        package_paths: Sequence[str | os.PathLike[str]] = (),
        *,
        near: str | os.PathLike[str] | None = None,
        environ: Mapping[str, str] | None = None,
        also: Sequence[str | os.PathLike[str]] = (),
    ) -> None:
        env = os.environ if environ is None else environ
        self._explicit = [Path(p).expanduser().resolve() for p in package_paths]
        # relative entries mean the working folder's, as for ROS tools (resolved now: xacro joins a
        # relative include onto the including file's folder)
        self._ros_package_path = [Path(p).expanduser().resolve()
                                  for p in env.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        self._ament_prefixes = [Path(p).expanduser().resolve()
                                for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
        self._local: list[Path] = []
        if near is not None:
            enclosing = _enclosing_package(Path(near).resolve())
            if enclosing is not None:
                self._local.append(enclosing)
                self._local.append(enclosing.parent)
                for folder in enclosing.parents:
                    if folder.name == "src":
                        self._local.append(folder)
                        break
        self._also = [Path(p).resolve() for p in also]
        self._own = _enclosing_package(Path(near).resolve()) if near is not None else None
        self._cache: dict[str, Path] = {}
        self._indexes: dict[Path, dict[str, list[Path]]] = {}
        self.twins: dict[str, tuple[Path, tuple[Path, ...]]] = {}
        """Packages used that have other copies: name → (the copy taken, the others)."""
        self._warned: set[str] = set()

    def _index(self, folder: Path) -> dict[str, list[Path]]:
        """Package name → its copies under ``folder``, shallower first (then in sorted order)."""
        if folder not in self._indexes:
            index: dict[str, list[Path]] = {}
            for name, path, _ in _crawl(folder):
                index.setdefault(name, []).append(path)
            self._indexes[folder] = index
        return self._indexes[folder]

    def searched(self) -> list[str]:
        """The places searched, in order, for error messages."""
        places = [f"`package_paths` {p}" for p in self._explicit]
        places += [f"ROS_PACKAGE_PATH {p}" for p in self._ros_package_path]
        places += [f"AMENT_PREFIX_PATH {p}/share" for p in self._ament_prefixes]
        places += [f"{p}" for p in [*self._local, *self._also]]
        return places

    def _misnamed(self, name: str) -> str:
        """A hint when a searched place has a folder called ``name`` whose package.xml names another
        package (a package is found by its package.xml's name, not its folder's)."""
        roots = [*self._explicit, *self._ros_package_path, *(p / "share" for p in self._ament_prefixes), *self._local,
                 *self._also]
        for root in roots:
            for folder in (root, root / name):
                if folder.name == name and folder.is_dir():
                    declared = package_name(folder)
                    if declared is not None and declared != name:
                        return (f" ({folder} is named so, but its package.xml names package '{declared}': a "
                                "package is found by the name in its package.xml)")
        return ""

    def find(self, name: str) -> Path:
        """The folder of package ``name``: the input's own package first, then the first copy found in
        the search order (shallower before deeper within a folder). Other copies are noted in
        :attr:`twins` (see :meth:`warn_twins`).

        Raises:
            DescriptionError: no package of that name in any searched place, or a name that is not one
                folder's (``..``, ``""``, a slash or a NUL): it would name a folder outside the package.
        """
        if name in self._cache:
            return self._cache[name]
        if name in ("", ".", "..") or any(c in name for c in "/\\\0"):
            raise DescriptionError(f"package name {name!r} is not the name of a package; refused")
        copies = self._lookup(name)
        if not copies:
            places = self.searched()
            where = "; ".join(places) if places else "no places (give `package_paths`)"
            raise DescriptionError(f"package '{name}' not found; searched: {where}{self._misnamed(name)}")
        found, others = copies[0], tuple(dict.fromkeys(c for c in copies[1:] if c.resolve() != copies[0].resolve()))
        if others:
            self.twins[name] = (found, others)
        self._cache[name] = found
        return found

    def warn_twins(self) -> None:
        """One warning per package used that has other copies (called once a load is done: inside
        xacro a warning would be taken for an error)."""
        for name, (found, others) in self.twins.items():
            if name not in self._warned:
                self._warned.add(name)
                warnings.warn(f"package '{name}' is in {found} and {', '.join(map(str, others))}; using {found}", TfrecWarning,
                              stacklevel=3)

    def taken(self, path: str | os.PathLike[str]) -> str | None:
        """For messages about a file: which copy of a package with twins it lies in, e.g. ``package
        'arm' is /ws/src/arm (not /ws/old/arm)``; None when the file is in no such package."""
        target = Path(path)
        for name, (found, others) in self.twins.items():
            if target == found or found in target.parents:
                return f"package '{name}' is {found} (not {', '.join(map(str, others))})"
        return None

    def _lookup(self, name: str) -> list[Path]:
        """Every copy of package ``name``, in the order they are taken."""
        copies: list[Path] = []
        if self._own is not None and package_name(self._own) == name:
            copies.append(self._own)
        elif self._own is not None and self._own.name == name and self._own.parent.name == "share":
            copies.append(self._own)  # an install space's share/<name>: found by its folder's name, as ament does
        for folder in [*self._explicit, *self._ros_package_path]:
            copies.extend(self._index(folder).get(name, ()))
        for prefix in self._ament_prefixes:
            share = prefix / "share" / name
            if share.is_dir():
                copies.append(share)
        for folder in self._local:
            copies.extend(self._index(folder).get(name, ()))
        for folder in self._also if not copies else ():
            copies.extend(self._index(folder).get(name, ()))
        return copies

    def resolve_uri(self, uri: str, *, relative_to: str | os.PathLike[str] | None = None) -> Path:
        """The file a URDF resource name points to: ``package://``, ``file://`` or a path.

        Relative paths resolve against ``relative_to``'s folder (the description file).

        Raises:
            DescriptionError: a ``package://`` URI naming an unknown package.
        """
        if uri.startswith("package://"):
            rest = uri[len("package://"):]
            pkg, _, sub = rest.partition("/")
            relative = unquote(sub)
            if relative.startswith(("/", "\\")) or ".." in Path(relative).parts or "\\.." in relative:
                raise DescriptionError(f"{uri}: leaves package '{pkg}' (a '..' or absolute path); refused")
            if "\0" in relative:  # percent-encoded (%00): no file has it in its name, and the OS refuses it
                raise DescriptionError(f"{uri}: a NUL character (%00) in the path; refused")
            return self.find(pkg) / relative
        if uri.startswith("file://"):
            decoded = unquote(urlparse(uri).path)
            if "\0" in decoded:
                raise DescriptionError(f"{uri}: a NUL character (%00) in the path; refused")
            return Path(decoded)
        path = Path(uri).expanduser()
        if not path.is_absolute() and relative_to is not None:
            path = Path(relative_to).resolve().parent / path
        return path


MAX_PACKAGE_ENTRIES = 200_000
"""The most files and folders :func:`find_in_package` looks at in one package."""


def find_in_package(
    package: str,
    file_name: str,
    *,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    environ: Mapping[str, str] | None = None,
    cwd: str | os.PathLike[str] | None = None,
) -> Path:
    """roslaunch's ``PKG FILE``: the file named ``file_name`` anywhere in package ``package``, as
    ``roslib.packages.find_resource`` finds it (``roslaunch marm_description view_marm.launch`` finds
    ``launch/view_marm.launch``): the package's folder is walked, hidden folders skipped. A name with a
    ``/`` is taken relative to the package's folder.

    The package is looked up like ``$(find pkg)`` (:class:`PackageFinder`), with the working folder's
    workspace in place of the input's: the package enclosing ``cwd`` and its siblings, then the packages
    below ``cwd``.

    Raises:
        DescriptionError: no such package, no such file in it, or several files of that name.
    """
    here = Path.cwd() if cwd is None else Path(cwd)
    finder = PackageFinder(package_paths, near=here / package, environ=environ, also=[here])
    try:
        folder = finder.find(package)
    except DescriptionError as err:
        raise DescriptionError(f"{package} {file_name} (roslaunch's form PKG FILE): {err}") from err
    where = f"package '{package}' ({folder})"
    if "/" in file_name or os.sep in file_name:
        path = folder / file_name
        if ".." in Path(file_name).parts or Path(file_name).is_absolute():
            raise DescriptionError(f"{file_name}: leaves {where} (a '..' or absolute path); refused")
        if not path.is_file():
            raise DescriptionError(f"{where} has no file {file_name}")
        return path
    matches: list[Path] = []
    seen = 0
    for root, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        seen += len(dirs) + len(files)
        if seen > MAX_PACKAGE_ENTRIES:
            raise DescriptionError(f"{where}: more than {MAX_PACKAGE_ENTRIES:,} files and folders; give the path of "
                                   f"{file_name} instead")
        if file_name in files:
            matches.append(Path(root) / file_name)
    if not matches:
        raise DescriptionError(f"{where} has no file named {file_name} (roslaunch's form: PKG FILE, the file "
                               "anywhere in the package)")
    if len(matches) > 1:
        listed = ", ".join(str(m.relative_to(folder)) for m in matches)
        raise DescriptionError(f"{where} has {len(matches)} files named {file_name} ({listed}): give the file's path "
                               "instead, as roslaunch asks")
    return matches[0]
