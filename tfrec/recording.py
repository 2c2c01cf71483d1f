"""``tfrec record``: robot + trajectory → FK in chunks → MCAP / rosbag2 directory / Rerun sinks.

Every output of one recording is written to a temporary file (or folder) beside its target and
renamed only when all of them are complete; after an error or Ctrl-C no partial output remains
and older files of those names are untouched.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import RecordingError
from .kinematics import DEFAULT_CHUNK_SIZE, iter_dynamic_chunks, static_transforms
from .mcap_io import DEFAULT_START_TIME_NS, McapSink, check_time_range, write_bag_metadata
from .model import Robot
from .trajectory import JointTrajectory

__all__ = [
    "DEFAULT_START_TIME_NS",
    "RecordResult",
    "RecordingPlan",
    "default_stem",
    "plan_outputs",
    "record",
    "recording_id",
]


COMPRESSIONS = ("none", "lz4", "zstd")


def default_stem(robot: Robot, traj: str, *, now: float | None = None) -> str:
    """``<robot>-<traj>-<YYYYmmdd-HHMMSS>`` (local time), like ros2 bag's default names."""
    label = Path(traj).stem if traj not in ("center", "random", "sine", "sweep") else traj
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(time.time() if now is None else now))
    return f"{robot.name}-{label}-{stamp}"


@dataclass(frozen=True, slots=True)
class RecordingPlan:
    """Where a recording goes. ``bag_dir`` set means a rosbag2 folder holding the MCAP."""

    mcap: Path | None
    rrd: Path | None
    bag_dir: Path | None = None

    def targets(self) -> list[Path]:
        return [p for p in (self.bag_dir if self.bag_dir else self.mcap, self.rrd) if p is not None]


def plan_outputs(
    *,
    stem: str,
    out: str | os.PathLike[str] | None = None,
    rrd: str | os.PathLike[str] | None = None,
    bag: str | os.PathLike[str] | None = None,
    no_mcap: bool = False,
    no_rrd: bool = False,
    folder: str | os.PathLike[str] = "recordings",
    force: bool = False,
) -> RecordingPlan:
    """Decide the output paths and check them before anything is written.

    Raises:
        RecordingError: nothing to write, conflicting options, or a target that exists
            without ``force``.
    """
    if no_mcap and no_rrd:
        raise RecordingError("--no-mcap and --no-rrd together leave nothing to write")
    if bag is not None and (out is not None or no_mcap):
        raise RecordingError("--bag DIR writes the MCAP inside DIR; it goes with neither -o nor --no-mcap")
    if no_rrd and rrd is not None:
        raise RecordingError("--rrd and --no-rrd contradict each other")
    bag_dir = Path(bag) if bag is not None else None
    mcap: Path | None = None
    if bag_dir is not None:
        mcap = bag_dir / f"{bag_dir.name}_0.mcap"
    elif not no_mcap:
        mcap = Path(out) if out is not None else Path(folder) / f"{stem}.mcap"
        if mcap.suffix != ".mcap":
            raise RecordingError(f"{mcap}: the MCAP output's name must end in .mcap")
    rrd_path: Path | None = None
    if not no_rrd:
        if rrd is not None:
            rrd_path = Path(rrd)
        elif bag_dir is not None:
            rrd_path = bag_dir.with_name(bag_dir.name + ".rrd")
        elif mcap is not None:
            rrd_path = mcap.with_suffix(".rrd")
        else:
            rrd_path = Path(folder) / f"{stem}.rrd"
        if rrd_path.suffix != ".rrd":
            raise RecordingError(f"{rrd_path}: the Rerun output's name must end in .rrd")
    plan = RecordingPlan(mcap=mcap, rrd=rrd_path, bag_dir=bag_dir)
    for target in plan.targets():
        if target.exists() and not force:
            raise RecordingError(f"{target}: already exists (use --force to overwrite)")
        if target.exists() and target.is_dir() != (target == bag_dir):
            raise RecordingError(f"{target}: exists and is a {'folder' if target.is_dir() else 'file'}")
    return plan


def recording_id(robot: Robot, trajectory: JointTrajectory, *, start_time_ns: int, frame_prefix: str) -> str:
    """A recording id derived from the inputs: the same command gives the same id."""
    digest = hashlib.sha256()
    digest.update(robot.urdf.encode())
    for name in trajectory.joint_names:
        digest.update(name.encode() + b"\0")
    digest.update(trajectory.time_ns.tobytes())
    digest.update(trajectory.positions.tobytes())
    digest.update(f"{start_time_ns}|{frame_prefix}".encode())
    return str(uuid.UUID(bytes=digest.digest()[:16], version=5))


@dataclass
class RecordResult:
    """What a recording wrote."""

    plan: RecordingPlan
    samples: int
    messages: int
    start_time_ns: int
    end_time_ns: int
    paths: list[Path] = field(default_factory=list)


class _Staging:
    """Temporary outputs beside their targets, renamed together on success."""

    def __init__(self) -> None:
        self._pairs: list[tuple[Path, Path]] = []

    def path(self, target: Path, *, directory: bool = False) -> Path:
        target.parent.mkdir(parents=True, exist_ok=True)
        temp = target.parent / f".{target.name}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        if directory:
            temp.mkdir()
        self._pairs.append((temp, target))
        return temp

    def target_of(self, filename: object) -> str:
        """The output a (temporary) file name stands for, for messages."""
        if filename is None:
            return "output"
        name = Path(os.fsdecode(filename))  # type: ignore[arg-type]
        for temp, target in self._pairs:
            if name == temp or temp in name.parents:
                return str(target)
        return str(name)

    def with_targets(self, message: str) -> str:
        """``message`` with every temporary path replaced by its target's."""
        for temp, target in self._pairs:
            message = message.replace(str(temp), str(target))
        return message

    def commit(self) -> None:
        for temp, target in self._pairs:
            if target.is_dir() and temp.is_dir():
                shutil.rmtree(target)
            os.replace(temp, target)
        self._pairs.clear()

    def abort(self) -> None:
        for temp, _ in self._pairs:
            if temp.is_dir():
                shutil.rmtree(temp, ignore_errors=True)
            else:
                temp.unlink(missing_ok=True)
        self._pairs.clear()


def _abort_sinks(sinks: Sequence[Any]) -> None:
    """Close sinks that hold files open (Rerun's writer) before their temporary files are removed."""
    for sink in sinks:
        abort = getattr(sink, "abort", None)
        if abort is not None:
            abort()


def record(
    robot: Robot,
    trajectory: JointTrajectory,
    plan: RecordingPlan,
    *,
    compression: str = "zstd",
    start_time_ns: int = DEFAULT_START_TIME_NS,
    frame_prefix: str = "",
    package_paths: Sequence[str | os.PathLike[str]] = (),
    chunk_size: int = DEFAULT_CHUNK_SIZE,
    progress: Callable[[int, int], None] | None = None,
    _fail_after_chunks: int | None = None,
) -> RecordResult:
    """Write the recording ``plan`` describes, streaming the trajectory in chunks.

    Args:
        robot: the robot (its ``urdf`` goes to /robot_description).
        trajectory: the joint trajectory, times from 0.
        plan: the outputs, from :func:`plan_outputs`.
        compression: MCAP chunk compression, ``none``, ``lz4`` or ``zstd``.
        start_time_ns: the stamp of the first sample.
        frame_prefix: put in front of every TF frame id.
        package_paths: where meshes' packages are looked up (Rerun geometry).
        chunk_size: samples per chunk; memory is bounded by it.
        progress: called with (samples done, samples in all) after every chunk.

    Raises:
        RecordingError: the outputs could not be written; no partial output remains.
    """
    if compression not in COMPRESSIONS:
        raise RecordingError(f"compression '{compression}' is not one of {', '.join(COMPRESSIONS)}")
    total = len(trajectory)
    if total:
        check_time_range(int(trajectory.time_ns[0]) + start_time_ns, int(trajectory.time_ns[-1]) + start_time_ns)
    static = static_transforms(robot, frame_prefix=frame_prefix)
    staging = _Staging()
    streams = []
    sinks: list[Any] = []
    try:
        mcap_temp: Path | None = None
        bag_temp: Path | None = None
        if plan.bag_dir is not None and plan.mcap is not None:
            bag_temp = staging.path(plan.bag_dir, directory=True)
            mcap_temp = bag_temp / plan.mcap.name
        elif plan.mcap is not None:
            mcap_temp = staging.path(plan.mcap)
        if mcap_temp is not None:
            stream = open(mcap_temp, "wb")  # noqa: SIM115 - closed below
            streams.append(stream)
            sinks.append(McapSink(stream, compression=compression, file_name=plan.mcap.name if plan.mcap else ""))
        if plan.rrd is not None:
            from .rerun_io import RerunSink

            sinks.append(RerunSink(
                staging.path(plan.rrd), robot=robot, package_paths=package_paths, frame_prefix=frame_prefix,
                recording_id=recording_id(robot, trajectory, start_time_ns=start_time_ns, frame_prefix=frame_prefix),
            ))
        for sink in sinks:
            sink.begin(robot_description=robot.urdf, static=static, start_time_ns=start_time_ns)
        done = 0
        for index, chunk in enumerate(iter_dynamic_chunks(robot, trajectory, chunk_size=chunk_size,
                                                          frame_prefix=frame_prefix)):
            if _fail_after_chunks is not None and index >= _fail_after_chunks:
                raise RecordingError("injected failure (test)")
            stamps = chunk.time_ns + start_time_ns
            for sink in sinks:
                sink.write_chunk(time_ns=stamps, joint_names=chunk.names, positions=chunk.positions,
                                 velocities=chunk.velocities, transforms=chunk.transforms)
            done += len(chunk.time_ns)
            if progress is not None:
                progress(done, total)
        for sink in sinks:
            sink.finish()
        for stream in streams:
            stream.close()
        if bag_temp is not None and mcap_temp is not None and plan.bag_dir is not None:
            write_bag_metadata(bag_temp, mcap_temp, final_mcap_name=plan.mcap.name if plan.mcap else mcap_temp.name)
        staging.commit()
    except OSError as err:
        where = staging.target_of(err.filename)
        _abort_sinks(sinks)
        staging.abort()
        raise RecordingError(f"{where}: cannot write: {err.strerror or err}") from None
    except RecordingError as err:  # a sink's message names its temporary file: name the target
        message = staging.with_targets(str(err))
        _abort_sinks(sinks)
        staging.abort()
        raise RecordingError(message) from None
    except BaseException:
        _abort_sinks(sinks)
        staging.abort()
        raise
    finally:
        for stream in streams:
            stream.close()
    first = int(trajectory.time_ns[0]) + start_time_ns if total else start_time_ns
    last = int(trajectory.time_ns[-1]) + start_time_ns if total else start_time_ns
    return RecordResult(plan=plan, samples=total, messages=2 + 2 * total, start_time_ns=first,
                        end_time_ns=last, paths=plan.targets())
