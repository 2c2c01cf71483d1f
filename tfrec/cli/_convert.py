"""``tfrec convert``: cut, filter and convert a recording between MCAP, rosbag2, ROS 1 bags and Rerun."""

from __future__ import annotations

import argparse
from typing import Any

from tfrec.cli._common import add_naming_arguments, add_xacro_arguments, load_robot_option

__all__ = ["add_parser"]


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """The ``convert`` subcommand."""
    conv: argparse.ArgumentParser = sub.add_parser(
        "convert", help="cut, filter and convert a recording (MCAP, rosbag2, ROS 1 bag, .rrd), keeping latched data",
        description="Write a recording as a ROS 2 MCAP (OUT.mcap), a ROS 1 bag (OUT.bag), a Rerun recording "
                    "(OUT.rrd, as replay --save) or a rosbag2 folder (--bag DIR). Every topic is kept, whatever its "
                    "type: copied as it is, or converted between ROS 1 and ROS 2 with the file's own message "
                    "definitions; a topic that cannot be carried over is named in a warning. With --start, the last "
                    "message before the cut of every latched topic (/tf_static, /robot_description, …) is written at "
                    "the cut. Where /tf lacks joints of a robot, their TF is computed from /joint_states as "
                    "robot_state_publisher would.",
    )
    conv.add_argument("file", metavar="IN", help="a .mcap file, a rosbag2 folder or a ROS 1 .bag")
    conv.add_argument("out", metavar="OUT", nargs="?", help="OUT.mcap, OUT.bag or OUT.rrd")
    conv.add_argument("--bag", metavar="DIR", help="write a rosbag2 folder instead (DIR/metadata.yaml + MCAP)")
    conv.add_argument("--force", action="store_true", help="replace an existing output tfrec would write there (never another file, nor the input)")
    conv.add_argument("--compression", metavar="C",
                      help="chunk compression: MCAP zstd (default), lz4 or none; ROS 1 none (default), bz2 or lz4")
    what = conv.add_argument_group("what is written")
    what.add_argument("--start", metavar="S", type=float, default=None,
                      help="keep what was logged this many seconds after the recording's start (when its first "
                           "/joint_states or /tf message was logged); latched topics keep their last message, at "
                           "the cut")
    what.add_argument("--end", metavar="S", type=float, default=None,
                      help="keep what was logged up to this many seconds after the recording's start")
    what.add_argument("--topics", metavar="TOPIC", nargs="+", help="write only these topics")
    what.add_argument("--exclude", metavar="TOPIC", nargs="+", default=[], help="leave these topics out")
    add_naming_arguments(what, log_time=False)
    tf = conv.add_argument_group("TF from joint states")
    switch = tf.add_mutually_exclusive_group()
    switch.add_argument("--tf-from-joints", dest="tf_from_joints", action="store_true", default=None,
                        help="compute /tf (and /tf_static) for every joint the recorded TF lacks, from /joint_states "
                             "and the description (default: when a robot's /tf lacks some of its moving joints)")
    switch.add_argument("--no-tf-from-joints", dest="tf_from_joints", action="store_false",
                        help="never compute TF: write what was recorded")
    tf.add_argument("--robot", metavar=("FILE", "name:=value"), nargs="+",
                    help="the robot's .urdf/.xacro (with xacro arguments): its TF is computed with it, and it "
                         "replaces the recorded /robot_description")
    tf.add_argument("--package-path", metavar="DIR", action="append", default=[],
                    help="a package, or a folder of packages, for $(find pkg) and package:// meshes (repeatable)")
    add_xacro_arguments(tf)
    conv.formatter_class = argparse.RawDescriptionHelpFormatter
    conv.epilog = ("examples:\n  tfrec convert robot.bag robot.mcap\n"
                   "  tfrec convert run.mcap cut.bag --start 60 --end 90\n"
                   "  tfrec convert bag_folder/ --bag small --topics /tf /tf_static /joint_states\n"
                   "  tfrec convert joints_only.bag with_tf.mcap --robot robot.urdf.xacro")
    conv.set_defaults(handler=_cmd_convert)
    return conv


def _cmd_convert(ns: argparse.Namespace) -> int:
    from tfrec.convert import check_convert_target, convert, output_kind

    target, kind = output_kind(ns.out, ns.bag)  # checked before anything is read, --robot included
    check_convert_target(target, kind, compression=ns.compression, force=ns.force,
                         inputs=[ns.file, ns.robot[0] if ns.robot else None])
    robot = load_robot_option(ns)
    result = convert(ns.file, ns.out, bag=ns.bag, start_s=ns.start, end_s=ns.end, topics=ns.topics,
                     exclude=ns.exclude, namespace=ns.namespace, remap=ns.remap, tf_from_joints=ns.tf_from_joints,
                     robot=robot, compression=ns.compression, force=ns.force, package_paths=ns.package_path)
    report = result.report
    if report is None:
        print(f"wrote {result.target} ({result.description})")
        return 0
    topics = sum(1 for count in report.written.values() if count)
    print(f"wrote {result.target} ({result.description}): {report.messages:,} messages on {topics} "
          f"topic{'s' if topics != 1 else ''}")
    start, end = result.window
    if start is not None or end is not None:
        span = f"{start or 0:g} s to " + ("the end" if end is None else f"{end:g} s")
        kept = f"; latched at the cut: {', '.join(report.latched)}" if report.latched else ""
        print(f"cut from {span}{kept}")
    for key, (joints, fixed) in report.derived.items():
        parts = ([f"{joints} joint{'s' if joints != 1 else ''} from /joint_states"] if joints else []) + (
            [f"{fixed} fixed frame{'s' if fixed != 1 else ''} from the description"] if fixed else [])
        if parts:
            print(f"TF computed{f' for {key}' if key else ''}: {' and '.join(parts)}")
    for topic, count in report.replaced.items():
        print(f"{topic}: {count:,} recorded description{'s' if count != 1 else ''} replaced by --robot's")
    if report.left_out:
        count = sum(report.left_out.values())
        print(f"left out: {len(report.left_out)} topic{'s' if len(report.left_out) != 1 else ''} "
              f"({count:,} messages) by --topics/--exclude/--namespace")
    return 0
