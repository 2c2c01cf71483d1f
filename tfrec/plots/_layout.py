"""A tidy top-down layout of a forest, in pure Python: y by depth, x packed by subtree contours.

Each node occupies a column of its own width at its depth. Subtrees are laid out bottom-up and
placed side by side as close as their contours (the leftmost and rightmost extent at every depth)
allow, as in Reingold and Tilford's tidy trees, so a leaf at one depth may sit above or below a
node of another subtree instead of getting a column of its own. A parent is centred over its
children — or straight above its only child with children of its own, its leaf children on either
side, so that a kinematic chain with sensor frames hanging off it stays a straight line.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

__all__ = ["Placement", "tidy_layout"]


@dataclass(frozen=True, slots=True)
class Placement:
    """Where the nodes go.

    Attributes:
        x: node → the centre of its column, from 0 at the left edge of the widest extent.
        depth: node → its depth (roots 0).
        width: the total width (same unit as the column widths).
        levels: the number of depths.
    """

    x: dict[str, float]
    depth: dict[str, int]
    width: float
    levels: int


def _order(node: str, children: Mapping[str, Sequence[str]]) -> list[str]:
    """The children of ``node`` left to right: with one child that has children, it goes in the middle."""
    kids = list(children.get(node, ()))
    inner = [kid for kid in kids if children.get(kid)]
    if len(inner) != 1 or len(kids) == 1:
        return kids
    leaves = [kid for kid in kids if kid != inner[0]]
    half = (len(leaves) + 1) // 2
    return leaves[:half] + inner + leaves[half:]


def _pack(parts: Sequence[tuple[list[float], list[float]]], gap: float) -> tuple[list[float], list[float], list[float]]:
    """Place contours left to right, each as far left as the ones before allow.

    Returns:
        (offsets of the parts, left contour, right contour) of the packed row.
    """
    offsets: list[float] = []
    left: list[float] = []
    right: list[float] = []
    for lo, hi in parts:
        common = min(len(right), len(lo))
        shift = max((right[d] - lo[d] + gap for d in range(common)), default=0.0) if offsets else 0.0
        offsets.append(shift)
        for d, value in enumerate(hi):
            if d < len(right):
                right[d] = value + shift
            else:
                right.append(value + shift)
        left.extend(value + shift for value in lo[len(left):])
    return offsets, left, right


def tidy_layout(roots: Sequence[str], children: Mapping[str, Sequence[str]], widths: Mapping[str, float],
                *, gap: float) -> Placement:
    """Lay out a forest top-down.

    Args:
        roots: the roots, left to right.
        children: node → its children (every node reachable from a root exactly once).
        widths: node → the width of its column.
        gap: the least space between two columns at the same depth.

    Returns:
        The placement; x is the centre of each node's column.
    """
    # post-order without recursion: a chain of thousands of frames is fine
    post: list[str] = []
    stack = list(reversed(roots))
    depth: dict[str, int] = {root: 0 for root in roots}
    while stack:
        node = stack.pop()
        post.append(node)
        for kid in children.get(node, ()):
            depth[kid] = depth[node] + 1
            stack.append(kid)
    relative: dict[str, float] = {}
    contours: dict[str, tuple[list[float], list[float]]] = {}
    for node in reversed(post):  # children before parents
        half = widths[node] / 2.0
        kids = _order(node, children)
        if not kids:
            contours[node] = ([-half], [half])
            continue
        offsets, left, right = _pack([contours.pop(kid) for kid in kids], gap)
        inner = [i for i, kid in enumerate(kids) if children.get(kid)]
        anchor = offsets[inner[0]] if len(inner) == 1 else (offsets[0] + offsets[-1]) / 2.0
        for kid, offset in zip(kids, offsets):
            relative[kid] = offset - anchor
        contours[node] = ([-half] + [v - anchor for v in left], [half] + [v - anchor for v in right])
    offsets, left, _ = _pack([contours[root] for root in roots], gap)
    x: dict[str, float] = {}
    for root, offset in zip(roots, offsets):
        x[root] = offset
    for node in post:  # parents before children
        for kid in children.get(node, ()):
            x[kid] = x[node] + relative[kid]
    lo = min((x[node] - widths[node] / 2.0 for node in x), default=0.0)
    hi = max((x[node] + widths[node] / 2.0 for node in x), default=0.0)
    return Placement({node: value - lo for node, value in x.items()}, depth, hi - lo,
                     1 + max(depth.values(), default=-1))
