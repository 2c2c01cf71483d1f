"""What ``tfrec diff`` compares: each input is a robot description or a recording, and the motion
the descriptions are driven along.

A path is a recording when its first bytes say so (:func:`tfrec.formats.recording_format`: MCAP,
rosbag2, ROS 1 bag, ``.rrd``) — or, when it does not exist, when its suffix is a recording's;
anything else is a description, loaded by the loader callable given (by default
:func:`tfrec.description.load_description`, which reads ``.urdf`` and ``.xacro`` files), so
another kind of description (a launch file) needs only a loader that knows it.

Motion: descriptions are driven along the same joint positions, by joint name — a generated
trajectory (``traj``), or the /joint_states of a recording (``joints``; a recording compared with a
description is that recording's own). A joint one description has and the motion does not give is
held at its center (joint_state_publisher's rule), and the report says so.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from tfrec.description import load_description, parse_urdf
from tfrec.errors import DescriptionError, DiffError, ReadError, TfrecWarning
from tfrec.formats.reader import read_recording, recording_format
from tfrec.model import Robot
from tfrec.recording import JointStates, Recording
from tfrec.resample import data_start_ns
from tfrec.trajectory.joints import center_positions
from tfrec.trajectory.types import JointTrajectory

__all__ = [
    "RECORDING_SUFFIXES",
    "DescriptionLoader",
    "DiffInput",
    "is_description",
    "is_recording_path",
    "joint_states_of",
    "load_input",
    "renamed",
    "trajectory_from_joint_states",
]

Array = NDArray[np.float64]

DescriptionLoader = Callable[..., Robot]
"""``loader(path, *, args, package_paths, strict_xacro) -> Robot``, like :func:`load_description`."""

RECORDING_SUFFIXES = frozenset({".mcap", ".bag", ".db3", ".rrd"})
"""Suffixes of recordings, for a path that is no readable recording (its error is then a recording's)."""


@dataclass
class DiffInput:
    """One side of a diff: a robot description, or a recording (and the robot it describes).

    Attributes:
        label: ``A`` or ``B``.
        path: as given (``<robot 'name'>`` for a :class:`Robot` given directly).
        robot: the description's robot; a recording's from its /robot_description (None when
            it has none, or one that does not parse: then ``robot_note`` says why).
        recording: the recording, or None for a description.
        args: the xacro arguments of a description.
    """

    label: str
    path: str
    robot: Robot | None
    recording: Recording | None = None
    args: dict[str, str] = field(default_factory=dict)
    robot_note: str | None = None

    @property
    def is_description(self) -> bool:
        return self.recording is None

    @property
    def title(self) -> str:
        """``new.xacro hand:=true``: the path and its arguments, as typed."""
        return " ".join([self.path, *(f"{name}:={value}" for name, value in self.args.items())])


def is_description(source: object) -> bool:
    """True for a :class:`Robot`, or a path that is no recording (:func:`is_recording_path`)."""
    if isinstance(source, Robot):
        return True
    if isinstance(source, (str, os.PathLike)):
        return not is_recording_path(source)
    return False


def is_recording_path(path: str | os.PathLike[str]) -> bool:
    """True for a recording (by its first bytes, or by its suffix: a missing, empty or damaged ``.bag`` is
    a recording that cannot be read, not a robot description)."""
    try:
        recording_format(path)
    except ReadError:
        return Path(path).suffix.lower() in RECORDING_SUFFIXES
    return True


def renamed(robot: Robot, names: Mapping[str, str], *, where: str) -> Robot:
    """``robot`` with links and joints named anew (``names``: old → new; a name not in it is kept): how a diff
    matches a joint or frame renamed between A and B (``--map``).

    Raises:
        DiffError: a name that is neither a link nor a joint, or a new name that another link or joint has.
    """
    known = set(robot.link_by_name) | set(robot.joint_by_name)
    for old in names:
        if old not in known:
            raise DiffError(f"`map`: {where} has no link or joint '{old}'")

    def name(old: str) -> str:
        return names.get(old, old)

    links = tuple(replace(link, name=name(link.name)) for link in robot.links)
    joints = tuple(replace(joint, name=name(joint.name), parent=name(joint.parent), child=name(joint.child),
                           mimic=None if joint.mimic is None else replace(joint.mimic, joint=name(joint.mimic.joint)))
                   for joint in robot.joints)
    for kind, items in (("link", [link.name for link in links]), ("joint", [joint.name for joint in joints])):
        if len(set(items)) != len(items):
            twice = next(item for item in items if items.count(item) > 1)
            raise DiffError(f"`map`: {where} would have two {kind}s named '{twice}'")
    return Robot(name=robot.name, links=links, joints=joints, urdf=robot.urdf, source=robot.source)


def load_input(
    source: Robot | Recording | str | os.PathLike[str],
    *,
    label: str,
    args: Mapping[str, str] | None = None,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
    loader: DescriptionLoader = load_description,
) -> DiffInput:
    """Load one side of a diff.

    Raises:
        DescriptionError: a description that does not load.
        ReadError: a recording that cannot be read.
        DiffError: xacro arguments given for a recording.
    """
    if isinstance(source, Robot):
        return DiffInput(label, source.source or f"<robot '{source.name}'>", source)
    if isinstance(source, Recording):
        if args:
            raise DiffError(f"{source.path}: xacro arguments given for a recording")
        return _recording_input(source, label)
    where = os.fspath(source)
    if is_recording_path(source):
        if args:
            raise DiffError(f"{where}: xacro arguments given for a recording "
                            f"({' '.join(f'{k}:={v}' for k, v in args.items())})")
        return _recording_input(read_recording(source), label)
    robot = loader(source, args=dict(args or {}), package_paths=package_paths, strict_xacro=strict_xacro)
    return DiffInput(label, where, robot, args=dict(args or {}))


def _recording_input(recording: Recording, label: str) -> DiffInput:
    side = DiffInput(label, recording.path, None, recording)
    if recording.read_error is not None:
        warnings.warn(recording.read_error, TfrecWarning, stacklevel=3)
    if recording.robot_description is None:
        side.robot_note = f"{recording.path} has no /robot_description"
        return side
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the recording's URDF was checked when it was recorded
            side.robot = parse_urdf(recording.robot_description, source=recording.path)
    except DescriptionError as err:
        side.robot_note = f"{recording.path}: its /robot_description is not a valid URDF ({err})"
    return side


def trajectory_from_joint_states(robot: Robot, states: JointStates, *, origin_ns: int) -> tuple[JointTrajectory, list[str]]:
    """A recording's /joint_states as a trajectory of ``robot``'s actuated joints, by name.

    Times count from ``origin_ns`` (the recording's start); samples at a stamp already seen are
    dropped (the last one is kept). A joint the messages never give is held at its center; a
    message without a joint's position keeps the previous one (the first known before that).

    Returns:
        (trajectory, joints held at center).

    Raises:
        DiffError: no /joint_states samples.
    """
    if len(states) == 0:
        raise DiffError("no /joint_states samples to drive the description along")
    times = states.time_ns - origin_ns
    order = np.argsort(times, kind="stable")
    times, positions = times[order], states.positions[order]
    last = np.r_[times[1:] != times[:-1], True]
    times, positions = times[last], positions[last]
    center = center_positions(robot)
    column = {name: k for k, name in enumerate(states.names)}
    out = np.empty((len(times), len(robot.actuated_joints)))
    held: list[str] = []
    for j, joint in enumerate(robot.actuated_joints):
        k = column.get(joint.name)
        values = positions[:, k] if k is not None else np.full(len(times), np.nan)
        known = np.isfinite(values)
        if not known.any():
            held.append(joint.name)
            out[:, j] = center[j]
            continue
        index = np.where(known, np.arange(len(values)), 0)
        np.maximum.accumulate(index, out=index)
        filled = values[index]
        filled[: int(np.argmax(known))] = values[int(np.argmax(known))]
        out[:, j] = filled
    names = tuple(joint.name for joint in robot.actuated_joints)
    return JointTrajectory(names, times.astype(np.int64), out, np.zeros_like(out)), held


def joint_states_of(side: DiffInput | Recording) -> tuple[JointStates, int]:
    """A recording's /joint_states and the start its times count from.

    Raises:
        DiffError: the recording has no /joint_states.
    """
    rec = side.recording if isinstance(side, DiffInput) else side
    assert rec is not None
    if rec.joint_states is None or len(rec.joint_states) == 0:
        raise DiffError(f"{rec.path}: no /joint_states to drive the description along (`joints`)")
    return rec.joint_states, data_start_ns(rec) or 0

