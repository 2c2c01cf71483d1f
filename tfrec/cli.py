"""The ``tfrec`` command line: the only module that parses argv, prints and picks exit codes.

Exit codes: 0 ok, 1 differences found, 2 user error (``tfrec: error: ...`` on stderr).
Heavy libraries (xacro, numpy, rerun, rosbags, yourdfpy) are imported inside the handlers,
so ``tfrec --help`` stays fast.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, TextIO

from . import __version__
from .errors import TfrecError

if TYPE_CHECKING:
    from .model import Joint, Robot

__all__ = ["main", "main_exit", "robot_to_json"]

PROG = "tfrec"


def _add_robot_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("robot", metavar="ROBOT", help="a .urdf, .xacro or .urdf.xacro file")
    parser.add_argument("xacro_args", metavar="name:=value", nargs="*", help="xacro arguments, as for ROS")
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


def _build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
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
    out = inspect.add_mutually_exclusive_group()
    out.add_argument("--urdf", action="store_true", help="print the expanded URDF")
    out.add_argument("--json", action="store_true", help="print the model as JSON")
    inspect.set_defaults(handler=_cmd_inspect)
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

    def walk(link: str, indent: str) -> None:
        joints = robot.child_joints[link]
        for i, joint in enumerate(joints):
            last = i == len(joints) - 1
            out.write(f"{indent}{'└── ' if last else '├── '}{joint.child}  ({joint.name}: {_joint_label(joint)})\n")
            walk(joint.child, indent + ("    " if last else "│   "))

    walk(robot.root, "")


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
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        warnings.showwarning = _show_warning
        try:
            return int(ns.handler(ns))
        except TfrecError as err:
            print(f"{PROG}: error: {err}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print(f"{PROG}: interrupted", file=sys.stderr)
            return 130
        except BrokenPipeError:
            return 0


def main_exit() -> None:
    """Console-script entry point: ``sys.exit(main())``."""
    sys.exit(main())
