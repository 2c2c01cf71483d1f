"""``tfrec serve``: a robot (moved by a trajectory or by the clients) or a recording, live to Foxglove."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from tfrec.cli._common import add_robot_arguments, load_robot_and_launch, show, start_time
from tfrec.cli._record import add_trajectory_arguments, is_csv_trajectory, parse_overrides, recipe_metadata
from tfrec.errors import ReplayError, WriteError

if TYPE_CHECKING:
    from tfrec.live.serve import ServeResult
    from tfrec.live.server import FoxgloveServer
    from tfrec.model import Robot
    from tfrec.recorder import RecordingPlan
    from tfrec.recording import Transforms
    from tfrec.viewer.spawn import LiveRerunSink

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers)."""
    srv = sub.add_parser(
        "serve", help="serve a robot (or a recording) live to Foxglove: joints as parameters, TF, meshes",
        description="joint_state_publisher_gui + robot_state_publisher + foxglove_bridge without ROS: a Foxglove "
                    "WebSocket server with /robot_description, /tf_static, /joint_states and /tf (ROS 2 schemas, "
                    "CDR) and the description's meshes. Without --traj each actuated joint is a parameter that "
                    "clients set (Foxglove's Parameters panel), and Center and Randomize are services; with --traj "
                    "the robot follows the trajectory in real time. A recording (.mcap, rosbag2 folder, .bag) is "
                    "played instead, --rate times real time. The server has no authentication: it listens on "
                    "127.0.0.1 unless --host says otherwise (docs/live.md).",
    )
    srv.formatter_class = argparse.RawDescriptionHelpFormatter
    srv.epilog = ("examples:\n  tfrec serve robots/marm.xacro                 (then in Foxglove: Open connection, "
                  "ws://127.0.0.1:8765)\n"
                  "  tfrec serve robots/marm.xacro --traj sine --loop --record live.mcap\n"
                  "  tfrec serve recordings/marm-sine.mcap --rate 2 --start 1 --end 5")
    add_robot_arguments(srv)
    add_trajectory_arguments(
        srv, default=None,
        duration_help="seconds of the trajectory (default 10); without --traj: stop after this many seconds (default: "
                      "at Ctrl-C)",
        rate_help="samples per second (default 50); with a CSV file: resample its rows onto this clock; for a "
                  "recording: the speed, 2 = twice as fast (default 1)")
    live = srv.add_argument_group("serving")
    live.add_argument("--host", default="127.0.0.1",
                      help="address to listen on (default 127.0.0.1: this machine only; 0.0.0.0 lets any machine "
                           "that reaches this one connect, without authentication)")
    live.add_argument("--port", type=int, default=8765, help="port to listen on (default 8765; 0: any free port)")
    live.add_argument("--loop", action="store_true", help="play the trajectory (or recording) again at its end")
    live.add_argument("--start-time", metavar="S", type=start_time, default=None,
                      help="stamp of the first sample, seconds since the Unix epoch (default: now)")
    live.add_argument("--record", metavar="OUT.mcap",
                      help="keep what was served: the files `tfrec record -o OUT.mcap` writes (OUT.rrd beside it, "
                           "unless --no-rrd; a ROS 1 bag when it ends in .bag)")
    live.add_argument("--no-rrd", action="store_true", help="with --record: write no Rerun recording")
    viewer = live.add_mutually_exclusive_group()
    viewer.add_argument("--rerun", action="store_true", help="stream the same to a Rerun viewer (spawned) at the same pace")
    viewer.add_argument("--connect", metavar="URL",
                        help="stream the same to a running Rerun viewer, e.g. rerun+http://127.0.0.1:9876/proxy")
    live.add_argument("--force", action="store_true", help="replace existing --record outputs tfrec would write")
    rec = srv.add_argument_group("a recording (FILE instead of ROBOT)")
    rec.add_argument("--start", metavar="S", type=float, default=None,
                     help="begin this many seconds after the recording's start")
    rec.add_argument("--end", metavar="S", type=float, default=None,
                     help="stop this many seconds after the recording's start")
    srv.set_defaults(handler=_cmd_serve)


def _cmd_serve(ns: argparse.Namespace) -> int:
    from tfrec.live.serve import is_recording

    _check_viewer(ns)
    if is_recording(ns.robot):
        return _serve_recording(ns)
    if ns.start is not None or ns.end is not None:
        raise ReplayError("--start and --end cut a recording; a robot is served from its start")
    plan = _plan(ns)
    robot, launch = load_robot_and_launch(ns)
    params = launch.node_params if launch is not None else None
    frame_prefix = ns.frame_prefix
    if frame_prefix is None:
        frame_prefix = params.frame_prefix if params is not None and params.frame_prefix else ""
    return _serve_robot(ns, robot, plan, frame_prefix)


def _plan(ns: argparse.Namespace) -> RecordingPlan | None:
    from tfrec.recorder import plan_outputs

    if ns.record is None:
        return None
    return plan_outputs(stem=None, out=ns.record, no_rrd=ns.no_rrd, force=ns.force,
                        inputs=[ns.robot, ns.traj if ns.traj is not None and is_csv_trajectory(ns.traj) else None])


def _serve_robot(ns: argparse.Namespace, robot: Robot, plan: RecordingPlan | None, frame_prefix: str) -> int:
    import contextlib
    import time

    from tfrec.kinematics.fk import static_transforms
    from tfrec.live.joints import JointControl
    from tfrec.live.serve import DEFAULT_RATE_HZ, ServeOptions, reach_poses, serve_robot
    from tfrec.live.server import description_assets
    from tfrec.recorder import open_sinks, recording_id
    from tfrec.trajectory.generators import make_trajectory

    overrides = parse_overrides(ns.overrides)
    trajectory = control = None
    if ns.traj is not None:
        trajectory = make_trajectory(robot, ns.traj, duration_s=ns.duration, rate_hz=ns.rate, seed=ns.seed,
                                     period_s=ns.period, amplitude=ns.amplitude, overrides=overrides,
                                     soft_limits=not ns.hard_limits, interp=ns.interp,
                                     velocity_limits=not ns.ignore_velocity_limits)
    else:
        control = JointControl(robot, seed=ns.seed, soft_limits=not ns.hard_limits, overrides=overrides)
    assets = description_assets(robot, ns.package_path)
    options = ServeOptions(rate_hz=ns.rate or DEFAULT_RATE_HZ, loop=ns.loop,
                           duration_s=ns.duration if trajectory is None else None,
                           start_time_ns=ns.start_time if ns.start_time is not None else time.time_ns(),
                           frame_prefix=frame_prefix)
    assert options.start_time_ns is not None
    server = _start(ns, control, assets)
    try:
        with contextlib.ExitStack() as stack:
            rid = None if trajectory is None or ns.loop else recording_id(  # as record names the same recording
                robot, trajectory, start_time_ns=options.start_time_ns, frame_prefix=frame_prefix)
            # a whole trajectory served is the recording `tfrec record` makes of it: its recipe too
            metadata = None if trajectory is None or ns.loop else recipe_metadata(
                ns, robot, is_csv_trajectory(ns.traj), ns.rate, overrides, frame_prefix, options.start_time_ns)
            sinks = [] if plan is None else stack.enter_context(open_sinks(
                robot, plan, start_time_ns=options.start_time_ns, frame_prefix=frame_prefix,
                package_paths=ns.package_path, rerun_recording_id=rid, metadata=metadata))
            live = _viewer(ns, robot, frame_prefix, reach_poses(robot, trajectory=trajectory, control=control,
                                                                frame_prefix=frame_prefix, seed=ns.seed))
            if live is not None:
                live.begin(robot_description=robot.urdf, static=static_transforms(robot, frame_prefix=frame_prefix),
                           start_time_ns=options.start_time_ns)
                stack.callback(live.finish)
            _announce(ns, server, robot.name, trajectory is None)
            result = serve_robot(robot, server, trajectory=trajectory, options=options, sinks=sinks,
                                 live_sinks=[] if live is None else [live])
    finally:
        server.stop()
    _summary(result, plan)
    return 0


def _check_viewer(ns: argparse.Namespace) -> None:
    """A viewer asked for is there before anything is read (Rerun retries in the background otherwise)."""
    from tfrec.viewer.spawn import check_can_connect, check_can_spawn

    if ns.connect is not None:
        check_can_connect(ns.connect)
    elif ns.rerun:
        try:
            check_can_spawn()
        except WriteError as err:
            reason = str(err).split(";")[0]
            raise WriteError(f"--rerun: {reason}; use --connect URL to a viewer running elsewhere") from None


def _viewer(ns: argparse.Namespace, robot: Robot, frame_prefix: str, reach: Transforms) -> LiveRerunSink | None:
    from tfrec.viewer.spawn import open_live_rerun_sink

    if ns.connect is None and not ns.rerun:
        return None
    return open_live_rerun_sink(connect=ns.connect, robot=robot, frame_prefix=frame_prefix,
                                package_paths=ns.package_path, reach=reach)


def _start(ns: argparse.Namespace, control: Any, assets: Any) -> FoxgloveServer:
    from tfrec.live.server import FoxgloveServer

    return FoxgloveServer(host=ns.host, port=ns.port, control=control, assets=assets)


def _announce(ns: argparse.Namespace, server: FoxgloveServer, name: str, interactive: bool) -> None:
    host = "127.0.0.1" if ns.host in ("0.0.0.0", "") else ns.host
    show(f"serving {name} on ws://{host}:{server.port}  (Foxglove: Open connection → Foxglove WebSocket; Ctrl-C stops)")
    if interactive:
        show("move the joints from Foxglove's Parameters panel; services Center and Randomize (Service Call panel)")
    sys.stdout.flush()


def _summary(result: ServeResult, plan: RecordingPlan | None) -> None:
    how = "stopped" if result.interrupted else "done"
    late = f", {result.late} sent late" if result.late else ""
    show(f"{how}: served {result.samples} samples{late}", file=sys.stderr)
    if plan is not None:
        for path in (plan.main, plan.rrd):
            if path is not None:
                show(f"wrote {path}")


def _serve_recording(ns: argparse.Namespace) -> int:
    from tfrec.live.serve import serve_recording
    from tfrec.replay.load import load_replay

    if ns.record is not None:
        raise WriteError("--record keeps a robot served live; a recording is already one (tfrec convert cuts it)")
    if ns.traj is not None:
        raise ReplayError("--traj drives a robot; a recording plays its own samples")
    rate = 1.0 if ns.rate is None else ns.rate
    if not rate > 0:
        raise ReplayError(f"--rate {rate:g}: a recording plays at a speed factor above 0")
    replay = load_replay(ns.robot, start_s=ns.start, end_s=ns.end)
    also = None
    if ns.rerun or ns.connect is not None:
        from tfrec.viewer.spawn import open_rerun_sink

        also = open_rerun_sink(connect=ns.connect, robot=replay.robot, frame_prefix=replay.frame_prefix)
    server = _start(ns, None, {})
    try:
        _announce(ns, server, replay.robot.name if replay.robot is not None else ns.robot, False)
        result = serve_recording(replay, server, rate=rate, loop=ns.loop, also=also)
    finally:
        server.stop()
    passes = f" over {result.passes} passes" if result.passes != 1 else ""
    show(f"{'stopped' if result.interrupted else 'done'}: served {result.samples} messages{passes} at {rate:g}x",
         file=sys.stderr)
    return 0
