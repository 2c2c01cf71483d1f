"""ROS 1 bags (format 2.0): reading record by record, damaged files included (:mod:`.reader`)."""

from __future__ import annotations

__all__ = ["reader"]
