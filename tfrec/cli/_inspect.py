"""``tfrec inspect``: load a robot description and print its tree, its URDF or JSON."""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from tfrec.cli._common import (
    add_robot_arguments,
    fmt,
    load_robot,
    show,
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
    inspect.add_argument("--force", action="store_true", help="replace an existing --graph picture (never another file)")
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


def _tree(robot: Robot) -> Iterator[str]:
    """The lines of check_urdf's tree."""
    actuated = len(robot.actuated_joints)
    yield f"robot name is: {robot.name}"
    yield f"{len(robot.links)} links, {len(robot.joints)} joints ({actuated} actuated)"
    yield f"root link: {robot.root}"
    yield robot.root

    # depth-first with an explicit stack: a chain may be longer than Python's recursion limit
    stack = [(joint, "", 1, i == len(robot.child_joints[robot.root]) - 1)
             for i, joint in enumerate(robot.child_joints[robot.root])][::-1]
    while stack:
        joint, indent, depth, last = stack.pop()
        mark = f"[{depth}] " if depth > MAX_INDENT else ""
        yield f"{indent}{mark}{'└── ' if last else '├── '}{joint.child}  ({joint.name}: {_joint_label(joint)})"
        below = robot.child_joints[joint.child]
        deeper = indent + ("    " if last else "│   ") if depth < MAX_INDENT else indent
        stack.extend([(child, deeper, depth + 1, i == len(below) - 1) for i, child in enumerate(below)][::-1])


def _xml_for_terminal(xml: str) -> str:
    """An XML document that can go to a terminal as it is: line ends as an XML parser reads them (``\\r\\n`` and
    ``\\r`` are ``\\n``), every other character that is not printable (a right-to-left override in a link's name)
    as a character reference (``&#x202E;``) — the same document to a parser, nothing that drives a terminal."""
    xml = xml.replace("\r\n", "\n").replace("\r", "\n")
    if xml.isprintable():
        return xml
    return "".join(c if c.isprintable() or c in "\n\t" else f"&#x{ord(c):X};" for c in xml)


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
        refuse_existing(ns.graph, force=ns.force, inputs=[ns.robot])
    robot = load_robot(ns)
    if ns.graph is not None:
        from tfrec.plots import render_graph, robot_graph

        render_graph(robot_graph(robot), ns.graph, force=ns.force)
        show(f"wrote {ns.graph}  ({len(robot.links)} links, {len(robot.joints)} joints)")
    elif ns.urdf:
        show(*_xml_for_terminal(robot.urdf).removesuffix("\n").split("\n"))
    elif ns.json:
        show(*json.dumps(robot_to_json(robot), indent=2).split("\n"))
    else:
        show(*_tree(robot))
    return 0
