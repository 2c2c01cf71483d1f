"""Robot descriptions: ``.urdf``, ``.xacro`` (and launch files) → a validated :class:`~tfrec.model.Robot`.

- :mod:`~tfrec.description.packages`: ``$(find pkg)`` and ``package://`` without ROS;
- :mod:`~tfrec.description.xacro`: PyPI xacro run in-process (legacy dialect, sandbox);
- :mod:`~tfrec.description.urdf`: URDF text → :class:`~tfrec.model.Robot`, with urdfdom's checks;
- :mod:`~tfrec.description.launch`: ROS 1 and ROS 2 launch files, read as roslaunch would (nothing run).

The only package that imports ``xacro``. Imports only the base modules (errors, model).
"""

from __future__ import annotations

from tfrec.description._load import load_description, load_launch, parse_xacro_args, read_description_text
from tfrec.description.packages import PackageFinder
from tfrec.description.urdf import parse_urdf

__all__ = [
    "PackageFinder",
    "load_description",
    "load_launch",
    "parse_urdf",
    "parse_xacro_args",
    "read_description_text",
]
