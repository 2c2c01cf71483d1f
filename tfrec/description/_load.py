"""Loading a robot description: a ``.urdf``, ``.xacro`` or ``.urdf.xacro`` file → :class:`Robot`.

xacro files are expanded in-process (:mod:`tfrec.description.xacro`), ``$(find pkg)`` resolves
through :class:`tfrec.description.packages.PackageFinder`, and the result is validated by
:func:`tfrec.description.urdf.parse_urdf`.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tfrec.description._confine import read_capped
from tfrec.description._sandbox import SandboxLimits
from tfrec.description._xml_bytes import decode_xml
from tfrec.description.mjcf import is_mjcf_file, load_mjcf
from tfrec.description.packages import PackageFinder
from tfrec.description.urdf import parse_urdf
from tfrec.description.xacro import xacro_expansion
from tfrec.errors import DescriptionError, display_path
from tfrec.model import Robot

__all__ = ["load_description", "load_launch", "parse_urdf", "parse_xacro_args", "read_description_text"]

if TYPE_CHECKING:
    from tfrec.description.launch import LaunchRobot


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


def _is_plain_urdf(path: Path) -> bool:
    return path.suffix == ".urdf"


def read_description_text(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None = None,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
    force_xacro: bool = False,
    allow_paths: Sequence[str | os.PathLike[str]] = (),
) -> tuple[str, bool]:
    """The URDF text of a description file, xacro-expanded when needed.

    A ``.urdf`` is never run through xacro (a URDF that mentions ``xmlns:xacro`` is still a URDF:
    urdfdom ignores what it does not know), unless ``force_xacro`` (a launch file's xacro run).

    Returns:
        (text, user_lines): user_lines is True when line numbers in text are the file's own.

    Raises:
        DescriptionError: a missing or unreadable file, or any xacro error.
    """
    text = _description_text(path, args=args, package_paths=package_paths, strict_xacro=strict_xacro,
                             force_xacro=force_xacro, allow_paths=allow_paths)
    return text.text, text.user_lines


@dataclass(frozen=True, slots=True)
class _Text:
    """A description's URDF text, and where its elements were written (for messages)."""

    text: str
    user_lines: bool
    origins: tuple[str | None, ...] | None = None

    def parse(self, source: str | os.PathLike[str]) -> Robot:
        return parse_urdf(self.text, source=os.fspath(source), user_lines=self.user_lines, origins=self.origins)


def _description_text(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None,
    package_paths: Sequence[str | os.PathLike[str]],
    strict_xacro: bool,
    force_xacro: bool,
    allow_paths: Sequence[str | os.PathLike[str]],
) -> _Text:
    file = Path(path)
    if not file.is_file():
        raise DescriptionError(f"{display_path(file)}: no such file" if not file.exists()
                               else f"{display_path(file)}: not a file")
    plain = _is_plain_urdf(file) and not force_xacro
    if plain:
        if args:
            raise DescriptionError(f"{display_path(file)}: xacro arguments given for a plain URDF file")
        try:  # UTF-16 and latin-1 URDFs with a correct declaration are valid XML: decoded as declared
            raw = decode_xml(read_capped(file, SandboxLimits().max_file_bytes), where=display_path(file),
                             declare_utf8=True)
        except OSError as err:
            raise DescriptionError(f"{display_path(file)}: cannot read: {err.strerror or err}") from err
        return _Text(raw, True)
    finder = PackageFinder(package_paths, near=file)
    expansion = xacro_expansion(file, args=args, finder=finder, strict=strict_xacro, package_paths=package_paths,
                                allow_paths=allow_paths)
    return _Text(expansion.text, False, expansion.origins)


def load_description(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None = None,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
    allow_paths: Sequence[str | os.PathLike[str]] = (),
) -> Robot:
    """Load and validate a robot description file.

    Args:
        path: a ``.urdf``, ``.xacro`` or ``.urdf.xacro`` file, a launch file that loads one
            (ROS 1 ``.launch``, ROS 2 ``.launch.xml``/``.launch.yaml``; see :func:`load_launch`), or a
            MuJoCo model (``.xml`` with a ``<mujoco>`` root; :func:`tfrec.description.mjcf.load_mjcf`).
        args: xacro arguments (``name:=value``); for a launch file, its launch arguments.
        package_paths: folders searched first for ``$(find pkg)``.
        strict_xacro: expand xacro exactly as PyPI xacro (ROS 2) does: the Kinetic-era dialect is left
            unexpanded, with a warning (docs/xacro.md).
        allow_paths: folders (or files) xacro may read besides the input's workspace, the packages
            found and ``package_paths`` (``--allow-path``; see docs/security.md).

    Raises:
        DescriptionError: one line naming the file and the element at fault.
    """
    from tfrec.description.launch import is_launch_file

    if is_launch_file(path):
        return load_launch(path, args=args, package_paths=package_paths, strict_xacro=strict_xacro,
                           allow_paths=allow_paths)[0]
    if is_mjcf_file(path):
        if args:
            raise DescriptionError(f"{display_path(path)}: xacro arguments given for a MuJoCo model")
        return load_mjcf(path, package_paths=package_paths, allow_paths=allow_paths)
    text = _description_text(path, args=args, package_paths=package_paths, strict_xacro=strict_xacro,
                             force_xacro=False, allow_paths=allow_paths)
    return text.parse(path)


def load_launch(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None = None,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
    allow_paths: Sequence[str | os.PathLike[str]] = (),
) -> tuple[Robot, LaunchRobot]:
    """Load the robot a launch file loads, as ``roslaunch``/``ros2 launch`` would (nothing is run).

    Args:
        path: the launch file.
        args: launch arguments (``name:=value`` on the command line).
        package_paths: folders searched first for ``$(find pkg)``.
        strict_xacro: expand the xacro it runs exactly as PyPI xacro does (docs/xacro.md).

    Returns:
        The robot, and what the launch file says of it (:class:`~tfrec.description.launch.LaunchRobot`:
        the description's source, namespace, and the parameters of joint_state_publisher and
        robot_state_publisher, which ``tfrec record`` takes as options).

    Raises:
        DescriptionError: one line naming the launch file (or the description) and what is wrong.
    """
    from tfrec.description._confine import ReadRoots
    from tfrec.description._launch_files import confined
    from tfrec.description.launch import DescriptionKind, read_launch

    finder = PackageFinder(package_paths, near=path)
    roots = ReadRoots(path, finder=finder, package_paths=package_paths, allow_paths=allow_paths)
    with confined(roots):  # what it includes and loads: the places a description may read
        launch = read_launch(path, args=args, finder=finder, yaml_loader=_yaml_loader())
    source = launch.description
    if source.file is not None and not roots.allows(source.file):
        raise DescriptionError(f"{display_path(path)}: robot_description from {source.file} refused: "
                               f"{roots.refusal(source.file)}")
    if source.kind is DescriptionKind.URDF_TEXT:
        robot = parse_urdf(source.text or "", source=f"{display_path(path)}: robot_description", user_lines=False)
    else:
        assert source.file is not None
        xacro_args = source.xacro_args if source.kind is DescriptionKind.XACRO else None
        # xacro 1.13's --xacro-ns: the prefix is required, un-prefixed tags are left alone (PyPI xacro's way)
        strict = strict_xacro or "--xacro-ns" in source.xacro_flags
        text = _description_text(source.file, args=xacro_args, package_paths=package_paths,
                                 strict_xacro=strict, force_xacro=xacro_args is not None, allow_paths=allow_paths)
        robot = text.parse(source.file)
    return robot, launch


def _yaml_loader() -> Callable[[str, str], Any]:
    """YAML for launch files (``<rosparam>``, ROS 2 YAML launch): :func:`tfrec._yaml.load_yaml`."""
    from tfrec._yaml import load_yaml

    def loader(text: str, source: str) -> Any:
        return load_yaml(text, where=source, error=DescriptionError)

    return loader
