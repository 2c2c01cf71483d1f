"""The robots of a recording: who published which robot topics, as ``info``, ``replay`` and ``diff`` see them.

A multi-robot system records each robot under a namespace (``/robot1/robot_description``,
``/robot1/joint_states``, ``/robot1/tf``), or several robots on shared topics with prefixed
frames (two robot_state_publishers with ``frame_prefix`` on one /tf, each publishing its own
description on /robot_description). :func:`find_robots` turns a :class:`~tfrec.recording.Recording`
into its robots, one :class:`~tfrec.recording.RecordedRobot` each (the one type of a robot's recorded data):

- every robot description of a namespace is a robot (several robots may publish on one
  /robot_description: each description is one);
- a namespace with joint states or TF but no description is a robot without a model;
- a robot's TF is its namespace's /tf and /tf_static, or, when its namespace has none, the root
  namespace's (robots sharing /tf); its joint states likewise. A TF shared by several robots is
  split by frame: each robot takes the pairs whose child frame is one of its links (with the
  frame prefix detected for it, :func:`detect_frame_prefix`); what no robot takes stays together
  as ``other_frames`` of that namespace, so that nothing recorded is lost.

``info`` lists the robots, ``replay`` plays each under its key and checks each (``--check``),
``diff`` compares them robot by robot, all through this one function, so they agree.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import DescriptionError, warn_again
from tfrec.model import Robot
from tfrec.recording import FrameSeries, RecordedRobot, Recording, robot_name

__all__ = [
    "OTHER_FRAMES",
    "ParsedDescriptions",
    "RecordedRobot",
    "detect_frame_prefix",
    "find_robots",
    "pair_robots",
    "parse_description",
    "robot_name",
]

Array = NDArray[np.float64]
Pair = tuple[str, str]

OTHER_FRAMES = "other_frames"
"""The key's last part for a shared TF's pairs that no robot of it claims."""


def pair_robots(a: Sequence[RecordedRobot],
                b: Sequence[RecordedRobot]) -> list[tuple[RecordedRobot | None, RecordedRobot | None]]:
    """The robots of two recordings paired for comparing: by key, a robot of one recording only with None;
    the one robot of each when each has one, whatever their namespaces."""
    if len(a) == 1 and len(b) == 1:
        return [(a[0], b[0])]
    by_key = {robot.key: robot for robot in b}
    pairs: list[tuple[RecordedRobot | None, RecordedRobot | None]] = [(r, by_key.pop(r.key, None)) for r in a]
    return pairs + [(None, robot) for robot in by_key.values()]


def parse_description(text: str, where: str) -> tuple[Robot | None, str | None]:
    """A recorded robot description as a model, or why it is none: (model, None) or (None, problem)."""
    from tfrec.description.urdf import parse_urdf

    try:
        return parse_urdf(text, source=None, user_lines=False), None
    except DescriptionError as err:
        return None, str(err)


class ParsedDescriptions:
    """Recorded descriptions parsed once (:func:`parse_description`), by text, for several :func:`find_robots` calls
    on recordings that share them (the pieces of one recording, A and B of a ``diff``): each call gives the
    warnings parsing gave, as parsing it again would."""

    def __init__(self) -> None:
        self._parsed: dict[str, tuple[tuple[Robot | None, str | None], list[warnings.WarningMessage]]] = {}
        self._registry: dict[Any, Any] = {}  # what the "default" action has shown already, as a module's registry

    def parse(self, text: str, where: str) -> tuple[Robot | None, str | None]:
        found = self._parsed.get(text)
        if found is None:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                result = parse_description(text, where)
            found = self._parsed[text] = (result, list(caught))
        for warning in found[1]:
            warn_again(warning, self._registry)
        return found[0]


def _prefix_counts(robot: Robot, frames: Iterable[str]) -> dict[str, int]:
    """Prefix → how many of the robot's links the frames name with it (``""``: the link names themselves)."""
    links = {link.name for link in robot.links}
    lengths = sorted({len(link) for link in links if link})  # a frame's suffixes of these lengths only: linear in frames
    counts: dict[str, int] = {}
    for frame in set(frames):
        if frame in links:
            counts[""] = counts.get("", 0) + 1
        for length in lengths:
            if length >= len(frame):
                break
            if frame[-length:] in links:
                prefix = frame[:-length]
                counts[prefix] = counts.get(prefix, 0) + 1
    return counts


def detect_frame_prefix(robot: Robot, frames: Iterable[str], *, namespace: str = "") -> str:
    """The prefix the recording's frame ids put in front of the robot's link names.

    robot_state_publisher's ``frame_prefix`` (``left/``), or ROS 1's leading ``/``: the prefix that
    turns the most frames into link names; no prefix when the frames are the link names. The
    namespace's own name (``robot1/`` for ``/robot1``) wins when some frames carry it: robots of
    one model in several namespaces share every other prefix's count.
    """
    counts = _prefix_counts(robot, frames)
    own = namespace.strip("/") + "/" if namespace else None
    if own is not None and counts.get(own):
        return own
    if not counts:
        return ""
    best = max(counts.values())
    if counts.get("", 0) == best:
        return ""
    return min((prefix for prefix, count in counts.items() if count == best), key=lambda p: (len(p), p))


def _instances(robot: Robot, frames: Sequence[str], namespace: str) -> list[str]:
    """The frame prefixes under which one description's robot appears several times in one TF (two
    arms of one model, ``left/`` and ``right/``): each prefix that names half its links or more; else
    the one prefix :func:`detect_frame_prefix` finds."""
    counts = _prefix_counts(robot, frames)
    own = namespace.strip("/") + "/" if namespace else None
    enough = max(1, len(robot.links) // 2)
    many = sorted(prefix for prefix, count in counts.items() if count >= enough)
    if len(many) > 1 and not (own is not None and counts.get(own)):
        return many
    return [detect_frame_prefix(robot, frames, namespace=namespace)]


_UNSAFE = re.compile(r"[^A-Za-z0-9_]")


def _part(name: str | None, index: int) -> str:
    """A robot's name as a key part (``left_arm``): its name, made a ROS name."""
    return _UNSAFE.sub("_", name) if name else f"robot_{index}"


def _joined(namespace: str, part: str) -> str:
    return f"{namespace}/{part}" if namespace else part


@dataclass
class _Candidate:
    namespace: str
    name: str | None
    description: str | None
    model: Robot | None
    problem: str | None
    pool: str = ""  # the namespace of the TF it reads
    leftover: bool = False  # the pairs of a shared TF that no robot claims
    prefix: str | None = None
    instance: str = ""  # one of several robots of one description (its frame prefix, ``left``)
    tf: dict[Pair, FrameSeries] = field(default_factory=dict)
    tf_static: dict[Pair, tuple[Array, Array]] = field(default_factory=dict)


def find_robots(rec: Recording, *, namespace: str | None = None,
                parsed: ParsedDescriptions | None = None) -> list[RecordedRobot]:
    """The robots of a recording (see the module docstring), in namespace order.

    Args:
        rec: the recording.
        namespace: only the robots of this namespace (``/robot1``; ``""`` the root's); they
            may still read the root namespace's TF and joint states.
        parsed: where descriptions parsed before are kept, and those parsed here go (:class:`ParsedDescriptions`:
            ``diff`` parses a description A and B share once, replay the one every piece of a recording has).

    Returns:
        One entry per robot, and one per shared TF's unclaimed pairs; empty when the recording
        has no robot topics.
    """
    names = rec.namespace_names()
    topics = {ns: rec.robot_topics(ns) for ns in names}
    has_tf = {ns for ns, t in topics.items() if t.tf or t.tf_static}
    has_js = {ns for ns, t in topics.items() if t.joint_states is not None}
    candidates: list[_Candidate] = []
    for ns in names:
        for text in topics[ns].descriptions:
            model, problem = parse_description(text, rec.path) if parsed is None else parsed.parse(text, rec.path)
            candidates.append(_Candidate(ns, model.name if model else robot_name(text), text, model, problem))
    for candidate in candidates:
        candidate.pool = candidate.namespace if candidate.namespace in has_tf or "" not in has_tf else ""
    used_pools = {c.pool for c in candidates}
    used_js = {c.namespace if c.namespace in has_js else "" for c in candidates}
    for ns in names:  # a namespace without a description whose data no robot reads: a robot without a model
        if not topics[ns].descriptions and ((ns in has_tf and ns not in used_pools)
                                             or (ns in has_js and ns not in used_js and ns not in used_pools)):
            candidates.append(_Candidate(ns, None, None, None, None, pool=ns))
    leftovers: dict[str, _Candidate] = {}
    for pool in sorted({c.pool for c in candidates}):
        pool_topics = topics.get(pool, RecordedRobot(pool))
        frames = [frame for pair in list(pool_topics.tf_static) + list(pool_topics.tf) for frame in pair]
        users = []
        for c, prefixes in _assign([c for c in candidates if c.pool == pool], frames):
            users += [replace(c, prefix=prefix, instance=prefix.strip("/") if len(prefixes) > 1 else "",
                              tf={}, tf_static={}) for prefix in prefixes]
        candidates = [c for c in candidates if c.pool != pool] + users
        _split_pool(pool_topics, pool, users, leftovers)
    candidates += leftovers.values()
    if namespace is not None:
        candidates = [c for c in candidates if c.namespace == namespace]
    return _keyed(candidates, topics, has_js)


def _assign(users: list[_Candidate], frames: Sequence[str]) -> list[tuple[_Candidate, list[str]]]:
    """The frame prefix(es) of each robot reading one TF. Descriptions of one model (the same link
    names) claim the same prefixes: a prefix goes first to the robot whose name holds it (``left/``
    to ``left_arm``), then to the robots in the order of their descriptions, one each; a
    description left alone with several prefixes is that many robots (two arms of one model)."""
    claims = [(_instances(u.model, frames, u.namespace) if u.model is not None else [""]) for u in users]
    assigned: dict[int, list[str]] = {}
    taken: set[str] = set()
    for i, (user, prefixes) in enumerate(zip(users, claims)):
        name = (user.name or "").lower()
        named = [p for p in prefixes if p.strip("/") and p.strip("/").lower() in name and p not in taken]
        if named and len(prefixes) > 1:
            assigned[i] = named[:1]
            taken.add(named[0])
    for i, prefixes in enumerate(claims):
        if i in assigned:
            continue
        free = [p for p in prefixes if p not in taken] or prefixes[:1]
        later = any(set(claims[j]) & set(free) for j in range(i + 1, len(users)) if j not in assigned)
        assigned[i] = free[:1] if later else free
        taken.update(assigned[i])
    return [(user, assigned[i]) for i, user in enumerate(users)]


def _split_pool(pool_topics: RecordedRobot, pool: str, users: list[_Candidate], leftovers: dict[str, _Candidate]) -> None:
    """Share one namespace's TF among the robots that read it (their prefixes found)."""
    if len(users) == 1:
        users[0].tf, users[0].tf_static = dict(pool_topics.tf), dict(pool_topics.tf_static)
        return
    owner: dict[str, _Candidate] = {}
    for user in users:
        if user.model is not None:
            for link in user.model.links:
                owner.setdefault((user.prefix or "") + link.name, user)
    rest = _Candidate(pool, None, None, None, None, pool=pool, leftover=True)
    for pair, series in pool_topics.tf.items():
        (owner.get(pair[1], rest)).tf[pair] = series
    for pair, pose in pool_topics.tf_static.items():
        (owner.get(pair[1], rest)).tf_static[pair] = pose
    if rest.tf or rest.tf_static:
        leftovers[pool] = rest


def _keyed(candidates: Sequence[_Candidate], topics: dict[str, RecordedRobot], has_js: set[str]) -> list[RecordedRobot]:
    per_namespace: dict[str, int] = {}
    for c in candidates:
        per_namespace[c.namespace] = per_namespace.get(c.namespace, 0) + 1
    robots = []
    for index, c in enumerate(sorted(candidates, key=lambda c: (c.namespace, c.leftover, c.description is None))):
        if per_namespace[c.namespace] == 1:
            key = c.namespace or ("/" if len(candidates) > 1 else "")
        elif c.leftover:
            key = _joined(c.namespace, OTHER_FRAMES)
        else:
            key = _joined(c.namespace, _part(c.instance or c.name, index))
        js_ns = c.namespace if c.namespace in has_js else ""
        js = None if c.leftover or js_ns not in topics else topics[js_ns].joint_states
        robots.append(RecordedRobot(
            namespace=c.namespace, descriptions=() if c.description is None else (c.description,), joint_states=js,
            tf=c.tf, tf_static=c.tf_static, key=key, name=c.name, model=c.model, problem=c.problem,
            frame_prefix=c.prefix or "", joint_states_namespace=js_ns, tf_namespace=c.pool, unclaimed=c.leftover))
    return robots
