"""Playing a prepared replay (:func:`tfrec.replay.load_replay`) into a sink, paced for live viewers.

:func:`play` sends latched data first, then the samples in time-ordered batches (a
:class:`tfrec.replay.pacing.Pacer` sleeps until each is due); :func:`replay_to_rerun` does it into a
spawned Rerun viewer, a running one, or an ``.rrd`` file (no pacing, written atomically).
"""

from __future__ import annotations

import hashlib
import math
import os
import uuid
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from tfrec._address_space import check_rerun_address_space
from tfrec._atomic import AtomicOutputs
from tfrec._outputs import check_target
from tfrec.errors import ReplayError, printable
from tfrec.formats.kinds import RRD
from tfrec.recording import FrameSeries, JointStates, RecordedRobot
from tfrec.replay.pacing import BATCH_WALL_S, Clock, MonotonicClock, Pacer, batches
from tfrec.replay.prepared import Replay

__all__ = ["PlayResult", "ReplaySink", "check_play_options", "play", "replay_to_rerun", "sample_poses"]

Array = NDArray[np.float64]
Pair = tuple[str, str]

# -- playing ------------------------------------------------------------------------------------


class ReplaySink(Protocol):
    """Where a replay goes (:class:`tfrec.viewer.spawn.RerunReplaySink`, or a test double).

    ``begin`` is called once per robot of the replay (``robot``: its index, in order); the samples
    of each robot go with its index.
    """

    def begin(self, *, start_time_ns: int, name: str, robot_description: str | None,
              static: dict[Pair, tuple[Array, Array]], frames: Sequence[str], root: str | None,
              poses: dict[Pair, tuple[Array, Array]], robot: int = 0) -> None: ...

    def write_transforms(self, parent: str, child: str, time_ns: NDArray[np.int64], translation: Array,
                         rotation: Array, *, robot: int = 0) -> None: ...

    def write_joint_positions(self, time_ns: NDArray[np.int64], names: Sequence[str], positions: Array, *,
                              robot: int = 0) -> None: ...

    def finish(self) -> None: ...

    def abort(self) -> None: ...


@dataclass(frozen=True, slots=True)
class PlayResult:
    """What :func:`play` did: passes over the recording, batches sent, and seconds slept."""

    passes: int
    batches: int
    slept_s: float


def _pass_length_ns(replay: Replay, span_ns: int) -> int:
    """The time between the starts of two passes of a loop: the replayed span plus one sample period."""
    assert replay.start_ns is not None and replay.end_ns is not None
    stamps = [s.time_ns for robot in replay.robots for s in robot.tf.values()]
    stamps += [robot.joint_states.time_ns for robot in replay.robots if robot.joint_states is not None]
    steps = np.concatenate([np.diff(s) for s in stamps if len(s) > 1] or [np.zeros(0, dtype=np.int64)])
    steps = steps[steps > 0]
    period = int(np.median(steps)) if len(steps) else span_ns
    return replay.end_ns - replay.start_ns + period


def play(
    replay: Replay,
    sink: ReplaySink,
    *,
    pacer: Pacer | None = None,
    loop: bool = False,
    max_loops: int | None = None,
    span_ns: int | None = None,
) -> PlayResult:
    """Send a replay to a sink: latched data first, then the samples in time-ordered batches.

    Args:
        replay: from :func:`load_replay`.
        sink: where to send it; finished on success, aborted on any error or interrupt.
        pacer: sleep until each batch is due (live viewers); None sends everything at once.
        loop: start again after the end, forever (or ``max_loops`` passes); each pass is logged
            after the previous one on the timeline, so a viewer following the newest time plays
            it again.
        max_loops: the number of passes of a loop (for tests); None for no limit.
        span_ns: recording time per batch; default :data:`tfrec.replay.pacing.BATCH_WALL_S` at the
            pacer's rate, or everything in one batch without a pacer.

    Returns:
        Passes made, batches sent and seconds slept.
    """
    _check_loop(loop, live=pacer is not None)
    if span_ns is None:
        span_ns = round(BATCH_WALL_S * pacer.rate * 1e9) if pacer is not None else 1 << 62
    span_ns = max(span_ns, 1)
    robots = [robot.displayed() for robot in replay.robots]
    named = next((robot.model for robot in robots if robot.model is not None), None)
    name = named.name if named is not None and len(robots) == 1 else printable(Path(replay.path).name)
    passes = sent = 0
    slept = 0.0
    try:
        for index, robot in enumerate(robots):
            sink.begin(start_time_ns=replay.start_ns if replay.start_ns is not None else replay.origin_ns,
                       name=name, robot_description=robot.robot_description, static=robot.tf_static,
                       frames=robot.frames(), root=robot.root_frame(), robot=index,
                       poses=sample_poses(replay, robot=robot))
        streams = [_Streams(index, robot) for index, robot in enumerate(robots)]
        if replay.start_ns is None:
            sink.finish()
            replay.report_damage()
            return PlayResult(1, 0, 0.0)
        stamps = [time_ns for stream in streams for time_ns in stream.stamps()]
        windows = batches(stamps, start_ns=replay.start_ns, span_ns=span_ns)
        edges = np.array([w.start_ns for w in windows] + [windows[-1].stop_ns], dtype=np.int64)
        for stream in streams:
            stream.index(edges)
        pass_ns = _pass_length_ns(replay, span_ns) if loop else 0
        while True:
            shift = passes * pass_ns
            for k, window in enumerate(windows):
                if pacer is not None:
                    slept += pacer.wait(shift + window.first_ns - replay.start_ns)
                for stream in streams:
                    stream.send(sink, k, shift)
                sent += 1
            passes += 1
            replay.report_damage()
            if not loop or (max_loops is not None and passes >= max_loops):
                break
        sink.finish()
    except BaseException:
        sink.abort()
        raise
    return PlayResult(passes, sent, slept)


REACH_SAMPLES = 64
"""Instants of a replay at which the camera's framing of the robot is computed."""


def sample_poses(replay: Replay, count: int = REACH_SAMPLES, *,
                 robot: RecordedRobot | None = None) -> dict[Pair, tuple[Array, Array]]:
    """Each /tf pair's transform (of ``robot``, default the first) at ``count`` instants spread evenly
    over the replay (its latest sample at or before each; its first before it starts): (translations
    (K, 3), rotations (K, 4))."""
    tf = (robot or replay.robots[0]).tf
    series = {pair: s for pair, s in tf.items() if len(s)}
    if not series or replay.start_ns is None or replay.end_ns is None:
        return {}
    instants = np.linspace(replay.start_ns, replay.end_ns, count).astype(np.int64)
    out = {}
    for pair, s in series.items():
        index = np.clip(np.searchsorted(s.time_ns, instants, side="right") - 1, 0, len(s) - 1)
        out[pair] = (s.translation[index], s.rotation[index])
    return out


def _check_loop(loop: bool, *, live: bool) -> None:
    """A loop plays forever, so only into a live viewer (paced), never into a file."""
    if loop and not live:
        raise ReplayError("`loop` replays forever; it needs a live viewer, not `save`")


class _Streams:
    """One robot's time series, cut into the batches of :func:`play`."""

    def __init__(self, index: int, robot: RecordedRobot) -> None:
        self.robot = index
        self.series: list[tuple[Pair, FrameSeries]] = [(pair, s) for pair, s in robot.tf.items() if len(s)]
        joints = robot.joint_states
        self.joints: JointStates | None = joints if joints is not None and len(joints) else None
        self.tf_index: list[NDArray[np.intp]] = []
        self.joint_index: NDArray[np.intp] | None = None

    def stamps(self) -> list[NDArray[np.int64]]:
        return [s.time_ns for _, s in self.series] + ([self.joints.time_ns] if self.joints is not None else [])

    def index(self, edges: NDArray[np.int64]) -> None:
        self.tf_index = [np.searchsorted(s.time_ns, edges) for _, s in self.series]
        self.joint_index = np.searchsorted(self.joints.time_ns, edges) if self.joints is not None else None

    def send(self, sink: ReplaySink, k: int, shift: int) -> None:
        """Send batch ``k`` (its stamps moved by ``shift``, for a loop's later passes)."""
        for ((parent, child), s), index in zip(self.series, self.tf_index):
            a, b = index[k], index[k + 1]
            if b > a:
                sink.write_transforms(parent, child, s.time_ns[a:b] + shift, s.translation[a:b], s.rotation[a:b],
                                      robot=self.robot)
        joints = self.joints
        if joints is not None and self.joint_index is not None:
            a, b = self.joint_index[k], self.joint_index[k + 1]
            if b > a:
                sink.write_joint_positions(joints.time_ns[a:b] + shift, joints.names, joints.positions[a:b],
                                           robot=self.robot)


# -- into Rerun ---------------------------------------------------------------------------------


def _recording_id(replay: Replay) -> str:
    """The same replay of the same file gives the same id (and the same .rrd)."""
    digest = hashlib.sha256()
    digest.update(os.fsencode(os.path.abspath(replay.path)))  # a name that is not UTF-8 too
    for robot in replay.robots:
        key = f"{robot.key}|" if len(replay.robots) > 1 else ""
        digest.update(f"{key}|{replay.start_ns}|{replay.end_ns}|{sorted(robot.tf)}|"
                      f"{robot.robot_description is None}".encode())
        if robot.model is not None:
            digest.update(robot.model.urdf.encode())
    return str(uuid.UUID(bytes=digest.digest()[:16], version=5))


def check_play_options(
    *, save: str | os.PathLike[str] | None, connect: str | None, rate: float, loop: bool, force: bool,
    inputs: Sequence[str | os.PathLike[str] | None] = (),
) -> None:
    """Check the options of :func:`replay_to_rerun` before anything is read or written.

    Args:
        inputs: what the replay reads (the recording, a description): never the ``save`` file.

    Raises:
        ReplayError: a rate that is not > 0, --save with --connect or --loop, no viewer at the --connect URL,
            or no viewer to spawn (no display or no ``rerun`` executable).
        WriteError: a --save name that is not ``.rrd``, a --save file that exists (without ``force``; a
            folder, a link or a file that is no Rerun recording in any case), or an input.
    """
    if not (math.isfinite(rate) and rate > 0):
        raise ReplayError(f"`rate` {rate:g} is not a speed > 0")
    if save is not None and connect is not None:
        raise ReplayError("`save` and `connect` exclude each other")
    _check_loop(loop, live=save is None)
    if save is None:
        from tfrec.viewer.spawn import check_can_connect, check_can_spawn

        if connect is None:
            check_can_spawn()
        else:
            check_can_connect(connect)
        return
    check_target(Path(save), RRD, force=force, inputs=inputs)
    check_rerun_address_space(os.fspath(save))


def replay_to_rerun(
    replay: Replay,
    *,
    save: str | os.PathLike[str] | None = None,
    connect: str | None = None,
    rate: float = 1.0,
    loop: bool = False,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    clock: Clock | None = None,
    max_loops: int | None = None,
    force: bool = False,
    checked: bool = False,
) -> PlayResult:
    """Play a replay into Rerun: a spawned viewer (default), a running one, or an ``.rrd`` file.

    Args:
        replay: from :func:`load_replay`.
        save: write this ``.rrd`` file instead, as fast as possible (written to a temporary file
            beside it and renamed when complete).
        connect: stream to the viewer (or server) at this URL, ``rerun+http://host:port/proxy``.
        rate: playback speed of a live replay (2 = twice as fast).
        loop: start again after the end (live only), until interrupted or ``max_loops``.
        package_paths: folders searched first for ``package://`` meshes.
        clock: the clock a live replay is paced by (default: the wall clock).
        max_loops: passes of a loop (for tests).
        force: overwrite an existing ``save`` file.
        checked: the options were checked with :func:`check_play_options` already (before the
            recording was read, as the CLI does), so the viewer is not probed a second time.

    Raises:
        ReplayError: bad options, an output that exists, no viewer to spawn or reach, or a
            file that cannot be written.
    """
    from tfrec.viewer.spawn import open_rerun_sink

    if not checked:
        check_play_options(save=save, connect=connect, rate=rate, loop=loop, force=force, inputs=[replay.path])
    shown = [robot.displayed() for robot in replay.robots]
    robots = [(robot.model, robot.frame_prefix, robot.entity_root) for robot in shown]
    names = [robot.key for robot in shown] if len(shown) > 1 else []
    prefixes = [robot.display_prefix for robot in replay.robots]
    if save is None:
        sink = open_rerun_sink(connect=connect, robots=robots, names=names, package_paths=package_paths,
                               display_prefixes=prefixes)
        return play(replay, sink, pacer=Pacer(clock or MonotonicClock(), rate=rate), loop=loop, max_loops=max_loops)
    with AtomicOutputs(replace=force) as outputs:
        sink = open_rerun_sink(save=outputs.path(Path(save), kind=RRD), recording_id=_recording_id(replay), robots=robots,
                               names=names, package_paths=package_paths, display_prefixes=prefixes)
        result = play(replay, sink)  # aborts the sink (closing its file) on any error
        outputs.commit()
    return result
