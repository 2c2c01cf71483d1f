"""YAML for descriptions (``xacro.load_yaml``, launch files' ``<rosparam>`` and ROS 2 YAML launch files).

Parsing YAML is the formats stage's: only :mod:`tfrec.formats` imports a YAML library, and its loader
(:func:`tfrec.formats._yaml.load_yaml`) is hardened against alias bombs and deep nesting. The description
stage comes before formats in the data flow and does not import it; it looks the loader up by name when a
description needs YAML — the one place a stage reaches a later one, at run time, documented in
docs/architecture.md.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

__all__ = ["load_yaml"]


def load_yaml(data: str | bytes, *, where: str, error: type[Exception], constructors: Any = None) -> Any:
    """:func:`tfrec.formats._yaml.load_yaml` (see it for the limits).

    Raises:
        error: malformed YAML, or past a limit; one line starting with ``where``.
    """
    loader: Callable[..., Any] = importlib.import_module("tfrec.formats._yaml").load_yaml
    return loader(data, where=where, error=error, constructors=constructors)
