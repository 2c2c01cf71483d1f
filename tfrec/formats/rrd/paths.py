"""Where tfrec puts things in a Rerun recording: the entity paths and the timeline.

Shared by the writer (:mod:`tfrec.viewer.sink`) and the reader (:mod:`tfrec.formats.rrd.reader`), which
parses them back with :func:`parse_entity`.

Entity paths (``<link>`` and ``<joint>`` are URDF names, escaped with
``rr.escape_entity_path_part``); static unless marked *ros_time*:

- ``/``: ``ViewCoordinates`` RIGHT_HAND_Z_UP (x forward, z up, as ROS's REP 103);
- ``/__properties``: ``RecordingInfo``, the recording's name and start time;
- ``/robot``: ``CoordinateFrame`` of the root link (the 3D view's origin);
- ``/robot/<link>``: ``CoordinateFrame`` of the link and ``TransformAxes3D`` (RViz's TF display);
- ``/robot/<link>/visual_<i>``: ``CoordinateFrame``, ``InstancePoses3D`` (the visual origin and
  mesh scale) and ``Boxes3D``, ``Cylinders3D``, ``Ellipsoids3D`` or ``Asset3D``;
- ``/tf_static/<joint>``: ``Transform3D`` parent_from_child of a fixed joint;
- ``/tf/<joint>``: ``Transform3D`` of a moving joint, *ros_time*;
- ``/joints/<joint>``: ``Scalars``, the joint position (rad or m), *ros_time*;
- ``/joints``: ``AnyValues`` ``joint_count`` 0, *ros_time*: the stamps of /joint_states messages that name
  no joint (a robot without moving joints), so that the timeline spans them;
- ``/joint_velocities/<joint>``: ``Scalars``, the joint velocity (rad/s or m/s), *ros_time*;
- ``/robot_description``: ``TextDocument``, the expanded URDF;
- ``/tf_tree``: ``GraphNodes`` (the frames) and ``GraphEdges`` (parent → child): the TF tree.

Joint plots carry a ``SeriesLines`` style (the joint's colour and name) beside their ``Scalars``.

A replay may hold frames the robot model does not name (or have no model); they keep entities
of their own: ``/tf/<parent>/<child>`` (*ros_time*) and ``/tf_static/<parent>/<child>`` for a
pair that is no joint of the robot (its child no link, or a link below another parent than its joint's), ``/robot/<frame>`` (``CoordinateFrame`` and ``TransformAxes3D``)
for such a frame.

The timeline ``ros_time`` holds the stamps of the recording as timestamps (integer
nanoseconds since the Unix epoch, like ROS time). Everything is sent with ``send_columns``:
one chunk per entity and piece of trajectory, no wall-clock ``log_time`` column, so the same
inputs and recording id give recordings ``rerun rrd compare`` finds identical.
"""

from __future__ import annotations

import re
import sys

import rerun as rr

from tfrec._address_space import check_rerun_address_space
from tfrec.errors import WriteError
from tfrec.model import Robot

__all__ = [
    "APPLICATION_ID",
    "DESCRIPTION_ROOT",
    "DISPLAY_PREFIX_ROOT",
    "ELAPSED_TIMELINE",
    "JOINTS_ROOT",
    "JOINT_COUNT",
    "MAX_LINKS",
    "NO_JOINTS_ENTITY",
    "ROBOT_ROOT",
    "TF_ROOT",
    "TF_STATIC_ROOT",
    "TF_TREE_ROOT",
    "TIMELINE",
    "VELOCITIES_ROOT",
    "check_rerun_robot",
    "joint_entity",
    "link_entity",
    "pair_entity",
    "parse_entity",
    "spoke_entity",
    "static_pair_entity",
    "tf_entity",
    "tf_static_entity",
    "velocity_entity",
    "visual_entity",
]

APPLICATION_ID = "tfrec"
"""The Rerun application id of every tfrec recording."""

TIMELINE = "ros_time"
"""The timeline holding the ROS stamps (timestamps, integer nanoseconds)."""

ELAPSED_TIMELINE = "time"
"""The timeline of the time since the recording's start (durations, integer nanoseconds): what the viewer shows
first, as seconds from 0 rather than a date."""

ROBOT_ROOT = "robot"
TF_ROOT = "tf"
TF_STATIC_ROOT = "tf_static"
JOINTS_ROOT = "joints"
VELOCITIES_ROOT = "joint_velocities"
DESCRIPTION_ROOT = "robot_description"
TF_TREE_ROOT = "tf_tree"
"""The top-level entity names (``/robot_description`` is an entity of its own)."""

JOINT_COUNT = "joint_count"
"""The ``AnyValues`` component at ``/joints`` whose rows are /joint_states messages naming no joint."""
NO_JOINTS_ENTITY = f"/{JOINTS_ROOT}"
"""Where the stamps of /joint_states messages that name no joint are logged."""

DISPLAY_PREFIX_ROOT = "frame_display_prefix"
"""A robot of a replay of several whose frame ids the viewer shows behind its name (``robot1/link0``:
robots of several namespaces with the same frame ids): that prefix, as a TextDocument, so that reading the
``.rrd`` back gives the frame ids the recording had."""

_UNESCAPED = {"n": "\n", "r": "\r", "t": "\t"}
_CODE_POINT = re.compile(r"u\{([0-9A-Fa-f]{1,6})\}")


def parse_entity(path: str) -> tuple[str, tuple[str, ...]]:
    """An entity path's top-level name and the names under it, unescaped: the inverse of the
    functions here (and of ``rr.escape_entity_path_part``).

    ``/tf/joint\\ 1`` → ``("tf", ("joint 1",))``; ``/tf/a/b`` → ``("tf", ("a", "b"))``;
    ``/`` → ``("", ())``.
    """
    parts: list[str] = []
    part: list[str] = []
    i, end = (1 if path.startswith("/") else 0), len(path)
    while i < end:
        char = path[i]
        if char == "/":
            parts.append("".join(part))
            part = []
        elif char == "\\" and i + 1 < end:
            code = _CODE_POINT.match(path, i + 1)
            if code is not None and int(code[1], 16) <= sys.maxunicode:
                part.append(chr(int(code[1], 16)))
                i = code.end() - 1
            else:
                i += 1
                part.append(_UNESCAPED.get(path[i], path[i]))
        else:
            part.append(char)
        i += 1
    if part or parts:
        parts.append("".join(part))
    return (parts[0], tuple(parts[1:])) if parts else ("", ())


def link_entity(link: str) -> str:
    """``/robot/<link>``: the link's frame and its TF axes."""
    return f"/{ROBOT_ROOT}/{rr.escape_entity_path_part(link)}"


def visual_entity(link: str, index: int) -> str:
    """``/robot/<link>/visual_<index>``: the link's visual number ``index`` (document order)."""
    return f"{link_entity(link)}/visual_{index}"


def spoke_entity(link: str) -> str:
    """``/robot/<link>/spoke``: a radius drawn on a wheel (the child link of a continuous joint), so that its turning
    shows."""
    return f"{link_entity(link)}/spoke"


def tf_entity(joint: str) -> str:
    """``/tf/<joint>``: the transforms of a moving joint over time."""
    return f"/{TF_ROOT}/{rr.escape_entity_path_part(joint)}"


def tf_static_entity(joint: str) -> str:
    """``/tf_static/<joint>``: the transform of a fixed joint."""
    return f"/{TF_STATIC_ROOT}/{rr.escape_entity_path_part(joint)}"


def pair_entity(parent: str, child: str) -> str:
    """``/tf/<parent>/<child>``: a pair on /tf that is no joint of the robot."""
    return f"/{TF_ROOT}/{rr.escape_entity_path_part(parent)}/{rr.escape_entity_path_part(child)}"


def static_pair_entity(parent: str, child: str) -> str:
    """``/tf_static/<parent>/<child>``: a pair on /tf_static that is no joint of the robot."""
    return f"/{TF_STATIC_ROOT}/{rr.escape_entity_path_part(parent)}/{rr.escape_entity_path_part(child)}"


def joint_entity(joint: str) -> str:
    """``/joints/<joint>``: the joint's position as a time series."""
    return f"/{JOINTS_ROOT}/{rr.escape_entity_path_part(joint)}"


def velocity_entity(joint: str) -> str:
    """``/joint_velocities/<joint>``: the joint's velocity as a time series."""
    return f"/{VELOCITIES_ROOT}/{rr.escape_entity_path_part(joint)}"


MAX_LINKS = 10_000
"""Links of a robot tfrec logs to Rerun at most. Rerun takes an entity per link and per visual, about a
millisecond and 60 kB each (a chain of 10,000 links: 10 s and 600 MB to record with an .rrd, 100,000 would take
minutes and gigabytes); the ROS outputs have no such bound."""


def check_rerun_robot(robot: Robot | None, target: str, *, hint: str = "") -> None:
    """Raise WriteError for a robot of more than :data:`MAX_LINKS` links, or an address space too small for
    Rerun (:func:`~tfrec._address_space.check_rerun_address_space`), before any output is written; ``hint``:
    what to do instead, ending the message."""
    check_rerun_address_space(target)
    if robot is not None and len(robot.links) > MAX_LINKS:
        raise WriteError(f"{target}: robot '{robot.name}' has {len(robot.links):,} links, more than tfrec logs to "
                         f"Rerun (at most {MAX_LINKS:,}: each link is an entity of its own, ~1 ms and 60 kB)"
                         + (f"; {hint}" if hint else ""))
