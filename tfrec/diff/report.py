"""The report of ``tfrec diff``: what differs, as readable text (verdict first) or JSON."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from tfrec.errors import printable
from tfrec.recording import Recording

__all__ = ["DiffReport", "Difference", "Largest", "at_time", "format_time"]

_KIND_TITLES = {
    "robot": "robots",
    "description": "robot description",
    "topic": "topics",
    "joint_states": "joint states (/joint_states)",
    "tf": "transforms (/tf)",
    "tf_static": "static transforms (/tf_static)",
    "frame": "frames",
}


@dataclass(frozen=True, slots=True)
class Difference:
    """One way in which the recordings differ.

    Attributes:
        kind: ``robot``, ``description``, ``topic``, ``joint_states``, ``tf``, ``tf_static`` or ``frame``.
        what: the element: ``joint 'joint2'``, ``/tf``, ``link1 → link2``.
        detail: one readable line.
        time_ns: when it first exceeds its tolerance (ns since A's start, its first
            /joint_states or /tf stamp; or since the epoch with ``absolute``), if it is about
            samples; ``time_s`` is the same in seconds.
        value: the largest error (m, rad, or joint units), if it is about values.
    """

    kind: str
    what: str
    detail: str
    time_ns: int | None = None
    value: float | None = None

    @property
    def time_s(self) -> float | None:
        return None if self.time_ns is None else self.time_ns / 1e9

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "what": self.what, "detail": self.detail, "time_s": self.time_s,
                "time_ns": self.time_ns, "value": self.value}


@dataclass(frozen=True, slots=True)
class Largest:
    """The largest error of one quantity, where and when it occurs (None for static data)."""

    value: float
    what: str
    time_ns: int | None


@dataclass
class DiffReport:
    """The result of :func:`compare`.

    Attributes:
        a, b: the recordings compared (paths and formats, time spans).
        differences: everything that differs beyond the tolerances; empty when equal.
        notes: remarks that are not differences (interpolation, float32 data, damaged files).
        largest: the largest translation (m), rotation (rad) and joint error found, whether
            within tolerance or not, by quantity.
        tolerances: ``pos_tol``, ``rot_tol``, ``joint_tol`` as used.
        absolute: whether samples were aligned on stamps rather than time since start.
        origins: each recording's start, the stamp its times count from (ns since the epoch):
            its first /joint_states or /tf stamp (:func:`tfrec.resample.data_start_ns`); None with
            ``absolute``.
        time_base: what the samples' times are: ``header`` stamps, or ``log`` times
            (``use_log_time``). The topic table's spans are always log times.
        whole: whether ``a`` and ``b`` hold every sample of their series (read whole, or of one piece); a
            comparison of long recordings read piece by piece holds only their first and last stamps there.
    """

    a: Recording
    b: Recording
    differences: list[Difference] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    largest: dict[str, Largest] = field(default_factory=dict)
    tolerances: dict[str, float] = field(default_factory=dict)
    absolute: bool = False
    origins: tuple[int | None, int | None] = (None, None)
    time_base: str = "header"
    whole: bool = True

    @property
    def equal(self) -> bool:
        """True when the recordings are the same within tolerance."""
        return not self.differences

    @property
    def verdict(self) -> str:
        """``identical within tolerance`` or ``N differences``."""
        n = len(self.differences)
        if n == 0:
            return "identical within tolerance"
        return f"{n} difference{'s' if n != 1 else ''}"

    def _side(self, label: str, rec: Recording) -> str:
        parts = [rec.format]
        if rec.start_ns is not None:
            parts.append(f"{rec.duration_ns / 1e9:.3f} s")
        parts.append(f"{len(rec.topics)} topic{'s' if len(rec.topics) != 1 else ''}")
        return f"{label}: {rec.path} ({', '.join(parts)})"

    def to_text(self) -> str:
        """The readable report; its first line is the verdict."""
        tol = self.tolerances
        lines = [
            self.verdict,
            self._side("A", self.a),
            self._side("B", self.b),
            f"tolerances: position {tol['pos_tol']:g} m, rotation {tol['rot_tol']:g} rad, "
            f"joint {tol['joint_tol']:g}; times are "
            + (("log times" if self.time_base == "log" else "stamps") + " (s since the epoch)" if self.absolute
               else "s since each recording's start (its first /joint_states or /tf "
               + ("message's log time)" if self.time_base == "log" else "stamp)"))
            + "; topic spans are log times" + ("" if self.absolute else ", s since that message was logged"),
        ]
        for kind, title in _KIND_TITLES.items():
            items = [d for d in self.differences if d.kind == kind]
            if items:
                lines.append("")
                lines.append(f"{title}:")
                lines.extend(f"  {d.detail}" for d in items)
        if self.largest:
            lines.append("")
            lines.append("largest differences:")
            for quantity, unit in (("translation", "m"), ("rotation", "rad"), ("joint position", "")):
                found = self.largest.get(quantity)
                if found is not None:
                    where = f" ({found.what}{at_time(found.time_ns)})" if found.value > 0 else ""
                    lines.append(f"  {quantity}: {found.value:.3g}{' ' + unit if unit else ''}{where}")
        if self.notes:
            lines.append("")
            lines.append("notes:")
            lines.extend(f"  {note}" for note in self.notes)
        return "".join(printable(line) + "\n" for line in lines)  # what the recordings name, escaped

    def to_dict(self) -> dict[str, Any]:
        def side(rec: Recording, origin_ns: int | None) -> dict[str, Any]:
            return {
                "path": rec.path,
                "format": rec.format,
                "start_ns": rec.start_ns,
                "end_ns": rec.end_ns,
                "origin_ns": origin_ns,
                "topics": {
                    name: {"type": info.type, "count": info.count, "first_ns": info.first_ns, "last_ns": info.last_ns}
                    for name, info in rec.topics.items()
                },
                "read_error": rec.read_error,
            }

        return {
            "equal": self.equal,
            "verdict": self.verdict,
            "a": side(self.a, self.origins[0]),
            "b": side(self.b, self.origins[1]),
            "tolerances": dict(self.tolerances),
            "absolute": self.absolute,
            "time_base": self.time_base,
            "differences": [d.to_dict() for d in self.differences],
            "largest": {
                quantity: {"value": found.value, "what": found.what,
                           "time_s": None if found.time_ns is None else found.time_ns / 1e9, "time_ns": found.time_ns}
                for quantity, found in self.largest.items()
            },
            "notes": list(self.notes),
        }

    def to_json(self) -> str:
        """The report as JSON (``tfrec diff --json``)."""
        return json.dumps(self.to_dict(), indent=2)


def format_time(time_ns: int) -> str:
    """Seconds, exactly: at least millisecond digits, more when the value needs them (up to ns)."""
    sign = "-" if time_ns < 0 else ""
    whole, frac = divmod(abs(int(time_ns)), 1_000_000_000)
    digits = f"{frac:09d}".rstrip("0").ljust(3, "0")
    return f"{sign}{whole}.{digits}"


def at_time(time_ns: int | None) -> str:
    """`` at t=1.240 s``, or nothing for None."""
    return "" if time_ns is None else f" at t={format_time(time_ns)} s"
