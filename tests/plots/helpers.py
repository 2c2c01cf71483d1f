"""Shared by the plot tests: the corpus, picture checks and a DOT tokenizer."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import CORPUS, CORPUS_ABSENT, REPO

# a git worktree (../wt/NAME) sees the shared corpus two levels up instead of one
CORPORA = (CORPUS, REPO.parents[1] / "shared" / "corpus")


def corpus_dir() -> Path:
    for folder in CORPORA:
        if folder.is_dir():
            return folder
    pytest.skip(CORPUS_ABSENT)


def png_pixels(path: Path) -> np.ndarray:
    """(H, W, 3) uint8 RGB of a PNG, read by matplotlib."""
    from matplotlib.image import imread

    image = imread(path)
    return np.round(np.asarray(image)[..., :3] * 255).astype(np.uint8)


def has_colour(pixels: np.ndarray, colour: str, *, tolerance: int = 12, at_least: int = 20) -> bool:
    """Whether at least ``at_least`` pixels are within ``tolerance`` of ``#rrggbb`` in every channel."""
    rgb = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)], dtype=np.int16)
    close = np.all(np.abs(pixels.astype(np.int16) - rgb) <= tolerance, axis=-1)
    return int(close.sum()) >= at_least


_TOKEN = re.compile(r'\s*(?:(//[^\n]*)|("(?:[^"\\]|\\.)*")|([A-Za-z_][A-Za-z_0-9.]*|-?[0-9.]+)|(->|[{}\[\];=,]))',
                    re.DOTALL)


def dot_tokens(text: str) -> list[str]:
    """The tokens of DOT text (comments dropped); fails on anything DOT does not allow."""
    tokens: list[str] = []
    at = 0
    while at < len(text.rstrip()):
        match = _TOKEN.match(text, at)
        assert match is not None and match.end() > at, f"not DOT at {at}: {text[at:at + 40]!r}"
        comment, quoted, word, punct = match.groups()
        if comment is None:
            tokens.append(quoted or word or punct)
        at = match.end()
    assert tokens.count("{") == tokens.count("}") == 1 and tokens[0] == "digraph" and tokens[-1] == "}"
    return tokens


def unquote(token: str) -> str:
    """A DOT quoted string's text, as Graphviz reads it (``\\n`` a line break in labels)."""
    assert token.startswith('"') and token.endswith('"')
    return re.sub(r"\\(.)", lambda m: "\n" if m.group(1) == "n" else m.group(1), token[1:-1], flags=re.DOTALL)


def dot_graph(text: str) -> tuple[set[str], set[tuple[str, str]], dict[tuple[str, str], str]]:
    """Nodes, edges and edge labels of the DOT text :func:`tfrec.plots.to_dot` writes."""
    tokens = dot_tokens(text)
    nodes: set[str] = set()
    edges: set[tuple[str, str]] = set()
    labels: dict[tuple[str, str], str] = {}
    body = tokens[tokens.index("{") + 1:-1]
    statements: list[list[str]] = [[]]
    depth = 0
    for token in body:
        depth += token == "["
        depth -= token == "]"
        if token == ";" and depth == 0:
            statements.append([])
        else:
            statements[-1].append(token)
    for statement in filter(None, statements):
        if statement[0] in ("graph", "node", "edge"):
            continue
        if len(statement) > 2 and statement[1] == "->":
            pair = (unquote(statement[0]), unquote(statement[2]))
            edges.add(pair)
            if "label" in statement:
                labels[pair] = unquote(statement[statement.index("label") + 2])
        else:
            nodes.add(unquote(statement[0]))
    return nodes, edges, labels
