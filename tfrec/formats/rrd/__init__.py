"""Rerun recordings (``.rrd``) read back: where tfrec puts things in one — entity paths and the timeline
(:mod:`.paths`), shared with the writing side, :mod:`tfrec.viewer` — and the reader (:mod:`.reader`, Rerun's own,
run in a child process by :mod:`._read_child`)."""

from __future__ import annotations

__all__ = ["paths", "reader"]
