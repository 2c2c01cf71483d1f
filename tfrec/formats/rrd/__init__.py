"""Rerun recordings (``.rrd``) and viewers: entity paths and timeline (:mod:`.paths`), a robot's
geometry (:mod:`.geometry`), the sink record and replay log through (:mod:`.sink`), the reader
(:mod:`.reader`), and spawning or connecting to a viewer (:mod:`.viewer`)."""

from __future__ import annotations

__all__ = ["columns", "geometry", "paths", "reader", "sink", "viewer"]
