"""``tfrec plot``: a recording's joint states and frame paths as a picture (PNG, SVG or PDF)."""

from __future__ import annotations

import argparse
from typing import Any

from tfrec.cli._common import load_robot_option, show
from tfrec.errors import TfrecWarning

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers)."""
    plot = sub.add_parser(
        "plot", help="draw a recording: joint positions and velocities over time, frame paths (PNG, SVG, PDF)",
        description="Draw a recording headless: joint positions and velocities over time, one panel per unit "
                    "(rad, m), each joint in its own stable colour, limits as shaded bands; and the paths of "
                    "chosen frames in top and side views. The same input gives the same SVG bytes.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  tfrec plot recordings/marm.mcap -o marm.png\n"
               "  tfrec plot bag_folder/ -o arm.svg --frames gripper_link tool0\n"
               "  tfrec plot robot.bag -o robot.pdf --robot robot.urdf\n"
               "  tfrec plot two_robots.bag -o robot1.png --namespace /robot1",
    )
    plot.add_argument("file", metavar="FILE", help="a .mcap file, a rosbag2 folder, a ROS 1 .bag or a .rrd")
    plot.add_argument("-o", "--output", metavar="OUT", required=True, help="the picture: OUT.png, .svg or .pdf")
    plot.add_argument("--frames", metavar="FRAME", nargs="+",
                      help="frames whose paths to draw (default: the leaves of the TF tree)")
    plot.add_argument("--robot", metavar=("FILE", "name:=value"), nargs="+",
                      help="the description (joint limits and units) when the recording has no /robot_description")
    plot.add_argument("--package-path", metavar="DIR", action="append", default=[],
                      help="a package, or a folder of packages, for $(find pkg) in --robot (repeatable)")
    plot.add_argument("--namespace", metavar="NS",
                      help="the robot of this namespace (/robot1; '/' for the root's) when the recording holds "
                           "several")
    plot.add_argument("--force", action="store_true", help="replace an existing OUT picture (never another file)")
    plot.set_defaults(handler=_cmd_plot)


def _cmd_plot(ns: argparse.Namespace) -> int:
    from tfrec.conventions import namespace_name
    from tfrec.formats import read_recording
    from tfrec.plots import plot_format, plot_recording, refuse_existing

    plot_format(ns.output)
    refuse_existing(ns.output, force=ns.force, inputs=[ns.file, ns.robot[0] if ns.robot else None])
    robot = load_robot_option(ns)
    namespace = None if ns.namespace is None else namespace_name(ns.namespace)
    recording = read_recording(ns.file, namespace=namespace)
    if recording.read_error:
        import warnings

        warnings.warn(recording.read_error, TfrecWarning, stacklevel=1)
    plot_recording(recording, ns.output, robot=robot, frames=ns.frames, namespace=namespace, force=ns.force)
    show(f"wrote {ns.output}")
    return 0
