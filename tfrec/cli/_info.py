"""``tfrec info``: summarize a recording."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from tfrec.cli._common import add_naming_arguments, show

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers)."""
    info = sub.add_parser("info", help="summarize a recording (MCAP, rosbag2 folder, ROS 1 bag or .rrd)",
                          description="Duration, start and end, topics with type, count and rate, and the "
                                      "robots (one per description and namespace) with their joints and TF "
                                      "frames, of tfrec's or any ROS recording, from the file's own index.")
    info.add_argument("file", metavar="FILE", help="a .mcap file, a rosbag2 folder, a ROS 1 .bag or a tfrec .rrd")
    info.add_argument("--json", action="store_true", help="print the summary as JSON")
    info.add_argument("--graph", metavar="OUT",
                      help="draw the recorded TF tree, like view_frames (parent → child, rates, static or "
                           "dynamic, topic): OUT.svg, .png, .pdf or .dot")
    info.add_argument("--force", action="store_true", help="replace an existing --graph picture (never another file)")
    info.formatter_class = argparse.RawDescriptionHelpFormatter
    info.epilog = ("examples:\n  tfrec info recordings/marm.mcap\n  tfrec info bag_folder/ --json\n"
                   "  tfrec info recordings/marm.mcap --graph frames.pdf")
    add_naming_arguments(info, log_time=False)
    info.set_defaults(handler=_cmd_info)


def _cmd_info(ns: argparse.Namespace) -> int:
    from tfrec.info import format_summary, summarize

    if ns.graph is not None:
        from tfrec.plots import graph_format, refuse_existing

        graph_format(ns.graph)
        refuse_existing(ns.graph, force=ns.force, inputs=[ns.file])
    summary = summarize(ns.file, namespace=ns.namespace, remap=ns.remap)
    if ns.graph is not None:
        from tfrec.conventions import ROBOT_DESCRIPTION, TF, TF_STATIC
        from tfrec.formats import read_recording
        from tfrec.plots import recorded_graph, render_graph

        topics = (TF, TF_STATIC, ROBOT_DESCRIPTION)  # a description's root link is the tree of a robot without TF
        render_graph(recorded_graph(read_recording(ns.file, topics=topics, namespace=ns.namespace,
                                                   remap=ns.remap)), ns.graph, force=ns.force)
    if ns.json:
        import json

        text = json.dumps(summary, indent=2)
    else:
        text = format_summary(summary).rstrip("\n")
    show(*text.split("\n"))
    if ns.graph is not None:
        show(f"wrote {ns.graph}", file=sys.stderr if ns.json else sys.stdout)
    return 0
