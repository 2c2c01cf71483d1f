"""What a MuJoCo model (MJCF) may make MuJoCo read and build, checked before MuJoCo opens anything.

MuJoCo's compiler trusts its input: ``<include file>`` and the ``file`` attributes of meshes, textures,
height fields, skins and attached models read any path, and a few attributes ask for unbounded work
(``<replicate count>``, ``<composite count>``, a texture's or height field's size). :func:`check_mjcf`
parses the model and every file it includes (bounded, as description files are, by
:class:`~tfrec.description._sandbox.SandboxLimits`), and refuses:

* a file a model names (includes, assets, ``meshdir``/``texturedir``/``assetdir`` with the file) that
  resolves outside :class:`~tfrec.description._confine.ReadRoots` (the model's folder, ``--package-path``
  folders, ``--allow-path``), or a missing include;
* more than :attr:`MjcfLimits.max_bodies` bodies (replicated and composite bodies counted), bodies nested
  deeper than :attr:`MjcfLimits.max_depth`, asset files larger than :attr:`MjcfLimits.max_asset_bytes`,
  generated textures or height fields over :attr:`MjcfLimits.max_grid_cells` cells, generated meshes over
  :attr:`MjcfLimits.max_mesh_vertices` vertices.

Each refusal is one :class:`~tfrec.errors.DescriptionError` line naming the file, its line and the element.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from tfrec.description._confine import ReadRoots, read_capped
from tfrec.description._sandbox import SandboxLimits
from tfrec.description._xml_bytes import decode_xml
from tfrec.description.urdf import parse_xml_with_lines
from tfrec.errors import DescriptionError, display_path

__all__ = ["MjcfLimits", "check_mjcf", "is_mjcf_text"]

_GENERATORS = ("composite", "flexcomp")
"""Elements that make many bodies (or particles) from one line: their ``count`` is counted as bodies."""

_ASSET_DIRS = {"mesh": ("meshdir",), "hfield": ("meshdir",), "skin": ("meshdir",), "texture": ("texturedir",)}
"""Which ``<compiler>`` folder an asset's file is looked up in (``assetdir`` is the fallback of each)."""


@dataclass(frozen=True, slots=True)
class MjcfLimits:
    """The bounds of one MuJoCo model.

    Attributes:
        max_bodies: bodies, replicated and composite ones counted. MuJoCo Menagerie's largest robots
            have under 100; a humanoid with hands ~60.
        max_depth: element nesting (bodies, frames, defaults classes). Real chains are under 40 bodies deep.
        max_files: XML files one model includes (each counted each time it is included).
        max_asset_bytes: the largest mesh, texture, height field or skin file.
        max_grid_cells: pixels of a generated texture (width × height × 6 faces at most) and samples of a
            height field (nrow × ncol).
        max_mesh_vertices: vertices of a mesh MuJoCo generates (``<mesh builtin>``; a resolution of 200 makes
            40,000 in half a second, and the time grows faster than the count).
    """

    max_bodies: int = 10_000
    max_depth: int = 256
    max_files: int = 1_000
    max_asset_bytes: int = 256 * 1024 * 1024
    max_grid_cells: int = 64 * 1024 * 1024
    max_mesh_vertices: int = 250_000


def is_mjcf_text(head: bytes) -> bool:
    """Whether the start of an XML file has a ``<mujoco>`` root (after a declaration and comments)."""
    text = head.lstrip(b"\xef\xbb\xbf")
    while True:
        text = text.lstrip()
        if text.startswith((b"<?", b"<!--")):
            end = text.find(b"?>" if text.startswith(b"<?") else b"-->")
            if end < 0:
                return False
            text = text[end + (2 if text.startswith(b"<?") else 3):]
            continue
        return text.startswith(b"<mujoco") and text[7:8] in (b" ", b">", b"/", b"\t", b"\n", b"\r")


@dataclass
class _Walk:
    """The state of one check: what was counted so far, and the compiler folders in force."""

    model: Path
    roots: ReadRoots
    limits: MjcfLimits
    files: int = 0
    bodies: int = 0
    dirs: dict[str, list[str]] = field(default_factory=dict)
    """Every value each ``<compiler>`` folder attribute takes in the model's files (any may be the one in force)."""
    trees: list[tuple[Path, ET.Element, dict[int, tuple[int, int]]]] = field(default_factory=list)


def check_mjcf(path: str | os.PathLike[str], roots: ReadRoots, limits: MjcfLimits | None = None) -> dict[str, str]:
    """Refuse a model whose files or size MuJoCo should not be asked to compile (see the module's docstring).

    Returns:
        The model's ``<compiler>`` folders (``meshdir``, ``texturedir``, ``assetdir``) as written (the last of
        each: an asset is checked against every one).

    Raises:
        DescriptionError: one line naming the file, line and element at fault.
    """
    file = Path(path)
    walk = _Walk(model=file, roots=roots, limits=limits or MjcfLimits())
    _read_tree(walk, file, None)
    for where, root, lines in walk.trees:  # compiler folders first: they apply to assets of every file
        for elem in root.iter("compiler"):
            for attr in ("meshdir", "texturedir", "assetdir"):
                if elem.get(attr) is not None:
                    walk.dirs.setdefault(attr, []).append(elem.get(attr, ""))
                    _check_dir(walk, where, lines, elem, attr)
    for where, root, lines in walk.trees:
        _check_tree(walk, where, root, lines)
    return {attr: values[-1] for attr, values in walk.dirs.items()}


def _read_tree(walk: _Walk, file: Path, parent: tuple[Path, ET.Element, int] | None) -> None:
    """Parse one file and, depth first (without recursion), the files it includes; an include cycle is refused."""
    stack: list[tuple[Path, tuple[Path, ET.Element, int] | None, tuple[Path, ...]]] = [(file, parent, ())]
    while stack:
        current, including, chain = stack.pop()
        walk.files += 1
        if walk.files > walk.limits.max_files:
            raise DescriptionError(_place(including, f"more than {walk.limits.max_files:,} XML files included"))
        real = current.resolve()
        if real in chain:
            raise DescriptionError(_place(including, f"{display_path(current)} includes itself (an include cycle)"))
        root, lines = _parse(current, including)
        walk.trees.append((current, root, lines))
        children = []
        for elem in _iter_named(root, "include", "model"):
            name = elem.get("file")
            if not name:
                continue
            targets = _resolve(walk, current, name)
            for candidate in targets:
                if not walk.roots.allows(candidate):
                    raise DescriptionError(_where(current, lines, elem, f"<{elem.tag} file> refused: "
                                                  f"{walk.roots.refusal(candidate)}"))
            children.append((targets[0], (current, elem, lines.get(id(elem), (0, 0))[0]), (*chain, real)))
        stack.extend(reversed(children))


def _parse(file: Path, including: tuple[Path, ET.Element, int] | None) -> tuple[ET.Element, dict[int, tuple[int, int]]]:
    shown = display_path(file)
    try:
        data = read_capped(file, SandboxLimits().max_file_bytes)
    except OSError as err:
        raise DescriptionError(_place(including, f"cannot read {shown}: {err.strerror or err}")) from err
    return parse_xml_with_lines(decode_xml(data, where=shown), shown)


def _resolve(walk: _Walk, including: Path, name: str) -> list[Path]:
    """The places MuJoCo may open an included file at: beside the main model, or beside the including file."""
    if os.path.isabs(name):
        return [Path(name)]
    return list(dict.fromkeys([walk.model.parent / name, including.parent / name]))


def _check_dir(walk: _Walk, file: Path, lines: dict[int, tuple[int, int]], elem: ET.Element, attr: str) -> None:
    folder = Path(elem.get(attr, ""))
    folder = folder if folder.is_absolute() else walk.model.parent / folder
    probe = folder / "_"  # a file inside the folder: the folder itself may be a root's parent's sibling
    if not walk.roots.allows(probe):
        raise DescriptionError(_where(file, lines, elem, f"<compiler {attr}=...> refused: "
                                      f"{walk.roots.refusal(folder)}"))


def _check_tree(walk: _Walk, file: Path, root: ET.Element, lines: dict[int, tuple[int, int]]) -> None:
    for elem in root.iter():
        for attr, value in elem.attrib.items():
            if attr.startswith("file") and value:
                _check_asset(walk, file, lines, elem, attr)
        if elem.tag in ("texture", "hfield"):
            _check_grid(walk, file, lines, elem)
        elif elem.tag == "mesh" and elem.get("builtin"):
            _check_builtin_mesh(walk, file, lines, elem)
    _count_bodies(walk, file, lines, root)


def _check_asset(walk: _Walk, file: Path, lines: dict[int, tuple[int, int]], elem: ET.Element, attr: str) -> None:
    name = elem.get(attr, "")
    if elem.tag in ("include", "model"):
        return  # read and checked as XML
    dirs = [value for d in (*_ASSET_DIRS.get(elem.tag, ()), "assetdir") for value in walk.dirs.get(d, [])]
    candidates = [Path(name)] if os.path.isabs(name) else [walk.model.parent / d / name for d in [*dirs, ""]]
    for candidate in candidates:
        if not walk.roots.allows(candidate):
            raise DescriptionError(_where(file, lines, elem, f"<{elem.tag} {attr}> refused: "
                                          f"{walk.roots.refusal(candidate)}"))
        try:
            size = candidate.stat().st_size
        except OSError:
            continue  # MuJoCo reports a missing file itself
        if size > walk.limits.max_asset_bytes:
            raise DescriptionError(_where(file, lines, elem, f"<{elem.tag} {attr}> {display_path(candidate)} has "
                                          f"{size:,} bytes, more than the {walk.limits.max_asset_bytes:,} a model's "
                                          "asset may have"))


def _check_grid(walk: _Walk, file: Path, lines: dict[int, tuple[int, int]], elem: ET.Element) -> None:
    dims = ("width", "height") if elem.tag == "texture" else ("nrow", "ncol")
    cells = 6 if elem.tag == "texture" else 1
    for attr in dims:
        cells *= max(1, _integer(file, lines, elem, attr))
    if cells > walk.limits.max_grid_cells:
        raise DescriptionError(_where(file, lines, elem, f"<{elem.tag}> asks for {cells:,} cells, more than the "
                                      f"{walk.limits.max_grid_cells:,} a model may generate"))


def _check_builtin_mesh(walk: _Walk, file: Path, lines: dict[int, tuple[int, int]], elem: ET.Element) -> None:
    """A mesh MuJoCo generates (``builtin="supersphere" params="res …"``): about res² vertices (``plate`` and
    ``wedge``: resx × resy), then a convex hull of them — a resolution of 2,000 takes MuJoCo minutes."""
    params = (elem.get("params") or "").split()
    grid = 2 if elem.get("builtin") in ("plate", "wedge") else 1
    resolution = [abs(_integer(file, lines, elem, "params", text)) for text in params[:grid]]
    vertices = resolution[0] * (resolution[1] if grid == 2 and len(resolution) > 1 else resolution[0]) \
        if resolution else 0
    if vertices > walk.limits.max_mesh_vertices:
        raise DescriptionError(_where(file, lines, elem, f"builtin mesh of about {vertices:,} vertices, more than the "
                                      f"{walk.limits.max_mesh_vertices:,} a model may generate"))


def _count_bodies(walk: _Walk, file: Path, lines: dict[int, tuple[int, int]], root: ET.Element) -> None:
    """Count bodies (times the ``<replicate count>`` around them) and the nesting of elements (bodies, frames,
    defaults classes: MuJoCo's compiler recurses on each), without recursion."""
    stack: list[tuple[ET.Element, int, int]] = [(root, 0, 1)]
    limits = walk.limits
    while stack:
        elem, depth, copies = stack.pop()
        for child in elem:
            child_depth, child_copies = depth + 1, copies
            if child.tag == "replicate":
                child_copies *= max(1, _integer(file, lines, child, "count"))
            elif child.tag in _GENERATORS:
                made = 1
                for count in (child.get("count") or "1").split():
                    made *= max(1, _integer(file, lines, child, "count", count))
                walk.bodies += copies * made
            elif child.tag == "body":
                walk.bodies += copies
            if walk.bodies > limits.max_bodies or child_copies > limits.max_bodies:
                raise DescriptionError(_where(file, lines, child, f"more than the {limits.max_bodies:,} bodies a "
                                              "model may have (replicated and composite bodies counted)"))
            if child_depth > limits.max_depth:
                raise DescriptionError(_where(file, lines, child, f"elements nested more than {limits.max_depth} "
                                              "deep"))
            stack.append((child, child_depth, child_copies))


def _integer(file: Path, lines: dict[int, tuple[int, int]], elem: ET.Element, attr: str,
             text: str | None = None) -> int:
    """An integer attribute (or one of its numbers, ``text``); 0 when absent."""
    try:
        return int(float(text if text is not None else elem.get(attr) or "0"))
    except (ValueError, OverflowError):
        raise DescriptionError(_where(file, lines, elem, f"{attr}={elem.get(attr)!r} is not a number")) from None


def _iter_named(root: ET.Element, *tags: str) -> Iterator[ET.Element]:
    return (elem for elem in root.iter() if elem.tag in tags)


def _where(file: Path, lines: dict[int, tuple[int, int]], elem: ET.Element, message: str) -> str:
    line = lines.get(id(elem), (0, 0))[0]
    return f"{display_path(file)}:{line}: <{elem.tag}>: {message}" if line else f"{display_path(file)}: {message}"


def _place(parent: tuple[Path, ET.Element, int] | None, message: str) -> str:
    if parent is None:
        return message
    file, elem, line = parent
    return f"{display_path(file)}:{line}: <{elem.tag}>: {message}"
