"""Robot descriptions: ``.urdf``, ``.xacro`` (and launch files) → a validated :class:`~tfrec.model.Robot`.

- :mod:`~tfrec.description.packages`: ``$(find pkg)`` and ``package://`` without ROS;
- :mod:`~tfrec.description.xacro`: PyPI xacro run in-process (legacy dialect, sandbox);
- :mod:`~tfrec.description.urdf`: URDF text → :class:`~tfrec.model.Robot`, with urdfdom's checks;
- :mod:`~tfrec.description.launch`: ROS 1 and ROS 2 launch files, read as roslaunch would (nothing run).

The only package that imports ``xacro``. Imports only the base modules (errors, model).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__all__ = [
    "PackageFinder",
    "load_description",
    "load_launch",
    "parse_urdf",
    "parse_xacro_args",
    "read_description_text",
]

if TYPE_CHECKING:
    from tfrec.description._load import load_description, load_launch, parse_xacro_args, read_description_text
    from tfrec.description.packages import PackageFinder
    from tfrec.description.urdf import parse_urdf


def __getattr__(name: str) -> Any:  # lazy: a recorded URDF (``tfrec info``) needs the parser, not xacro's sandbox
    if name == "parse_urdf":
        from tfrec.description.urdf import parse_urdf

        return parse_urdf
    if name == "PackageFinder":
        from tfrec.description.packages import PackageFinder

        return PackageFinder
    if name in __all__:
        from tfrec.description import _load

        return getattr(_load, name)
    raise AttributeError(f"module 'tfrec.description' has no attribute {name!r}")
