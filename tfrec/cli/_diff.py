"""``tfrec diff``: compare two recordings by meaning."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from tfrec.cli._common import (
    add_naming_arguments,
    as_flags,
    number,
    tolerance,
)
from tfrec.conventions import (
    DIFF_JOINT_TOL,
    DIFF_POS_TOL,
    DIFF_ROT_TOL,
)

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers)."""
    diff = sub.add_parser(
        "diff", help="compare two recordings by meaning (description, topics, joint states, TF)",
        description="Compare two recordings — MCAP, rosbag2 folder, ROS 1 bag or tfrec .rrd — by meaning: the "
                    "robot description as URDF, topics, joint positions and transforms, aligned by the time "
                    "since each recording's start (its first /joint_states or /tf stamp). Exit 0 when "
                    "identical within tolerance, 1 when different, 2 on error.",
    )
    diff.add_argument("a", metavar="A", help="a recording: .mcap, rosbag2 folder, ROS 1 .bag or .rrd")
    diff.add_argument("b", metavar="B", help="the recording to compare with A")
    diff.add_argument("--pos-tol", metavar="M", type=tolerance, default=DIFF_POS_TOL,
                      help=f"translations within M metres are equal (default {number(DIFF_POS_TOL)})")
    diff.add_argument("--rot-tol", metavar="RAD", type=tolerance, default=DIFF_ROT_TOL,
                      help=f"rotations within RAD radians are equal (default {number(DIFF_ROT_TOL)})")
    diff.add_argument("--joint-tol", metavar="X", type=tolerance, default=DIFF_JOINT_TOL,
                      help=f"joint positions within X (rad or m) are equal (default {number(DIFF_JOINT_TOL)})")
    diff.add_argument("--topics", metavar="TOPIC", nargs="+", help="compare only these topics (default: all)")
    diff.add_argument("--absolute", action="store_true",
                      help="align samples on their stamps, not on the time since each recording's start")
    diff.add_argument("--json", action="store_true", help="print the report as JSON")
    diff.add_argument("--plot", metavar="OUT",
                      help="draw each frame's translation and rotation error over time, worst frames first, with "
                           "the tolerance and the first time it is exceeded (OUT.png, .svg or .pdf)")
    diff.add_argument("--force", action="store_true", help="overwrite an existing --plot file")
    diff.formatter_class = argparse.RawDescriptionHelpFormatter
    diff.epilog = ("examples:\n  tfrec diff golden.mcap new.mcap\n"
                   "  tfrec diff a.mcap b.bag --pos-tol 1e-6 --json\n"
                   "  tfrec diff before.mcap after.mcap --plot diff.png")
    add_naming_arguments(diff)
    diff.set_defaults(handler=_cmd_diff)


def _cmd_diff(ns: argparse.Namespace) -> int:
    from tfrec.diff.compare import compare

    if ns.plot is not None:
        from tfrec.plots import plot_format, refuse_existing

        plot_format(ns.plot)
        refuse_existing(ns.plot, force=ns.force)
    report = compare(ns.a, ns.b, pos_tol=ns.pos_tol, rot_tol=ns.rot_tol, joint_tol=ns.joint_tol,
                     topics=ns.topics, absolute=ns.absolute, namespace=ns.namespace, remap=ns.remap,
                     use_log_time=ns.use_log_time)
    sys.stdout.write(report.to_json() + "\n" if ns.json else as_flags(report.to_text()))
    if ns.plot is not None:
        from tfrec.plots import plot_diff

        plot_diff(report, ns.plot, force=ns.force)
        print(f"wrote {ns.plot}", file=sys.stderr if ns.json else sys.stdout)
    return 0 if report.equal else 1
