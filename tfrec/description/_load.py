"""Loading a robot description: a ``.urdf``, ``.xacro`` or ``.urdf.xacro`` file → :class:`Robot`.

xacro files are expanded in-process (:mod:`tfrec.description.xacro`), ``$(find pkg)`` resolves
through :class:`tfrec.description.packages.PackageFinder`, and the result is validated by
:func:`tfrec.description.urdf.parse_urdf`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from tfrec.description.packages import PackageFinder
from tfrec.description.urdf import parse_urdf
from tfrec.description.xacro import expand_xacro
from tfrec.errors import DescriptionError, display_path
from tfrec.model import Robot

__all__ = ["load_description", "parse_urdf", "parse_xacro_args", "read_description_text"]


def parse_xacro_args(items: Sequence[str]) -> dict[str, str]:
    """``["hand:=true", "ur_type:=ur5"]`` → ``{"hand": "true", "ur_type": "ur5"}``.

    Raises:
        DescriptionError: an item that is not ``name:=value``.
    """
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition(":=")
        if not sep or not name or not name.replace("_", "a").replace("-", "a").isalnum():
            raise DescriptionError(f"'{item}' is not a xacro argument of the form name:=value")
        out[name] = value
    return out


def _is_plain_urdf(path: Path, text: str) -> bool:
    return path.suffix == ".urdf" and "xmlns:xacro" not in text


def read_description_text(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None = None,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
) -> tuple[str, bool]:
    """The URDF text of a description file, xacro-expanded when needed.

    Returns:
        (text, user_lines): user_lines is True when line numbers in text are the file's own.

    Raises:
        DescriptionError: a missing or unreadable file, or any xacro error.
    """
    file = Path(path)
    if not file.is_file():
        raise DescriptionError(f"{display_path(file)}: no such file" if not file.exists()
                               else f"{display_path(file)}: not a file")
    try:
        raw = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise DescriptionError(f"{display_path(file)}: cannot read: {err}") from err
    if _is_plain_urdf(file, raw):
        if args:
            raise DescriptionError(f"{display_path(file)}: xacro arguments given for a plain URDF file")
        return raw, True
    finder = PackageFinder(package_paths, near=file)
    return expand_xacro(file, args=args, finder=finder, strict=strict_xacro), False


def load_description(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None = None,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
) -> Robot:
    """Load and validate a robot description file.

    Args:
        path: a ``.urdf``, ``.xacro`` or ``.urdf.xacro`` file.
        args: xacro arguments (``name:=value``).
        package_paths: folders searched first for ``$(find pkg)``.
        strict_xacro: refuse legacy un-prefixed macro calls instead of expanding them.

    Raises:
        DescriptionError: one line naming the file and the element at fault.
    """
    text, user_lines = read_description_text(
        path, args=args, package_paths=package_paths, strict_xacro=strict_xacro
    )
    return parse_urdf(text, source=os.fspath(path), user_lines=user_lines)
