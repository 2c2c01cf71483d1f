"""A recording replayed piece by piece, in memory that does not grow with its length: what ``replay --check`` and
``tfrec check`` re-simulate.

:func:`replay_pieces` reads a recording in consecutive pieces (:func:`tfrec.formats.reader.read_pieces`: every piece
has the latched data and the topic table) and prepares each as :func:`tfrec.replay.load_replay` prepares a whole
recording. So that every recorded transform meets the joint states around it, as in the whole recording:

- each piece starts with the joint states of the last :data:`LATE_NS` before it (twice the lateness seen, when
  more), and before them the last joint state that gives each joint a position (the sample before its first
  transforms, also for transforms that the file holds after later joint states);
- transforms stamped after the last position of a joint in their piece wait for the next piece (the sample after
  them); while a robot's joint states pause (a piece without any, more of them in the topic table), its
  transforms after their last one wait for them to come again, up to :data:`HOLD_SAMPLES`; the last piece takes
  what is left.

Each transform is thus in one piece, and interpolated between the same two joint states as in the whole recording
(when the joint states arrive in stamp order, as a recorder writes them — one that arrives behind a later piece's
is used from that piece on —, transforms come no later than the joint states kept, and a pause is shorter than
the hold).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, robot_topic_kind
from tfrec.errors import LackingWarning, TfrecError, TfrecWarning
from tfrec.formats.reader import read_pieces
from tfrec.model import Robot
from tfrec.recording import FrameSeries, JointStates, Recording
from tfrec.replay.load import _check_topics, _prepare_recording, _read_topics
from tfrec.replay.prepared import Replay
from tfrec.resample import start_of
from tfrec.robots import ParsedDescriptions

__all__ = ["ReplayPiece", "replay_pieces"]

Pair = tuple[str, str]


@dataclass(frozen=True, slots=True)
class ReplayPiece:
    """One piece of a recording, prepared for replaying or checking.

    Attributes:
        replay: the piece prepared (:func:`tfrec.replay.load_replay`'s result for it). The last piece's
            ``origin_ns``, ``start_ns``, ``end_ns`` and ``read_error`` are the whole recording's.
        joint_stamps: namespace → the stamps of the piece's own joint states (not those carried from the piece
            before).
        last: whether it is the last piece.
    """

    replay: Replay
    joint_stamps: dict[str, NDArray[np.int64]] = field(default_factory=dict)
    last: bool = False


def _joined(first: JointStates, then: JointStates) -> JointStates:
    """Two sets of joint states as one, columns united (NaN where one lacks a joint), sorted by stamp (stable)."""
    names = first.names + tuple(n for n in then.names if n not in first.names)
    positions = np.full((len(first) + len(then), len(names)), np.nan)
    column = {name: k for k, name in enumerate(names)}
    positions[: len(first), [column[n] for n in first.names]] = first.positions
    positions[len(first):, [column[n] for n in then.names]] = then.positions
    time = np.concatenate([first.time_ns, then.time_ns])
    order = np.argsort(time, kind="stable")
    repeated = first.repeated + tuple(n for n in then.repeated if n not in first.repeated)
    return JointStates(time[order], names, positions[order], repeated)


LATE_NS = 5_000_000_000
"""How far back (ns) a piece's joint states are kept for the next piece at least: transforms the file holds after
later joint states (a writer that puts each topic's messages of a stretch one after the other) meet the joint
states around them; twice the lateness seen so far when more."""


def _last_known(joint_states: JointStates, fresh: JointStates | None, since: int | None = None,
                late_ns: int = LATE_NS) -> tuple[JointStates | None, int | None]:
    """(what the next piece needs of the joint states so far, the earliest stamp among the last ones of the joints
    given a position from ``since`` on — ``fresh``, the piece's own joint states, and the piece's before —: how
    far they interpolate; a joint no longer published holds nothing back, one that a message of a subset left out
    does).

    The next piece needs the joint states of the last ``late_ns`` — its transforms may be stamped among them, in a
    file not in time order — and before them each joint's last position; a piece without joint states of its own
    passes on what it was given."""
    known = np.isfinite(joint_states.positions)
    has = np.asarray(known.any(axis=0), dtype=bool)
    if not has.any():
        return None, None
    if fresh is None:
        return joint_states, None
    recent = int(np.searchsorted(joint_states.time_ns, int(joint_states.time_ns[-1]) - late_ns, side="left"))
    rows = np.arange(recent, len(known))
    if recent:
        earlier = known[:recent]
        before = np.asarray(earlier.any(axis=0), dtype=bool)
        rows = np.concatenate([np.unique((recent - 1 - np.argmax(earlier[::-1], axis=0))[before]), rows])
    carried = JointStates(joint_states.time_ns[rows], joint_states.names, joint_states.positions[rows],
                          joint_states.repeated)
    last = len(known) - 1 - np.argmax(known[::-1], axis=0)
    start = int(np.searchsorted(joint_states.time_ns, fresh.time_ns[0] if since is None else since, side="left"))
    moved = np.asarray(known[start:].any(axis=0), dtype=bool)
    stamps = joint_states.time_ns[last[has & moved]]
    return carried, int(stamps.min()) if len(stamps) else None


def _cut(series: FrameSeries, frontier: int | None) -> tuple[FrameSeries, FrameSeries | None]:
    """(the transforms up to ``frontier``, those after it: None when none)."""
    if frontier is None or not len(series) or series.time_ns[-1] <= frontier:
        return series, None
    k = int(np.searchsorted(series.time_ns, frontier, side="right"))
    return (FrameSeries(series.time_ns[:k], series.translation[:k], series.rotation[:k]),
            FrameSeries(series.time_ns[k:], series.translation[k:], series.rotation[k:]))


def _merged(first: FrameSeries | None, then: FrameSeries | None) -> FrameSeries | None:
    if first is None or not len(first):
        return then
    if then is None or not len(then):
        return first
    time = np.concatenate([first.time_ns, then.time_ns])
    order = np.argsort(time, kind="stable")
    return FrameSeries(time[order], np.concatenate([first.translation, then.translation])[order],
                       np.concatenate([first.rotation, then.rotation])[order])


HOLD_SAMPLES = 600_000
"""Transform samples held back, at most, while a robot's joint states pause (~40 MB): the pause's transforms wait
for the joint state after it, as the whole recording interpolates them; past this many (a pause of ~12 minutes of
8 frames at 100 Hz) they are compared with the joint states before the pause alone (those after its last one:
not compared, as the recording's end), with a warning."""


class _Joiner:
    """What passes from one piece to the next: each namespace's recent joint states, and transforms that wait."""

    def __init__(self) -> None:
        self.carried: dict[str, JointStates] = {}
        self.waiting: dict[str, dict[Pair, FrameSeries]] = {}
        self.frontier: dict[str, int] = {}  # namespace → how far its joint states interpolated, when last given
        self.seen: dict[str, int] = {}  # namespace → its joint states' messages so far
        self.recent: dict[str, int] = {}  # namespace → the first stamp of the last piece that had joint states
        self.overheld: set[str] = set()  # namespaces whose pause was longer than the hold (said once)
        self.late_ns = LATE_NS  # how far back joint states are kept for the next piece
        self.released: int | None = None  # how far the last piece compared transforms
        self.firsts: list[int] = []  # the first stamp of any series: the recording's start
        self.lasts: list[int] = []

    def saw(self, first: int, last: int) -> None:
        self.firsts = [min([first, *self.firsts])]
        self.lasts = [max([last, *self.lasts])]

    def join(self, piece: Recording, *, last: bool) -> tuple[Recording, dict[str, NDArray[np.int64]]]:
        names = sorted({*piece.namespaces, "", *self.carried, *self.waiting})
        self._see_lateness(piece, names)
        frontiers: list[int] = []
        own: dict[str, NDArray[np.int64]] = {}
        joint_states: dict[str, JointStates | None] = {}
        for ns in names:
            found = piece.robot_topics(ns).joint_states
            if found is not None and len(found):
                own[ns] = found.time_ns
                self.seen[ns] = self.seen.get(ns, 0) + len(found)
                self.saw(int(found.time_ns[0]), int(found.time_ns[-1]))
            else:
                found = None
            before = self.carried.pop(ns, None)
            js = found if before is None else before if found is None else _joined(before, found)
            joint_states[ns] = js
            since = None  # the joints given a position from here on hold transforms back
            if found is not None:
                first = int(found.time_ns[0])
                since, self.recent[ns] = min(self.recent.get(ns, first), first), first
            if js is not None and len(js):
                carried, frontier = _last_known(js, found, since, self.late_ns)
                if carried is not None:
                    self.carried[ns] = carried
                if frontier is not None:
                    self.frontier[ns] = frontier
                    frontiers.append(frontier)
                elif found is None and ns in self.frontier and self._paused(piece, ns):
                    frontiers.append(self.frontier[ns])
        frontier = None if last or not frontiers else min(frontiers)
        self.released = frontier
        tf: dict[str, dict[Pair, FrameSeries]] = {}
        for ns in names:
            waiting = self.waiting.pop(ns, {})
            series = dict(piece.robot_topics(ns).tf)
            for pair, s in series.items():
                if len(s):
                    self.saw(int(s.time_ns[0]), int(s.time_ns[-1]))
            out: dict[Pair, FrameSeries] = {}
            for pair in [*waiting, *(p for p in series if p not in waiting)]:
                both = _merged(waiting.get(pair), series.get(pair))
                if both is None:
                    continue
                now, later = _cut(both, frontier)
                out[pair] = now
                if later is not None:
                    self.waiting.setdefault(ns, {})[pair] = later
            tf[ns] = out
        return _rebuilt(piece, joint_states, tf), own

    def _see_lateness(self, piece: Recording, names: list[str]) -> None:
        """Keep joint states twice as far back as transforms came late (stamped before what the last piece
        compared)."""
        if self.released is None:
            return
        firsts = [int(s.time_ns[0]) for ns in names for s in piece.robot_topics(ns).tf.values() if len(s)]
        if firsts and min(firsts) < self.released:
            self.late_ns = max(self.late_ns, 2 * (self.released - min(firsts)))

    def _paused(self, piece: Recording, ns: str) -> bool:
        """Whether a namespace's joint states pause in this piece and come again later (the recording's topic table
        has more of them than were read; a table that does not tell: perhaps), and the transforms waiting for them
        are fewer than :data:`HOLD_SAMPLES`."""
        total = [info.count for topic, info in piece.topics.items() if robot_topic_kind(topic) == (ns, JOINT_STATES)]
        if total and self.seen.get(ns, 0) >= sum(total):
            return False
        if sum(len(s) for pairs in self.waiting.values() for s in pairs.values()) < HOLD_SAMPLES:
            return True
        if ns not in self.overheld:
            self.overheld.add(ns)
            topic = f"{ns}/{JOINT_STATES.lstrip('/')}"
            warnings.warn(f"{topic} pauses for longer than a check read piece by piece holds transforms "
                          f"({HOLD_SAMPLES:,}): those after its last message before the pause are not compared "
                          "(`replay --check --start 0` reads the recording whole)",
                          TfrecWarning, stacklevel=2)
        return False


def _rebuilt(piece: Recording, joint_states: dict[str, JointStates | None],
             tf: dict[str, dict[Pair, FrameSeries]]) -> Recording:
    """The piece with these joint states and transforms, namespace by namespace."""
    out = replace(piece, namespaces=dict(piece.namespaces))
    for ns, js in joint_states.items():
        if ns:
            if ns not in out.namespaces and js is None and not tf.get(ns):
                continue
            robot = out.namespaces.get(ns) or piece.robot_topics(ns)
            out.namespaces[ns] = replace(robot, joint_states=js, tf=tf.get(ns, {}))
        else:
            out.joint_states, out.tf = js, tf.get("", {})
    return out


def replay_pieces(
    path: str | os.PathLike[str],
    *,
    robot: Robot | None = None,
    topics: Collection[str] | None = None,
    need_robot: bool = False,
    namespace: str | None = None,
    remap: Iterable[str] | Mapping[str, str] | None = None,
    use_log_time: bool = False,
    messages: int | None = None,
) -> Iterator[ReplayPiece]:
    """A recording prepared for replaying piece by piece (:func:`tfrec.replay.load_replay`'s arguments, without a
    time window), in memory that does not grow with its length; each warning is given once.

    Raises:
        as :func:`tfrec.replay.load_replay`, from the first piece.
    """
    selected = _check_topics(topics)
    where = os.fspath(path)
    joiner = _Joiner()
    parsed = ParsedDescriptions()  # every piece has the recording's descriptions
    said: dict[tuple[type[Warning], str], tuple[warnings.WarningMessage, int]] = {}  # → (first, how many pieces)
    pieces = read_pieces(path, topics=_read_topics(selected, robot), namespace=namespace, remap=remap,
                         use_log_time=use_log_time, messages=messages)
    for count, (piece, last) in enumerate(pieces, start=1):
        joined, own = joiner.join(piece, last=last)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            failed: TfrecError | None = None
            try:
                replay = _prepare_recording(joined, where, selected, robot=robot, given=topics is not None,
                                            window=(None, None), need_robot=need_robot, namespace=namespace,
                                            parsed=parsed)
            except TfrecError as err:
                failed = err
        firsts: dict[tuple[type[Warning], str], warnings.WarningMessage] = {}
        for warning in caught:
            firsts.setdefault((warning.category, str(warning.message)), warning)
        for key, warning in firsts.items():
            said[key] = (said[key][0], said[key][1] + 1) if key in said else (warning, 1)
        if failed is not None:
            _say(said, count)
            raise failed
        if last:
            _say(said, count)
            origin = start_of(joiner.firsts, joined)
            replay = replace(replay, origin_ns=replay.origin_ns if origin is None else origin,
                             start_ns=min(joiner.firsts, default=None), end_ns=max(joiner.lasts, default=None))
        yield ReplayPiece(replay, own, last)


def _say(said: dict[tuple[type[Warning], str], tuple[warnings.WarningMessage, int]], pieces: int) -> None:
    """The warnings the pieces gave, once each: what a piece has (a TF cycle, an unusable description) as soon as one
    piece says it; what the recording lacks (:class:`~tfrec.errors.LackingWarning`: a joint never published)
    only when every piece says it — what only some pieces lack (a joint's transforms all in the next piece) is not
    the recording's."""
    for warning, count in said.values():
        if count == pieces or not issubclass(warning.category, LackingWarning):
            warnings.warn(str(warning.message), warning.category, stacklevel=3)
