"""The ``tfrec`` command line: the only module that parses argv, prints and picks exit codes.

Exit codes: 0 ok, 1 differences found, 2 user error (``tfrec: error: ...`` on stderr).
Heavy libraries (xacro, numpy, rerun, rosbags, yourdfpy) are imported inside the handlers,
so ``tfrec --help`` stays fast.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import signal
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, NoReturn, TextIO

from . import __version__
from .conventions import (
    CHECK_POS_TOL,
    CHECK_ROT_TOL,
    COMPRESSIONS,
    DEFAULT_START_TIME_NS,
    DIFF_JOINT_TOL,
    DIFF_POS_TOL,
    DIFF_ROT_TOL,
    NS_PER_S,
    RECORDED_TOPICS,
)
from .errors import TfrecError, TrajectoryError

if TYPE_CHECKING:
    from .model import Joint, Robot

__all__ = ["main", "main_exit", "robot_to_json"]

PROG = "tfrec"


def _add_robot_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("robot", metavar="ROBOT", help="a .urdf, .xacro or .urdf.xacro file")
    parser.add_argument("xacro_args", metavar="name:=value", nargs="*", default=[], help="xacro arguments, as for ROS")
    parser.add_argument(
        "--package-path", metavar="DIR", action="append", default=[],
        help="a package, or a folder of packages, for $(find pkg) and package:// (repeatable; searched "
             "before ROS_PACKAGE_PATH, AMENT_PREFIX_PATH and the input's own workspace)",
    )
    parser.add_argument(
        "--strict-xacro", action="store_true",
        help="refuse macro calls without the 'xacro:' prefix (legacy xacro <= 1.13 dialect) "
             "instead of expanding them with a warning",
    )


class _Parser(argparse.ArgumentParser):
    """argparse with usage errors as one line, like every other tfrec error (exit 2)."""

    def error(self, message: str) -> NoReturn:
        if message.startswith("unrecognized arguments") and ":=" in message:
            message += " (xacro arguments name:=value go right after ROBOT)"
        self.exit(2, f"{PROG}: error: {message} (see '{self.prog} --help')\n")


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog=PROG,
        description="Record, replay and compare what a robot description does — headless, without ROS.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    inspect = sub.add_parser(
        "inspect", help="load a robot description and print its link/joint tree (like check_urdf)",
        description="Load a robot description (xacro expanded, validated) and print its name, root link "
                    "and link/joint tree with joint types, axes and limits.",
    )
    _add_robot_arguments(inspect)
    printed = inspect.add_mutually_exclusive_group()
    printed.add_argument("--urdf", action="store_true", help="print the expanded URDF")
    printed.add_argument("--json", action="store_true", help="print the model as JSON")
    inspect.set_defaults(handler=_cmd_inspect)

    rec = sub.add_parser(
        "record", help="drive the joints along a trajectory and record TF (MCAP, rosbag2, Rerun)",
        description="What joint_state_publisher + robot_state_publisher + `ros2 bag record -s mcap` would "
                    "record: /robot_description, /tf_static, /joint_states and /tf, as a ROS 2 MCAP file, "
                    "plus a Rerun .rrd beside it.",
    )
    _add_robot_arguments(rec)
    traj = rec.add_argument_group("trajectory")
    traj.add_argument("--traj", metavar="KIND", default="sine",
                      help="center, random, sine, sweep, or a CSV file (time column in s + one column per "
                           "joint) (default: sine)")
    traj.add_argument("--duration", metavar="S", type=float, default=None, help="seconds (default 10)")
    traj.add_argument("--rate", metavar="HZ", type=float, default=None, help="samples per second (default 50)")
    traj.add_argument("--seed", metavar="N", type=int, default=0, help="seed of --traj random (default 0)")
    traj.add_argument("--period", metavar="S", type=float, default=2.0,
                      help="seconds between random waypoints (Randomize presses); sine periods; at least 1/rate "
                           "(default 2)")
    traj.add_argument("--amplitude", metavar="F", type=float, default=0.8,
                      help="sine amplitude, a fraction of each joint's half-range (default 0.8)")
    traj.add_argument("--set", metavar="JOINT=VALUE", action="append", default=[], dest="overrides",
                      help="hold a joint at a value (repeatable), like joint_state_publisher's zeros")
    traj.add_argument("--frame-prefix", metavar="P", default="",
                      help="put P in front of every TF frame id, as robot_state_publisher's frame_prefix")
    out = rec.add_argument_group("output")
    out.add_argument("-o", "--output", metavar="OUT.mcap",
                     help="MCAP file (default recordings/<robot>-<traj>-<YYYYmmdd-HHMMSS>.mcap)")
    out.add_argument("--bag", metavar="DIR", help="write a rosbag2 folder (metadata.yaml + .mcap) instead")
    out.add_argument("--rrd", metavar="OUT.rrd", help="Rerun recording (default: beside the MCAP, same stem)")
    out.add_argument("--no-rrd", action="store_true", help="write no Rerun recording")
    out.add_argument("--no-mcap", action="store_true", help="write no MCAP (only the .rrd)")
    out.add_argument("--compression", choices=COMPRESSIONS, default="zstd",
                     help="MCAP chunk compression (default zstd)")
    out.add_argument("--start-time", metavar="S", type=_start_time, default=None,
                     help="stamp of the first sample, seconds since the Unix epoch "
                          f"(default {DEFAULT_START_TIME_NS // NS_PER_S} = 2023-11-14T22:13:20Z, so runs are "
                          "byte-identical)")
    out.add_argument("--force", action="store_true", help="overwrite existing outputs")
    rec.set_defaults(handler=_cmd_record)

    info = sub.add_parser("info", help="summarize a recording (MCAP, rosbag2 folder, ROS 1 bag or .rrd)",
                          description="Duration, start and end, topics with type, count and rate, joints, "
                                      "TF frames and the robot's name, of tfrec's or any ROS 2 recording.")
    info.add_argument("file", metavar="FILE", help="a .mcap file, a rosbag2 folder, a ROS 1 .bag or a tfrec .rrd")
    info.add_argument("--json", action="store_true", help="print the summary as JSON")
    info.set_defaults(handler=_cmd_info)

    diff = sub.add_parser(
        "diff", help="compare two recordings by meaning (description, topics, joint states, TF)",
        description="Compare two recordings — MCAP, rosbag2 folder, ROS 1 bag or tfrec .rrd — by meaning: the "
                    "robot description as URDF, topics, joint positions and transforms, aligned by the time "
                    "since each recording's start (its first /joint_states or /tf stamp). Exit 0 when "
                    "identical within tolerance, 1 when different, 2 on error.",
    )
    diff.add_argument("a", metavar="A", help="a recording: .mcap, rosbag2 folder, ROS 1 .bag or .rrd")
    diff.add_argument("b", metavar="B", help="the recording to compare with A")
    diff.add_argument("--pos-tol", metavar="M", type=_tolerance, default=DIFF_POS_TOL,
                      help=f"translations within M metres are equal (default {_number(DIFF_POS_TOL)})")
    diff.add_argument("--rot-tol", metavar="RAD", type=_tolerance, default=DIFF_ROT_TOL,
                      help=f"rotations within RAD radians are equal (default {_number(DIFF_ROT_TOL)})")
    diff.add_argument("--joint-tol", metavar="X", type=_tolerance, default=DIFF_JOINT_TOL,
                      help=f"joint positions within X (rad or m) are equal (default {_number(DIFF_JOINT_TOL)})")
    diff.add_argument("--topics", metavar="TOPIC", nargs="+", help="compare only these topics (default: all)")
    diff.add_argument("--absolute", action="store_true",
                      help="align samples on their stamps, not on the time since each recording's start")
    diff.add_argument("--json", action="store_true", help="print the report as JSON")
    diff.set_defaults(handler=_cmd_diff)
    _add_replay_parser(sub)
    return parser


def _load_robot(ns: argparse.Namespace) -> Robot:
    from .description import load_description, parse_xacro_args

    return load_description(
        ns.robot,
        args=parse_xacro_args(ns.xacro_args),
        package_paths=ns.package_path,
        strict_xacro=ns.strict_xacro,
    )


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _number(x: float) -> str:
    """A default in help texts, as a user would type it: ``1e-9``, not ``1e-09``."""
    mantissa, _, exponent = f"{x:g}".partition("e")
    return f"{mantissa}e{int(exponent)}" if exponent else mantissa


def _joint_label(joint: Joint) -> str:
    parts = [joint.type.value]
    if joint.type.moves:
        parts.append("axis " + " ".join(_fmt(a) for a in joint.axis))
    if joint.limit is not None and joint.type.value in ("revolute", "prismatic"):
        parts.append(f"limits [{_fmt(joint.limit.lower)}, {_fmt(joint.limit.upper)}]")
    if joint.mimic is not None:
        parts.append(f"mimics {joint.mimic.joint} ×{_fmt(joint.mimic.multiplier)} {joint.mimic.offset:+.6g}")
    return ", ".join(parts)


def _print_tree(robot: Robot, out: TextIO) -> None:
    actuated = len(robot.actuated_joints)
    out.write(f"robot name is: {robot.name}\n")
    out.write(f"{len(robot.links)} links, {len(robot.joints)} joints ({actuated} actuated)\n")
    out.write(f"root link: {robot.root}\n")
    out.write(f"{robot.root}\n")

    # depth-first with an explicit stack: a chain may be longer than Python's recursion limit
    stack = [(joint, "", i == len(robot.child_joints[robot.root]) - 1)
             for i, joint in enumerate(robot.child_joints[robot.root])][::-1]
    while stack:
        joint, indent, last = stack.pop()
        out.write(f"{indent}{'└── ' if last else '├── '}{joint.child}  ({joint.name}: {_joint_label(joint)})\n")
        below = robot.child_joints[joint.child]
        deeper = indent + ("    " if last else "│   ")
        stack.extend([(child, deeper, i == len(below) - 1) for i, child in enumerate(below)][::-1])


def robot_to_json(robot: Robot) -> dict[str, Any]:
    """The ``inspect --json`` document."""
    return {
        "name": robot.name,
        "root": robot.root,
        "links": [link.name for link in robot.links],
        "joints": [
            {
                "name": j.name,
                "type": j.type.value,
                "parent": j.parent,
                "child": j.child,
                "axis": list(j.axis),
                "limit": None if j.limit is None else {"lower": j.limit.lower, "upper": j.limit.upper},
                "mimic": None if j.mimic is None else {
                    "joint": j.mimic.joint, "multiplier": j.mimic.multiplier, "offset": j.mimic.offset,
                },
            }
            for j in robot.joints
        ],
    }


def _cmd_inspect(ns: argparse.Namespace) -> int:
    robot = _load_robot(ns)
    if ns.urdf:
        sys.stdout.write(robot.urdf if robot.urdf.endswith("\n") else robot.urdf + "\n")
    elif ns.json:
        json.dump(robot_to_json(robot), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        _print_tree(robot, sys.stdout)
    return 0


def _parse_overrides(items: Sequence[str]) -> dict[str, float]:
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


class _Progress:
    """A progress bar on stderr, shown only on a terminal and once a recording takes over a second."""

    def __init__(self, stream: TextIO, *, clock: Callable[[], float] | None = None) -> None:
        import time

        self._clock = time.monotonic if clock is None else clock
        self._start = self._clock()
        self._enabled = stream.isatty()
        self._stream = stream
        self._shown = False

    def __call__(self, done: int, total: int) -> None:
        if not self._enabled or (not self._shown and self._clock() - self._start < 1.0):
            return
        self._shown = True
        width = 30
        filled = int(width * done / max(total, 1))
        self._stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {100 * done // max(total, 1):3d}% "
                           f"{done}/{total} samples")
        self._stream.flush()

    def close(self) -> None:
        if self._shown:
            self._stream.write("\n")
            self._stream.flush()


def _cmd_record(ns: argparse.Namespace) -> int:
    from .recording import default_stem, plan_outputs, record
    from .trajectory import TrajectoryKind, make_trajectory

    start_ns = DEFAULT_START_TIME_NS if ns.start_time is None else ns.start_time
    robot = _load_robot(ns)
    if ns.traj not in TrajectoryKind._value2member_map_ and (ns.duration is not None or ns.rate is not None):
        warnings.warn(f"--duration and --rate do not apply to the CSV trajectory {ns.traj}: its own times are used",
                      stacklevel=1)
    trajectory = make_trajectory(
        robot, ns.traj, duration_s=10.0 if ns.duration is None else ns.duration,
        rate_hz=50.0 if ns.rate is None else ns.rate, seed=ns.seed, period_s=ns.period,
        amplitude=ns.amplitude, overrides=_parse_overrides(ns.overrides),
    )
    plan = plan_outputs(stem=default_stem(robot, ns.traj), out=ns.output, rrd=ns.rrd, bag=ns.bag,
                        no_mcap=ns.no_mcap, no_rrd=ns.no_rrd, force=ns.force)
    progress = _Progress(sys.stderr)
    try:
        result = record(robot, trajectory, plan, compression=ns.compression, start_time_ns=start_ns,
                        frame_prefix=ns.frame_prefix, package_paths=ns.package_path, progress=progress)
    finally:
        progress.close()
    seconds = (result.end_time_ns - result.start_time_ns) / NS_PER_S
    print(f"recorded {robot.name}: {result.samples} samples over {seconds:g} s "
          f"({len(trajectory.joint_names)} actuated joints, --traj {ns.traj})")
    if plan.bag_dir is not None:
        print(f"wrote {plan.bag_dir}/  (rosbag2: metadata.yaml + {plan.mcap.name if plan.mcap else ''})")
    elif plan.mcap is not None:
        print(f"wrote {plan.mcap}")
    if plan.rrd is not None:
        print(f"wrote {plan.rrd}")
    hints = []
    if plan.rrd is not None:
        hints.append(f"rerun {plan.rrd}")
    target = plan.bag_dir or plan.mcap
    if target is not None:
        hints.append(f"tfrec info {target}")
    if hints:
        print("open with: " + "   |   ".join(hints))
    return 0


def _cmd_info(ns: argparse.Namespace) -> int:
    from .info import format_summary, summarize

    summary = summarize(ns.file)
    if ns.json:
        json.dump(summary, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_summary(summary).rstrip("\n") + "\n")
    return 0


def _start_time(text: str) -> int:
    """argparse type of --start-time: decimal seconds since the epoch → exact integer nanoseconds."""
    import decimal

    try:
        seconds = decimal.Decimal(text.strip())
    except decimal.InvalidOperation:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number of seconds") from None
    if not seconds.is_finite() or seconds < 0:
        raise argparse.ArgumentTypeError(f"{text} is not a time since the epoch in seconds")
    return int((seconds * NS_PER_S).to_integral_value(rounding=decimal.ROUND_HALF_EVEN))


def _tolerance(text: str) -> float:
    """argparse type of the tolerances of diff and replay --check: a finite number >= 0."""
    import math

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text} is not a tolerance (a number >= 0)")
    return value


def _cmd_diff(ns: argparse.Namespace) -> int:
    from .diff import compare

    report = compare(ns.a, ns.b, pos_tol=ns.pos_tol, rot_tol=ns.rot_tol, joint_tol=ns.joint_tol,
                     topics=ns.topics, absolute=ns.absolute)
    sys.stdout.write(report.to_json() + "\n" if ns.json else report.to_text())
    return 0 if report.equal else 1


def _add_replay_parser(sub: Any) -> argparse.ArgumentParser:
    """The ``replay`` subcommand."""
    rep: argparse.ArgumentParser = sub.add_parser(
        "replay", help="play a recording back into Rerun, like ros2 bag play into RViz (or check it)",
        description="Play /robot_description, /tf_static, /joint_states and /tf of a recording into the Rerun "
                    "viewer in real time: tfrec's or ros2 bag's MCAP, a rosbag2 folder (mcap or sqlite3), a ROS 1 "
                    ".bag, or an .rrd. Where /tf lacks a joint of the robot, its transforms are computed from "
                    "/joint_states as robot_state_publisher does. With --check, re-simulate instead: recompute TF "
                    "from the joint states and report how far the recorded TF is from it (exit 1 above tolerance).",
    )
    rep.add_argument("file", metavar="FILE", help="a .mcap file, a rosbag2 folder, a ROS 1 .bag or a .rrd")
    model = rep.add_argument_group("robot model")
    model.add_argument("--robot", metavar=("FILE", "name:=value"), nargs="+",
                       help="use this .urdf/.xacro (with xacro arguments) instead of the recording's "
                            "/robot_description")
    model.add_argument("--package-path", metavar="DIR", action="append", default=[],
                       help="a package, or a folder of packages, for $(find pkg) and package:// meshes (repeatable)")
    model.add_argument("--strict-xacro", action="store_true",
                       help="refuse macro calls without the 'xacro:' prefix in --robot")
    where = rep.add_argument_group("where to (default: spawn the Rerun viewer)")
    target = where.add_mutually_exclusive_group()
    target.add_argument("--save", metavar="OUT.rrd", help="write a Rerun recording instead, as fast as possible")
    target.add_argument("--connect", metavar="URL",
                        help="stream to a running viewer, e.g. rerun+http://127.0.0.1:9876/proxy")
    where.add_argument("--force", action="store_true", help="overwrite an existing --save file")
    how = rep.add_argument_group("playback")
    how.add_argument("--rate", metavar="F", type=float, default=1.0,
                     help="speed factor of a live replay: 0.5 half speed, 2 twice as fast (default 1)")
    how.add_argument("--loop", action="store_true", help="start again at the end, until Ctrl-C (live only)")
    how.add_argument("--start", metavar="S", type=float, default=None,
                     help="begin this many seconds after the recording's start (its first /joint_states or /tf "
                          "stamp); latched data is re-emitted at the cut")
    how.add_argument("--end", metavar="S", type=float, default=None,
                     help="stop this many seconds after the recording's start")
    how.add_argument("--topics", metavar="TOPIC", nargs="+",
                     help=f"replay only these of {' '.join(RECORDED_TOPICS)}")
    check = rep.add_argument_group("re-simulation")
    check.add_argument("--check", action="store_true",
                       help="recompute TF from /joint_states and the description and compare with the recorded "
                            "TF, per frame; exit 1 above tolerance (replays too only with --save or --connect)")
    check.add_argument("--pos-tol", metavar="M", type=_tolerance, default=CHECK_POS_TOL,
                       help=f"translation tolerance (default {_number(CHECK_POS_TOL)})")
    check.add_argument("--rot-tol", metavar="RAD", type=_tolerance, default=CHECK_ROT_TOL,
                       help=f"rotation tolerance (default {_number(CHECK_ROT_TOL)})")
    check.add_argument("--json", action="store_true", help="print the --check report as JSON")
    rep.set_defaults(handler=_cmd_replay)
    return rep


def _cmd_replay(ns: argparse.Namespace) -> int:
    from .playback import check_play_options, replay_to_rerun
    from .replay import load_replay
    from .replay_check import check_replay, format_check

    live = not ns.check or ns.save is not None or ns.connect is not None
    if live:
        check_play_options(save=ns.save, connect=ns.connect, rate=ns.rate, loop=ns.loop, force=ns.force)
    robot = None
    if ns.robot:
        from .description import load_description, parse_xacro_args

        robot = load_description(ns.robot[0], args=parse_xacro_args(ns.robot[1:]), package_paths=ns.package_path,
                                 strict_xacro=ns.strict_xacro)
    replay = load_replay(ns.file, robot=robot, topics=ns.topics, start_s=ns.start, end_s=ns.end,
                         need_robot=ns.check)
    status = 0
    if ns.check:
        report = check_replay(replay, pos_tol=ns.pos_tol, rot_tol=ns.rot_tol)
        if ns.json:
            json.dump(report.to_dict(), sys.stdout, indent=2)
            sys.stdout.write("\n")
        else:
            sys.stdout.write(format_check(report))
        status = 0 if report.passed else 1
        if not live:
            return status
    replay_to_rerun(replay, save=ns.save, connect=ns.connect, rate=ns.rate, loop=ns.loop,
                    package_paths=ns.package_path, force=ns.force, checked=True)
    span = 0.0 if replay.start_ns is None or replay.end_ns is None else (replay.end_ns - replay.start_ns) / NS_PER_S
    derived = f", {replay.derived_summary()}" if replay.derived else ""
    print(f"replayed {ns.file}: {span:g} s{derived}" + (f"; wrote {ns.save}" if ns.save else ""),
          file=sys.stdout if ns.save and not ns.json else sys.stderr)
    return status


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: TextIO | None = None, line: str | None = None) -> None:
    print(f"{PROG}: warning: {message}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    parser = _build_parser()
    try:
        ns = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help, --version, or a usage error (exit 2)
        return int(exc.code or 0)
    with warnings.catch_warnings(), _terminate_as_interrupt():
        warnings.simplefilter("default")
        warnings.showwarning = _show_warning
        try:
            return int(ns.handler(ns))
        except TfrecError as err:
            print(f"{PROG}: error: {err}", file=sys.stderr)
            return 2
        except _Terminated:
            print(f"{PROG}: terminated", file=sys.stderr)
            return 143
        except KeyboardInterrupt:
            print(f"{PROG}: interrupted", file=sys.stderr)
            return 130
        except BrokenPipeError:
            return 0


class _Terminated(KeyboardInterrupt):
    """SIGTERM (``kill``, ``timeout``), raised like Ctrl-C so that outputs are cleaned up the same way."""


@contextlib.contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    def handler(signum: int, frame: object) -> None:
        raise _Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def main_exit() -> None:
    """Console-script entry point: ``sys.exit(main())``."""
    sys.exit(main())
