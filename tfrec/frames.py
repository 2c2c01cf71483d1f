"""The TF graph of a set of (parent, child) frame pairs, walked once: the one place tfrec walks a frame graph.

A recording's /tf and /tf_static need not form a tree: a frame may be its own parent, frames may form a
cycle (through the root or apart from the rest), and a frame may have several parents (reparented over
time, or published by two nodes). tf2 refuses a self-transform and cannot look a frame up through a
cycle; every walk here keeps a visited set, so none of these makes a walk endless.

:func:`frame_tree` places every frame exactly once, breadth-first from the roots, below the first parent
that reaches it (pairs in the order given: a caller lists /tf_static before /tf, and recorded order
within each); the pairs left over — self-transforms, the edges that close a cycle, a second parent —
are listed, and :func:`graph_problems` names them in one sentence each, for a warning. Everything is
iterative and linear in the number of pairs: a chain of 100,000 frames is walked like a short one.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

__all__ = ["MAX_NAMED", "FrameTree", "frame_tree", "graph_problems", "named"]

Pair = tuple[str, str]

MAX_NAMED = 8
"""Frames named in one sentence of :func:`graph_problems` (a cycle of 100,000 frames is not listed whole)."""


@dataclass(frozen=True, slots=True)
class FrameTree:
    """Every frame of some pairs placed once, in a forest.

    Attributes:
        order: every frame once, tree after tree (the roots' order), each tree breadth-first: a frame
            comes after its parent.
        parent: frame → the parent it is placed below (roots have none).
        root: frame → the root of its tree.
        depth: frame → its depth (roots 0).
        left_out: the pairs that are no edge of the forest: self-transforms, edges closing a
            cycle, second parents.
        cycles: the frames of each cycle (a strongly connected set, or a frame that is its own
            parent), in the order the frames first appear.
        several_parents: frame → its parents (in pair order), for frames with more than one.
    """

    order: tuple[str, ...]
    parent: dict[str, str]
    root: dict[str, str]
    depth: dict[str, int]
    left_out: tuple[Pair, ...]
    cycles: tuple[tuple[str, ...], ...]
    several_parents: dict[str, tuple[str, ...]]

    @property
    def roots(self) -> list[str]:
        """The roots, in tree order."""
        return [frame for frame in self.order if frame not in self.parent]

    def edges(self) -> list[Pair]:
        """The forest's (parent, child) pairs, parents before children."""
        return [(self.parent[frame], frame) for frame in self.order if frame in self.parent]

    def reachable(self, root: str) -> list[str]:
        """The frames of ``root``'s tree (``root`` first), breadth-first."""
        return [frame for frame in self.order if self.root.get(frame) == root]


def frame_tree(pairs: Iterable[Pair], roots: Sequence[str] = ()) -> FrameTree:
    """Place the frames of ``pairs`` in a forest, each once, breadth-first from the roots.

    Args:
        pairs: (parent, child) frame pairs; repeats count once.
        roots: frames to start from, in order: each that the trees before it did not reach is the
            root of a tree, even when some pair names a parent of it (a cycle through the root).
            Then every frame that is nobody's child, in order of first appearance; then, for frames
            only a cycle reaches, the first of them to appear.

    Returns:
        The forest; see :class:`FrameTree`.
    """
    unique = list(dict.fromkeys(pairs))
    children: dict[str, list[str]] = {}
    parents: dict[str, list[str]] = {}
    frames: dict[str, None] = dict.fromkeys(roots)
    self_loops: list[str] = []
    for parent, child in unique:
        frames.setdefault(parent)
        frames.setdefault(child)
        if parent == child:
            self_loops.append(child)
            continue
        children.setdefault(parent, []).append(child)
        parents.setdefault(child, []).append(parent)
    placed_parent: dict[str, str] = {}
    root_of: dict[str, str] = {}
    depth: dict[str, int] = {}
    order: list[str] = []
    starts = [*roots, *(frame for frame in frames if frame not in parents), *frames]
    for start in starts:
        if start in root_of:
            continue
        root_of[start] = start
        depth[start] = 0
        head = len(order)
        order.append(start)
        while head < len(order):
            frame = order[head]
            head += 1
            for child in children.get(frame, ()):
                if child not in root_of:
                    root_of[child] = start
                    placed_parent[child] = frame
                    depth[child] = depth[frame] + 1
                    order.append(child)
    left_out = tuple(pair for pair in unique if placed_parent.get(pair[1]) != pair[0])
    first = {frame: k for k, frame in enumerate(frames)}
    cycles = sorted([*_strongly_connected(children, frames), *((frame,) for frame in dict.fromkeys(self_loops))],
                    key=lambda cycle: first[cycle[0]])
    several = {child: tuple(of) for child, of in parents.items() if len(of) > 1}
    return FrameTree(tuple(order), placed_parent, root_of, depth, left_out, tuple(cycles), several)


def _strongly_connected(children: dict[str, list[str]], frames: Iterable[str]) -> list[tuple[str, ...]]:
    """The strongly connected sets of more than one frame (Tarjan's algorithm without recursion), each
    in order of first appearance."""
    first = {frame: k for k, frame in enumerate(frames)}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[tuple[str, ...]] = []
    for start in first:
        if start in index:
            continue
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        work = [(start, 0)]
        while work:
            frame, i = work[-1]
            kids = children.get(frame, ())
            if i < len(kids):
                work[-1] = (frame, i + 1)
                kid = kids[i]
                if kid not in index:
                    index[kid] = low[kid] = len(index)
                    stack.append(kid)
                    on_stack.add(kid)
                    work.append((kid, 0))
                elif kid in on_stack:
                    low[frame] = min(low[frame], index[kid])
                continue
            work.pop()
            if work:
                up = work[-1][0]
                low[up] = min(low[up], low[frame])
            if low[frame] == index[frame]:
                component: list[str] = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == frame:
                        break
                if len(component) > 1:
                    out.append(tuple(sorted(component, key=first.__getitem__)))
    return out


def named(frames: Sequence[str], limit: int = MAX_NAMED) -> str:
    """``'a', 'b', 'c'`` — at most ``limit`` names, then how many more."""
    shown = ", ".join(repr(frame) for frame in frames[:limit])
    return shown + (f" and {len(frames) - limit:,} more" if len(frames) > limit else "")


def graph_problems(tree: FrameTree, *, parents: bool = True) -> list[str]:
    """One sentence per thing that keeps the pairs from being a tree, for a warning: cycles and frames that
    are their own parent (which tf2 refuses), and (``parents``) frames with several parents, with the
    parent each is placed below. At most :data:`MAX_NAMED` sentences of each kind."""
    out: list[str] = []
    for cycle in tree.cycles[:MAX_NAMED]:
        if len(cycle) == 1:
            out.append(f"frame {cycle[0]!r} is its own parent (tf2 ignores such a transform)")
        else:
            out.append(f"frames {named(cycle)} form a cycle (tf2 cannot look a frame up through it)")
    if len(tree.cycles) > MAX_NAMED:
        out.append(f"{len(tree.cycles) - MAX_NAMED:,} more cycles")
    if parents:
        in_cycle = {frame for cycle in tree.cycles for frame in cycle}
        several = [(child, of) for child, of in tree.several_parents.items() if child not in in_cycle]
        for child, of in several[:MAX_NAMED]:
            kept = tree.parent.get(child)
            where = f"placed below {kept!r}" if kept is not None else "placed as a root"
            out.append(f"frame {child!r} has {len(of)} parents ({named(of)}): {where}")
        if len(several) > MAX_NAMED:
            out.append(f"{len(several) - MAX_NAMED:,} more frames with several parents")
    return out
