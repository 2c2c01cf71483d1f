"""What every picture of :mod:`tfrec.plots` shares: output formats, stable colours, deterministic saving.

matplotlib is imported inside the functions that draw, so importing :mod:`tfrec.plots` stays cheap.
Figures are ``matplotlib.figure.Figure`` objects with an Agg canvas of their own — never pyplot and
its global figure manager — and are saved with fixed metadata and a fixed SVG hash salt, so the same
input gives the same bytes.
"""

from __future__ import annotations

import os
import re
import warnings
import zlib
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tfrec._atomic import AtomicOutputs
from tfrec._outputs import FileKind, check_target
from tfrec.errors import PlotError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "DISTINCT",
    "DPI",
    "GRAPH_FORMATS",
    "MAX_POINTS",
    "PALETTE",
    "PLOT_FORMATS",
    "PlotError",
    "assign_colours",
    "envelope",
    "graph_format",
    "natural_key",
    "new_figure",
    "picture_kind",
    "plot_format",
    "refuse_existing",
    "save_figure",
    "stable_colour",
]

Array = NDArray[np.float64]

DPI = 110
"""Pixels per inch of PNG output: a 14-inch-wide plot is 1540 px, readable in a PR comment."""

GRAPH_FORMATS = ("dot", "svg", "png", "pdf")
"""Output formats of a TF tree graph, by file suffix."""

PLOT_FORMATS = ("png", "svg", "pdf")
"""Output formats of a plot, by file suffix."""

PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf",
    "#bcbd22", "#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#1b9e77", "#7570b3",
    "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#0868ac", "#b2182b", "#4d9221", "#542788",
)
"""24 qualitative colours, dark enough for thin lines on white (no grey: grey means static or tolerance)."""

DISTINCT = 9
"""The first colours of :data:`PALETTE` that are told apart at a glance (tab10 without grey)."""

LINESTYLES = ("-", "--", "-.", ":")
"""Line styles that tell apart names that had to share a colour (more names than colours)."""

MAX_POINTS = 4000
"""Samples drawn per line at most; longer series are drawn as their min/max envelope (:func:`envelope`)."""

_FONT = "DejaVu Sans"  # ships with matplotlib: the same metrics everywhere


def _svg(path: Path, head: bytes) -> str | None:
    text = head.decode("utf-8", "replace").lstrip("\ufeff \t\r\n")
    return None if text.startswith("<") and "<svg" in text else "its text is not SVG"


_DOT = re.compile(r"\s*(?:(?://|#)[^\n]*\n\s*|/\*.*?\*/\s*)*(?:strict\s+)?(?:di)?graph\b", re.IGNORECASE | re.DOTALL)


def _dot(path: Path, head: bytes) -> str | None:
    return None if _DOT.match(head.decode("utf-8", "replace").lstrip("\ufeff")) else "no graph or digraph statement begins it"


PICTURE_KINDS: dict[str, FileKind] = {
    "png": FileKind("a PNG picture", (b"\x89PNG\r\n\x1a\n",)),
    "pdf": FileKind("a PDF document", (b"%PDF-",)),
    "svg": FileKind("an SVG picture", test=_svg),
    "dot": FileKind("a Graphviz DOT graph", test=_dot),
}
"""The kind of each picture format (:class:`tfrec._outputs.OutputKind`: how an existing one is recognized)."""


def picture_kind(path: str | os.PathLike[str]) -> FileKind:
    """The kind of the picture ``path`` from its suffix (checked by :func:`plot_format` or :func:`graph_format`)."""
    return PICTURE_KINDS[Path(path).suffix.lower().lstrip(".")]


def refuse_existing(path: str | os.PathLike[str], *, force: bool,
                    inputs: Iterable[str | os.PathLike[str] | None] = ()) -> None:
    """Check a picture's name before anything is drawn (:func:`tfrec._outputs.check_target`): an existing file
    only with ``force``, and only a picture of its format; never an input.

    Raises:
        WriteError: ``path`` exists (without ``force``; a folder, a link or a file of another kind in any case), is
            too long a name, or is an input.
    """
    check_target(Path(path), picture_kind(path), force=force, inputs=inputs)


def _output_format(path: str | os.PathLike[str], formats: tuple[str, ...], what: str) -> str:
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in formats:
        given = f"'.{suffix}'" if suffix else "no suffix"
        raise PlotError(f"{os.fspath(path)}: a {what} is written as {', '.join('.' + f for f in formats)} "
                        f"(chosen by the file's suffix), not {given}")
    return suffix


def graph_format(path: str | os.PathLike[str]) -> str:
    """The format of a TF tree graph file, from its suffix: ``dot``, ``svg``, ``png`` or ``pdf``.

    Raises:
        PlotError: any other suffix (the message lists the formats).
    """
    return _output_format(path, GRAPH_FORMATS, "graph")


def plot_format(path: str | os.PathLike[str]) -> str:
    """The format of a plot file, from its suffix: ``png``, ``svg`` or ``pdf``.

    Raises:
        PlotError: any other suffix (the message lists the formats).
    """
    return _output_format(path, PLOT_FORMATS, "plot")


def stable_colour(name: str) -> str:
    """The palette colour of a name, the same in every run and every plot (CRC-32 of the name)."""
    return PALETTE[zlib.crc32(name.encode("utf-8")) % len(PALETTE)]


def assign_colours(names: Iterable[str]) -> dict[str, tuple[str, str]]:
    """Colours and line styles for names drawn together, distinct within the set and stable across plots.

    Up to :data:`DISTINCT` names share the first, most distinct colours of :data:`PALETTE`, more
    names the whole palette. Each name gets the colour its CRC-32 picks, or, when another name of
    the set has it already, the next free one (names taken in sorted order): a name's colour
    depends on the name and on the set only. Past 24 names colours repeat with another line style.

    Returns:
        name → (colour, line style).
    """
    unique = sorted(set(names))
    n = DISTINCT if len(unique) <= DISTINCT else len(PALETTE)
    out: dict[str, tuple[str, str]] = {}
    used: set[int] = set()
    for name in unique:
        slot = zlib.crc32(name.encode("utf-8")) % n
        if len(used) >= n:
            used.clear()
        while slot in used:
            slot = (slot + 1) % n
        used.add(slot)
        out[name] = (PALETTE[slot], LINESTYLES[(len(out) // n) % len(LINESTYLES)])
    return out


def envelope(t: Array, y: Array) -> tuple[Array, Array]:
    """At most :data:`MAX_POINTS` samples of (N,) ``t`` and (N,) or (N, J) ``y``: each bucket's min and
    max (NaN ignored), so that peaks survive in a line drawn from them."""
    if len(t) <= MAX_POINTS:
        return t, y
    edges = np.linspace(0, len(t), MAX_POINTS // 2 + 1).astype(np.int64)
    starts = edges[:-1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        lo = np.fmin.reduceat(y, starts, axis=0)
        hi = np.fmax.reduceat(y, starts, axis=0)
    tt = np.empty(2 * len(starts))
    tt[0::2], tt[1::2] = t[starts], t[edges[1:] - 1]
    yy = np.empty((2 * len(starts),) + y.shape[1:])
    yy[0::2], yy[1::2] = lo, hi
    return tt, yy


def natural_key(text: str) -> tuple[tuple[int, int | str], ...]:
    """A sort key that puts ``link2`` before ``link10``."""
    return tuple((0, int(part)) if part.isdigit() else (1, part)
                 for part in re.split(r"(\d+)", text) if part)


_RC: dict[str, Any] = {
    "svg.hashsalt": "tfrec",  # ids of clip paths and the like: the same in every run
    "svg.fonttype": "none",  # text stays text: searchable, and every name is in the file
    "pdf.fonttype": 42,
    "font.family": "sans-serif",
    "font.sans-serif": [_FONT],
    "font.size": 9.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 9.0,
    "legend.fontsize": 8.0,
    "path.simplify": True,
    "axes.unicode_minus": False,
}


@contextmanager
def plot_style() -> Iterator[None]:
    """matplotlib settings of every tfrec picture, for the duration of drawing and saving."""
    import matplotlib

    settings: Any = _RC  # matplotlib types the keys as a Literal of every rcParam
    with matplotlib.rc_context(settings):
        yield


def new_figure(width_in: float, height_in: float) -> Figure:
    """A Figure with its own Agg canvas (no pyplot), ``DPI`` pixels per inch. Call inside :func:`plot_style`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


_METADATA: dict[str, dict[str, str | None]] = {
    "svg": {"Date": None, "Creator": "tfrec"},
    "png": {"Software": "tfrec"},
    "pdf": {"CreationDate": None, "ModDate": None, "Creator": "tfrec", "Producer": "tfrec"},
}


def save_figure(fig: Figure, path: str | os.PathLike[str], fmt: str, *, force: bool = False) -> None:
    """Write ``fig`` to ``path`` as ``fmt`` (``png``, ``svg`` or ``pdf``), atomically and deterministically.

    Call inside :func:`plot_style` (the SVG hash salt and font settings apply at saving time).

    Raises:
        WriteError: the file cannot be written (its message names ``path``).
    """
    target = Path(path)
    with AtomicOutputs(replace=force) as outputs:
        temp = outputs.path(target, kind=PICTURE_KINDS[fmt])
        fig.savefig(temp, format=fmt, dpi=DPI, metadata=_METADATA[fmt])
        outputs.commit()


def write_text(path: str | os.PathLike[str], text: str, *, force: bool = False) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically.

    Raises:
        WriteError: the file cannot be written.
    """
    target = Path(path)
    with AtomicOutputs(replace=force) as outputs:
        outputs.path(target, kind=picture_kind(target)).write_text(text, encoding="utf-8")
        outputs.commit()
