"""The Rerun sink: a robot's TF, joint states and geometry as Rerun data, for record and replay.

Opened with ``rerun OUT.rrd`` it shows what RViz shows with the RobotModel and TF displays, plus
plots of the joint states. It uses Rerun's named transform frames, which model ROS's tf2: every
link is a frame named like its TF frame (``frame_prefix`` + link name), joint transforms relate
frame pairs, and geometry is attached to frames.

``tfrec record`` writes a ``.rrd`` file through :class:`RerunSink`; ``tfrec replay`` logs
through the same sink (:mod:`tfrec.formats.rrd.viewer`) to a file, a spawned viewer or a running one,
so a replayed recording has the entities of a recorded one.

Entity paths and the timeline are defined in :mod:`tfrec.formats.rrd.paths`.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from tfrec.errors import KinematicsError, WriteError
from tfrec.formats.rrd.columns import check_stamps, repeated_strings, time_column
from tfrec.formats.rrd.geometry import (
    MeshLoader,
    default_axis_length,
    fit_eye,
    missing_meshes,
    visual_columns,
    visual_radius,
)
from tfrec.formats.rrd.layout import blueprint_of, robot_views
from tfrec.formats.rrd.paths import (
    APPLICATION_ID,
    DESCRIPTION_ROOT,
    ROBOT_ROOT,
    joint_entity,
    link_entity,
    pair_entity,
    static_pair_entity,
    tf_entity,
    tf_static_entity,
    velocity_entity,
    visual_entity,
)
from tfrec.kinematics.fk import Transforms, root_from_link
from tfrec.model import Mesh, Robot

__all__ = ["RerunSink"]

Array = NDArray[np.float64]

_EYE_SAMPLES = 256
"""Samples of the first chunk the default camera is fitted to."""

_FRAME_AXIS_LENGTH_M = 0.1
"""Length of the TF axes of frames that are not links of the robot."""

_FLUSH_BYTES = 16 << 20
"""Payload bytes sent between two blocking flushes. ``send_columns`` only queues a chunk for Rerun's
writer thread (which encodes, compresses and writes it), and the queue has no limit: a writer
slower than the sender would hold any amount of the recording in memory."""


class RerunSink:
    """Logs one robot recording to Rerun, streamed: to a ``.rrd`` file, or to any recording stream.

    Call :meth:`begin` once, then log the samples, then :meth:`finish`; after an error call
    :meth:`abort`. ``tfrec record`` logs a trajectory with :meth:`write_chunk`, all joints at
    shared stamps increasing from chunk to chunk; a replay logs each frame pair with
    :meth:`write_transforms` and the joint states with :meth:`write_joint_positions`, in any
    order (only each pair's own stamps must not go back). Memory stays flat with the recording's
    duration: the sink waits for Rerun's writer after every 16 MiB of data sent.

    Args:
        path: the file to write (the caller renames it into place on success); see
            :meth:`from_stream` for a viewer.
        robot: the robot; its ``source`` anchors relative mesh paths and its own package. None
            logs transforms alone (a replay without a robot model).
        recording_id: the Rerun recording id; derive it from the inputs for reproducible files
            (None: a new random one).
        package_paths: folders searched first for ``package://`` meshes.
        frame_prefix: put in front of every TF frame id (as in the transforms given).
        axis_length_m: length of the links' TF axes; default: a tenth of the robot's reach,
            between 2 cm and 25 cm.
        entity_root: put in front of every entity path (``/robot1``: one robot of several).

    Raises:
        WriteError: the file cannot be created.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        robot: Robot | None,
        recording_id: str | None,
        package_paths: Sequence[str | os.PathLike[str]] = (),
        frame_prefix: str = "",
        axis_length_m: float | None = None,
        entity_root: str = "",
    ) -> None:
        file = Path(path)
        stream = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id, send_properties=False)
        try:
            with open(file, "wb"):
                pass  # fail here with the OS's own words, not in Rerun's writer thread
            stream.save(file)
        except OSError as err:
            raise WriteError(f"{file}: cannot write: {err.strerror or err}") from err
        except RuntimeError as err:  # Rerun could not write the file's header
            raise WriteError(f"{file}: cannot write: {err}") from err
        self._setup(stream, target=os.fspath(file), file=file, robot=robot, package_paths=package_paths,
                    frame_prefix=frame_prefix, axis_length_m=axis_length_m, entity_root=entity_root)

    @classmethod
    def from_stream(
        cls,
        stream: rr.RecordingStream,
        *,
        target: str,
        robot: Robot | None,
        package_paths: Sequence[str | os.PathLike[str]] = (),
        frame_prefix: str = "",
        axis_length_m: float | None = None,
        entity_root: str = "",
    ) -> RerunSink:
        """A sink logging to a stream already pointed at its target (a spawned viewer, a connection,
        another sink's stream: :attr:`stream`).

        Args:
            stream: the recording stream, of application id :data:`APPLICATION_ID`.
            target: what the stream goes to, for error messages (a URL, "the Rerun viewer on port 9876").
            robot, package_paths, frame_prefix, axis_length_m, entity_root: as for the constructor.
        """
        sink = cls.__new__(cls)
        sink._setup(stream, target=target, file=None, robot=robot, package_paths=package_paths,
                    frame_prefix=frame_prefix, axis_length_m=axis_length_m, entity_root=entity_root)
        return sink

    def _setup(
        self,
        stream: rr.RecordingStream,
        *,
        target: str,
        file: Path | None,
        robot: Robot | None,
        package_paths: Sequence[str | os.PathLike[str]],
        frame_prefix: str,
        axis_length_m: float | None,
        entity_root: str = "",
    ) -> None:
        self._rec = stream
        self._root = entity_root.rstrip("/")
        self._target = target
        self._file = file
        self._robot = robot
        self._prefix = frame_prefix
        self._package_paths = tuple(package_paths)
        if axis_length_m is None:
            axis_length_m = default_axis_length(robot) if robot is not None else _FRAME_AXIS_LENGTH_M
        self._axis_length_m = axis_length_m
        links = robot.links if robot is not None else ()
        self._link_frames = frozenset(frame_prefix + link.name for link in links)
        joints = robot.joints if robot is not None else ()
        self._joint_of_child = {frame_prefix + joint.child: joint.name for joint in joints}
        self._other_frames: set[str] = set()
        self._static: Transforms | None = None
        self._eye: rrb.EyeControls3D | None = None
        self._visual_radii: dict[tuple[str, int], float] = {}
        self._last_time_ns: int | None = None
        self._last_pair_ns: dict[tuple[str, str], int] = {}
        self._has_velocities = False
        self._blueprint_sent = False
        self._unflushed_bytes = 0

    @property
    def path(self) -> Path | None:
        """The file written, or None for a sink made with :meth:`from_stream`."""
        return self._file

    @property
    def stream(self) -> rr.RecordingStream:
        """The recording stream, for more sinks into the same recording (:meth:`from_stream`)."""
        return self._rec

    # -- what does not change --------------------------------------------------------------

    def begin(
        self,
        *,
        static: Transforms,
        start_time_ns: int,
        robot_description: str | None = None,
        name: str | None = None,
        root: str | None = None,
        properties: bool = True,
    ) -> None:
        """Log what does not change: name and start time, geometry, frames and TF axes, fixed joints, the URDF.

        Args:
            static: the latched transforms (N = 1): the fixed joints', as from
                :func:`tfrec.kinematics.static_transforms` with the same frame prefix, or a
                recording's /tf_static.
            start_time_ns: the stamp of the first sample (the recording's start time).
            robot_description: the URDF text, kept at ``/robot_description``.
            name: the recording's name in the viewer (default: the robot's).
            root: the frame the 3D view is drawn in when there is no robot (with one: its root link).
            properties: log the recording's name, start time and view coordinates (not for the
                second robot of a replay).

        A mesh that cannot be found or read gives one warning naming the file and the link;
        the rest of the robot is logged.
        """
        self._static = static
        robot = self._robot
        if name is None and robot is not None:
            name = robot.name
        # The recording's name and start time, in one chunk (the SDK's own calls go through its
        # batcher, whose time-based flushes split them differently from run to run).
        if properties:
            info = rr.archetypes.RecordingInfo.columns(start_time=[int(start_time_ns)],
                                                       name=None if name is None else [name])
            self._send_static("/__properties", info, rooted=False)
            self._send_static("/", rr.ViewCoordinates.columns(xyz=[rr.ViewCoordinates.RIGHT_HAND_Z_UP]), rooted=False)
        if robot is not None:
            root = self._prefix + robot.root
        if root is not None:
            self._send_static(f"/{ROBOT_ROOT}", rr.CoordinateFrame.columns(frame=[root]))
        if robot_description is not None:
            self._send_static(f"/{DESCRIPTION_ROOT}",
                              rr.TextDocument.columns(text=[robot_description], media_type=["text/plain"]))
        self.log_robot()
        for k, (parent, child) in enumerate(zip(static.parents, static.children)):
            joint = self._joint_of_child.get(child)
            entity = tf_static_entity(joint) if joint is not None else static_pair_entity(parent, child)
            self._send_static(
                entity,
                rr.Transform3D.columns(
                    translation=static.translation[:1, k],
                    quaternion=static.rotation[:1, k],
                    parent_frame=[parent],
                    child_frame=[child],
                ),
            )

    def log_robot(self) -> None:
        """Log every link's frame and TF axes and its visuals' geometry (:meth:`begin` does).

        Meshes that cannot be found or read give one warning: how many, and the first few
        (file, link and why); the visuals' entities are logged without them.
        """
        robot = self._robot
        if robot is None:
            return
        meshes = MeshLoader(self._package_paths, source=robot.source)
        missing: dict[tuple[str, str], str] = {}
        for link in robot.links:
            frame = [self._prefix + link.name]
            self._send_static(link_entity(link.name), [
                *rr.CoordinateFrame.columns(frame=frame),
                *rr.TransformAxes3D.columns(axis_length=[self._axis_length_m], show_frame=[True])])
            for index, visual in enumerate(link.visuals):
                asset = None
                if isinstance(visual.geometry, Mesh):
                    uri = visual.geometry.filename
                    found = meshes.load(uri)
                    if isinstance(found, str):
                        missing.setdefault((uri, link.name), found)
                    else:
                        asset = found
                self._visual_radii[(link.name, index)] = visual_radius(visual, asset)
                columns = [*rr.CoordinateFrame.columns(frame=frame), *visual_columns(visual, asset)]
                self._send_static(visual_entity(link.name, index), columns)
        if missing:
            warnings.warn(missing_meshes(missing), stacklevel=3)

    def log_frames(self, frames: Iterable[str]) -> None:
        """Log TF axes at ``/robot/<frame>`` for each frame that is no link of the robot, once."""
        for frame in frames:
            if frame in self._link_frames or frame in self._other_frames:
                continue
            self._other_frames.add(frame)
            self._send_static(link_entity(frame), [
                *rr.CoordinateFrame.columns(frame=[frame]),
                *rr.TransformAxes3D.columns(axis_length=[_FRAME_AXIS_LENGTH_M], show_frame=[True]),
            ])

    # -- samples ---------------------------------------------------------------------------

    def write_chunk(
        self,
        *,
        stamp_ns: NDArray[np.int64],
        joint_names: Sequence[str],
        positions: Array,
        velocities: Array,
        transforms: Transforms,
    ) -> None:
        """Log a piece of a trajectory: joint states and the moving joints' transforms.

        The first chunk also fits the 3D view's camera (:meth:`fit_camera`).

        Args:
            stamp_ns: int64 (n,) absolute stamps (nanoseconds since the epoch), increasing.
            joint_names: the joints of the position and velocity columns.
            positions, velocities: float64 (n, J).
            transforms: parent_from_child of the moving joints, N = n.

        Raises:
            WriteError: arrays whose shapes do not match, stamps that go back in time, or a
                failed write (see :meth:`flush`).
        """
        stamps = check_stamps(stamp_ns)
        n = len(stamps)
        shape = (n, len(joint_names))
        if np.shape(positions) != shape or np.shape(velocities) != shape or len(transforms) != n:
            raise WriteError(
                f"chunk of {n} stamps has positions {np.shape(positions)}, velocities {np.shape(velocities)} "
                f"and {len(transforms)} transforms; expected {shape}"
            )
        if n == 0:
            return
        if np.any(np.diff(stamps) < 0) or (self._last_time_ns is not None and stamps[0] < self._last_time_ns):
            raise WriteError("chunk stamps go back in time")
        self._last_time_ns = int(stamps[-1])
        index = [time_column(stamps)]
        for j, name in enumerate(joint_names):
            self._write_scalars(joint_entity(name), index, stamps, positions[:, j])
            self._write_scalars(velocity_entity(name), index, stamps, velocities[:, j])
            self._has_velocities = True
        for k, (parent, child) in enumerate(zip(transforms.parents, transforms.children)):
            self._write_pair(parent, child, index, stamps, transforms.translation[:, k], transforms.rotation[:, k])
        if self._eye is None:
            self.fit_camera(transforms)

    def write_transforms(
        self, parent: str, child: str, time_ns: NDArray[np.int64], translation: Array, rotation: Array
    ) -> None:
        """Log one frame pair's transforms at their own stamps.

        A pair whose child is a link of the robot goes to ``/tf/<joint>``, any other to
        ``/tf/<parent>/<child>``. Pairs are independent of each other and of the joint states.

        Args:
            parent, child: the frame ids (frame prefix included).
            time_ns: int64 (n,) stamps, not before those this pair was logged at so far.
            translation: float64 (n, 3), parent_from_child.
            rotation: float64 (n, 4), quaternions (x, y, z, w).

        Raises:
            WriteError: arrays whose shapes do not match, stamps that go back in time, or a
                failed write (see :meth:`flush`).
        """
        stamps = check_stamps(time_ns)
        n = len(stamps)
        if np.shape(translation) != (n, 3) or np.shape(rotation) != (n, 4):
            raise WriteError(f"transforms '{parent}' -> '{child}': {n} stamps with translation "
                                 f"{np.shape(translation)} and rotation {np.shape(rotation)}")
        if n:
            self._write_pair(parent, child, [time_column(stamps)], stamps, translation, rotation)

    def write_joint_positions(self, time_ns: NDArray[np.int64], names: Sequence[str], positions: Array) -> None:
        """Log joint positions at ``/joints/<joint>``; NaN (no position in that message) is skipped.

        Args:
            time_ns: int64 (n,) stamps.
            names: the joints of the columns.
            positions: float64 (n, J).

        Raises:
            WriteError: arrays whose shapes do not match, or a failed write (see :meth:`flush`).
        """
        stamps = check_stamps(time_ns)
        if np.shape(positions) != (len(stamps), len(names)):
            raise WriteError(f"{len(stamps)} stamps of {len(names)} joints have positions {np.shape(positions)}")
        if len(stamps):
            index = [time_column(stamps)]
            for j, name in enumerate(names):
                self._write_scalars(joint_entity(name), index, stamps, positions[:, j])

    # -- the view --------------------------------------------------------------------------

    def fit_camera(self, moving: Transforms) -> None:
        """Aim the 3D view's camera at the robot at (up to 256 of) the instants of ``moving``.

        ``moving`` is composed with :meth:`begin`'s latched transforms and the camera placed by
        :func:`tfrec.formats.rrd.geometry.fit_eye`. Without a robot, or when the frames do not form a
        tree, the viewer's own camera is kept.
        """
        if self._static is None or self._robot is None:
            return
        picked = np.unique(np.linspace(0, len(moving) - 1, min(len(moving), _EYE_SAMPLES)).astype(int))
        sampled = Transforms(moving.parents, moving.children, moving.translation[picked], moving.rotation[picked])
        try:
            world = root_from_link(self._static, sampled, root=self._prefix + self._robot.root)
        except KinematicsError:  # a frame with two parents (in a replayed recording)
            return
        self._eye = fit_eye(self._robot, world, frame_prefix=self._prefix, radii=self._visual_radii)

    def blueprint(self) -> rrb.Blueprint:
        """The layout (:mod:`tfrec.formats.rrd.layout`) of :meth:`views`."""
        return blueprint_of([self.views()])

    def views(self, name: str | None = None) -> rrb.Container:
        """A 3D view of ``/robot`` (camera from :meth:`fit_camera`) beside a plot of the joint positions,
        and in a second tab of the joint velocities when some were logged (``name``: a tab's title)."""
        return robot_views(self._root, eye=self._eye, velocities=self._has_velocities, name=name)

    def send_blueprint(self, blueprint: rrb.Blueprint | None = None) -> None:
        """Send :meth:`blueprint` (or several sinks' :func:`blueprint_of`) now; :meth:`finish` then sends
        none (that would reset a live viewer's layout)."""
        self._rec.send_blueprint(self.blueprint() if blueprint is None else blueprint)
        self._blueprint_sent = True

    # -- the end ---------------------------------------------------------------------------

    def flush(self) -> None:
        """Write (or send) everything logged so far.

        Raises:
            WriteError: Rerun's file writer failed (disk full, file too large…) or the
                viewer cannot be reached.
        """
        self._unflushed_bytes = 0
        try:
            self._rec.flush()
        except RuntimeError as err:
            verb = "cannot write" if self._file is not None else "cannot send to the recording"
            raise WriteError(f"{self._target}: {verb}: {err}") from err

    def finish(self) -> None:
        """Send the blueprint (unless :meth:`send_blueprint` did), flush everything and close the target.

        Raises:
            WriteError: the data could not be written out or sent.
        """
        if not self._blueprint_sent:
            self.send_blueprint()
        try:
            self.flush()
        finally:
            self._rec.disconnect()

    def abort(self) -> None:
        """Stop logging; the file of a sink made with a path is deleted."""
        self._rec.disconnect()
        if self._file is not None:
            self._file.unlink(missing_ok=True)

    # -- helpers ---------------------------------------------------------------------------

    def _send(self, entity: str, index: list[rr.TimeColumn], columns: Any, *, nbytes: int = 0,
              rooted: bool = True) -> None:
        if rooted and self._root:
            entity = self._root + entity
        rr.send_columns(entity, indexes=index, columns=columns, recording=self._rec, strict=True)
        self._unflushed_bytes += nbytes
        if self._unflushed_bytes >= _FLUSH_BYTES:
            self.flush()

    def _send_static(self, entity: str, columns: Any, *, rooted: bool = True) -> None:
        self._send(entity, [], columns, rooted=rooted)

    def _write_scalars(self, entity: str, index: list[rr.TimeColumn], stamps: NDArray[np.int64],
                       values: Array) -> None:
        """One column of joint values at ``index`` (the ``stamps``); values that are NaN are left out."""
        given = np.isfinite(values)
        if given.all():
            self._send(entity, index, rr.Scalars.columns(scalars=values), nbytes=stamps.nbytes + values.nbytes)
        elif given.any():
            kept = stamps[given]
            self._send(entity, [time_column(kept)], rr.Scalars.columns(scalars=values[given]), nbytes=2 * kept.nbytes)

    def _write_pair(self, parent: str, child: str, index: list[rr.TimeColumn], stamps: NDArray[np.int64],
                    translation: Array, rotation: Array) -> None:
        last = self._last_pair_ns.get((parent, child))
        if np.any(np.diff(stamps) < 0) or (last is not None and stamps[0] < last):
            raise WriteError(f"transforms '{parent}' -> '{child}': stamps go back in time")
        self._last_pair_ns[(parent, child)] = int(stamps[-1])
        joint = self._joint_of_child.get(child)
        n = len(stamps)
        self._send(
            tf_entity(joint) if joint is not None else pair_entity(parent, child),
            index,
            rr.Transform3D.columns(translation=translation, quaternion=rotation,
                                   parent_frame=repeated_strings(parent, n), child_frame=repeated_strings(child, n)),
            nbytes=stamps.nbytes + translation.nbytes + rotation.nbytes + n * (len(parent) + len(child)),
        )


