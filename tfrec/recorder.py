"""``tfrec record``: robot + trajectory → FK in chunks → MCAP / rosbag2 directory / Rerun sinks.

Every output of one recording is written to a temporary file (or folder) beside its target and
renamed only when all of them are complete; after an error or Ctrl-C no partial output remains
and older files of those names are untouched.

How a recording was made is kept in it: the recipe (:class:`Recipe`) ``tfrec record`` writes into an MCAP's
metadata, a record named :data:`RECIPE` (a map of strings): the description's path as it was given and the
sha256 of its bytes and of the expanded URDF, the xacro arguments, the trajectory (a kind, or a CSV file's
path and sha256), its seed, rate, duration and the other trajectory options, the start time, the chunk
compression and tfrec's version. ``tfrec record --like REC`` reads it back (:func:`read_recipe`) and makes
the same recording again — byte for byte when nothing it names has changed — and ``tfrec info`` shows it.
The pytest plugin's goldens are made with :func:`record_recipe`. Paths are kept as given; a relative one
is looked up beside the recording first, then in the current folder (:func:`resolve_path`), so a golden
and its description can move together.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import time
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from tfrec._address_space import check_rerun_address_space
from tfrec._atomic import AtomicOutputs
from tfrec._outputs import OutputKind, check_outputs
from tfrec._version import __version__
from tfrec.conventions import DEFAULT_START_TIME_NS
from tfrec.errors import ReadError, WriteError
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
    "RECIPE",
    "Recipe",
    "RecordResult",
    "RecordingPlan",
    "default_stem",
    "needs_stem",
    "open_sinks",
    "plan_outputs",
    "read_recipe",
    "record",
    "record_recipe",
    "recording_id",
    "resolve_path",
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
    metadata: Mapping[str, Mapping[str, str]] | None = None,
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
        metadata: MCAP metadata records (name → map of strings) written into the MCAP (also the one of a
            rosbag2 folder): how the recording was made (:mod:`tfrec.recipe`); a ROS 1 bag has no place for them.

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
                    package_paths=package_paths, rerun_recording_id=rid, metadata=metadata) as sinks:
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
    metadata: Mapping[str, Mapping[str, str]] | None = None,
) -> Iterator[list[RecordSink]]:
    """The outputs of ``plan`` as begun sinks (/robot_description and /tf_static written, stamped
    ``start_time_ns``): the caller writes the samples; on leaving the block they are finished and renamed into
    place, after an error or an interrupt aborted and removed (older files of those names untouched).
    :func:`record` writes through it, and so does ``tfrec serve --record``. ``metadata``: MCAP metadata
    records written into the MCAP (:func:`record`'s).

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
                mcap_sink = McapSink(stream, compression=compression or "zstd", metadata=metadata)
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


# -- the recipe: how a recording was made --------------------------------------------------

RECIPE = "tfrec.recipe"
"""The name of the MCAP metadata record that holds a recording's recipe."""

_VERSION = "1"


@dataclass(frozen=True, slots=True)
class Recipe:
    """What ``tfrec record`` was given (its effective values): enough to make the recording again.

    Attributes:
        description: the description's path, as given.
        args: xacro (or launch) arguments.
        traj: a trajectory kind, or a CSV file's path as given.
        duration_s, rate_hz: None where the default (or a CSV file's own clock) was used.
        seed, period_s, amplitude, interp, hard_limits, overrides: the trajectory options.
        frame_prefix, start_time_ns, compression: the recording options (compression None: the default).
        strict_xacro: xacro expanded as ROS 2's xacro does (``--strict-xacro``).
        velocity_limits: generated trajectories within the joints' velocity limits (not ``--ignore-velocity-limits``).
        description_sha256, urdf_sha256, traj_sha256: hashes of the description file, the expanded
            URDF and a CSV trajectory ("" for a generated one), filled in by the recorder.
        tfrec_version: the version that made the recording.
    """

    description: str
    args: Mapping[str, str] = field(default_factory=dict)
    traj: str = "sine"
    duration_s: float | None = None
    rate_hz: float | None = None
    seed: int = 0
    period_s: float = 2.0
    amplitude: float = 0.8
    interp: str = "linear"
    hard_limits: bool = False
    overrides: Mapping[str, float] = field(default_factory=dict)
    frame_prefix: str = ""
    start_time_ns: int = DEFAULT_START_TIME_NS
    compression: str | None = None
    strict_xacro: bool = False
    velocity_limits: bool = True
    description_sha256: str = ""
    urdf_sha256: str = ""
    traj_sha256: str = ""
    tfrec_version: str = __version__

    def metadata(self) -> dict[str, str]:
        """The recipe as an MCAP metadata map (strings; floats as their exact ``repr``)."""
        return {
            "recipe_version": _VERSION,
            "tfrec_version": self.tfrec_version,
            "description": self.description,
            "description_sha256": self.description_sha256,
            "urdf_sha256": self.urdf_sha256,
            "args": json.dumps(dict(self.args), sort_keys=True),
            "traj": self.traj,
            "traj_sha256": self.traj_sha256,
            "duration_s": "" if self.duration_s is None else repr(float(self.duration_s)),
            "rate_hz": "" if self.rate_hz is None else repr(float(self.rate_hz)),
            "seed": str(self.seed),
            "period_s": repr(float(self.period_s)),
            "amplitude": repr(float(self.amplitude)),
            "interp": self.interp,
            "hard_limits": "true" if self.hard_limits else "false",
            "overrides": json.dumps({name: float(value) for name, value in self.overrides.items()}, sort_keys=True),
            "frame_prefix": self.frame_prefix,
            "start_time_ns": str(self.start_time_ns),
            "compression": self.compression or "",
            "strict_xacro": "true" if self.strict_xacro else "false",
            "velocity_limits": "true" if self.velocity_limits else "false",
            "command": self.command(),
        }

    def command(self) -> str:
        """The ``tfrec record`` command line that makes this recording (shell-quoted)."""
        import shlex

        words = ["tfrec", "record", self.description, *(f"{k}:={v}" for k, v in self.args.items()), "--traj", self.traj]
        for flag, value, default in (("--duration", self.duration_s, None), ("--rate", self.rate_hz, None),
                                     ("--seed", self.seed, 0), ("--period", self.period_s, 2.0),
                                     ("--amplitude", self.amplitude, 0.8), ("--interp", self.interp, "linear"),
                                     ("--compression", self.compression, None)):
            if value != default:
                words += [flag, f"{value:g}" if isinstance(value, float) else str(value)]
        words += [word for name, value in self.overrides.items() for word in ("--set", f"{name}={value:g}")]
        words += ["--hard-limits"] * self.hard_limits + ["--strict-xacro"] * self.strict_xacro
        words += ["--ignore-velocity-limits"] * (not self.velocity_limits)
        if self.frame_prefix:
            words += ["--frame-prefix", self.frame_prefix]
        if self.start_time_ns != DEFAULT_START_TIME_NS:
            words += ["--start-time", f"{self.start_time_ns / 1e9:.9f}"]
        return shlex.join(words)


def parse_recipe(values: Mapping[str, str], *, source: str) -> Recipe:
    """A recipe from its metadata map.

    Raises:
        ReadError: a field missing or malformed (``source`` names the recording).
    """
    try:
        return Recipe(
            description=values["description"],
            args={str(k): str(v) for k, v in json.loads(values.get("args", "{}")).items()},
            traj=values["traj"],
            duration_s=float(values["duration_s"]) if values.get("duration_s") else None,
            rate_hz=float(values["rate_hz"]) if values.get("rate_hz") else None,
            seed=int(values.get("seed", "0")),
            period_s=float(values.get("period_s", "2.0")),
            amplitude=float(values.get("amplitude", "0.8")),
            interp=values.get("interp", "linear"),
            hard_limits=values.get("hard_limits") == "true",
            overrides={str(k): float(v) for k, v in json.loads(values.get("overrides", "{}")).items()},
            frame_prefix=values.get("frame_prefix", ""),
            start_time_ns=int(values.get("start_time_ns", str(DEFAULT_START_TIME_NS))),
            compression=values.get("compression") or None,
            strict_xacro=values.get("strict_xacro") == "true",
            velocity_limits=values.get("velocity_limits", "true") == "true",
            description_sha256=values.get("description_sha256", ""),
            urdf_sha256=values.get("urdf_sha256", ""),
            traj_sha256=values.get("traj_sha256", ""),
            tfrec_version=values.get("tfrec_version", ""),
        )
    except KeyError as err:
        raise ReadError(f"{source}: its {RECIPE} metadata has no '{err.args[0]}'") from None
    except (ValueError, TypeError, AttributeError) as err:
        raise ReadError(f"{source}: its {RECIPE} metadata is malformed: {err}") from None


def read_recipe(path: str | os.PathLike[str]) -> Recipe:
    """The recipe kept in a recording (an MCAP file, or a rosbag2 folder holding one).

    Raises:
        ReadError: no such recording, or one without a recipe (made by another tool, or by
            ``tfrec record`` to a ROS 1 bag).
    """
    from tfrec.formats.mcap.summary import metadata_records

    given = Path(path)
    files = sorted(given.glob("*.mcap")) if given.is_dir() else [given]
    for file in files:
        try:
            records = metadata_records(file)
        except OSError as err:
            raise ReadError(f"{path}: cannot read: {err.strerror or err}") from err
        if RECIPE in records:
            return parse_recipe(records[RECIPE], source=os.fspath(path))
    raise ReadError(f"{path}: holds no recipe (no '{RECIPE}' metadata: not made by `tfrec record` into an MCAP)")


def resolve_path(given: str, *, beside: str | os.PathLike[str] | None) -> str:
    """A recipe's relative path: beside the recording (``beside``, a folder) when it is there, else as given
    (the current folder)."""
    if beside is not None and not os.path.isabs(given):
        candidate = os.path.normpath(os.path.join(beside, given))  # ``..`` of a folder not made yet too
        if os.path.exists(candidate):
            return candidate
    return given


def file_sha256(path: str | os.PathLike[str]) -> str:
    """The sha256 of a file's bytes ("" when it cannot be read: the loader then says why)."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as stream:
            for piece in iter(lambda: stream.read(1 << 20), b""):
                digest.update(piece)
    except OSError:
        return ""
    return digest.hexdigest()


def with_hashes(recipe: Recipe, *, description_path: str | os.PathLike[str], urdf: str,
                traj_path: str | os.PathLike[str] | None) -> Recipe:
    """The recipe with the hashes of the files it was made from, and this tfrec's version."""
    return replace(recipe, description_sha256=file_sha256(description_path),
                   urdf_sha256=hashlib.sha256(urdf.encode()).hexdigest(),
                   traj_sha256=file_sha256(traj_path) if traj_path is not None else "", tfrec_version=__version__)


def record_recipe(recipe: Recipe, out: str | os.PathLike[str], *, beside: str | os.PathLike[str] | None = None,
                  force: bool = False, package_paths: Sequence[str | os.PathLike[str]] = ()) -> RecordResult:
    """Make the recording a recipe describes (an MCAP file, no ``.rrd``), as ``tfrec record`` does, with the
    recipe in it.

    Args:
        recipe: what to record (its hashes are computed anew).
        out: the MCAP file.
        beside: where the recipe's relative paths are looked up first (:func:`resolve_path`).
        force: replace an existing MCAP tfrec wrote.
        package_paths: for ``$(find pkg)``.

    Raises:
        DescriptionError, TrajectoryError, WriteError: as ``tfrec record``.
    """
    from tfrec.description import load_description
    from tfrec.trajectory.generators import make_trajectory
    from tfrec.trajectory.types import TrajectoryKind

    description = resolve_path(recipe.description, beside=beside)
    csv = recipe.traj not in TrajectoryKind._value2member_map_
    traj = resolve_path(recipe.traj, beside=beside) if csv else recipe.traj
    plan = plan_outputs(stem=None, out=out, no_rrd=True, force=force, inputs=[description, traj if csv else None])
    robot = load_description(description, args=dict(recipe.args), package_paths=package_paths,
                             strict_xacro=recipe.strict_xacro)
    trajectory = make_trajectory(robot, traj, duration_s=recipe.duration_s, rate_hz=recipe.rate_hz, seed=recipe.seed,
                                 period_s=recipe.period_s, amplitude=recipe.amplitude, overrides=recipe.overrides,
                                 soft_limits=not recipe.hard_limits, interp=recipe.interp,
                                 velocity_limits=recipe.velocity_limits)
    made = with_hashes(recipe, description_path=description, urdf=robot.urdf, traj_path=traj if csv else None)
    return record(robot, trajectory, plan, compression=recipe.compression, start_time_ns=recipe.start_time_ns,
                  frame_prefix=recipe.frame_prefix, package_paths=package_paths, metadata={RECIPE: made.metadata()})
