"""``rerun FILE`` opens what tfrec reads: the Rerun importer ``rerun-importer-tfrec``.

Rerun (the pinned rerun-sdk 0.41) runs every executable on ``PATH`` named ``rerun-importer-*`` for each file it
opens, with the file as the one positional argument and ``--application-id``, ``--recording-id`` (and optional
``--opened-…``, ``--entity-path-prefix``, ``--static``, ``--time_…``) options; the importer answers with an RRD
stream on standard output, or exit code 66 for a file it does not handle (:data:`INCOMPATIBLE_EXIT_CODE`).

What tfrec answers for (:func:`import_file`):

- a robot description (``.xacro``, ``.urdf.xacro``, ``.urdf``): the robot at its center pose, with its meshes, TF
  tree and joints — as ``tfrec record --traj center`` logs it, one sample;
- a ROS 1 ``.bag``, a rosbag2 folder (``metadata.yaml`` beside ``.db3`` or ``.mcap`` storage; Rerun passes the
  ``.db3`` file, whose folder is read), formats Rerun cannot open: the whole replay, as ``tfrec replay --save``
  writes it;
- nothing else (exit 66). Rerun 0.41 gives an ``.mcap`` to its own MCAP importer alone, never to an external one
  (docs/live.md).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from tfrec.errors import ReplayError

__all__ = ["INCOMPATIBLE_EXIT_CODE", "import_file", "importable"]

INCOMPATIBLE_EXIT_CODE = 66
"""What an importer exits with for a file it does not handle (Rerun's EXTERNAL_IMPORTER_INCOMPATIBLE_EXIT_CODE)."""

DESCRIPTION_SUFFIXES = (".xacro", ".urdf")
BAG_SUFFIXES = (".bag", ".db3")


def importable(path: str | os.PathLike[str]) -> Path | None:
    """What tfrec reads for the file Rerun opens: the description or recording, or None (exit 66)."""
    file = Path(path)
    if file.suffix.lower() in DESCRIPTION_SUFFIXES and file.is_file():
        return file
    if file.suffix.lower() == ".bag" and file.is_file():
        return file
    if file.suffix.lower() == ".db3" and file.is_file():
        return file.parent if (file.parent / "metadata.yaml").is_file() else None
    if file.is_dir() and (file / "metadata.yaml").is_file():
        return file
    return None


def import_file(path: str | os.PathLike[str], *, recording_id: str | None, application_id: str | None,
                package_paths: Sequence[str | os.PathLike[str]] = ()) -> bool:
    """Write what Rerun shows of ``path`` as an RRD stream to standard output; False (nothing written) for a file
    tfrec does not handle.

    Raises:
        TfrecError: the file is one tfrec handles but cannot read (a bad description, a damaged bag).
    """
    target = importable(path)
    if target is None:
        return False
    if target.is_file() and target.suffix.lower() in DESCRIPTION_SUFFIXES:
        _import_description(target, recording_id=recording_id, application_id=application_id,
                            package_paths=package_paths)
    else:
        _import_recording(target, recording_id=recording_id, application_id=application_id,
                          package_paths=package_paths)
    return True


def _import_description(path: Path, *, recording_id: str | None, application_id: str | None,
                        package_paths: Sequence[str | os.PathLike[str]]) -> None:
    from tfrec.conventions import DEFAULT_START_TIME_NS
    from tfrec.description import load_description
    from tfrec.kinematics.fk import iter_dynamic_chunks, static_transforms
    from tfrec.trajectory.generators import make_trajectory
    from tfrec.viewer.spawn import open_stdout_sink

    robot = load_description(path, package_paths=package_paths)
    trajectory = make_trajectory(robot, "center", duration_s=1.0, rate_hz=1.0)  # two samples: the pose, held
    sink = open_stdout_sink(robots=[(robot, "", "")], recording_id=recording_id, application_id=application_id,
                            package_paths=package_paths).sinks[0]
    try:
        sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=DEFAULT_START_TIME_NS)
        for chunk in iter_dynamic_chunks(robot, trajectory):
            sink.write_chunk(stamp_ns=chunk.time_ns + DEFAULT_START_TIME_NS, joint_names=chunk.names,
                             positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
        sink.finish()
    except BaseException:
        sink.abort()
        raise


def _import_recording(path: Path, *, recording_id: str | None, application_id: str | None,
                      package_paths: Sequence[str | os.PathLike[str]]) -> None:
    from tfrec.replay.load import load_replay
    from tfrec.replay.play import play
    from tfrec.viewer.spawn import open_stdout_sink

    replay = load_replay(path)
    if not replay.robots:
        raise ReplayError(f"{path}: no robot to show")
    shown = [robot.displayed() for robot in replay.robots]
    sink = open_stdout_sink(
        recording_id=recording_id, application_id=application_id, package_paths=package_paths,
        robots=[(robot.model, robot.frame_prefix, robot.entity_root) for robot in shown],
        names=[robot.key for robot in shown] if len(shown) > 1 else [],
        display_prefixes=[robot.display_prefix for robot in replay.robots],
    )
    play(replay, sink)
