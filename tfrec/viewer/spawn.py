"""Replaying into Rerun: a spawned viewer, a running one (``--connect``), or an ``.rrd`` file.

A replay is logged through :class:`tfrec.viewer.sink.RerunSink`, the sink ``tfrec record`` writes
with, so a replayed recording looks like a recorded one: the robot's geometry under
``/robot/<link>``, a transform pair whose child frame is a link of the robot at ``/tf/<joint>``
(``/tf_static/<joint>`` when latched), joint positions at ``/joints/<joint>``, the same
blueprint with the camera framing the robot's reach over the replay. What the robot model does not
name keeps its own entities, so nothing recorded is dropped:

================================  =========================================================
``/tf/<parent>/<child>``          ``Transform3D`` of a pair on /tf whose child is no link
``/tf_static/<parent>/<child>``   the same for /tf_static
``/robot/<frame>``                ``CoordinateFrame`` + ``TransformAxes3D`` of such a frame
================================  =========================================================

A recording of several robots (namespaces, or several descriptions on one topic) is replayed
into one Rerun recording, each robot under its own entity prefix (``/robot1/robot/<link>``,
``/robot1/tf/<joint>``…), each in a tab of the layout.

:class:`RerunReplaySink` adapts the sink to :class:`tfrec.replay.play.ReplaySink`;
:func:`open_rerun_sink` points it at its target.
"""

from __future__ import annotations

import os
import shutil
import socket
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import rerun as rr
from numpy.typing import NDArray

from tfrec.errors import WriteError
from tfrec.formats.rrd.paths import APPLICATION_ID
from tfrec.model import Robot
from tfrec.recording import Transforms
from tfrec.viewer.blueprint import blueprint_of
from tfrec.viewer.sink import RerunSink

__all__ = [
    "RerunReplaySink", "check_can_connect", "check_can_spawn", "open_live_rerun_sink", "open_rerun_sink",
    "open_stdout_sink", "wait_for_viewer",
]

_SCHEMES = ("rerun", "rerun+http", "rerun+https")
"""The URL schemes of a Rerun viewer's gRPC endpoint."""
CONNECT_TIMEOUT_S = 3.0
"""How long :func:`check_can_connect` waits for the viewer to accept a connection."""

Array = NDArray[np.float64]
Pair = tuple[str, str]


class RerunReplaySink:
    """Logs a recording being replayed to one Rerun target, through one :class:`RerunSink` per robot.

    Make one with :func:`open_rerun_sink`; call :meth:`begin` once per robot (in order),
    :meth:`write_transforms` and :meth:`write_joint_positions` for each batch, then
    :meth:`finish` (or :meth:`abort` after an error).

    Args:
        sinks: the Rerun sinks, one per robot, all on one recording stream (the first one's).
        names: each robot's name in the layout's tabs (when there are several).
        live: True for a viewer: the static data is flushed at once, to fail early.
    """

    def __init__(self, sinks: Sequence[RerunSink], *, names: Sequence[str] = (), live: bool,
                 display_prefixes: Sequence[str] = ()) -> None:
        self._sinks = list(sinks)
        self._names = list(names) or [""] * len(self._sinks)
        self._live = live
        self._display_prefixes = list(display_prefixes) or [""] * len(self._sinks)

    def begin(
        self,
        *,
        start_time_ns: int,
        name: str,
        robot_description: str | None,
        static: Mapping[Pair, tuple[Array, Array]],
        frames: Sequence[str] = (),
        root: str | None = None,
        poses: Mapping[Pair, tuple[Array, Array]] | None = None,
        robot: int = 0,
    ) -> None:
        """Log what does not change of one robot: geometry, frames, latched transforms, the URDF; after the
        last robot, the blueprint (one tab per robot when there are several).

        Args:
            start_time_ns: the stamp the replay starts at.
            name: the recording's name in the viewer.
            robot_description: the URDF text for ``robot_description``, or None.
            static: /tf_static, (parent, child) → (translation (3,), rotation (4,)).
            frames: every frame id of the robot; those that are not links get TF axes.
            root: the frame the 3D view is drawn in when there is no robot model.
            poses: each /tf pair's transforms at K instants spread over the replay, (parent,
                child) → (translations (K, 3), rotations (K, 4)); the 3D view's camera frames the
                robot's reach over them.
            robot: which robot (the order of :func:`open_rerun_sink`'s ``robots``).

        Raises:
            WriteError: a live viewer cannot be reached.
        """
        sink = self._sinks[robot]
        sink.begin(static=Transforms.from_poses(static), start_time_ns=start_time_ns,
                   robot_description=robot_description, name=name, root=root, properties=robot == 0)
        if self._display_prefixes[robot]:
            sink.log_display_prefix(self._display_prefixes[robot])
        sink.log_frames([*frames, *(frame for pair in static for frame in pair)])
        latched = {child for _, child in static}
        moving = {pair: pose for pair, pose in (poses or {}).items() if pair[1] not in latched}
        if moving:
            sink.fit_camera(Transforms(tuple(p for p, _ in moving), tuple(c for _, c in moving),
                                       np.stack([t for t, _ in moving.values()], axis=1),
                                       np.stack([r for _, r in moving.values()], axis=1)))
        if robot == len(self._sinks) - 1:  # the first sink sends and finishes for all: they share a stream
            layouts = [s.layout(name or None) for s, name in zip(self._sinks, self._names)]
            self._sinks[0].send_blueprint(blueprint_of(*layouts) if len(layouts) > 1 else None)
            if self._live:
                sink.flush()

    @property
    def sinks(self) -> list[RerunSink]:
        """The Rerun sinks, one per robot (each a :class:`tfrec.formats.RecordSink`)."""
        return self._sinks

    def write_transforms(self, parent: str, child: str, time_ns: NDArray[np.int64], translation: Array,
                         rotation: Array, *, robot: int = 0) -> None:
        """Log one frame pair's transforms: int64 stamps (n,), translations (n, 3), quaternions (n, 4)."""
        self._sinks[robot].write_transforms(parent, child, time_ns, translation, rotation)

    def write_joint_positions(self, time_ns: NDArray[np.int64], names: Sequence[str], positions: Array, *,
                              robot: int = 0) -> None:
        """Log joint positions (n, J) at stamps (n,); NaN (no position in that message) is skipped."""
        self._sinks[robot].write_joint_positions(time_ns, names, positions)

    def finish(self) -> None:
        """Flush everything and close the target.

        Raises:
            WriteError: the data could not be written out or sent.
        """
        self._sinks[0].finish()

    def abort(self) -> None:
        """Stop logging; a file target is deleted."""
        self._sinks[0].abort()


def open_rerun_sink(
    *,
    save: str | os.PathLike[str] | None = None,
    connect: str | None = None,
    recording_id: str | None = None,
    robot: Robot | None = None,
    frame_prefix: str = "",
    robots: Sequence[tuple[Robot | None, str, str]] | None = None,
    names: Sequence[str] = (),
    package_paths: Sequence[str | os.PathLike[str]] = (),
    port: int = 9876,
    display_prefixes: Sequence[str] = (),
) -> RerunReplaySink:
    """A sink to the ``.rrd`` file ``save``, to the viewer at ``connect``, or else to a spawned viewer.

    The viewer is not probed here: check first, before reading the recording, with
    :func:`check_can_connect` or :func:`check_can_spawn` (:func:`tfrec.replay.play.check_play_options`
    does), so that a missing viewer fails at once rather than after Rerun's background retries.

    Args:
        save: write this file (``recording_id`` names the recording in it).
        connect: stream to the viewer (or server) at this URL, ``rerun+http://host:port/proxy``.
        recording_id: the recording id (default: a new one).
        robot, frame_prefix: the model and frame prefix of a replay of one robot, as for
            :class:`tfrec.viewer.sink.RerunSink`.
        robots: (model, frame prefix, entity prefix) of each robot of a replay of several, instead.
        names: each robot's name in the layout's tabs.
        package_paths: folders searched first for ``package://`` meshes.
        port: where a spawned viewer listens; a viewer already listening there is reused.
        display_prefixes: what the viewer puts in front of each robot's recorded frame ids (part of
            its frame prefix in ``robots``), kept in the ``.rrd`` so that reading it back undoes it.

    Raises:
        WriteError: the file cannot be created, the URL is malformed, or the viewer cannot
            be spawned.
    """
    parts = list(robots) if robots is not None else [(robot, frame_prefix, "")]
    model, prefix, root = parts[0]
    if save is not None:
        first = RerunSink(save, robot=model, recording_id=recording_id, frame_prefix=prefix, entity_prefix=root,
                          package_paths=package_paths)
        return RerunReplaySink([first, *_more_sinks(first, parts[1:], package_paths)], names=names, live=False,
                               display_prefixes=display_prefixes)
    stream = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
    if connect is not None:
        try:
            stream.connect_grpc(connect)
        except RuntimeError as err:
            raise WriteError(f"{connect}: not a Rerun viewer address ({err})") from err
        target = connect
    else:
        executable = shutil.which("rerun") or _bundled_viewer()
        try:
            rr.sinks.spawn(port=port, recording=stream, executable_path=executable)
        except RuntimeError as err:
            raise WriteError(
                f"cannot spawn the Rerun viewer ({err}); use `save` OUT.rrd or `connect` URL"
            ) from err
        target = f"the Rerun viewer on port {port}"
        wait_for_viewer(port)  # a replay starts playing when the viewer can show it, not before its window is up
    return _on_stream(stream, target, parts, names, package_paths, display_prefixes, live=True)


def open_stdout_sink(
    *,
    application_id: str | None,
    recording_id: str | None,
    robots: Sequence[tuple[Robot | None, str, str]],
    names: Sequence[str] = (),
    package_paths: Sequence[str | os.PathLike[str]] = (),
    display_prefixes: Sequence[str] = (),
) -> RerunReplaySink:
    """A sink writing an RRD stream to standard output, what a Rerun importer answers (``rerun-importer-tfrec``);
    the options as for :func:`open_rerun_sink`, ``application_id`` the one Rerun asks for (default tfrec's)."""
    stream = rr.RecordingStream(application_id or APPLICATION_ID, recording_id=recording_id)
    stream.stdout()
    return _on_stream(stream, "standard output", list(robots), names, package_paths, display_prefixes, live=False)


def _on_stream(stream: rr.RecordingStream, target: str, parts: Sequence[tuple[Robot | None, str, str]],
               names: Sequence[str], package_paths: Sequence[str | os.PathLike[str]],
               display_prefixes: Sequence[str], *, live: bool) -> RerunReplaySink:
    model, prefix, root = parts[0]
    first = RerunSink.from_stream(stream, target=target, robot=model, frame_prefix=prefix, entity_prefix=root,
                                  package_paths=package_paths)
    return RerunReplaySink([first, *_more_sinks(first, parts[1:], package_paths)], names=names, live=live,
                           display_prefixes=display_prefixes)


def open_live_rerun_sink(
    *,
    connect: str | None,
    robot: Robot,
    frame_prefix: str = "",
    package_paths: Sequence[str | os.PathLike[str]] = (),
    port: int = 9876,
    reach: Transforms | None = None,
) -> LiveRerunSink:
    """What ``tfrec record`` logs (a :class:`tfrec.formats.RecordSink`), sent live to the viewer at ``connect`` or
    to a spawned one (``tfrec serve --rerun``): the layout goes with the robot's static data, at :meth:`begin`, its
    camera framing the robot at the dynamic transforms ``reach`` (poses it will take).

    Raises:
        WriteError: as :func:`open_rerun_sink`.
    """
    replay = open_rerun_sink(connect=connect, robot=robot, frame_prefix=frame_prefix, package_paths=package_paths,
                             port=port)
    return LiveRerunSink(replay.sinks[0], reach=reach)


class LiveRerunSink:
    """A :class:`RerunSink` to a viewer, as a :class:`tfrec.formats.RecordSink` whose :meth:`begin` also sends the
    layout and flushes (the viewer shows the robot at once) and whose chunks are flushed as they come."""

    def __init__(self, sink: RerunSink, *, reach: Transforms | None = None) -> None:
        self.sink = sink
        self._reach = reach

    def begin(self, *, robot_description: str, static: Transforms, start_time_ns: int) -> None:
        self.sink.begin(robot_description=robot_description, static=static, start_time_ns=start_time_ns)
        if self._reach is not None:
            self.sink.fit_camera(self._reach)
        self.sink.send_blueprint()
        self.sink.flush()

    def write_chunk(self, *, stamp_ns: NDArray[np.int64], joint_names: Sequence[str], positions: Array,
                    velocities: Array, transforms: Transforms) -> None:
        self.sink.write_chunk(stamp_ns=stamp_ns, joint_names=joint_names, positions=positions, velocities=velocities,
                              transforms=transforms)

    def finish(self) -> None:
        self.sink.finish()

    def abort(self) -> None:
        self.sink.abort()


def _more_sinks(first: RerunSink, parts: Sequence[tuple[Robot | None, str, str]],
                package_paths: Sequence[str | os.PathLike[str]]) -> list[RerunSink]:
    """The other robots' sinks of a replay, on the first one's recording stream."""
    target = str(first.path) if first.path is not None else "the Rerun viewer"
    return [RerunSink.from_stream(first.stream, target=target, robot=model, frame_prefix=prefix, entity_prefix=root,
                                  package_paths=package_paths) for model, prefix, root in parts]


def check_can_connect(url: str) -> None:
    """Check that something accepts connections at a viewer's URL, before anything is sent.

    Rerun connects in the background and, when nothing listens, logs its own retries to stderr
    for several seconds before giving up; a plain TCP connection fails at once. A URL without a
    port is left to Rerun.

    Raises:
        WriteError: a URL that is not ``rerun+http://host:port/proxy`` (or ``rerun://``,
            ``rerun+https://``), or nothing accepting connections at its host and port.
    """
    from urllib.parse import urlsplit

    try:
        parts = urlsplit(url)
        host, port = parts.hostname, parts.port
    except ValueError as err:
        raise WriteError(f"{url}: not a Rerun viewer address ({err})") from err
    if parts.scheme not in _SCHEMES or not host:
        raise WriteError(f"{url}: not a Rerun viewer address "
                             "(expected rerun+http://host:port/proxy, rerun+https:// or rerun://)")
    if port is None:
        return
    try:
        with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S):
            pass
    except OSError as err:
        reason = "timed out" if isinstance(err, TimeoutError) else err.strerror or str(err)
        raise WriteError(f"cannot connect to the Rerun viewer at {url}: {reason} "
                             "(is the viewer running? start it with 'rerun', or use `save` OUT.rrd)") from err


def wait_for_viewer(port: int) -> bool:
    """Wait until the viewer listening on ``port`` answers as an application (its window up and running), at most
    the 15 s Rerun's viewer client waits; True when it answered. A spawned viewer accepts connections before its
    window shows: a short replay would be over before anyone saw it."""
    from rerun.experimental import ViewerClient

    try:
        ViewerClient.connect(f"rerun+http://127.0.0.1:{port}/proxy").get_state()
    except (OSError, RuntimeError, ValueError):  # no viewer there, or one that cannot answer: play anyway
        return False
    return True


def check_can_spawn() -> None:
    """Check, before anything is read, that a Rerun viewer can be spawned on this machine.

    Raises:
        WriteError: no display (a headless machine), or no ``rerun`` executable.
    """
    if not _has_display():
        raise WriteError("cannot spawn the Rerun viewer (headless machine?); use `save` OUT.rrd or `connect` URL")
    if shutil.which("rerun") is None and _bundled_viewer() is None:
        raise WriteError("cannot spawn the Rerun viewer (no 'rerun' executable on PATH); "
                             "use `save` OUT.rrd or `connect` URL")


def _has_display() -> bool:
    """False on a Linux (or BSD) machine with neither X11 nor Wayland: the viewer would panic."""
    if sys.platform == "darwin" or sys.platform.startswith("win"):
        return True
    return any(os.environ.get(name) for name in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"))


def _bundled_viewer() -> str | None:
    """The ``rerun`` script beside this Python (a virtual environment not on PATH)."""
    candidate = Path(sys.executable).with_name("rerun")
    return os.fspath(candidate) if candidate.is_file() else None
