"""``tfrec replay``: play a recording back into Rerun, or re-simulate it (``--check``)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from tfrec.cli._common import (
    add_naming_arguments,
    add_xacro_arguments,
    as_flags,
    load_robot_option,
    number,
    show,
    tolerance,
)
from tfrec.conventions import (
    CHECK_POS_TOL,
    CHECK_ROT_TOL,
    NS_PER_S,
    RECORDED_TOPICS,
)
from tfrec.errors import ReplayError

__all__ = ["add_parser"]


def add_parser(sub: Any) -> argparse.ArgumentParser:
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
    add_xacro_arguments(model)
    where = rep.add_argument_group("where to (default: spawn the Rerun viewer)")
    target = where.add_mutually_exclusive_group()
    target.add_argument("--save", metavar="OUT.rrd", help="write a Rerun recording instead, as fast as possible")
    target.add_argument("--connect", metavar="URL",
                        help="stream to a running viewer, e.g. rerun+http://127.0.0.1:9876/proxy")
    where.add_argument("--force", action="store_true", help="replace an existing --save recording or --plot picture (never another file, nor the input)")
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
                     help=f"replay only these of {' '.join(RECORDED_TOPICS)} (of every namespace), or of one "
                          "namespace (/robot1/tf)")
    add_naming_arguments(rep.add_argument_group("topics and robots"))
    check = rep.add_argument_group("re-simulation")
    check.add_argument("--check", action="store_true",
                       help="recompute TF from /joint_states and the description and compare with the recorded "
                            "TF, per frame; exit 1 above tolerance (replays too only with --save or --connect)")
    check.add_argument("--pos-tol", metavar="M", type=tolerance, default=CHECK_POS_TOL,
                       help=f"translation tolerance (default {number(CHECK_POS_TOL)})")
    check.add_argument("--rot-tol", metavar="RAD", type=tolerance, default=CHECK_ROT_TOL,
                       help=f"rotation tolerance (default {number(CHECK_ROT_TOL)})")
    check.add_argument("--json", action="store_true", help="print the --check report as JSON")
    check.add_argument("--plot", metavar="OUT",
                       help="with --check: draw each frame's translation and rotation error over time, with the "
                            "tolerance and the first time it is exceeded (OUT.png, .svg or .pdf; --force replaces one)")
    rep.formatter_class = argparse.RawDescriptionHelpFormatter
    rep.epilog = ("examples:\n  tfrec replay recordings/marm.mcap\n"
                  "  tfrec replay bag_folder/ --save bag.rrd --start 10 --end 20\n"
                  "  tfrec replay robot.bag --check --robot robot.urdf --plot check.png")
    rep.set_defaults(handler=_cmd_replay)
    return rep


def _check_outputs(ns: argparse.Namespace, inputs: list[str | None]) -> None:
    """``--save`` and ``--plot``, checked together before anything is read (:func:`tfrec._outputs.check_outputs`)."""
    from pathlib import Path

    from tfrec._outputs import OutputKind, check_outputs
    from tfrec.formats.kinds import RRD

    outputs: list[tuple[Path, OutputKind]] = []
    if ns.plot is not None:
        from tfrec.plots import picture_kind, plot_format

        if not ns.check:
            raise ReplayError("`plot` draws a check: it goes with `check`")
        plot_format(ns.plot)
        outputs.append((Path(ns.plot), picture_kind(ns.plot)))
    if ns.save is not None:
        outputs.append((Path(ns.save), RRD))
    check_outputs(outputs, force=ns.force, inputs=inputs)


def _cmd_replay(ns: argparse.Namespace) -> int:
    from tfrec.replay.check import check_recording_pieces, check_replay, format_check
    from tfrec.replay.load import load_replay
    from tfrec.replay.play import check_play_options, replay_to_rerun

    live = not ns.check or ns.save is not None or ns.connect is not None
    inputs = [ns.file, ns.robot[0] if ns.robot else None]
    _check_outputs(ns, inputs)
    if live:
        from tfrec.formats import identify_recording

        identify_recording(ns.file)  # a missing file or not a recording: said before looking for a viewer
        check_play_options(save=ns.save, connect=ns.connect, rate=ns.rate, loop=ns.loop, force=ns.force,
                           inputs=inputs)
    robot = load_robot_option(ns)
    if ns.check and not live and ns.plot is None and ns.start is None and ns.end is None:  # read piece by piece
        report = check_recording_pieces(ns.file, robot=robot, topics=ns.topics, namespace=ns.namespace,
                                        remap=ns.remap, use_log_time=ns.use_log_time, pos_tol=ns.pos_tol,
                                        rot_tol=ns.rot_tol)
        show(*(json.dumps(report.to_dict(), indent=2) if ns.json else as_flags(format_check(report)).rstrip("\n")).split("\n"))
        return 0 if report.passed else 1
    replay = load_replay(ns.file, robot=robot, topics=ns.topics, start_s=ns.start, end_s=ns.end,
                         need_robot=ns.check, namespace=ns.namespace, remap=ns.remap, use_log_time=ns.use_log_time)
    status = 0
    if ns.check:  # a plot of the errors over time, or a time window: the whole recording
        report = check_replay(replay, pos_tol=ns.pos_tol, rot_tol=ns.rot_tol)
        show(*(json.dumps(report.to_dict(), indent=2) if ns.json else as_flags(format_check(report)).rstrip("\n")).split("\n"))
        status = 0 if report.passed else 1
        if ns.plot is not None:
            from tfrec.plots import plot_check

            plot_check(report, ns.plot, force=ns.force)
            show(f"wrote {ns.plot}", file=sys.stderr if ns.json else sys.stdout)
        if not live:
            return status
    replay_to_rerun(replay, save=ns.save, connect=ns.connect, rate=ns.rate, loop=ns.loop,
                    package_paths=ns.package_path, force=ns.force, checked=True)
    span = 0.0 if replay.start_ns is None or replay.end_ns is None else (replay.end_ns - replay.start_ns) / NS_PER_S
    derived = f", {replay.derived_summary()}" if replay.derived else ""
    keys = [robot.key for robot in replay.robots]
    robots = f", {len(keys)} robots ({', '.join(key or '/' for key in keys)})" if len(keys) > 1 else ""
    show(f"replayed {ns.file}: {span:g} s{robots}{derived}" + (f"; wrote {ns.save}" if ns.save else ""),
          file=sys.stdout if ns.save and not ns.json else sys.stderr)
    return status
