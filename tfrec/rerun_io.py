"""The Rerun sink: a robot moving along a trajectory as a ``.rrd`` recording.

Opened with ``rerun OUT.rrd`` it shows what RViz shows with the RobotModel and TF displays, plus
plots of the joint states. It uses Rerun's named transform frames, which model ROS's tf2: every
link is a frame named like its TF frame (``frame_prefix`` + link name), joint transforms relate
frame pairs, and geometry is attached to frames.

Entity paths (``<link>`` and ``<joint>`` are URDF names, escaped with
``rr.escape_entity_path_part``); static unless marked *ros_time*:

- ``/``: ``ViewCoordinates`` RIGHT_HAND_Z_UP (x forward, z up, as ROS's REP 103);
- ``/__properties``: ``RecordingInfo``, the robot's name and the start time;
- ``/robot``: ``CoordinateFrame`` of the root link (the 3D view's origin);
- ``/robot/<link>``: ``CoordinateFrame`` of the link and ``TransformAxes3D`` (RViz's TF display);
- ``/robot/<link>/visual_<i>``: ``CoordinateFrame``, ``InstancePoses3D`` (the visual origin and
  mesh scale) and ``Boxes3D``, ``Cylinders3D``, ``Ellipsoids3D`` or ``Asset3D``;
- ``/tf_static/<joint>``: ``Transform3D`` parent_from_child of a fixed joint;
- ``/tf/<joint>``: ``Transform3D`` of a moving joint, *ros_time*;
- ``/joints/<joint>``: ``Scalars``, the joint position (rad or m), *ros_time*;
- ``/joint_velocities/<joint>``: ``Scalars``, the joint velocity (rad/s or m/s), *ros_time*;
- ``/robot_description``: ``TextDocument``, the expanded URDF.

The timeline ``ros_time`` holds the stamps of the recording as timestamps (integer
nanoseconds since the Unix epoch, like ROS time). Everything is sent with ``send_columns``:
one chunk per entity and piece of trajectory, no wall-clock ``log_time`` column, so the same
inputs and recording id give recordings ``rerun rrd compare`` finds identical.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from .errors import RecordingError
from .kinematics import Transforms, world_from_link
from .model import Mesh, Robot
from .rerun_geometry import MeshLoader, visual_columns, visual_radius
from .rotations import quaternion_rotate

__all__ = [
    "APPLICATION_ID",
    "TIMELINE",
    "RerunSink",
    "joint_entity",
    "link_entity",
    "tf_entity",
    "tf_static_entity",
    "velocity_entity",
    "visual_entity",
]

APPLICATION_ID = "tfrec"
"""The Rerun application id of every tfrec recording."""

TIMELINE = "ros_time"
"""The timeline holding the ROS stamps (timestamps, integer nanoseconds)."""

_EYE_SAMPLES = 256
"""Samples of the first chunk the default camera is fitted to."""


def link_entity(link: str) -> str:
    """``/robot/<link>``: the link's frame and its TF axes."""
    return f"/robot/{rr.escape_entity_path_part(link)}"


def visual_entity(link: str, index: int) -> str:
    """``/robot/<link>/visual_<index>``: the link's visual number ``index`` (document order)."""
    return f"{link_entity(link)}/visual_{index}"


def tf_entity(joint: str) -> str:
    """``/tf/<joint>``: the transforms of a moving joint over time."""
    return f"/tf/{rr.escape_entity_path_part(joint)}"


def tf_static_entity(joint: str) -> str:
    """``/tf_static/<joint>``: the transform of a fixed joint."""
    return f"/tf_static/{rr.escape_entity_path_part(joint)}"


def joint_entity(joint: str) -> str:
    """``/joints/<joint>``: the joint's position as a time series."""
    return f"/joints/{rr.escape_entity_path_part(joint)}"


def velocity_entity(joint: str) -> str:
    """``/joint_velocities/<joint>``: the joint's velocity as a time series."""
    return f"/joint_velocities/{rr.escape_entity_path_part(joint)}"


class RerunSink:
    """Writes one robot recording to a ``.rrd`` file, in chunks.

    Call :meth:`begin` once, :meth:`write_chunk` for each piece of the trajectory (stamps
    increasing), then :meth:`finish`; after an error call :meth:`abort`. Writing is streamed:
    memory stays bounded by the chunk size.

    Args:
        path: the file to write (the caller renames it into place on success).
        robot: the robot; its ``source`` anchors relative mesh paths and its own package.
        recording_id: the Rerun recording id; derive it from the inputs for reproducible files.
        package_paths: folders searched first for ``package://`` meshes.
        frame_prefix: put in front of every TF frame id (as in the transforms given).
        axis_length_m: length of the TF axes; default: a tenth of the robot's reach, between
            2 cm and 25 cm.

    Raises:
        RecordingError: the file cannot be created.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        robot: Robot,
        recording_id: str,
        package_paths: Sequence[str | os.PathLike[str]] = (),
        frame_prefix: str = "",
        axis_length_m: float | None = None,
    ) -> None:
        self._path = Path(path)
        self._robot = robot
        self._prefix = frame_prefix
        self._package_paths = tuple(package_paths)
        self._axis_length_m = axis_length_m if axis_length_m is not None else _default_axis_length(robot)
        self._joint_of_child = {frame_prefix + joint.child: joint.name for joint in robot.joints}
        self._static: Transforms | None = None
        self._eye: rrb.EyeControls3D | None = None
        self._visual_radii: dict[tuple[str, int], float] = {}
        self._last_time_ns: int | None = None
        self._rec = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id, send_properties=False)
        try:
            with open(self._path, "wb"):
                pass  # fail here with the OS's own words
            self._rec.save(self._path)
        except OSError as err:
            raise RecordingError(f"{self._path}: cannot write: {err.strerror or err}") from None
        except RuntimeError as err:  # Rerun could not write the file's header
            raise RecordingError(f"{self._path}: cannot write: {err}") from None

    @property
    def path(self) -> Path:
        return self._path

    def begin(self, *, static: Transforms, start_time_ns: int, robot_description: str | None = None) -> None:
        """Log what does not change: geometry, frames and TF axes, fixed joints, the URDF.

        Args:
            static: the fixed joints' transforms (N = 1), as from
                :func:`tfrec.kinematics.static_transforms` with the same frame prefix.
            start_time_ns: the stamp of the first sample (the recording's start time).
            robot_description: the URDF text, kept at ``/robot_description``.

        A mesh that cannot be found or read gives one warning naming the file and the link;
        the rest of the robot is logged.
        """
        self._static = static
        robot = self._robot
        # The recording's name and start time, in one chunk (the SDK's own calls go through its
        # batcher, whose time-based flushes split them differently from run to run).
        info = rr.archetypes.RecordingInfo.columns(start_time=[int(start_time_ns)], name=[robot.name])
        self._static_columns("/__properties", info)
        self._static_columns("/", rr.ViewCoordinates.columns(xyz=[rr.ViewCoordinates.RIGHT_HAND_Z_UP]))
        self._static_columns("/robot", rr.CoordinateFrame.columns(frame=[self._prefix + robot.root]))
        if robot_description is not None:
            self._static_columns(
                "/robot_description", rr.TextDocument.columns(text=[robot_description], media_type=["text/plain"])
            )
        meshes = MeshLoader(self._package_paths, source=robot.source)
        warned: set[tuple[str, str]] = set()
        for link in robot.links:
            frame = [self._prefix + link.name]
            self._static_columns(
                link_entity(link.name),
                [
                    *rr.CoordinateFrame.columns(frame=frame),
                    *rr.TransformAxes3D.columns(axis_length=[self._axis_length_m], show_frame=[True]),
                ],
            )
            for index, visual in enumerate(link.visuals):
                asset = None
                if isinstance(visual.geometry, Mesh):
                    uri = visual.geometry.filename
                    found = meshes.load(uri)
                    if isinstance(found, str):
                        if (uri, link.name) not in warned:
                            warned.add((uri, link.name))
                            warnings.warn(
                                f"{uri}: mesh for link '{link.name}' {found}; link logged without it", stacklevel=2
                            )
                    else:
                        asset = found
                self._visual_radii[(link.name, index)] = visual_radius(visual, asset)
                columns = [*rr.CoordinateFrame.columns(frame=frame), *visual_columns(visual, asset)]
                self._static_columns(visual_entity(link.name, index), columns)
        for k in range(len(static.children)):
            self._static_columns(
                tf_static_entity(self._joint_name(static.children[k])),
                rr.Transform3D.columns(
                    translation=static.translation[:1, k],
                    quaternion=static.rotation[:1, k],
                    parent_frame=[static.parents[k]],
                    child_frame=[static.children[k]],
                ),
            )

    def write_chunk(
        self,
        *,
        time_ns: NDArray[np.int64],
        joint_names: Sequence[str],
        positions: NDArray[np.float64],
        velocities: NDArray[np.float64],
        transforms: Transforms,
    ) -> None:
        """Log a piece of the trajectory: joint states and the moving joints' transforms.

        Args:
            time_ns: int64 (n,) absolute stamps (nanoseconds since the epoch), increasing.
            joint_names: the joints of the position and velocity columns.
            positions, velocities: float64 (n, J).
            transforms: parent_from_child of the moving joints, N = n.

        Raises:
            RecordingError: arrays whose shapes do not match, or stamps that go back in time.
        """
        stamps = np.asarray(time_ns)
        n = len(stamps)
        if stamps.dtype != np.int64 or stamps.shape != (n,):
            raise RecordingError(f"time_ns must be int64 of shape (n,), got {stamps.dtype} {stamps.shape}")
        shape = (n, len(joint_names))
        if np.shape(positions) != shape or np.shape(velocities) != shape or len(transforms) != n:
            raise RecordingError(
                f"chunk of {n} stamps has positions {np.shape(positions)}, velocities {np.shape(velocities)} "
                f"and {len(transforms)} transforms; expected {shape}"
            )
        if n == 0:
            return
        if np.any(np.diff(stamps) < 0) or (self._last_time_ns is not None and stamps[0] < self._last_time_ns):
            raise RecordingError("chunk stamps go back in time")
        self._last_time_ns = int(stamps[-1])
        index = [rr.TimeColumn(TIMELINE, timestamp=stamps.astype("datetime64[ns]"))]
        for j, name in enumerate(joint_names):
            self._send(joint_entity(name), index, rr.Scalars.columns(scalars=positions[:, j]))
            self._send(velocity_entity(name), index, rr.Scalars.columns(scalars=velocities[:, j]))
        for k, (parent, child) in enumerate(zip(transforms.parents, transforms.children)):
            self._send(
                tf_entity(self._joint_name(child)),
                index,
                rr.Transform3D.columns(
                    translation=transforms.translation[:, k],
                    quaternion=transforms.rotation[:, k],
                    parent_frame=_repeated(parent, n),
                    child_frame=_repeated(child, n),
                ),
            )
        if self._eye is None and self._static is not None:
            self._eye = self._eye_at(transforms)

    def finish(self) -> None:
        """Send the blueprint, flush everything and close the file.

        Raises:
            RecordingError: the data could not be written out.
        """
        self._rec.send_blueprint(self._blueprint())
        try:
            self._rec.flush()
        except RuntimeError as err:  # Rerun's file writer stopped: disk full, file too large...
            raise RecordingError(f"{self._path}: cannot write: {err}") from None
        finally:
            self._rec.disconnect()

    def abort(self) -> None:
        """Stop writing and delete the partial file."""
        self._rec.disconnect()
        self._path.unlink(missing_ok=True)

    # -- helpers ---------------------------------------------------------------------------

    def _joint_name(self, child_frame: str) -> str:
        return self._joint_of_child.get(child_frame, child_frame)

    def _send(self, entity: str, index: list[rr.TimeColumn], columns: Any) -> None:
        rr.send_columns(entity, indexes=index, columns=columns, recording=self._rec, strict=True)

    def _static_columns(self, entity: str, columns: Any) -> None:
        self._send(entity, [], columns)

    def _blueprint(self) -> rrb.Blueprint:
        view3d = rrb.Spatial3DView(name="robot", origin="/robot", eye_controls=self._eye)
        plots = rrb.Tabs(
            rrb.TimeSeriesView(name="joint positions", origin="/joints"),
            rrb.TimeSeriesView(name="joint velocities", origin="/joint_velocities"),
        )
        return rrb.Blueprint(
            rrb.Horizontal(view3d, plots, column_shares=[3, 2]),
            rrb.BlueprintPanel(state="collapsed"),
            rrb.SelectionPanel(state="collapsed"),
            rrb.TimePanel(state="collapsed", timeline=TIMELINE),
        )

    def _eye_at(self, transforms: Transforms) -> rrb.EyeControls3D | None:
        """A camera that sees the robot move through ``transforms``, from front-left and above.

        RViz's orbit view starts at 45° yaw and pitch; this looks from 45° yaw, 30° pitch at
        the middle of the space swept by the links and visuals, from a distance that fits it.
        """
        assert self._static is not None
        picked = np.unique(np.linspace(0, len(transforms) - 1, min(len(transforms), _EYE_SAMPLES)).astype(int))
        moving = Transforms(transforms.parents, transforms.children, transforms.translation[picked],
                            transforms.rotation[picked])
        world = world_from_link(self._static, moving, root=self._prefix + self._robot.root)
        by_frame = {child: k for k, child in enumerate(world.children)}
        points: list[NDArray[np.float64]] = []
        radii: list[float] = []
        for link in self._robot.links:
            k = by_frame.get(self._prefix + link.name)
            if k is None:
                continue
            origin = world.translation[:, k]
            points.append(origin)
            radii.append(0.0)
            for index, visual in enumerate(link.visuals):
                points.append(origin + quaternion_rotate(world.rotation[:, k], np.asarray(visual.origin.xyz)))
                radii.append(self._visual_radii.get((link.name, index), 0.0))
        if not points:
            return None
        cloud = np.concatenate(points)
        pad = np.repeat(radii, len(picked))[:, np.newaxis]
        low, high = (cloud - pad).min(axis=0), (cloud + pad).max(axis=0)
        centre = (low + high) / 2.0
        radius = max(float(np.max(np.linalg.norm(cloud - centre, axis=1) + pad[:, 0])), 0.1)
        distance = 2.0 * radius
        yaw, pitch = math.radians(45.0), math.radians(30.0)
        direction = np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)])
        return rrb.EyeControls3D(
            position=(centre + distance * direction).tolist(), look_target=centre.tolist(), eye_up=[0.0, 0.0, 1.0]
        )


def _repeated(text: str, n: int) -> pa.Array:
    """``n`` copies of ``text`` as an Arrow string array, built from buffers (a list of n Python
    strings costs Rerun's converter about as much as everything else in a chunk)."""
    data = text.encode()
    offsets = np.arange(n + 1, dtype=np.int32) * len(data)
    return pa.StringArray.from_buffers(n, pa.py_buffer(offsets), pa.py_buffer(data * n))


def _default_axis_length(robot: Robot) -> float:
    """A tenth of the longest chain of joint offsets from the root, within [2 cm, 25 cm]."""
    reach: dict[str, float] = {robot.root: 0.0}
    for joint in robot.tree_order:
        reach[joint.child] = reach.get(joint.parent, 0.0) + float(np.linalg.norm(joint.origin.xyz))
    return min(max(0.1 * max(reach.values()), 0.02), 0.25)
