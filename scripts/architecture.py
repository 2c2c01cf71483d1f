"""Draw docs/images/architecture.svg (and .png): tfrec's stages and the imports between them.

The picture is computed from the code, not drawn by hand: grimp (import-linter's graph library)
reads every import of the ``tfrec`` package, imports are collapsed to the stages (the top-level
packages and modules), and the stages are placed in the rows of import-linter's ``layers`` contract
in pyproject.toml, the highest first. An arrow A → B means "A imports B"; every arrow points down.

    .venv/bin/python scripts/architecture.py       (needs the lint extra: make lint installs it)
"""

from __future__ import annotations

import sys
from pathlib import Path

import tomllib

REPO = Path(__file__).resolve().parents[1]
BASE = {"tfrec.errors", "tfrec.conventions", "tfrec.model", "tfrec.frames", "tfrec.recording", "tfrec._atomic",
        "tfrec._yaml", "tfrec._outputs"}
BASE_EVERYONE = {"tfrec.errors", "tfrec.conventions", "tfrec.model"}
"""Imported by nearly every stage: their arrows are left out of the picture."""
NOTES = {
    "tfrec.cli": "argv, printing, exit codes",
    "tfrec.fleet": "check / diff many files\n(process pool, Ray)",
    "tfrec.plots": "TF tree, recording and\nerror plots (matplotlib)",
    "tfrec.convert": "cut, convert,\nadd TF to bags",
    "tfrec.diff": "recordings and descriptions\ncompared by meaning",
    "tfrec.replay": "play back, pace,\nre-simulate (--check)",
    "tfrec.recorder": "the record pipeline",
    "tfrec.info": "summaries",
    "tfrec.viewer": "Rerun output: sink, blueprint,\ngeometry, overlay, viewers",
    "tfrec.formats": "MCAP · rosbag2 · ROS 1 · .rrd: one\nsource, one writer per format",
    "tfrec.resample": "alignment, interpolation",
    "tfrec.robots": "robots by namespace\nand description",
    "tfrec.kinematics": "rotations, mimic joints,\nbatched FK",
    "tfrec.trajectory": "center · random · sine ·\nsweep · CSV",
    "tfrec.description": "packages, xacro (sandboxed),\nURDF → Robot, launch files",
    "tfrec.recording": "Recording, RecordedRobot,\nTransforms, FrameSeries",
    "tfrec._atomic": "atomic outputs",
    "tfrec._yaml": "the one YAML loader\n(bounded) and dumper",
    "tfrec._outputs": "outputs checked\nbefore anything is read",
    "tfrec.frames": "the one walk of\na frame graph",
    "tfrec.model": "Robot, Joint, Link",
    "tfrec.conventions": "topics, time base,\ntolerances",
    "tfrec.errors": "TfrecError and one\nclass per layer",
}


def _layers() -> list[list[str]]:
    config = tomllib.loads((REPO / "pyproject.toml").read_text())
    contract = next(c for c in config["tool"]["importlinter"]["contracts"] if c["type"] == "layers")
    rows = []
    for layer in contract["layers"]:
        names = [name.strip().strip("()") for name in layer.split("|")]
        rows.append(names)
    return rows


def _stage(module: str, stages: set[str]) -> str | None:
    parts = module.split(".")
    for depth in range(len(parts), 1, -1):
        name = ".".join(parts[:depth])
        if name in stages:
            return name
    return None


def _reduce(edges: set[tuple[str, str]]) -> set[tuple[str, str]]:
    """The transitive reduction: a → c is left out when a reaches c through another stage."""
    out: dict[str, set[str]] = {}
    for a, b in edges:
        out.setdefault(a, set()).add(b)

    def reaches(start: str, goal: str, skip: tuple[str, str]) -> bool:
        stack, seen = [start], {start}
        while stack:
            node = stack.pop()
            for nxt in out.get(node, ()):
                if (node, nxt) == skip or nxt in seen:
                    continue
                if nxt == goal:
                    return True
                seen.add(nxt)
                stack.append(nxt)
        return False

    return {(a, b) for a, b in edges if not reaches(a, b, (a, b))}


def main() -> int:
    import grimp
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

    sys.path.insert(0, str(REPO))
    graph = grimp.build_graph("tfrec", exclude_type_checking_imports=True)
    rows = [[name for name in row if name in graph.modules] for row in _layers()]
    rows = [row for row in rows if row]
    stages = {name for row in rows for name in row}
    edges: set[tuple[str, str]] = set()
    for module in graph.modules:
        a = _stage(module, stages)
        if a is None:
            continue
        for imported in graph.find_modules_directly_imported_by(module):
            b = _stage(imported, stages)
            if b is not None and b != a:
                edges.add((a, b))
    shown = _reduce({(a, b) for a, b in edges if b not in BASE_EVERYONE})
    width, row_h = 11.0, 1.25
    fig = Figure(figsize=(width, row_h * len(rows) + 0.8), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, width)
    ax.set_ylim(-0.4, row_h * len(rows) + 0.4)
    ax.axis("off")
    box_h = 0.85
    centre: dict[str, tuple[float, float]] = {}
    box_w: dict[str, float] = {}
    for r, row in enumerate(rows):
        y = row_h * (len(rows) - 1 - r) + 0.4
        for i, name in enumerate(row):
            x = width * (i + 1) / (len(row) + 1)
            centre[name] = (x, y)
            box_w[name] = min(3.0, width / (len(row) + 1) - 0.25)
    for a, b in sorted(shown):
        (xa, ya), (xb, yb) = centre[a], centre[b]
        ax.add_patch(FancyArrowPatch((xa, ya - box_h / 2), (xb, yb + box_h / 2), arrowstyle="-|>",
                                     mutation_scale=9, color="#9aa5b1", lw=0.7,
                                     connectionstyle="arc3,rad=0.0", zorder=1))
    palette = {"tfrec.formats": "#fde2c0", "tfrec.viewer": "#fde2c0", "tfrec.cli": "#d7e3fc"}
    for name, (x, y) in centre.items():
        colour = palette.get(name, "#e8f5e9" if name not in BASE else "#eeeeee")
        ax.add_patch(FancyBboxPatch((x - box_w[name] / 2, y - box_h / 2), box_w[name], box_h,
                                    boxstyle="round,pad=0.02,rounding_size=0.08", fc=colour, ec="#52606d",
                                    lw=1.0, zorder=2))
        ax.text(x, y + 0.18, name.removeprefix("tfrec."),
                ha="center", va="center", fontsize=11, fontweight="bold", zorder=3)
        ax.text(x, y - 0.14, NOTES.get(name, ""), ha="center", va="center", fontsize=7.5, color="#323f4b",
                zorder=3, linespacing=1.0)
    ax.text(0.2, -0.2, "A → B: A imports B (arrows implied by others, and those to errors, conventions and model,"
            " which every stage uses, are left out)", fontsize=8, color="#52606d")
    out = REPO / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "architecture.svg", metadata={"Date": None, "Creator": None})
    fig.savefig(out / "architecture.png", metadata={"Software": None})
    print(f"wrote {out / 'architecture.svg'} and .png: {len(stages)} stages, {len(edges)} imports between them")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
