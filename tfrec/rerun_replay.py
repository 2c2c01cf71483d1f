"""Replaying into Rerun: a spawned viewer, a running one (``--connect``), or an ``.rrd`` file.

The entities are those of :mod:`tfrec.rerun_io`, so a replayed recording looks like one written by
``tfrec record``: the robot's geometry under ``/robot/<link>``, a transform pair whose child frame
is a link of the robot at ``/tf/<joint>`` (``/tf_static/<joint>`` when latched), joint positions at
``/joints/<joint>``. What the robot model does not name keeps its own entities, so nothing recorded
is dropped:

================================  =========================================================
``/tf/<parent>/<child>``          ``Transform3D`` of a pair on /tf whose child is no link
``/tf_static/<parent>/<child>``   the same for /tf_static
``/robot/<frame>``                ``CoordinateFrame`` + ``TransformAxes3D`` of such a frame
================================  =========================================================

Transforms come per frame pair with their own stamps (a recording's /tf is not one array at
shared times), so this is a sink of its own rather than :class:`tfrec.rerun_io.RerunSink`, which
logs all joints of a trajectory at shared stamps into a file.
"""

from __future__ import annotations

import os
import shutil
import sys
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from .errors import RecordingError
from .model import Mesh, Robot
from .rerun_geometry import MeshLoader, visual_columns
from .rerun_io import (
    APPLICATION_ID,
    TIMELINE,
    joint_entity,
    link_entity,
    tf_entity,
    tf_static_entity,
    visual_entity,
)

__all__ = ["RerunReplaySink", "check_can_spawn", "open_rerun_sink", "pair_entity", "static_pair_entity"]

Array = NDArray[np.float64]
Pair = tuple[str, str]

_AXIS_LENGTH_M = 0.1
"""Length of the TF axes of frames that are not links of the robot."""


def pair_entity(parent: str, child: str) -> str:
    """``/tf/<parent>/<child>``: a pair on /tf that is no joint of the robot."""
    return f"/tf/{rr.escape_entity_path_part(parent)}/{rr.escape_entity_path_part(child)}"


def static_pair_entity(parent: str, child: str) -> str:
    """``/tf_static/<parent>/<child>``: a pair on /tf_static that is no joint of the robot."""
    return f"/tf_static/{rr.escape_entity_path_part(parent)}/{rr.escape_entity_path_part(child)}"


class RerunReplaySink:
    """Logs a recording being replayed to one Rerun target.

    Make one with :func:`open_rerun_sink`; call :meth:`begin` once,
    :meth:`write_transforms` and :meth:`write_joint_positions` for each batch, then
    :meth:`finish` (or :meth:`abort` after an error).

    Args:
        stream: the recording stream, already pointed at its target.
        target: the target for messages (a path or a URL).
        live: True for a viewer (the first data is flushed at once, to fail early).
        robot: the robot model, or None to log transforms alone.
        frame_prefix: the prefix of the recording's frame ids in front of the link names.
        package_paths: folders searched first for ``package://`` meshes.
    """

    def __init__(
        self,
        stream: rr.RecordingStream,
        *,
        target: str,
        live: bool,
        robot: Robot | None,
        frame_prefix: str = "",
        package_paths: Sequence[str | os.PathLike[str]] = (),
    ) -> None:
        self._rec = stream
        self._target = target
        self._live = live
        self._robot = robot
        self._prefix = frame_prefix
        self._package_paths = tuple(package_paths)
        self._joint_of_child = {} if robot is None else {frame_prefix + j.child: j.name for j in robot.joints}
        self._link_frames = set() if robot is None else {frame_prefix + link.name for link in robot.links}
        self._frames: set[str] = set()

    # -- logging ----------------------------------------------------------------------------------

    def begin(
        self,
        *,
        start_time_ns: int,
        name: str,
        robot_description: str | None,
        static: Mapping[Pair, tuple[Array, Array]],
        frames: Sequence[str] = (),
        root: str | None = None,
    ) -> None:
        """Log what does not change: the blueprint, geometry, frames, latched transforms and URDF.

        Args:
            start_time_ns: the stamp the replay starts at.
            name: the recording's name in the viewer.
            robot_description: the URDF text for ``/robot_description``, or None.
            static: /tf_static, (parent, child) → (translation (3,), rotation (4,)).
            frames: every frame id of the replay; those that are not links get TF axes.
            root: the frame the 3D view is drawn in when there is no robot model.

        Raises:
            RecordingError: a live viewer cannot be reached.
        """
        self._rec.send_recording_name(name)
        self._rec.send_recording_start_time_nanos(int(start_time_ns))
        self._rec.send_blueprint(self._blueprint())
        self._static("/", rr.ViewCoordinates.columns(xyz=[rr.ViewCoordinates.RIGHT_HAND_Z_UP]))
        if self._robot is not None:
            root = self._prefix + self._robot.root
        if root is not None:
            self._static("/robot", rr.CoordinateFrame.columns(frame=[root]))
        if robot_description is not None:
            self._static("/robot_description",
                         rr.TextDocument.columns(text=[robot_description], media_type=["text/plain"]))
        if self._robot is not None:
            self._log_robot(self._robot)
        for frame in frames:
            self._log_frame(frame)
        for (parent, child), (translation, rotation) in static.items():
            self._log_frame(parent)
            self._log_frame(child)
            joint = self._joint_of_child.get(child)
            entity = tf_static_entity(joint) if joint is not None else static_pair_entity(parent, child)
            self._static(entity, rr.Transform3D.columns(
                translation=np.reshape(translation, (1, 3)), quaternion=np.reshape(rotation, (1, 4)),
                parent_frame=[parent], child_frame=[child],
            ))
        if self._live:
            self._flush()

    def write_transforms(self, parent: str, child: str, time_ns: NDArray[np.int64], translation: Array,
                         rotation: Array) -> None:
        """Log one frame pair's transforms: int64 stamps (n,), translations (n, 3), quaternions (n, 4)."""
        n = len(time_ns)
        if not n:
            return
        joint = self._joint_of_child.get(child)
        entity = tf_entity(joint) if joint is not None else pair_entity(parent, child)
        rr.send_columns(
            entity, indexes=[_time_column(time_ns)], recording=self._rec, strict=True,
            columns=rr.Transform3D.columns(translation=translation, quaternion=rotation,
                                           parent_frame=[parent] * n, child_frame=[child] * n),
        )

    def write_joint_positions(self, time_ns: NDArray[np.int64], names: Sequence[str], positions: Array) -> None:
        """Log joint positions (n, J) at stamps (n,); NaN (no position in that message) is skipped."""
        for j, name in enumerate(names):
            given = np.isfinite(positions[:, j])
            if given.any():
                rr.send_columns(joint_entity(name), indexes=[_time_column(time_ns[given])], recording=self._rec,
                                columns=rr.Scalars.columns(scalars=positions[given, j]), strict=True)

    def finish(self) -> None:
        """Flush everything and close the target.

        Raises:
            RecordingError: the data could not be written out or sent.
        """
        try:
            self._flush()
        finally:
            self._rec.disconnect()

    def abort(self) -> None:
        """Stop logging; a file target is deleted."""
        self._rec.disconnect()
        if not self._live:
            Path(self._target).unlink(missing_ok=True)

    # -- helpers ----------------------------------------------------------------------------------

    def _flush(self) -> None:
        try:
            self._rec.flush()
        except RuntimeError as err:  # Rerun's writer stopped (disk full…) or the viewer is unreachable
            verb = "send to" if self._live else "write"
            raise RecordingError(f"{self._target}: cannot {verb} the recording: {err}") from err

    def _static(self, entity: str, columns: Any) -> None:
        rr.send_columns(entity, indexes=[], columns=columns, recording=self._rec, strict=True)

    def _log_robot(self, robot: Robot) -> None:
        """Geometry, frames and TF axes of every link, as :class:`tfrec.rerun_io.RerunSink` logs them."""
        meshes = MeshLoader(self._package_paths, source=robot.source)
        warned: set[tuple[str, str]] = set()
        axis_length = _axis_length(robot)
        for link in robot.links:
            frame = [self._prefix + link.name]
            self._static(link_entity(link.name), [
                *rr.CoordinateFrame.columns(frame=frame),
                *rr.TransformAxes3D.columns(axis_length=[axis_length], show_frame=[True]),
            ])
            for index, visual in enumerate(link.visuals):
                asset = None
                if isinstance(visual.geometry, Mesh):
                    found = meshes.load(visual.geometry.filename)
                    if isinstance(found, str):
                        if (visual.geometry.filename, link.name) not in warned:
                            warned.add((visual.geometry.filename, link.name))
                            warnings.warn(f"{visual.geometry.filename}: mesh for link '{link.name}' {found}; "
                                          "link logged without it", stacklevel=3)
                    else:
                        asset = found
                self._static(visual_entity(link.name, index),
                             [*rr.CoordinateFrame.columns(frame=frame), *visual_columns(visual, asset)])

    def _log_frame(self, frame: str) -> None:
        """TF axes for a frame that is no link of the robot, once."""
        if frame in self._frames or frame in self._link_frames:
            return
        self._frames.add(frame)
        self._static(link_entity(frame), [
            *rr.CoordinateFrame.columns(frame=[frame]),
            *rr.TransformAxes3D.columns(axis_length=[_AXIS_LENGTH_M], show_frame=[True]),
        ])

    def _blueprint(self) -> rrb.Blueprint:
        view3d = rrb.Spatial3DView(name="robot", origin="/robot")
        plots = rrb.TimeSeriesView(name="joint positions", origin="/joints")
        return rrb.Blueprint(
            rrb.Horizontal(view3d, plots, column_shares=[3, 2]),
            rrb.BlueprintPanel(state="collapsed"),
            rrb.SelectionPanel(state="collapsed"),
            rrb.TimePanel(state="collapsed", timeline=TIMELINE),
        )


def open_rerun_sink(
    *,
    save: str | os.PathLike[str] | None = None,
    connect: str | None = None,
    recording_id: str | None = None,
    robot: Robot | None,
    frame_prefix: str = "",
    package_paths: Sequence[str | os.PathLike[str]] = (),
    port: int = 9876,
) -> RerunReplaySink:
    """A sink to the ``.rrd`` file ``save``, to the viewer at ``connect``, or else to a spawned viewer.

    Args:
        save: write this file (``recording_id`` names the recording in it).
        connect: stream to the viewer (or server) at this URL, ``rerun+http://host:port/proxy``.
        recording_id: the recording id (default: a new one).
        robot, frame_prefix, package_paths: as for :class:`RerunReplaySink`.
        port: where a spawned viewer listens; a viewer already listening there is reused.

    Raises:
        RecordingError: the file cannot be created, the URL is malformed, or no viewer can be
            started (no display, or no ``rerun`` executable).
    """
    stream = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id, send_properties=save is None)
    options: dict[str, Any] = {"robot": robot, "frame_prefix": frame_prefix, "package_paths": package_paths}
    if save is not None:
        target = Path(save)
        try:
            with open(target, "wb"):
                pass  # fail here, with the OS's reason, rather than in Rerun's writer thread
            stream.save(target)
        except OSError as err:
            raise RecordingError(f"{target}: cannot write: {err.strerror or err}") from None
        except RuntimeError as err:  # Rerun could not write the file's header
            raise RecordingError(f"{target}: cannot write: {err}") from None
        return RerunReplaySink(stream, target=os.fspath(target), live=False, **options)
    if connect is not None:
        try:
            stream.connect_grpc(connect)
        except RuntimeError as err:
            raise RecordingError(f"{connect}: not a Rerun viewer address ({err})") from None
        return RerunReplaySink(stream, target=connect, live=True, **options)
    check_can_spawn()
    executable = shutil.which("rerun") or _bundled_viewer()
    try:
        rr.sinks.spawn(port=port, recording=stream, executable_path=executable)
    except RuntimeError as err:
        raise RecordingError(f"cannot spawn the Rerun viewer ({err}); use --save OUT.rrd or --connect URL") from None
    return RerunReplaySink(stream, target=f"the Rerun viewer on port {port}", live=True, **options)


def check_can_spawn() -> None:
    """Check, before anything is read, that a Rerun viewer can be spawned on this machine.

    Raises:
        RecordingError: no display (a headless machine), or no ``rerun`` executable.
    """
    if not _has_display():
        raise RecordingError("cannot spawn the Rerun viewer (headless machine?); use --save OUT.rrd or --connect URL")
    if shutil.which("rerun") is None and _bundled_viewer() is None:
        raise RecordingError("cannot spawn the Rerun viewer (no 'rerun' executable on PATH); "
                             "use --save OUT.rrd or --connect URL")


def _time_column(time_ns: NDArray[np.int64]) -> rr.TimeColumn:
    return rr.TimeColumn(TIMELINE, timestamp=np.asarray(time_ns, dtype=np.int64).astype("datetime64[ns]"))


def _axis_length(robot: Robot) -> float:
    """A tenth of the longest chain of joint offsets from the root, within [2 cm, 25 cm] (as RerunSink)."""
    reach: dict[str, float] = {robot.root: 0.0}
    for joint in robot.tree_order:
        reach[joint.child] = reach.get(joint.parent, 0.0) + float(np.linalg.norm(joint.origin.xyz))
    return min(max(0.1 * max(reach.values()), 0.02), 0.25)


def _has_display() -> bool:
    """False on a Linux (or BSD) machine with neither X11 nor Wayland: the viewer would panic."""
    if sys.platform == "darwin" or sys.platform.startswith("win"):
        return True
    return any(os.environ.get(name) for name in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"))


def _bundled_viewer() -> str | None:
    """The ``rerun`` script beside this Python (a virtual environment not on PATH)."""
    candidate = Path(sys.executable).with_name("rerun")
    return os.fspath(candidate) if candidate.is_file() else None
