"""The report of ``tfrec diff`` on robot descriptions: URDF changes, then where each link went.

Text (verdict first) or JSON, like :class:`tfrec.diff.report.DiffReport`; the differences use
its :class:`~tfrec.diff.report.Difference` with the kinds ``description`` (a URDF-level change),
``frame`` (a link only one side places) and ``link`` (a link's world position or orientation,
root → link, beyond tolerance).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from tfrec.diff.report import Difference, Largest, at_time
from tfrec.errors import printable

__all__ = ["DescriptionDiffReport", "LinkDelta", "Side"]

_KIND_TITLES = {
    "description": "robot description",
    "frame": "links",
    "link": "world poses (root → link)",
}


@dataclass(frozen=True, slots=True)
class Side:
    """What one input was: ``kind`` ``description`` or ``recording`` (with its ``format``)."""

    path: str
    kind: str
    format: str | None = None
    robot: str | None = None
    args: dict[str, str] = field(default_factory=dict)

    @property
    def title(self) -> str:
        return " ".join([self.path, *(f"{name}:={value}" for name, value in self.args.items())])

    def to_dict(self) -> dict[str, Any]:
        return {"path": self.path, "kind": self.kind, "format": self.format, "robot": self.robot,
                "args": dict(self.args)}


@dataclass(frozen=True, slots=True)
class LinkDelta:
    """How far one link is apart in A and B, in the root link's frame, over the motion.

    Attributes:
        link: the link (its TF frame).
        position_m: the largest distance between its origins (m); inf when one side does not
            place it at some instant.
        position_time_ns: when (ns from the motion's start).
        rotation_rad: the largest angle between its orientations (rad).
        rotation_time_ns: when.
        first_exceed_ns: when either first exceeds its tolerance, or None.
        samples_over: instants at which either exceeds its tolerance.
    """

    link: str
    position_m: float
    position_time_ns: int
    rotation_rad: float
    rotation_time_ns: int
    first_exceed_ns: int | None
    samples_over: int

    def to_dict(self) -> dict[str, Any]:
        return {"link": self.link, "position_m": self.position_m, "position_time_s": self.position_time_ns / 1e9,
                "rotation_rad": self.rotation_rad, "rotation_time_s": self.rotation_time_ns / 1e9,
                "first_exceed_s": None if self.first_exceed_ns is None else self.first_exceed_ns / 1e9,
                "samples_over": self.samples_over}


@dataclass
class DescriptionDiffReport:
    """The result of :func:`tfrec.diff.compare_descriptions`.

    Attributes:
        a, b: what each input was.
        motion: how the descriptions were driven, one phrase.
        samples: instants compared.
        root: the link poses are relative to (A's root link).
        differences: URDF changes, links only one side places, links beyond tolerance.
        links: every link compared, in A's tree order.
        largest: the largest ``position`` (m) and ``rotation`` (rad) difference of any link.
        worst: the worst instant: ``time_ns``, ``link`` and the joint positions there (``joints``).
        tolerances: ``pos_tol``, ``rot_tol``, ``joint_tol`` as given.
        notes: remarks that are not differences (joints held at center, float32 data, ...).
    """

    a: Side
    b: Side
    motion: str
    samples: int
    root: str
    differences: list[Difference] = field(default_factory=list)
    links: list[LinkDelta] = field(default_factory=list)
    largest: dict[str, Largest] = field(default_factory=dict)
    worst: dict[str, Any] = field(default_factory=dict)
    tolerances: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def equal(self) -> bool:
        """True when nothing differs beyond tolerance."""
        return not self.differences

    @property
    def verdict(self) -> str:
        n = len(self.differences)
        return "identical within tolerance" if n == 0 else f"{n} difference{'s' if n != 1 else ''}"

    @staticmethod
    def _side(label: str, side: Side) -> str:
        what = f"description of robot '{side.robot}'" if side.kind == "description" else f"{side.format} recording"
        return f"{label}: {side.title} ({what})"

    def to_text(self) -> str:
        """The readable report; its first line is the verdict."""
        tol = self.tolerances
        lines = [
            self.verdict,
            self._side("A", self.a),
            self._side("B", self.b),
            f"motion: {self.motion} ({self.samples} samples)",
            (f"tolerances: position {tol['pos_tol']:g} m, rotation {tol['rot_tol']:g} rad, joint {tol['joint_tol']:g}; "
             f"link poses are in the frame of the root link '{self.root}'; times are s from the start of the motion"),
        ]
        for kind, title in _KIND_TITLES.items():
            items = [d for d in self.differences if d.kind == kind]
            if items:
                lines += ["", f"{title}:", *(f"  {d.detail}" for d in items)]
        if self.largest:
            lines += ["", "largest differences:"]
            for quantity, unit in (("position", "m"), ("rotation", "rad")):
                found = self.largest.get(quantity)
                if found is not None:
                    where = f" ({found.what}{at_time(found.time_ns)})" if found.value > 0 else ""
                    lines.append(f"  {quantity}: {found.value:.3g} {unit}{where}")
        if self.worst.get("joints"):
            joints = " ".join(f"{name}={value:.4g}" for name, value in self.worst["joints"].items())
            lines.append(f"  worst configuration{at_time(self.worst['time_ns'])}: {joints}")
        if self.notes:
            lines += ["", "notes:", *(f"  {note}" for note in self.notes)]
        return "".join(printable(line) + "\n" for line in lines)  # what the descriptions name, escaped

    def to_dict(self) -> dict[str, Any]:
        worst = dict(self.worst)
        if "time_ns" in worst:
            worst["time_s"] = worst["time_ns"] / 1e9
        return {
            "equal": self.equal,
            "verdict": self.verdict,
            "a": self.a.to_dict(),
            "b": self.b.to_dict(),
            "motion": self.motion,
            "samples": self.samples,
            "root": self.root,
            "tolerances": dict(self.tolerances),
            "differences": [d.to_dict() for d in self.differences],
            "links": [link.to_dict() for link in self.links],
            "largest": {
                quantity: {"value": found.value, "what": found.what,
                           "time_s": None if found.time_ns is None else found.time_ns / 1e9, "time_ns": found.time_ns}
                for quantity, found in self.largest.items()
            },
            "worst": worst,
            "notes": list(self.notes),
        }

    def to_json(self) -> str:
        """The report as JSON (``tfrec diff --json``)."""
        return json.dumps(self.to_dict(), indent=2)
