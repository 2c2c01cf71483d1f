"""``tfrec info``: summarize a recording."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers)."""
    info = sub.add_parser("info", help="summarize a recording (MCAP, rosbag2 folder, ROS 1 bag or .rrd)",
                          description="Duration, start and end, topics with type, count and rate, joints, "
                                      "TF frames and the robot's name, of tfrec's or any ROS 2 recording.")
    info.add_argument("file", metavar="FILE", help="a .mcap file, a rosbag2 folder, a ROS 1 .bag or a tfrec .rrd")
    info.add_argument("--json", action="store_true", help="print the summary as JSON")
    info.set_defaults(handler=_cmd_info)


def _cmd_info(ns: argparse.Namespace) -> int:
    from tfrec.info import format_summary, summarize

    summary = summarize(ns.file)
    if ns.json:
        json.dump(summary, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_summary(summary).rstrip("\n") + "\n")
    return 0
