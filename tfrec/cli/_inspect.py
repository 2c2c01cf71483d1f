"""``tfrec inspect``: load a robot description and print its tree, its URDF or JSON."""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any, TextIO

from tfrec.cli._common import (
    add_robot_arguments,
    fmt,
    load_robot,
)

if TYPE_CHECKING:
    from tfrec.model import Joint, Robot

__all__ = ["add_parser", "robot_to_json"]


def add_parser(sub: Any) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers)."""
    inspect = sub.add_parser(
        "inspect", help="load a robot description and print its link/joint tree (like check_urdf)",
        description="Load a robot description (xacro expanded, validated) and print its name, root link "
                    "and link/joint tree with joint types, axes and limits.",
    )
    add_robot_arguments(inspect)
    printed = inspect.add_mutually_exclusive_group()
    printed.add_argument("--urdf", action="store_true", help="print the expanded URDF")
    printed.add_argument("--json", action="store_true", help="print the model as JSON")
    printed.add_argument("--graph", metavar="OUT",
                         help="draw the link/joint tree, like urdf_to_graphiz: OUT.svg, .png, .pdf or .dot")
    inspect.add_argument("--force", action="store_true", help="overwrite an existing --graph file")
    inspect.formatter_class = argparse.RawDescriptionHelpFormatter
    inspect.epilog = ("examples:\n  tfrec inspect robots/marm.xacro\n"
                      "  tfrec inspect robots/marm.xacro --graph marm-tree.svg\n"
                      "  tfrec inspect panda.urdf.xacro hand:=true --package-path ~/ws/src --urdf > panda.urdf")
    inspect.set_defaults(handler=_cmd_inspect)


def _joint_label(joint: Joint) -> str:
    parts = [joint.type.value]
    if joint.type.moves:
        parts.append("axis " + " ".join(fmt(a) for a in joint.axis))
    if joint.limit is not None and joint.type.value in ("revolute", "prismatic"):
        parts.append(f"limits [{fmt(joint.limit.lower)}, {fmt(joint.limit.upper)}]")
    if joint.mimic is not None:
        parts.append(f"mimics {joint.mimic.joint} ×{fmt(joint.mimic.multiplier)} {joint.mimic.offset:+.6g}")
    return ", ".join(parts)


MAX_INDENT = 40
"""Levels of the printed tree drawn as indentation; deeper links are printed at this indentation with their
depth in front (a chain of 100,000 links would otherwise print 20 GB of spaces)."""


def _print_tree(robot: Robot, out: TextIO) -> None:
    actuated = len(robot.actuated_joints)
    out.write(f"robot name is: {robot.name}\n")
    out.write(f"{len(robot.links)} links, {len(robot.joints)} joints ({actuated} actuated)\n")
    out.write(f"root link: {robot.root}\n")
    out.write(f"{robot.root}\n")

    # depth-first with an explicit stack: a chain may be longer than Python's recursion limit
    stack = [(joint, "", 1, i == len(robot.child_joints[robot.root]) - 1)
             for i, joint in enumerate(robot.child_joints[robot.root])][::-1]
    while stack:
        joint, indent, depth, last = stack.pop()
        mark = f"[{depth}] " if depth > MAX_INDENT else ""
        out.write(f"{indent}{mark}{'└── ' if last else '├── '}{joint.child}  ({joint.name}: {_joint_label(joint)})\n")
        below = robot.child_joints[joint.child]
        deeper = indent + ("    " if last else "│   ") if depth < MAX_INDENT else indent
        stack.extend([(child, deeper, depth + 1, i == len(below) - 1) for i, child in enumerate(below)][::-1])


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
    if ns.graph is not None:
        from tfrec.plots import graph_format, refuse_existing

        graph_format(ns.graph)
        refuse_existing(ns.graph, force=ns.force)
    robot = load_robot(ns)
    if ns.graph is not None:
        from tfrec.plots import render_graph, robot_graph

        render_graph(robot_graph(robot), ns.graph, force=ns.force)
        print(f"wrote {ns.graph}  ({len(robot.links)} links, {len(robot.joints)} joints)")
    elif ns.urdf:
        sys.stdout.write(robot.urdf if robot.urdf.endswith("\n") else robot.urdf + "\n")
    elif ns.json:
        json.dump(robot_to_json(robot), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        _print_tree(robot, sys.stdout)
    return 0
