"""``tfrec diff`` on robot descriptions: what moved, and by how much, when the URDF changed.

Two descriptions (or a description and a recording) are driven along the same motion
(:mod:`tfrec.diff.inputs`) and compared twice: as URDF, element by element
(:func:`tfrec.diff.urdf.diff_robots`), and by where every link is — its pose in the root link's
frame (root → link, composed through every joint, :func:`tfrec.kinematics.root_from_link`) at every
instant. A 1 mm change of a joint's origin thus shows as the 1 mm world displacement of every link
below that joint, with the instant and the configuration where a link is furthest apart.

A recording is placed by its own TF (/tf interpolated at the compared instants, /tf_static), its
robot from its /robot_description; a description by the forward kinematics of the motion's joint
positions. The instants are the motion's: the generated trajectory's samples, or the recording's
/joint_states stamps (counted from its start, :func:`tfrec.resample.data_start_ns`).

Errors are those of :mod:`tfrec.diff.compare`: a position error is the distance between the
link's origins (m), an orientation error the angle of ``q_a⁻¹ q_b`` (rad); a link one side does
not place at an instant has an infinite error there. A recording of float32 transforms (``.rrd``)
compares at the precision float32 holds (:func:`tfrec.diff.compare.float32_tolerance`).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import DIFF_JOINT_TOL, DIFF_POS_TOL, DIFF_ROT_TOL
from tfrec.description import load_description
from tfrec.description.mjcf import is_mjcf_robot
from tfrec.diff.inputs import (
    DescriptionLoader,
    DiffInput,
    joint_states_of,
    load_input,
    renamed,
    trajectory_from_joint_states,
)
from tfrec.diff.motion_report import DescriptionDiffReport, LinkDelta, Side
from tfrec.diff.precision import float32_tolerance
from tfrec.diff.report import Difference, Largest, at_time
from tfrec.diff.urdf import diff_robots
from tfrec.errors import DiffError, TfrecWarning
from tfrec.formats.reader import read_recording
from tfrec.frames import frame_tree, graph_problems
from tfrec.kinematics.fk import dynamic_transforms, root_from_link, static_transforms
from tfrec.kinematics.joints import all_joint_states
from tfrec.kinematics.rotations import rotation_error
from tfrec.model import Robot
from tfrec.recording import Recording, Transforms
from tfrec.resample import align, data_start_ns
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.types import JointTrajectory

__all__ = ["MotionComparison", "Posed", "assert_descriptions_match", "compare_descriptions", "compare_motion"]

Array = NDArray[np.float64]
Source = Robot | Recording | str | os.PathLike[str]

DEFAULT_TRAJ = "random"
DEFAULT_PERIOD_S = 0.5
"""``random``'s waypoint period for a diff: 20 configurations over the default 10 s, so that the
motion visits each joint's whole range."""


@dataclass
class Posed:
    """One side at the compared instants.

    Attributes:
        side: the input.
        static, dynamic: its transforms (N = 1 and N), parent_from_child, as a recording holds them.
        joint_names, joint_positions: the moving joints' positions (N, M); none for a recording.
        world: root_from_link of every frame reachable from the root, (N, K); NaN where unknown.
    """

    side: DiffInput
    static: Transforms
    dynamic: Transforms
    joint_names: tuple[str, ...]
    joint_positions: Array
    world: Transforms


@dataclass
class MotionComparison:
    """Everything :func:`compare_motion` computed: the report, and for the overlay the poses and errors.

    Attributes:
        report: the report.
        time_ns: int64 (N,) instants, ns from the motion's start.
        a, b: the two sides.
        links: the links compared (both sides place them), in A's order.
        position_error, rotation_error: float64 (N, len(links)), m and rad; inf where a side
            does not place the link.
        position_tol, rotation_tol: the tolerances in force (N, len(links)) (float32 widens them).
    """

    report: DescriptionDiffReport
    time_ns: NDArray[np.int64]
    a: Posed
    b: Posed
    links: tuple[str, ...]
    position_error: Array
    rotation_error: Array
    position_tol: Array
    rotation_tol: Array


def compare_descriptions(a: Source, b: Source, **options: Any) -> DescriptionDiffReport:
    """Compare two robot descriptions (or a description and a recording) by what their links do.

    Args:
        a, b: a description (path or :class:`Robot`) or a recording (path or :class:`Recording`).
        **options: :func:`compare_motion`'s keyword arguments.

    Returns:
        The report; ``report.equal`` is False when anything differs beyond tolerance.
    """
    return compare_motion(a, b, **options).report


def compare_motion(  # noqa: PLR0913 - the keyword-only options of a diff of descriptions
    a: Source,
    b: Source,
    *,
    args_a: Mapping[str, str] | None = None,
    args_b: Mapping[str, str] | None = None,
    traj: str | os.PathLike[str] | None = None,
    duration_s: float = 10.0,
    rate_hz: float = 50.0,
    seed: int = 0,
    joints: Recording | str | os.PathLike[str] | None = None,
    pos_tol: float = DIFF_POS_TOL,
    rot_tol: float = DIFF_ROT_TOL,
    joint_tol: float = DIFF_JOINT_TOL,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
    loader: DescriptionLoader = load_description,
    names: Mapping[str, str] | None = None,
) -> MotionComparison:
    """Drive two inputs along one motion and compare their URDFs and every link's pose over it.

    Args:
        a, b: each a description (a path the ``loader`` reads, or a :class:`Robot`) or a recording
            (a path, or a :class:`Recording`). Two recordings are compared at A's stamps, each
            placed by its own TF (for the overlay; :func:`tfrec.diff.compare` reports on them).
        args_a, args_b: xacro arguments of each description (``{"hand": "true"}``).
        traj: the trajectory both descriptions follow: ``random`` (default: seeded, a new
            configuration every 0.5 s, so each joint visits its range), ``sweep``, ``sine``,
            ``center`` or a CSV file; not with a recording, which brings its own motion.
        duration_s, rate_hz, seed: of the generated trajectory.
        joints: follow this recording's /joint_states instead; with a recording as A or B it
            may only be that recording (the default then).
        pos_tol, rot_tol, joint_tol: as for :func:`tfrec.diff.compare`.
        package_paths, strict_xacro: for loading descriptions.
        loader: reads a description file (:func:`tfrec.description.load_description`).
        names: joints and frames renamed from A to B (``{name in A: name in B}``; ``--map a:=b``): B's are
            compared under A's names.

    Raises:
        DescriptionError: a description that does not load.
        ReadError: a recording that cannot be read.
        DiffError: options that do not go together (``traj`` or another
            ``joints`` with a recording), a recording without /joint_states, or TF in which a
            frame has two parents.
        TrajectoryError: a bad trajectory option.
    """
    tolerances = {"pos_tol": _tolerance("pos_tol", pos_tol), "rot_tol": _tolerance("rot_tol", rot_tol),
                  "joint_tol": _tolerance("joint_tol", joint_tol)}
    load = {"package_paths": package_paths, "strict_xacro": strict_xacro, "loader": loader}
    side_a = load_input(a, label="A", args=args_a, **load)  # type: ignore[arg-type]
    side_b = load_input(b, label="B", args=args_b, **load)  # type: ignore[arg-type]
    if names:
        if side_b.robot is None:
            raise DiffError(f"`map`: {side_b.path} has no robot description to rename")
        side_b = replace(side_b, robot=renamed(side_b.robot, {new: old for old, new in names.items()},
                                               where=side_b.path))
    recordings = [side for side in (side_a, side_b) if not side.is_description]
    notes: list[str] = []
    if recordings:
        rec = recordings[0]
        if traj is not None:
            raise DiffError(f"`traj`: {rec.path} is a recording, which brings its own motion (its /joint_states)")
        if joints is not None and not _same_recording(joints, rec):
            raise DiffError(f"`joints` {os.fspath(joints) if not isinstance(joints, Recording) else joints.path}: "
                            f"{rec.path} is a recording, whose own /joint_states drive the description")
        source: Recording | None = rec.recording
    elif joints is not None:
        source = joints if isinstance(joints, Recording) else read_recording(joints)
    else:
        source = None
    trajectories: dict[str, JointTrajectory] = {}
    if len(recordings) == 2:
        assert source is not None
        time_ns = _recording_times(source)
        motion = f"the recorded motion, at the stamps of {source.path}"
    elif source is not None:
        states, origin = joint_states_of(source)
        motion = f"the /joint_states of {source.path}"
        for side in (side_a, side_b):
            if side.is_description:
                assert side.robot is not None
                trajectories[side.label], held = trajectory_from_joint_states(side.robot, states, origin_ns=origin)
                if held:
                    notes.append(f"{side.label}'s joints not in {source.path}'s /joint_states are held at their "
                                 f"center: {', '.join(held)}")
        time_ns = next(iter(trajectories.values())).time_ns
    else:
        kind = DEFAULT_TRAJ if traj is None else traj
        trajectories = _shared_trajectories(side_a, side_b, kind, duration_s=duration_s, rate_hz=rate_hz, seed=seed)
        time_ns = trajectories["A"].time_ns
        label = kind if isinstance(kind, str) and "/" not in kind and "." not in kind else os.fspath(kind)
        motion = f"`traj` {label}" + (f" (`seed` {seed})" if label == "random" else "") + \
            f", {duration_s:g} s at {rate_hz:g} Hz, the same joint positions in A and B"
    root = _shared_root(side_a, side_b)
    posed_a = _pose(side_a, trajectories.get("A"), time_ns, root)
    posed_b = _pose(side_b, trajectories.get("B"), time_ns, root)
    return _compare(posed_a, posed_b, time_ns, root, motion, tolerances, notes)


def assert_descriptions_match(a: Source, b: Source, **options: Any) -> DescriptionDiffReport:
    """Fail a test, with the readable report, unless two descriptions place every link alike.

    Args:
        a, b: descriptions (or one recording), as for :func:`compare_motion`.
        **options: :func:`compare_motion`'s keyword arguments (``args_a``, ``args_b``, ``traj``,
            ``joints``, tolerances, ...).

    Returns:
        The report, when they match.

    Raises:
        AssertionError: they differ; the message is :meth:`DescriptionDiffReport.to_text`.
    """
    __tracebackhide__ = True  # pytest: show the report, not this frame
    report = compare_descriptions(a, b, **options)
    if not report.equal:
        raise AssertionError("descriptions differ: " + report.to_text())
    return report


# -- the motion ---------------------------------------------------------------------------------


def _tolerance(name: str, value: float) -> float:
    if not (isinstance(value, (int, float)) and np.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def _recording_times(rec: Recording) -> NDArray[np.int64]:
    """The stamps of a recording's /joint_states (else of its /tf), from its start."""
    origin = data_start_ns(rec) or 0
    if rec.joint_states is not None and len(rec.joint_states):
        return np.unique(rec.joint_states.time_ns) - origin
    stamps = [series.time_ns for series in rec.tf.values()]
    if not stamps:
        raise DiffError(f"{rec.path}: neither /joint_states nor /tf: no motion to compare")
    return np.unique(np.concatenate(stamps)) - origin


def _same_recording(joints: Recording | str | os.PathLike[str], side: DiffInput) -> bool:
    if isinstance(joints, Recording):
        return joints is side.recording
    return os.path.abspath(os.fspath(joints)) == os.path.abspath(side.path)


def _shared_root(a: DiffInput, b: DiffInput) -> str:
    """The frame link poses are taken in: A's root, or B's when only B's is a link of both (a MuJoCo model's root
    is ``world``, above the URDF's root link)."""
    first = a.robot or b.robot or _no_robot(a, b)
    other = b.robot if a.robot is not None else None
    if other is not None and first.root not in other.link_by_name and other.root in first.link_by_name:
        return other.root
    return first.root


def _no_robot(a: DiffInput, b: DiffInput) -> Robot:
    raise DiffError("; ".join(side.robot_note or f"{side.path}: no robot" for side in (a, b)))


def _shared_trajectories(a: DiffInput, b: DiffInput, kind: str | os.PathLike[str], **options: Any) -> dict[str, JointTrajectory]:
    """Each description's trajectory of ``kind``; B takes A's positions for the joints both have."""
    if kind == "random":
        options["period_s"] = DEFAULT_PERIOD_S
    assert a.robot is not None and b.robot is not None
    options["velocity_limits"] = False  # one motion for both, whatever their limits: B's may differ from A's
    ta = make_trajectory(a.robot, kind, **options)
    tb = make_trajectory(b.robot, kind, **options)
    column_a = {name: k for k, name in enumerate(ta.joint_names)}
    shared = [(j, column_a[name]) for j, name in enumerate(tb.joint_names) if name in column_a]
    if shared and len(ta) == len(tb):
        positions, velocities = tb.positions.copy(), tb.velocities.copy()
        for j, k in shared:
            positions[:, j] = ta.positions[:, k]
            velocities[:, j] = ta.velocities[:, k]
        tb = JointTrajectory(tb.joint_names, ta.time_ns, positions, velocities)
    return {"A": ta, "B": tb}


def _pose(side: DiffInput, trajectory: JointTrajectory | None, time_ns: NDArray[np.int64], root: str) -> Posed:
    """A side's transforms and root → frame poses at the instants ``time_ns``."""
    if side.is_description:
        assert side.robot is not None and trajectory is not None
        names, positions, _ = all_joint_states(side.robot, trajectory)
        static = static_transforms(side.robot)
        dynamic = dynamic_transforms(side.robot, names, positions)
    else:
        rec = side.recording
        assert rec is not None
        origin = data_start_ns(rec) or 0
        names, positions = (), np.zeros((len(time_ns), 0))
        static = Transforms.from_poses(rec.tf_static)
        k = len(rec.tf)
        translation, rotation = np.full((len(time_ns), k, 3), np.nan), np.full((len(time_ns), k, 4), np.nan)
        for i, series in enumerate(rec.tf.values()):
            alignment = align(time_ns, series.time_ns - origin)
            translation[alignment.inside, i] = alignment.linear(series.translation)
            rotation[alignment.inside, i] = alignment.rotations(series.rotation)
        dynamic = Transforms(tuple(p for p, _ in rec.tf), tuple(c for _, c in rec.tf), translation, rotation)
        for problem in graph_problems(frame_tree([*rec.tf_static, *rec.tf], roots=(root,))):
            warnings.warn(f"{side.path}: {problem}; links are placed along the other transforms", TfrecWarning, stacklevel=3)
    world = root_from_link(static, dynamic, root=root)
    return Posed(side, static, dynamic, tuple(names), positions, world)


# -- the comparison -----------------------------------------------------------------------------


def _compare(pa: Posed, pb: Posed, time_ns: NDArray[np.int64], root: str, motion: str,
             tolerances: dict[str, float], notes: list[str]) -> MotionComparison:
    report = DescriptionDiffReport(_side_of(pa.side), _side_of(pb.side), motion, len(time_ns), root,
                                   tolerances=tolerances, notes=notes)
    for side in (pa.side, pb.side):
        if side.robot_note:
            report.notes.append(side.robot_note + ": its robot description is not compared")
    if pa.side.robot is not None and pb.side.robot is not None:
        across = is_mjcf_robot(pa.side.robot) != is_mjcf_robot(pb.side.robot)
        if across:
            report.notes.append("one description is a MuJoCo model: the descriptions compare by their moving joints "
                                "(type, axis, limits, mimic) and by the world pose of every frame both have")
        for change in diff_robots(pa.side.robot, pb.side.robot, pos_tol=tolerances["pos_tol"],
                                  rot_tol=tolerances["rot_tol"], value_tol=tolerances["joint_tol"],
                                  moving_joints_only=across):
            report.differences.append(Difference("description", change.what, change.detail))
    frames_a = {child: k for k, child in enumerate(pa.world.children)}
    frames_b = {child: k for k, child in enumerate(pb.world.children)}
    order = _link_order(pa, pb)
    links = tuple(link for link in order if link in frames_a and link in frames_b and link != root)
    for label, frames, other in (("A", frames_a, frames_b), ("B", frames_b, frames_a)):
        alone = [link for link in order if link in frames and link not in other]
        if alone:
            report.differences.append(Difference(
                "frame", "links", f"placed only in {label} (no pose in the other): {', '.join(alone)}"))
    ia = [frames_a[link] for link in links]
    ib = [frames_b[link] for link in links]
    ta, tb = pa.world.translation[:, ia], pb.world.translation[:, ib]
    position = _nan_is_inf(np.linalg.norm(ta - tb, axis=2))
    rotation = _nan_is_inf(rotation_error(pa.world.rotation[:, ia], pb.world.rotation[:, ib]))
    pos_tol = np.full(position.shape, tolerances["pos_tol"])
    rot_tol = np.full(rotation.shape, tolerances["rot_tol"])
    float32 = [side.path for side in (pa.side, pb.side) if side.recording is not None and side.recording.float32]
    if float32:
        magnitude = np.linalg.norm(np.nan_to_num(ta, posinf=0.0, neginf=0.0), axis=2)
        pos_tol = float32_tolerance(tolerances["pos_tol"], magnitude)
        rot_tol = float32_tolerance(tolerances["rot_tol"], np.ones(rotation.shape))
        report.notes.append(f"{' and '.join(float32)} holds transforms as float32: link poses compare at the "
                            "precision float32 holds, max(`pos_tol`, 4·eps32·|t|) and max(`rot_tol`, 4·eps32)")
    comparison = MotionComparison(report, time_ns, pa, pb, links, position, rotation, pos_tol, rot_tol)
    _link_deltas(comparison, pa if pa.joint_names else pb)
    return comparison


def _link_deltas(c: MotionComparison, driven: Posed) -> None:
    """Fill the report's per-link lines, largest errors and worst configuration from the errors."""
    report, time_ns = c.report, c.time_ns
    worst_score, worst_at, worst_link = -1.0, 0, ""
    for j, link in enumerate(c.links):
        pos, rot = c.position_error[:, j], c.rotation_error[:, j]
        if not len(pos):
            continue
        over = (pos > c.position_tol[:, j]) | (rot > c.rotation_tol[:, j])
        ip, ir = int(np.argmax(pos)), int(np.argmax(rot))
        first = int(np.argmax(over)) if over.any() else None
        report.links.append(LinkDelta(link, float(pos[ip]), int(time_ns[ip]), float(rot[ir]), int(time_ns[ir]),
                                      None if first is None else int(time_ns[first]), int(over.sum())))
        for quantity, value, at in (("position", float(pos[ip]), ip), ("rotation", float(rot[ir]), ir)):
            current = report.largest.get(quantity)
            if current is None or value > current.value:
                report.largest[quantity] = Largest(value, f"link '{link}'", int(time_ns[at]))
        ratio = np.maximum(pos / np.maximum(c.position_tol[:, j], 1e-300), rot / np.maximum(c.rotation_tol[:, j], 1e-300))
        at = int(np.argmax(ratio))
        if first is not None and float(ratio[at]) > worst_score:
            worst_score, worst_at, worst_link = float(ratio[at]), at, link
        if first is None:
            continue
        pieces = []
        if (pos > c.position_tol[:, j]).any():
            pieces.append(_detail("position", "m", pos, c.position_tol[:, j], time_ns))
        if (rot > c.rotation_tol[:, j]).any():
            pieces.append(_detail("orientation", "rad", rot, c.rotation_tol[:, j], time_ns))
        report.differences.append(Difference("link", f"link '{link}'", f"{link}: " + "; ".join(pieces),
                                             int(time_ns[first]), float(pos[ip])))
    if worst_link and driven.joint_names:
        side = driven.side
        actuated = [joint.name for joint in side.robot.actuated_joints] if side.robot is not None else []
        column = {name: k for k, name in enumerate(driven.joint_names)}
        report.worst = {"time_ns": int(time_ns[worst_at]), "link": worst_link,
                        "joints": {name: float(driven.joint_positions[worst_at, column[name]])
                                   for name in actuated if name in column}}


def _detail(quantity: str, unit: str, error: Array, tol: Array, time_ns: NDArray[np.int64]) -> str:
    worst = int(np.argmax(error))
    over = error > tol
    first = int(np.argmax(over))
    if np.isinf(error[worst]):
        missing = np.isinf(error)
        return (f"{quantity} unknown in one side in {int(missing.sum())} of {len(error)} samples, "
                f"first{at_time(int(time_ns[int(np.argmax(missing))]))}")
    return (f"{quantity} differs by up to {error[worst]:.3g} {unit}{at_time(int(time_ns[worst]))}, "
            f"first above {tol[first]:g} {unit}{at_time(int(time_ns[first]))} ({int(over.sum())} of {len(error)} samples)")


def _link_order(a: Posed, b: Posed) -> list[str]:
    """A's links in tree order (root first), then B's that A lacks; frames without a robot as placed."""
    order: list[str] = []
    for posed in (a, b):
        robot = posed.side.robot
        names = [robot.root, *(joint.child for joint in robot.tree_order)] if robot is not None else list(posed.world.children)
        order += [name for name in names if name not in order]
    return order


def _side_of(side: DiffInput) -> Side:
    if side.recording is not None:
        return Side(side.path, "recording", side.recording.format, side.robot.name if side.robot else None)
    return Side(side.path, "description", None, side.robot.name if side.robot else None, dict(side.args))


def _nan_is_inf(error: Array) -> Array:
    return np.where(np.isnan(error), np.inf, error)
