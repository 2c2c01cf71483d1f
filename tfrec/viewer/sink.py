"""The Rerun sink: a robot's TF, joint states and geometry as Rerun data, for record and replay.

Opened with ``rerun OUT.rrd`` it shows what RViz shows with the RobotModel and TF displays, plus
plots of the joint states and the TF tree (the layout: :mod:`tfrec.viewer.blueprint`). It uses Rerun's named transform frames, which model ROS's tf2: every
link is a frame named like its TF frame (``frame_prefix`` + link name), joint transforms relate
frame pairs, and geometry is attached to frames.

``tfrec record`` writes a ``.rrd`` file through :class:`RerunSink`; ``tfrec replay`` logs
through the same sink (:mod:`tfrec.viewer.spawn`) to a file, a spawned viewer or a running one,
so a replayed recording has the entities of a recorded one.
Entity paths and the timeline: :mod:`tfrec.formats.rrd.paths`."""

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

from tfrec.errors import TfrecWarning, WriteError
from tfrec.formats.rrd.paths import (
    APPLICATION_ID,
    DESCRIPTION_ROOT,
    DISPLAY_PREFIX_ROOT,
    NO_JOINTS_ENTITY,
    ROBOT_ROOT,
    TF_TREE_ROOT,
    check_rerun_robot,
    joint_entity,
    link_entity,
    pair_entity,
    spoke_entity,
    static_pair_entity,
    tf_entity,
    tf_static_entity,
    velocity_entity,
    visual_entity,
)
from tfrec.kinematics.fk import root_from_link
from tfrec.model import JointType, Link, Mesh, Robot
from tfrec.recording import Transforms
from tfrec.viewer._flush import disconnect, flush
from tfrec.viewer.blueprint import Reach, blueprint_of, joint_colour, joint_units, robot_layout, tf_tree_columns
from tfrec.viewer.columns import (
    ArrowTimeColumn,
    check_stamps,
    elapsed_column,
    no_joint_columns,
    scalar_column,
    time_column,
    transform_columns,
)
from tfrec.viewer.geometry import (
    MeshAsset,
    MeshLoader,
    axial_extent,
    default_axis_length,
    missing_meshes,
    spoke_columns,
    visual_columns,
    visual_radius,
)

__all__ = ["RerunSink"]

Array = NDArray[np.float64]

_FRAME_AXIS_LENGTH_M = 0.1  # of the TF axes of frames that are not links of the robot

_FLUSH_BYTES = 16 << 20
"""Payload bytes sent between two blocking flushes. ``send_columns`` only queues a chunk for Rerun's
writer thread (which encodes, compresses and writes it), and the queue has no limit: a writer
slower than the sender would hold any amount of the recording in memory."""


class RerunSink:
    """Logs one robot recording to Rerun, streamed: to a ``.rrd`` file, or to any recording stream.

    :meth:`begin` once, then the samples, then :meth:`finish` (:meth:`abort` after an error). ``tfrec
    record`` logs chunks of a trajectory (:meth:`write_chunk`); a replay each frame pair
    (:meth:`write_transforms`) and the joint states (:meth:`write_joint_positions`), in any order.
    Memory stays flat: the sink waits for Rerun's writer after every 16 MiB of data sent.

    Args:
        path: the file to write (the caller renames it into place on success); see
            :meth:`from_stream` for a viewer.
        robot: the robot (its ``source`` anchors relative mesh paths); None: transforms alone.
        recording_id: the Rerun recording id; derive it from the inputs for reproducible files.
        package_paths: folders searched first for ``package://`` meshes.
        frame_prefix: put in front of every TF frame id (as in the transforms given).
        axis_length_m: length of the links' TF axes; default: a tenth of the robot's reach,
            between 2 cm and 25 cm.
        entity_prefix: put in front of every entity path but ``/`` and ``/__properties``
            (``/a``: two robots in one recording, :mod:`tfrec.viewer.overlay`).
        colour: one colour (0xRRGGBBAA) for every visual instead of its material's (a ghost); 0
            for none (to colour them over time: static colours would hide those).

    Raises:
        WriteError: the file cannot be created, or a robot of more than :data:`MAX_LINKS` links.
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
        entity_prefix: str = "",
        colour: int | None = None,
    ) -> None:
        file = Path(path)
        check_rerun_robot(robot, os.fspath(file))
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
                    frame_prefix=frame_prefix, axis_length_m=axis_length_m, entity_prefix=entity_prefix,
                    colour=colour)

    @classmethod
    def from_stream(
        cls,
        stream: rr.RecordingStream,
        *,
        target: str,
        robot: Robot | None,
        **options: Any,
    ) -> RerunSink:
        """A sink logging to a stream already pointed at its target (a spawned viewer, a connection).

        Args:
            stream: the recording stream, of application id :data:`APPLICATION_ID`.
            target: what the stream goes to, for error messages (a URL, "the Rerun viewer on port 9876").
            robot, **options: as for the constructor (``package_paths``, ``frame_prefix``, ...).
        """
        check_rerun_robot(robot, target)
        sink = cls.__new__(cls)
        sink._setup(stream, target=target, file=None, robot=robot, **options)
        return sink

    def _setup(
        self,
        stream: rr.RecordingStream,
        *,
        target: str,
        file: Path | None,
        robot: Robot | None,
        package_paths: Sequence[str | os.PathLike[str]] = (),
        frame_prefix: str = "",
        axis_length_m: float | None = None,
        entity_prefix: str = "",
        colour: int | None = None,
    ) -> None:
        self._rec = stream
        self._root = entity_prefix.rstrip("/")
        self._colour = colour
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
        # a pair that names a link below another parent (reparented, a cycle) keeps an entity of its own
        self._joint_of_pair = {(frame_prefix + joint.parent, frame_prefix + joint.child): joint.name for joint in joints}
        self._other_frames: set[str] = set()
        self._static: Transforms | None = None
        self._visual_radii: dict[tuple[str, int], float] = {}
        self._reach = Reach(robot, frame_prefix, self._visual_radii) if robot is not None else None
        self._joint_order = {joint.name: k for k, joint in enumerate(joints)}
        self._units: dict[str, str] = {}  # joint logged → its unit
        self._tf_tree = False
        self._last_time_ns: int | None = None
        self._last_pair_ns: dict[tuple[str, str], int] = {}
        self._has_velocities = False
        self._blueprint_sent = False
        self._unflushed_bytes = 0
        self._origin_ns: int | None = None

    @property
    def reach(self) -> Reach | None:  # the space the robot took up in what was logged (None without a robot)
        return self._reach

    @property
    def stream(self) -> rr.RecordingStream:
        """The recording stream logged to (for a second robot, :meth:`from_stream`)."""
        return self._rec

    @property
    def path(self) -> Path | None:  # the file written, or None for a sink made with :meth:`from_stream`
        return self._file

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
            properties: log the recording's name and start time and the view coordinates (a
                second robot in the same recording does not).

        Meshes that cannot be found or read give one warning naming how many, and the first few;
        the rest of the robot is logged.
        """
        self._static = static
        self._origin_ns = int(start_time_ns)
        robot = self._robot
        if name is None and robot is not None:
            name = robot.name
        # The recording's name and start time (the first stamp, no wall clock), in one chunk (the SDK's
        # own calls go through its batcher, whose time-based flushes split them differently from run to run).
        if properties:
            for entity, columns in (
                ("/__properties", rr.archetypes.RecordingInfo.columns(start_time=[int(start_time_ns)],
                                                                      name=None if name is None else [name])),
                ("/", rr.ViewCoordinates.columns(xyz=[rr.ViewCoordinates.RIGHT_HAND_Z_UP])),
            ):
                rr.send_columns(entity, indexes=[], columns=columns, recording=self._rec, strict=True)
        if robot is not None:
            root = self._prefix + robot.root
        if root is not None:
            self._send_static(f"/{ROBOT_ROOT}", rr.CoordinateFrame.columns(frame=[root]))
        if robot_description is not None:
            self._send_static(f"/{DESCRIPTION_ROOT}",
                              rr.TextDocument.columns(text=[robot_description], media_type=["text/plain"]))
        self.log_robot()
        for k, (parent, child) in enumerate(zip(static.parents, static.children)):
            joint = self._joint_of_pair.get((parent, child))
            entity = tf_static_entity(joint) if joint is not None else static_pair_entity(parent, child)
            self._send_static(entity, rr.Transform3D.columns(
                translation=static.translation[:1, k], quaternion=static.rotation[:1, k], parent_frame=[parent],
                child_frame=[child]))
        self.fit_camera(Transforms((), (), np.zeros((1, 0, 3)), np.zeros((1, 0, 4))))  # the fixed joints' reach

    def log_robot(self) -> None:
        """Log every link's frame and TF axes and its visuals' geometry (:meth:`begin` does).

        Meshes that cannot be found or read give one warning: how many, and the first few (file,
        link and why); the visuals' entities are logged without them.
        """
        robot = self._robot
        if robot is None:
            return
        meshes = MeshLoader(self._package_paths, source=robot.source)
        missing: dict[tuple[str, str], str] = {}
        wheels = {j.child: j.axis for j in robot.joints if j.type is JointType.CONTINUOUS}
        for link in robot.links:
            assets: list[MeshAsset | None] = []
            frame = [self._prefix + link.name]
            self._send_static(link_entity(link.name), [
                *rr.CoordinateFrame.columns(frame=frame),
                *rr.TransformAxes3D.columns(axis_length=[self._axis_length_m], show_frame=[False])])
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
                assets.append(asset)
                self._send_static(visual_entity(link.name, index), [
                    *rr.CoordinateFrame.columns(frame=frame), *visual_columns(visual, asset, colour=self._colour)])
            if link.name in wheels:  # a wheel turning looks still: spokes on its faces show its angle
                self._log_spokes(link, wheels[link.name], frame, assets)
        if missing:
            warnings.warn(missing_meshes(missing), TfrecWarning, stacklevel=3)
        self.log_tf_tree([(self._prefix + j.parent, self._prefix + j.child) for j in robot.tree_order])

    def _log_spokes(self, link: Link, axis: tuple[float, float, float], frame: list[str],
                    assets: list[MeshAsset | None]) -> None:
        """Spokes on the faces of a wheel (:func:`tfrec.viewer.geometry.spoke_columns`), reaching a little past its
        rim."""
        radius = max((self._visual_radii[(link.name, i)] for i in range(len(link.visuals))), default=0.0)
        radius = radius or self._axis_length_m
        face = max((axial_extent(v, axis, asset) for v, asset in zip(link.visuals, assets)), default=0.0)
        self._send_static(spoke_entity(link.name), [
            *rr.CoordinateFrame.columns(frame=frame), *spoke_columns(axis, 1.1 * radius, 1.02 * face)])

    def log_frames(self, frames: Iterable[str]) -> None:
        """Log TF axes at ``/robot/<frame>`` for each frame that is no link of the robot, once."""
        for frame in frames:
            if frame in self._link_frames or frame in self._other_frames:
                continue
            self._other_frames.add(frame)
            self._send_static(link_entity(frame), [
                *rr.CoordinateFrame.columns(frame=[frame]),
                *rr.TransformAxes3D.columns(axis_length=[_FRAME_AXIS_LENGTH_M], show_frame=[False]),
            ])

    def log_tf_tree(self, pairs: Sequence[tuple[str, str]]) -> None:
        """Log the TF tree, (parent, child) frame pairs, as a graph at ``/tf_tree`` (once)."""
        if self._tf_tree or not pairs:
            return
        self._tf_tree = True
        self._send_static(f"/{TF_TREE_ROOT}", tf_tree_columns(pairs))

    # -- samples ---------------------------------------------------------------------------

    def write_chunk(self, *, stamp_ns: NDArray[np.int64], joint_names: Sequence[str], positions: Array,
                    velocities: Array, transforms: Transforms) -> None:
        """Log a piece of a trajectory: joint states and the moving joints' transforms (without joints: the stamps).

        Every chunk widens the robot's reach the 3D view's camera frames (:meth:`fit_camera`).

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
            raise WriteError(f"chunk of {n} stamps has positions {np.shape(positions)}, velocities "
                             f"{np.shape(velocities)} and {len(transforms)} transforms; expected {shape}")
        if n == 0:
            return
        if np.any(np.diff(stamps) < 0) or (self._last_time_ns is not None and stamps[0] < self._last_time_ns):
            raise WriteError("chunk stamps go back in time")
        self._last_time_ns = int(stamps[-1])
        index = self._index(stamps)
        if not joint_names:  # empty joint states: their stamps alone
            self._send(NO_JOINTS_ENTITY, index, no_joint_columns(n), nbytes=2 * stamps.nbytes)
        # each column is copied once, into the contiguous array (float32 for the transforms, what Rerun stores) Rerun
        # is handed (tfrec.viewer.columns): Rerun's own conversion of every strided float64 column cost more than all
        # tfrec's logging
        for j, name in enumerate(joint_names):
            self._style_joint(name, velocity=True)
            self._write_scalars(joint_entity(name), index, stamps, positions[:, j])
            self._write_scalars(velocity_entity(name), index, stamps, velocities[:, j])
            self._has_velocities = True
        for k, (parent, child) in enumerate(zip(transforms.parents, transforms.children)):
            self._write_pair(parent, child, index, stamps, transforms.translation[:, k], transforms.rotation[:, k])
        self.fit_camera(transforms)

    def write_transforms(
        self, parent: str, child: str, time_ns: NDArray[np.int64], translation: Array, rotation: Array
    ) -> None:
        """Log one frame pair's transforms at their own stamps.

        A pair that is a joint of the robot (its parent and child frames) goes to ``/tf/<joint>``, any
        other to ``/tf/<parent>/<child>``. Pairs are independent of each other and of the joint states.

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
            self._write_pair(parent, child, self._index(stamps), stamps, translation, rotation)

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
            index = self._index(stamps)
            if not names:
                self._send(NO_JOINTS_ENTITY, index, no_joint_columns(len(stamps)), nbytes=2 * stamps.nbytes)
            for j, name in enumerate(names):
                self._style_joint(name, velocity=False)
                self._write_scalars(joint_entity(name), index, stamps, positions[:, j])

    # -- the view --------------------------------------------------------------------------

    def fit_camera(self, moving: Transforms) -> None:
        """Widen the robot's reach (the camera frames it) by the robot at (up to 64 of) the instants of ``moving``.

        ``moving`` is composed with :meth:`begin`'s latched transforms; the camera looks at the
        whole reach (:class:`tfrec.viewer.blueprint.Reach`). Without a robot the viewer's own camera
        is kept; frames that do not form a tree are placed as :func:`~tfrec.kinematics.root_from_link` places them.
        """
        if self._static is None or self._robot is None or self._reach is None or not len(moving):
            return
        picked = Reach.instants(len(moving), frames=len(self._static.children) + len(moving.children) + 1)
        sampled = Transforms(moving.parents, moving.children, moving.translation[picked], moving.rotation[picked])
        self._reach.add(root_from_link(self._static, sampled, root=self._prefix + self._robot.root))

    def blueprint(self) -> rrb.Blueprint:  # the layout (tfrec.viewer.blueprint) of :meth:`layout`
        return blueprint_of(self.layout())

    def layout(self, name: str | None = None) -> rrb.Container | rrb.View:
        """The 3D view, joint plots and TF tree of the sink's robot, under its entity prefix (``name``: a tab's)."""
        units = joint_units(self._robot, [j.name for j in self._robot.moving_joints] if self._robot else []) | self._units
        return robot_layout(eye=self._reach.eye() if self._reach is not None else None, units=units,
                                velocities=self._has_velocities, tf_tree=self._tf_tree, root=self._root, name=name)

    def send_blueprint(self, blueprint: rrb.Blueprint | None = None) -> None:
        """Send ``blueprint`` (default :meth:`blueprint`) now; :meth:`finish` then sends none."""
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
        flush(self._rec, file=self._file, target=self._target)

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
            disconnect(self._rec)

    def abort(self) -> None:
        """Stop logging; the file of a sink made with a path is deleted."""
        disconnect(self._rec)
        if self._file is not None:
            self._file.unlink(missing_ok=True)

    # -- helpers ---------------------------------------------------------------------------

    def _send(self, entity: str, index: list[ArrowTimeColumn], columns: Any, *, nbytes: int = 0) -> None:
        rr.send_columns(self._root + entity, indexes=index, columns=columns, recording=self._rec, strict=True)
        self._unflushed_bytes += nbytes
        if self._unflushed_bytes >= _FLUSH_BYTES:
            self.flush()

    def log_display_prefix(self, prefix: str) -> None:  # what the viewer puts before the frame ids (paths)
        self._send_static(f"/{DISPLAY_PREFIX_ROOT}", rr.TextDocument.columns(text=[prefix], media_type=["text/plain"]))

    def _send_static(self, entity: str, columns: Any) -> None:
        self._send(entity, [], columns)

    def _style_joint(self, name: str, *, velocity: bool) -> None:
        """A joint's plot colour and name, once (its colour from its place in the robot's URDF)."""
        if name in self._units:
            return
        self._units[name] = joint_units(self._robot, [name])[name]
        index = self._joint_order.setdefault(name, len(self._joint_order))
        style = rr.SeriesLines.columns(colors=[joint_colour(index)], names=[name])
        self._send_static(joint_entity(name), style)
        if velocity:
            self._send_static(velocity_entity(name), style)

    def _index(self, stamps: NDArray[np.int64]) -> list[ArrowTimeColumn]:
        """The index columns of ``stamps``: ROS time, and the time since the start given to :meth:`begin`."""
        if self._origin_ns is None:
            return [time_column(stamps)]
        return [time_column(stamps), elapsed_column(stamps, self._origin_ns)]

    def _write_scalars(self, entity: str, index: list[ArrowTimeColumn], stamps: NDArray[np.int64],
                       values: Array) -> None:
        """One column of joint values at ``index`` (the ``stamps``); values that are NaN are left out."""
        given = np.isfinite(values)
        if given.all():
            self._send(entity, index, [scalar_column(values)], nbytes=stamps.nbytes + values.nbytes)
        elif given.any():
            kept = stamps[given]
            self._send(entity, self._index(kept), [scalar_column(values[given])], nbytes=2 * kept.nbytes)

    def _write_pair(self, parent: str, child: str, index: list[ArrowTimeColumn], stamps: NDArray[np.int64],
                    translation: Array, rotation: Array) -> None:
        last = self._last_pair_ns.get((parent, child))
        if np.any(np.diff(stamps) < 0) or (last is not None and stamps[0] < last):
            raise WriteError(f"transforms '{parent}' -> '{child}': stamps go back in time")
        self._last_pair_ns[(parent, child)] = int(stamps[-1])
        joint = self._joint_of_pair.get((parent, child))
        n = len(stamps)
        columns = transform_columns(translation, rotation, parent, child)
        self._send(tf_entity(joint) if joint is not None else pair_entity(parent, child), index, columns,
                   nbytes=stamps.nbytes + n * (28 + len(parent) + len(child)))  # float32 x 7


