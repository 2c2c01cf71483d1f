"""``tfrec record``: robot + trajectory → FK in chunks → MCAP / rosbag2 directory / Rerun sinks.

Every output of one recording is written to a temporary file (or folder) beside its target and
renamed only when all of them are complete; after an error or Ctrl-C no partial output remains
and older files of those names are untouched.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tfrec._address_space import check_rerun_address_space
from tfrec._atomic import AtomicOutputs
from tfrec._outputs import OutputKind, check_outputs
from tfrec.conventions import DEFAULT_START_TIME_NS
from tfrec.errors import WriteError
from tfrec.formats.kinds import MCAP, ROS1_BAG, ROSBAG2, RRD
from tfrec.formats.mcap.sink import McapSink
from tfrec.formats.mcap.writer import check_time_range
from tfrec.formats.rosbag2.metadata import bag_storage_name, write_bag_metadata
from tfrec.formats.sink import RecordSink
from tfrec.kinematics.fk import DEFAULT_CHUNK_SAMPLES, iter_dynamic_chunks, static_transforms
from tfrec.model import Robot
from tfrec.trajectory.types import JointTrajectory, TrajectoryKind

__all__ = [
    "DEFAULT_START_TIME_NS",  # re-exported from tfrec.conventions
    "RecordResult",
    "RecordingPlan",
    "default_stem",
    "needs_stem",
    "open_sinks",
    "plan_outputs",
    "record",
    "recording_id",
]


def default_stem(robot: Robot, traj: str, *, now: float | None = None) -> str:
    """``<robot>-<traj>-<YYYYmmdd-HHMMSS>`` (local time), like ros2 bag's default names (``robot`` for a robot
    whose name is empty, which urdfdom allows)."""
    label = traj if traj in {kind.value for kind in TrajectoryKind} else Path(traj).stem
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(time.time() if now is None else now))
    return f"{robot.name or 'robot'}-{label}-{stamp}"


@dataclass(frozen=True, slots=True)
class RecordingPlan:
    """Where a recording goes. ``bag_dir`` set means a rosbag2 folder holding the MCAP; ``ros1_bag`` a
    ROS 1 bag (``-o out.bag``), written instead of the MCAP."""

    mcap: Path | None
    rrd: Path | None
    bag_dir: Path | None = None
    force: bool = False
    """Existing outputs may be replaced (``--force``)."""
    ros1_bag: Path | None = None

    @property
    def main(self) -> Path | None:
        """The ROS output (rosbag2 folder, ROS 1 bag or MCAP), or None when only the ``.rrd`` is written."""
        return self.bag_dir or self.ros1_bag or self.mcap


def plan_outputs(
    *,
    stem: str | None,
    out: str | os.PathLike[str] | None = None,
    rrd: str | os.PathLike[str] | None = None,
    bag: str | os.PathLike[str] | None = None,
    no_mcap: bool = False,
    no_rrd: bool = False,
    folder: str | os.PathLike[str] = "recordings",
    force: bool = False,
    inputs: Sequence[str | os.PathLike[str] | None] = (),
) -> RecordingPlan:
    """Decide the output paths and check them before anything is written.

    Args:
        stem: the name of default outputs (:func:`default_stem`); None when every output is named
            (:func:`needs_stem` is False), so that they are checked before the robot is loaded.
        inputs: what the recording reads (the description, a CSV trajectory): never an output.

    Raises:
        WriteError: nothing to write, conflicting options, or a target that
            :func:`tfrec._outputs.check_outputs` refuses (wrong extension, exists without ``force``, not
            what tfrec writes there, an input).
    """
    if no_mcap and no_rrd:
        raise WriteError("`no_mcap` and `no_rrd` together leave nothing to write")
    if bag is not None and (out is not None or no_mcap):
        raise WriteError("`bag` writes the MCAP inside its folder; it goes with neither `out` nor `no_mcap`")
    if no_rrd and rrd is not None:
        raise WriteError("`rrd` and `no_rrd` contradict each other")
    if stem is None and needs_stem(out=out, rrd=rrd, bag=bag, no_mcap=no_mcap):
        raise ValueError("plan_outputs: a default output name needs `stem`")
    bag_dir = Path(bag) if bag is not None else None
    mcap: Path | None = None
    ros1_bag: Path | None = None
    if bag_dir is not None:
        mcap = bag_dir / bag_storage_name(bag_dir.name)
    elif out is not None and Path(out).suffix == ".bag":
        ros1_bag = Path(out)
    elif not no_mcap:
        mcap = Path(out) if out is not None else Path(folder) / f"{stem}.mcap"
    rrd_path = None if no_rrd else _rrd_path(rrd, bag_dir, ros1_bag or mcap, folder, stem)
    targets: list[tuple[Path, OutputKind]] = []
    if bag_dir is not None:
        targets.append((bag_dir, ROSBAG2))
    elif ros1_bag is not None:
        targets.append((ros1_bag, ROS1_BAG))
    elif mcap is not None:
        targets.append((mcap, MCAP))
    if rrd_path is not None:
        targets.append((rrd_path, RRD))
    check_outputs(targets, force=force, inputs=inputs)
    return RecordingPlan(mcap=mcap, rrd=rrd_path, bag_dir=bag_dir, force=force, ros1_bag=ros1_bag)


def _rrd_path(rrd: str | os.PathLike[str] | None, bag_dir: Path | None, main: Path | None,
              folder: str | os.PathLike[str], stem: str | None) -> Path:
    """Where the ``.rrd`` goes: ``rrd``, else beside the bag folder or the main output, else the default."""
    if rrd is not None:
        return Path(rrd)
    if bag_dir is not None:
        return bag_dir.with_name(bag_dir.name + ".rrd")
    if main is not None:
        return main.with_suffix(".rrd")
    return Path(folder) / f"{stem}.rrd"


def needs_stem(*, out: str | os.PathLike[str] | None, rrd: str | os.PathLike[str] | None,
               bag: str | os.PathLike[str] | None, no_mcap: bool) -> bool:
    """Whether an output goes to its default name (which :func:`default_stem` makes from the robot's name)."""
    return out is None and bag is None and not (no_mcap and rrd is not None)


def recording_id(robot: Robot, trajectory: JointTrajectory, *, start_time_ns: int, frame_prefix: str) -> str:
    """A recording id derived from the inputs: the same command gives the same id."""
    digest = hashlib.sha256()
    digest.update(robot.urdf.encode())
    for name in trajectory.joint_names:
        digest.update(name.encode() + b"\0")
    digest.update(_bytes_of(trajectory.time_ns))
    for piece in trajectory.chunks(DEFAULT_CHUNK_SAMPLES):  # the positions' bytes in order, never all at once
        digest.update(_bytes_of(piece.positions))
    digest.update(f"{start_time_ns}|{frame_prefix}".encode())
    return str(uuid.UUID(bytes=digest.digest()[:16], version=5))


def _bytes_of(array: np.ndarray[Any, Any]) -> memoryview:
    """The bytes of an array, hashed in place (not copied); none for an array without elements (a robot
    without moving joints), whose memoryview cannot be cast."""
    contiguous = np.ascontiguousarray(array)
    return contiguous.data.cast("B") if contiguous.size else memoryview(b"")


@dataclass(frozen=True, slots=True)
class RecordResult:
    """What a recording wrote: the outputs, and the samples with the stamps of the first and last."""

    plan: RecordingPlan
    samples: int
    start_time_ns: int
    end_time_ns: int


def _abort_sinks(sinks: Sequence[RecordSink]) -> None:
    """Give the outputs up (Rerun's writer holds its file open) before their temporary files are removed."""
    for sink in sinks:
        sink.abort()


def record(
    robot: Robot,
    trajectory: JointTrajectory,
    plan: RecordingPlan,
    *,
    compression: str | None = None,
    start_time_ns: int = DEFAULT_START_TIME_NS,
    frame_prefix: str = "",
    package_paths: Sequence[str | os.PathLike[str]] = (),
    chunk_samples: int = DEFAULT_CHUNK_SAMPLES,
    progress: Callable[[int, int], None] | None = None,
) -> RecordResult:
    """Write the recording ``plan`` describes, streaming the trajectory in chunks.

    Args:
        robot: the robot (its ``urdf`` goes to /robot_description).
        trajectory: the joint trajectory, times from 0.
        plan: the outputs, from :func:`plan_outputs`.
        compression: chunk compression: for an MCAP one of :data:`~tfrec.conventions.COMPRESSIONS`
            (default zstd), for a ROS 1 bag one of :data:`~tfrec.conventions.ROS1_COMPRESSIONS` (default
            none, as ``rosbag record``).
        start_time_ns: the stamp of the first sample.
        frame_prefix: put in front of every TF frame id.
        package_paths: where meshes' packages are looked up (Rerun geometry).
        chunk_samples: samples per chunk; memory is bounded by it.
        progress: called with (samples done, samples in all) after every chunk.

    Raises:
        WriteError: the outputs could not be written (or an unknown compression); no partial
            output remains.
    """
    total = len(trajectory)
    first = int(trajectory.time_ns[0]) + start_time_ns if total else start_time_ns
    last = int(trajectory.time_ns[-1]) + start_time_ns if total else start_time_ns
    check_time_range(first, last)
    if plan.rrd is not None:
        check_rerun_address_space(os.fspath(plan.rrd))  # before rerun is loaded
        from tfrec.formats.rrd.paths import check_rerun_robot

        check_rerun_robot(robot, os.fspath(plan.rrd), hint="record without it (`no_rrd`)")
    rid = (recording_id(robot, trajectory, start_time_ns=start_time_ns, frame_prefix=frame_prefix)
           if plan.rrd is not None else None)
    with open_sinks(robot, plan, compression=compression, start_time_ns=start_time_ns, frame_prefix=frame_prefix,
                    package_paths=package_paths, rerun_recording_id=rid) as sinks:
        done = 0
        # a robot without moving joints gets an empty /joint_states message per sample (so the recording
        # lasts what was asked) and nothing on /tf: robot_state_publisher publishes no /tf for it
        for chunk in iter_dynamic_chunks(robot, trajectory, chunk_samples=chunk_samples, frame_prefix=frame_prefix):
            stamps = chunk.time_ns + start_time_ns
            for sink in sinks:
                sink.write_chunk(stamp_ns=stamps, joint_names=chunk.names, positions=chunk.positions,
                                 velocities=chunk.velocities, transforms=chunk.transforms)
            done += len(chunk.time_ns)
            if progress is not None:
                progress(done, total)
    return RecordResult(plan=plan, samples=total, start_time_ns=first, end_time_ns=last)


@contextlib.contextmanager
def open_sinks(
    robot: Robot,
    plan: RecordingPlan,
    *,
    compression: str | None = None,
    start_time_ns: int = DEFAULT_START_TIME_NS,
    frame_prefix: str = "",
    package_paths: Sequence[str | os.PathLike[str]] = (),
    rerun_recording_id: str | None = None,
) -> Iterator[list[RecordSink]]:
    """The outputs of ``plan`` as begun sinks (/robot_description and /tf_static written, stamped
    ``start_time_ns``): the caller writes the samples; on leaving the block they are finished and renamed into
    place, after an error or an interrupt aborted and removed (older files of those names untouched).
    :func:`record` writes through it, and so does ``tfrec serve --record``.

    Raises:
        WriteError: the outputs could not be written; no partial output remains.
    """
    static = static_transforms(robot, frame_prefix=frame_prefix)
    streams = []
    sinks: list[RecordSink] = []
    with AtomicOutputs(replace=plan.force) as outputs:
        try:
            mcap_sink: McapSink | None = None
            bag_temp: Path | None = None
            if plan.mcap is not None:
                if plan.bag_dir is not None:
                    bag_temp = outputs.path(plan.bag_dir, kind=ROSBAG2)
                    mcap_temp = bag_temp / plan.mcap.name
                else:
                    mcap_temp = outputs.path(plan.mcap, kind=MCAP)
                stream = open(mcap_temp, "wb")  # noqa: SIM115 - closed below
                streams.append(stream)
                mcap_sink = McapSink(stream, compression=compression or "zstd")
                sinks.append(mcap_sink)
            if plan.ros1_bag is not None:
                from tfrec.formats.rosbag1 import Ros1BagSink

                sinks.append(Ros1BagSink(outputs.path(plan.ros1_bag, kind=ROS1_BAG), compression=compression or "none"))
            if plan.rrd is not None:
                from tfrec.viewer.sink import RerunSink

                sinks.append(RerunSink(
                    outputs.path(plan.rrd, kind=RRD), robot=robot, package_paths=package_paths, frame_prefix=frame_prefix,
                    recording_id=rerun_recording_id,
                ))
            for sink in sinks:
                sink.begin(robot_description=robot.urdf, static=static, start_time_ns=start_time_ns)
            yield sinks
            for sink in sinks:
                sink.finish()
            if bag_temp is not None and mcap_sink is not None and plan.mcap is not None:
                write_bag_metadata(bag_temp, mcap_sink.bag_info, file_name=plan.mcap.name)
        except BaseException:
            _abort_sinks(sinks)  # before their temporary files are removed
            raise
        finally:
            for stream in streams:
                stream.close()
        outputs.commit()
