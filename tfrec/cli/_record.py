"""``tfrec record``: drive the joints along a trajectory and record TF."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import warnings
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any

from tfrec.cli._common import (
    Progress,
    add_robot_arguments,
    command,
    load_robot_and_launch,
    show,
    start_time,
)
from tfrec.conventions import (
    COMPRESSIONS,
    DEFAULT_START_TIME_NS,
    NS_PER_S,
    ROS1_COMPRESSIONS,
)
from tfrec.errors import KinematicsError, TfrecWarning, TrajectoryError, WriteError

if TYPE_CHECKING:
    from tfrec.description.launch import LaunchRobot
    from tfrec.model import Robot

__all__ = ["add_parser", "add_trajectory_arguments", "parse_overrides"]


def add_parser(sub: Any) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers)."""
    rec = sub.add_parser(
        "record", help="drive the joints along a trajectory and record TF (MCAP, rosbag2, Rerun)",
        description="What joint_state_publisher + robot_state_publisher + `ros2 bag record -s mcap` would "
                    "record: /robot_description, /tf_static, /joint_states and /tf, as a ROS 2 MCAP file, "
                    "plus a Rerun .rrd beside it.",
    )
    rec.formatter_class = argparse.RawDescriptionHelpFormatter
    rec.epilog = ("examples:\n  tfrec record robots/mbot.xacro --traj sine\n"
                  "  tfrec record robots/marm.xacro --traj random --seed 3 --duration 60 -o marm.bag\n"
                  "  tfrec record marm_description/launch/view_marm.launch --traj keyframes.csv --rate 100 "
                  "--interp cubic")
    add_robot_arguments(rec)
    for action in rec._actions:  # ROBOT may be left out for --like
        if action.dest == "robot":
            action.nargs, action.default = "?", None
    rec.add_argument("--like", metavar="REC", default=None,
                     help="make the recording REC was made as (its description, xacro arguments, trajectory and "
                          "options, kept in its MCAP metadata): byte for byte the same when nothing changed; ROBOT "
                          "and the trajectory options are not given with it")
    add_trajectory_arguments(rec, default="sine")
    out = rec.add_argument_group("output")
    out.add_argument("-o", "--output", metavar="OUT.mcap",
                     help="MCAP file, or a ROS 1 bag when it ends in .bag "
                          "(default recordings/<robot>-<traj>-<YYYYmmdd-HHMMSS>.mcap)")
    out.add_argument("--bag", metavar="DIR", help="write a rosbag2 folder (metadata.yaml + .mcap) instead")
    out.add_argument("--rrd", metavar="OUT.rrd", help="Rerun recording (default: beside the MCAP, same stem)")
    out.add_argument("--no-rrd", action="store_true", help="write no Rerun recording")
    out.add_argument("--no-mcap", action="store_true", help="write no MCAP (only the .rrd)")
    out.add_argument("--compression", choices=sorted({*COMPRESSIONS, *ROS1_COMPRESSIONS}), default=None,
                     help=f"chunk compression: MCAP {', '.join(COMPRESSIONS)} (default zstd); ROS 1 bag "
                          f"{', '.join(ROS1_COMPRESSIONS)} (default none, as rosbag record)")
    out.add_argument("--start-time", metavar="S", type=start_time, default=None,
                     help="stamp of the first sample, seconds since the Unix epoch "
                          f"(default {DEFAULT_START_TIME_NS // NS_PER_S} = 2023-11-14T22:13:20Z, so runs are "
                          "byte-identical)")
    out.add_argument("--force", action="store_true", help="replace existing outputs tfrec would write there (never another file or folder, nor an input)")
    rec.set_defaults(handler=_cmd_record)


def add_trajectory_arguments(parser: argparse.ArgumentParser, *, default: str | None, duration_help: str | None = None,
                             rate_help: str | None = None) -> None:
    """The options of the trajectory a robot is driven along (``record``, ``serve``: its own words for ``--duration``
    and ``--rate``)."""
    traj = parser.add_argument_group("trajectory")
    traj.add_argument("--traj", metavar="KIND", default=default,
                      help="center, random, sine, sweep, or a CSV file (time column in s + one column per "
                           "joint) " + (f"(default: {default})" if default else
                                        "(default: none, the joints are parameters clients set)"))
    traj.add_argument("--duration", metavar="S", type=float, default=None, help=duration_help or "seconds (default 10)")
    traj.add_argument("--rate", metavar="HZ", type=float, default=None,
                      help=rate_help or "samples per second (default 50, or what a launch file gives "
                                        "joint_state_publisher); with a CSV file: resample its rows (keyframes) onto "
                                        "this clock")
    traj.add_argument("--interp", choices=("linear", "cubic", "hold"), default="linear",
                      help="how --rate resamples CSV keyframes: linear, cubic (smooth velocity, no overshoot) or "
                           "hold (steps) (default linear)")
    traj.add_argument("--hard-limits", action="store_true",
                      help="move joints within their hard <limit>s; by default, as joint_state_publisher does "
                           "(use_smallest_joint_limits), within their <safety_controller> soft limits")
    traj.add_argument("--ignore-velocity-limits", action="store_true",
                      help="move random, sine and sweep as fast as --period and --duration make them; by default no "
                           "joint moves faster than its <limit velocity> (joint_state_publisher's Randomize is a jump; "
                           "tfrec interpolates)")
    traj.add_argument("--seed", metavar="N", type=int, default=0, help="seed of --traj random (default 0)")
    traj.add_argument("--period", metavar="S", type=float, default=2.0,
                      help="seconds between random waypoints (Randomize presses); sine periods; at least 1/rate "
                           "(default 2)")
    traj.add_argument("--amplitude", metavar="F", type=float, default=0.8,
                      help="sine amplitude, a fraction of each joint's half-range (default 0.8)")
    traj.add_argument("--set", metavar="JOINT=VALUE", action="append", default=[], dest="overrides",
                      help="hold a joint at a value (repeatable), like joint_state_publisher's zeros")
    traj.add_argument("--frame-prefix", metavar="P", default=None,
                      help="put P in front of every TF frame id, as robot_state_publisher's frame_prefix")


def parse_overrides(items: Sequence[str]) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep or not name.strip():
            raise TrajectoryError(f"--set '{item}' is not of the form joint=number")
    return out


def _cmd_record(ns: argparse.Namespace) -> int:
    from tfrec.recorder import needs_stem, plan_outputs

    ns.recipe_paths = None
    if ns.like is not None:
        _take_recipe(ns)
    elif ns.robot is None:
        raise TrajectoryError("record: ROBOT (a description or launch file) or `--like REC` is required")
    start_ns = DEFAULT_START_TIME_NS if ns.start_time is None else ns.start_time
    csv = is_csv_trajectory(ns.traj)
    if not needs_stem(out=ns.output, rrd=ns.rrd, bag=ns.bag, no_mcap=ns.no_mcap):
        plan_outputs(stem=None, **_outputs(ns, csv))  # named outputs: checked before anything is read
    robot, launch = load_robot_and_launch(ns)
    params = launch.node_params if launch is not None else None
    if csv and ns.duration is not None:
        warnings.warn(f"--duration does not apply to the CSV trajectory {ns.traj}: its own times are used", TfrecWarning,
                      stacklevel=1)
    rate = ns.rate
    if rate is None and params is not None and not csv:  # the launch file's joint_state_publisher and
        rates = [r for r in (params.jsp_rate_hz, params.publish_frequency_hz) if r]  # robot_state_publisher
        if rates:
            rate = min(rates)  # /tf is published at the slower of the two
            if len(rates) == 2 and params.publish_frequency_hz and params.publish_frequency_hz < (params.jsp_rate_hz or 0):
                warnings.warn(f"{launch.launch_file if launch else ''}: robot_state_publisher publishes /tf at "
                              f"{params.publish_frequency_hz:g} Hz, below joint_state_publisher's {params.jsp_rate_hz:g} "
                              "Hz: both are recorded at the /tf rate (--rate overrides)", TfrecWarning, stacklevel=1)
    overrides = parse_overrides(ns.overrides)
    if not overrides and params is not None and params.jsp_zeros and ns.traj == "center":
        overrides = dict(params.jsp_zeros)  # joint_state_publisher's zeros: where Center puts the joints
    frame_prefix = ns.frame_prefix
    if frame_prefix is None:
        frame_prefix = params.frame_prefix if params is not None and params.frame_prefix else ""
    with _naming_the_robot(ns.robot):
        return _record_robot(ns, robot, launch, csv, rate, overrides, frame_prefix, start_ns)


_TRAJECTORY_DEFAULTS: dict[str, Any] = {"traj": "sine", "duration": None, "rate": None, "interp": "linear", "hard_limits": False,
                        "seed": 0, "period": 2.0, "amplitude": 0.8, "overrides": [], "frame_prefix": None,
                        "start_time": None, "compression": None, "strict_xacro": False,
                        "ignore_velocity_limits": False}


def _take_recipe(ns: argparse.Namespace) -> None:
    """``--like REC``: the options of the recording REC's recipe (:mod:`tfrec.recorder`) in ``ns``.

    Raises:
        TrajectoryError: ROBOT, its arguments or a trajectory option given too.
        ReadError: REC holds no recipe.
    """
    from tfrec.recorder import read_recipe, resolve_path

    given = [f"--{dest.replace('_', '-')}" for dest, default in _TRAJECTORY_DEFAULTS.items()
             if getattr(ns, dest) != default]
    if ns.robot is not None or ns.xacro_args or given:
        what = "ROBOT" if ns.robot is not None or ns.xacro_args else f"`{given[0]}`"
        raise TrajectoryError(f"record: {what} goes with no `--like`: {ns.like} says how the recording is made")
    recipe = read_recipe(ns.like)
    beside = os.path.dirname(os.path.abspath(ns.like))
    ns.robot = resolve_path(recipe.description, beside=beside)
    ns.xacro_args = [f"{name}:={value}" for name, value in recipe.args.items()]
    csv = is_csv_trajectory(recipe.traj)
    ns.traj = resolve_path(recipe.traj, beside=beside) if csv else recipe.traj
    ns.duration, ns.rate, ns.seed, ns.period = recipe.duration_s, recipe.rate_hz, recipe.seed, recipe.period_s
    ns.amplitude, ns.interp, ns.hard_limits = recipe.amplitude, recipe.interp, recipe.hard_limits
    ns.overrides = [f"{name}={value!r}" for name, value in recipe.overrides.items()]
    ns.frame_prefix, ns.start_time, ns.compression = recipe.frame_prefix, recipe.start_time_ns, recipe.compression
    ns.strict_xacro, ns.ignore_velocity_limits = recipe.strict_xacro, not recipe.velocity_limits
    ns.recipe_paths = (recipe.description, recipe.traj)  # kept as the recipe gives them, not as resolved


def is_csv_trajectory(traj: str) -> bool:
    """Whether ``--traj`` names a CSV file rather than a kind (center, random, sine, sweep)."""
    from tfrec.trajectory.types import TrajectoryKind

    return traj not in TrajectoryKind._value2member_map_


def recipe_metadata(ns: argparse.Namespace, robot: Robot, csv: bool, rate: float | None, overrides: dict[str, float],
            frame_prefix: str, start_ns: int) -> dict[str, dict[str, str]]:
    """The metadata that says how this recording is made (:mod:`tfrec.recorder`): ``record``'s, and ``serve
    --traj --record``'s (the same recording)."""
    from tfrec.description import parse_xacro_args
    from tfrec.recorder import RECIPE, Recipe, with_hashes

    description, traj = getattr(ns, "recipe_paths", None) or (ns.robot, ns.traj)
    recipe = Recipe(description=description, args=parse_xacro_args(ns.xacro_args), traj=traj,
                    duration_s=None if csv else ns.duration, rate_hz=rate, seed=ns.seed, period_s=ns.period,
                    amplitude=ns.amplitude, interp=ns.interp, hard_limits=ns.hard_limits, overrides=overrides,
                    frame_prefix=frame_prefix, start_time_ns=start_ns, compression=getattr(ns, "compression", None),
                    strict_xacro=ns.strict_xacro, velocity_limits=not ns.ignore_velocity_limits)
    made = with_hashes(recipe, description_path=ns.robot, urdf=robot.urdf, traj_path=ns.traj if csv else None)
    return {RECIPE: made.metadata()}


def _warn_of_motion(robot: Robot, trajectory: Any, where: str) -> None:
    """A CSV trajectory that moves a joint beyond its limits or faster than its velocity limit: one warning each
    (:class:`tfrec.replay.motion_checks.MotionChecker`, which ``tfrec check`` runs on recordings)."""
    from tfrec.replay.motion_checks import MotionChecker

    checker = MotionChecker(robot)
    for chunk in trajectory.chunks(65536):
        checker.feed(chunk.joint_names, chunk.time_ns, chunk.positions)
    for finding in checker.findings():
        warnings.warn(f"{where}: {finding.detail()}", TfrecWarning, stacklevel=1)


def _outputs(ns: argparse.Namespace, csv: bool) -> dict[str, Any]:
    """The options of :func:`tfrec.recorder.plan_outputs` from the command line: the outputs, and the inputs
    they must not be."""
    return {"out": ns.output, "rrd": ns.rrd, "bag": ns.bag, "no_mcap": ns.no_mcap, "no_rrd": ns.no_rrd,
            "force": ns.force, "inputs": [ns.robot, ns.traj if csv else None]}


@contextlib.contextmanager
def _naming_the_robot(path: str) -> Iterator[None]:
    """Errors about one of the robot's joints (its limits, a mimic multiplier) name its description too."""
    try:
        yield
    except (TrajectoryError, KinematicsError) as err:
        if str(err).startswith("joint "):
            raise type(err)(f"{path}: {err}") from None
        raise


def _record_robot(ns: argparse.Namespace, robot: Robot, launch: LaunchRobot | None, csv: bool, rate: float | None,
                  overrides: dict[str, float], frame_prefix: str, start_ns: int) -> int:
    from tfrec.recorder import default_stem, plan_outputs, record
    from tfrec.trajectory.generators import make_trajectory

    trajectory = make_trajectory(
        robot, ns.traj, duration_s=ns.duration, rate_hz=rate, seed=ns.seed, period_s=ns.period,
        amplitude=ns.amplitude, overrides=overrides, soft_limits=not ns.hard_limits, interp=ns.interp,
        velocity_limits=not ns.ignore_velocity_limits,
    )
    if csv:
        _warn_of_motion(robot, trajectory, ns.traj)
    plan = plan_outputs(stem=default_stem(robot, ns.traj), **_outputs(ns, csv))
    allowed = ROS1_COMPRESSIONS if plan.ros1_bag is not None else COMPRESSIONS
    if ns.compression is not None and ns.compression not in allowed and plan.main is not None:
        raise WriteError(f"--compression {ns.compression}: a {'ROS 1 bag' if plan.ros1_bag else 'MCAP'} chunk "
                         f"compression is one of {', '.join(allowed)}")
    progress = Progress(sys.stderr)
    try:
        result = record(robot, trajectory, plan, compression=ns.compression, start_time_ns=start_ns,
                        frame_prefix=frame_prefix, package_paths=ns.package_path, progress=progress,
                        metadata=recipe_metadata(ns, robot, csv, rate, overrides, frame_prefix, start_ns))
    finally:
        progress.close()
    seconds = (result.end_time_ns - result.start_time_ns) / NS_PER_S
    if robot.moving_joints:
        show(f"recorded {robot.name}: {result.samples} samples over {seconds:g} s "
              f"({len(trajectory.joint_names)} actuated joints, --traj {ns.traj})")
    else:  # empty joint states keep the clock; robot_state_publisher publishes no /tf for them
        links = f"{len(robot.links)} link{'s' if len(robot.links) != 1 else ''}"
        show(f"recorded {robot.name}: {result.samples} samples over {seconds:g} s (no moving joints, {links}: "
             "empty /joint_states messages, nothing on /tf)")
    if plan.bag_dir is not None:
        show(f"wrote {plan.bag_dir}/  (rosbag2: metadata.yaml + {plan.mcap.name if plan.mcap else ''})")
    elif plan.ros1_bag is not None:
        show(f"wrote {plan.ros1_bag}  (ROS 1 bag)")
    elif plan.mcap is not None:
        show(f"wrote {plan.mcap}")
    if plan.rrd is not None:
        show(f"wrote {plan.rrd}")
    hints = []
    if plan.rrd is not None:
        hints.append(f"{command('rerun')} {plan.rrd}")
    target = plan.main
    if target is not None:
        hints.append(f"{command('tfrec')} info {target}")
    if hints:
        show("open with: " + "   |   ".join(hints))
    return 0
