"""``tfrec serve``: a robot, or a recording, served live — to Foxglove (:class:`tfrec.live.server.FoxgloveServer`),
and to any :class:`~tfrec.formats.RecordSink` besides (``--record``'s files, a Rerun viewer).

Three sources of samples, paced in real time (:class:`tfrec.replay.pacing.Pacer`):

- a trajectory (``--traj``, as ``record`` makes it), played once or in a loop (each pass after the previous one on
  the clock);
- the joints clients move (no trajectory): one sample per tick at ``rate_hz`` from
  :class:`tfrec.live.joints.JointControl`, until stopped or ``duration_s``;
- a recording (:func:`serve_recording`): what ``tfrec replay`` plays (:func:`tfrec.replay.play.play`).

Samples are stamped ``start_time_ns`` (default: the wall clock when serving starts) plus their time; each message is
logged with the wall clock when it is sent, so a client sees how late the loop is. A loop that falls behind sends the
late samples at once and keeps its clock; nothing waits for a client. Ctrl-C (or SIGTERM) ends serving as its normal
end: the files of ``--record`` keep what was served.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, NS_PER_S, TF
from tfrec.errors import TfrecWarning
from tfrec.formats.sink import RecordSink
from tfrec.kinematics.fk import DynamicChunk, iter_dynamic_chunks
from tfrec.live.joints import JointControl
from tfrec.live.server import FoxgloveServer
from tfrec.model import Robot
from tfrec.recording import Transforms
from tfrec.replay.pacing import BATCH_WALL_S, MonotonicClock, Pacer
from tfrec.replay.play import ReplaySink, play
from tfrec.replay.prepared import Replay
from tfrec.trajectory.types import JointTrajectory

__all__ = ["DEFAULT_RATE_HZ", "FoxgloveReplaySink", "ServeOptions", "ServeResult", "is_recording", "reach_poses",
           "serve_recording", "serve_robot", "take_chunk"]

DEFAULT_RATE_HZ = 50.0
"""Samples per second of the joints clients move (joint_state_publisher's default rate)."""

RECORD_FLUSH_SAMPLES = 256
"""Served samples gathered before they go to the other sinks (``--record``, Rerun) together."""

RECORDING_SUFFIXES = (".mcap", ".bag", ".db3", ".rrd")

Array = NDArray[np.float64]


def is_recording(path: str) -> bool:
    """Whether ``tfrec serve PATH`` plays a recording (an ``.mcap``, ``.bag``, ``.db3``, ``.rrd`` or a folder)
    rather than a robot description."""
    return Path(path).suffix.lower() in RECORDING_SUFFIXES or Path(path).is_dir()


@dataclass(frozen=True, slots=True)
class ServeOptions:
    """How to serve.

    Attributes:
        rate_hz: samples per second of the joints clients move (a trajectory has its own clock).
        loop: play the trajectory again after its end, until stopped.
        duration_s: stop after this many seconds of samples (None: at the trajectory's end, or never).
        start_time_ns: the stamp of the first sample; None: the wall clock when serving starts.
        frame_prefix: put in front of every TF frame id.
    """

    rate_hz: float = DEFAULT_RATE_HZ
    loop: bool = False
    duration_s: float | None = None
    start_time_ns: int | None = None
    frame_prefix: str = ""


@dataclass(frozen=True, slots=True)
class ServeResult:
    """What was served: samples, passes over a trajectory, samples sent late (the loop behind by more than a
    period), and whether it was stopped (Ctrl-C, SIGTERM)."""

    samples: int
    passes: int
    late: int
    interrupted: bool
    start_time_ns: int


def _trajectory_chunks(robot: Robot, trajectory: JointTrajectory, options: ServeOptions,
                       passes: list[int]) -> Iterator[DynamicChunk]:
    """The trajectory's samples, times from 0, once or (``loop``) forever; ``passes[0]`` counts the passes."""
    times = trajectory.time_ns
    steps = np.diff(times)
    period = int(np.median(steps)) if len(steps) else round(NS_PER_S / options.rate_hz)
    pass_ns = int(times[-1]) + period if len(times) else period
    chunk = max(1, round(len(times) / max(1.0, (int(times[-1]) if len(times) else 0) / NS_PER_S) / 10))
    while True:
        shift = passes[0] * pass_ns
        for piece in iter_dynamic_chunks(robot, trajectory, chunk_samples=chunk, frame_prefix=options.frame_prefix):
            yield piece._replace(time_ns=piece.time_ns + shift)
        passes[0] += 1
        if not options.loop or not len(times):
            return


def _control_chunks(robot: Robot, control: JointControl, options: ServeOptions) -> Iterator[DynamicChunk]:
    """One sample per tick from the joints clients move, forever."""
    names = control.names
    zeros = np.zeros((1, len(names)))
    tick = 0
    while True:
        time_ns = np.array([round(tick * NS_PER_S / options.rate_hz)], dtype=np.int64)
        sample = JointTrajectory(names, time_ns, control.positions()[np.newaxis, :], zeros)
        yield from iter_dynamic_chunks(robot, sample, chunk_samples=1, frame_prefix=options.frame_prefix)
        tick += 1


REACH_SAMPLES = 64
"""Poses a live viewer's camera is fitted to (:func:`reach_poses`)."""


def reach_poses(robot: Robot, *, trajectory: JointTrajectory | None, control: JointControl | None,
                frame_prefix: str = "", seed: int = 0) -> Transforms:
    """The dynamic transforms of poses the robot will take, for a live viewer's camera: :data:`REACH_SAMPLES`
    samples of the trajectory, or (joints moved by clients) the center and random poses within the joints'
    ranges."""
    if trajectory is not None:
        picked = np.unique(np.linspace(0, max(len(trajectory) - 1, 0), REACH_SAMPLES).astype(np.int64))
        names, positions = trajectory.joint_names, trajectory.positions[picked]
    elif control is not None:
        rng = np.random.default_rng(seed)
        names = control.names
        middle, half = control.lower / 2.0 + control.upper / 2.0, control.upper / 2.0 - control.lower / 2.0
        positions = np.vstack([control.positions()[np.newaxis, :],
                               middle + half * rng.uniform(-1.0, 1.0, size=(REACH_SAMPLES - 1, len(names)))])
    else:
        raise ValueError("reach_poses: no trajectory and no joint control")
    samples = JointTrajectory(names, np.arange(len(positions), dtype=np.int64), positions, np.zeros_like(positions))
    chunk = next(iter_dynamic_chunks(robot, samples, chunk_samples=len(positions), frame_prefix=frame_prefix))
    return chunk.transforms


def take_chunk(chunk: DynamicChunk, stop: int) -> DynamicChunk:
    """The first ``stop`` samples of a chunk."""
    t = chunk.transforms
    return DynamicChunk(chunk.time_ns[:stop], chunk.names, chunk.positions[:stop], chunk.velocities[:stop],
                        Transforms(t.parents, t.children, t.translation[:stop], t.rotation[:stop]))


class _Forward:
    """Served samples gathered and handed to other sinks every ``samples`` (default :data:`RECORD_FLUSH_SAMPLES`)."""

    def __init__(self, sinks: Sequence[RecordSink], start_time_ns: int, samples: int = RECORD_FLUSH_SAMPLES) -> None:
        self._sinks = sinks
        self._start = start_time_ns
        self._samples = max(1, samples)
        self._pending: list[DynamicChunk] = []
        self._count = 0

    def add(self, chunk: DynamicChunk) -> None:
        if not self._sinks or not len(chunk.time_ns):
            return
        self._pending.append(chunk)
        self._count += len(chunk.time_ns)
        if self._count >= self._samples:
            self.flush()

    def flush(self) -> None:
        if not self._pending:
            return
        pending, self._pending, self._count = self._pending, [], 0
        first = pending[0].transforms
        transforms = Transforms(first.parents, first.children,
                                np.concatenate([c.transforms.translation for c in pending]),
                                np.concatenate([c.transforms.rotation for c in pending]))
        stamps = np.concatenate([c.time_ns for c in pending]) + self._start
        for sink in self._sinks:
            sink.write_chunk(stamp_ns=stamps, joint_names=pending[0].names,
                             positions=np.concatenate([c.positions for c in pending]),
                             velocities=np.concatenate([c.velocities for c in pending]), transforms=transforms)


def serve_robot(
    robot: Robot,
    server: FoxgloveServer,
    *,
    trajectory: JointTrajectory | None,
    options: ServeOptions,
    sinks: Sequence[RecordSink] = (),
    live_sinks: Sequence[RecordSink] = (),
    clock: Callable[[], int] = time.time_ns,
) -> ServeResult:
    """Serve ``robot`` moved by ``trajectory``, or (None) by the clients through ``server.control``.

    ``sinks`` are begun already (:func:`tfrec.recorder.open_sinks`); they get every sample served, in order, in
    chunks of :data:`RECORD_FLUSH_SAMPLES`. ``live_sinks`` (begun too: a Rerun viewer) get them at the pace they are
    served, :data:`tfrec.replay.pacing.BATCH_WALL_S` at a time. The caller finishes them (and stops the server).

    Returns:
        What was served; Ctrl-C or SIGTERM ends serving without an error (``interrupted``).
    """
    from tfrec.kinematics.fk import static_transforms

    start_ns = clock() if options.start_time_ns is None else options.start_time_ns
    server.publish_latched(robot_description=robot.urdf,
                           static=static_transforms(robot, frame_prefix=options.frame_prefix), start_time_ns=start_ns)
    passes = [0]
    period_ns = round(NS_PER_S / options.rate_hz)
    if trajectory is not None:
        chunks = _trajectory_chunks(robot, trajectory, options, passes)
        if len(trajectory) > 1:
            period_ns = int(np.median(np.diff(trajectory.time_ns)))
    elif server.control is not None:
        chunks = _control_chunks(robot, server.control, options)
    else:
        raise ValueError("serve_robot: no trajectory and no joint control")
    end_ns = None if options.duration_s is None else round(options.duration_s * NS_PER_S)
    forwards = [_Forward(sinks, start_ns),
                _Forward(live_sinks, start_ns, round(BATCH_WALL_S * NS_PER_S / max(period_ns, 1)))]
    loop = _Loop(server, forwards, period_ns, end_ns, clock)
    interrupted = False
    try:
        for chunk in chunks:
            if not loop.send(chunk, start_ns):
                break
    except KeyboardInterrupt:
        interrupted = True
    for forward in forwards:
        forward.flush()
    return ServeResult(loop.served, max(passes[0], 1), loop.late, interrupted, start_ns)


class _Loop:
    """Sends samples when they are due; counts them and the late ones."""

    def __init__(self, server: FoxgloveServer, forwards: Sequence[_Forward], period_ns: int, end_ns: int | None,
                 clock: Callable[[], int]) -> None:
        self.server = server
        self.forwards = forwards
        self.pacer = Pacer(MonotonicClock())
        self.period_s = period_ns / NS_PER_S
        self.end_ns = end_ns
        self.clock = clock
        self.served = self.late = 0

    def send(self, chunk: DynamicChunk, start_ns: int) -> bool:
        """Send the chunk's samples, each when due; False when ``end_ns`` is reached. The samples sent go to
        the other sinks, also when interrupted."""
        joint_states, tf = self.server.encode(stamp_ns=chunk.time_ns + start_ns, joint_names=chunk.names,
                                              positions=chunk.positions, velocities=chunk.velocities,
                                              transforms=chunk.transforms)
        done = 0
        try:
            for offset in chunk.time_ns.tolist():
                if self.end_ns is not None and offset > self.end_ns:
                    return False
                self.pacer.wait(offset)
                if self.served and self.pacer.lag_s(offset) > self.period_s:
                    self.late += 1
                now = self.clock()
                self.server.service_requests(now)
                self.server.log_sample(joint_states[done].tobytes(), None if tf is None else tf[done].tobytes(), now)
                self.served += 1
                done += 1
                _warn(self.server.take_notes())
        finally:
            sent = chunk if done == len(chunk.time_ns) else take_chunk(chunk, done)
            for forward in self.forwards:
                forward.add(sent)
        return True


def _warn(notes: list[str]) -> None:
    for note in notes:
        warnings.warn(note, TfrecWarning, stacklevel=2)


class FoxgloveReplaySink:
    """A replay (:func:`tfrec.replay.play.play`) sent to a :class:`FoxgloveServer`: a
    :class:`tfrec.replay.play.ReplaySink` of the first robot of a recording (the others are left out), each message
    logged with the wall clock when it is sent."""

    def __init__(self, server: FoxgloveServer, *, clock: Callable[[], int] = time.time_ns) -> None:
        self._server = server
        self._clock = clock
        self.messages = 0

    def begin(self, *, start_time_ns: int, name: str, robot_description: str | None,
              static: dict[tuple[str, str], tuple[Array, Array]], frames: Sequence[str], root: str | None,
              poses: dict[tuple[str, str], tuple[Array, Array]], robot: int = 0) -> None:
        if robot:
            return
        self._server.publish_latched(robot_description=robot_description or "",
                                     static=Transforms.from_poses(static), start_time_ns=start_time_ns)

    def write_transforms(self, parent: str, child: str, time_ns: NDArray[np.int64], translation: Array,
                         rotation: Array, *, robot: int = 0) -> None:
        if robot or not len(time_ns):
            return
        transforms = Transforms((parent,), (child,), translation[:, np.newaxis, :], rotation[:, np.newaxis, :])
        _, tf = self._server.encode(stamp_ns=time_ns, joint_names=(), positions=np.zeros((len(time_ns), 0)),
                                    velocities=np.zeros((len(time_ns), 0)), transforms=transforms)
        assert tf is not None
        self._send(TF, tf)

    def write_joint_positions(self, time_ns: NDArray[np.int64], names: Sequence[str], positions: Array, *,
                              robot: int = 0) -> None:
        if robot or not len(time_ns):
            return
        rows, _ = self._server.encode(stamp_ns=time_ns, joint_names=names, positions=positions,
                                      velocities=np.zeros_like(positions), transforms=_no_transforms(len(time_ns)))
        self._send(JOINT_STATES, rows)

    def _send(self, topic: str, rows: NDArray[np.uint8]) -> None:
        now = self._clock()
        self._server.service_requests(now)
        for row in rows:
            self._server.log(topic, row.tobytes(), now)
        self.messages += len(rows)
        _warn(self._server.take_notes())

    def finish(self) -> None:
        pass

    def abort(self) -> None:
        pass


def _no_transforms(n: int) -> Transforms:
    return Transforms((), (), np.zeros((n, 0, 3)), np.zeros((n, 0, 4)))


def serve_recording(replay: Replay, server: FoxgloveServer, *, rate: float = 1.0, loop: bool = False,
                    also: ReplaySink | None = None, clock: Callable[[], int] = time.time_ns) -> ServeResult:
    """Play a recording (:func:`tfrec.replay.load.load_replay`) to ``server`` at ``rate`` times real time, once or
    (``loop``) until stopped: what ``tfrec replay`` plays into Rerun (its first robot); to ``also`` too (a Rerun
    viewer, :func:`tfrec.viewer.spawn.open_rerun_sink`), which is finished at the end.

    Returns:
        What was served (``samples``: messages); Ctrl-C or SIGTERM ends serving without an error.
    """
    sink = FoxgloveReplaySink(server, clock=clock)
    try:
        result = play(replay, sink if also is None else _Tee(sink, also), pacer=Pacer(MonotonicClock(), rate=rate),
                      loop=loop)
    except KeyboardInterrupt:
        return ServeResult(sink.messages, 1, 0, True, replay.origin_ns)
    return ServeResult(sink.messages, result.passes, 0, False, replay.origin_ns)


class _Tee:
    """Two replay sinks as one (:class:`tfrec.replay.play.ReplaySink`)."""

    def __init__(self, *sinks: ReplaySink) -> None:
        self._sinks = sinks

    def begin(self, **kwargs: Any) -> None:
        for sink in self._sinks:
            sink.begin(**kwargs)

    def write_transforms(self, parent: str, child: str, time_ns: NDArray[np.int64], translation: Array,
                         rotation: Array, *, robot: int = 0) -> None:
        for sink in self._sinks:
            sink.write_transforms(parent, child, time_ns, translation, rotation, robot=robot)

    def write_joint_positions(self, time_ns: NDArray[np.int64], names: Sequence[str], positions: Array, *,
                              robot: int = 0) -> None:
        for sink in self._sinks:
            sink.write_joint_positions(time_ns, names, positions, robot=robot)

    def finish(self) -> None:
        for sink in self._sinks:
            sink.finish()

    def abort(self) -> None:
        for sink in self._sinks:
            sink.abort()
