"""Where tfrec puts things in a Rerun recording: the entity paths and the timeline.

Shared by the writer (:mod:`tfrec.rerun_io`) and the reader (:mod:`tfrec.rrd_read`).

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
- ``/joint_velocities/<joint>``: ``Scalars``, the joint velocity (rad/s or m/s), *ros_time*;
- ``/robot_description``: ``TextDocument``, the expanded URDF.

A replay may hold frames the robot model does not name (or have no model); they keep entities
of their own: ``/tf/<parent>/<child>`` (*ros_time*) and ``/tf_static/<parent>/<child>`` for a
pair whose child is no link, ``/robot/<frame>`` (``CoordinateFrame`` and ``TransformAxes3D``)
for such a frame.

The timeline ``ros_time`` holds the stamps of the recording as timestamps (integer
nanoseconds since the Unix epoch, like ROS time). Everything is sent with ``send_columns``:
one chunk per entity and piece of trajectory, no wall-clock ``log_time`` column, so the same
inputs and recording id give recordings ``rerun rrd compare`` finds identical.
"""

from __future__ import annotations

import rerun as rr

__all__ = [
    "APPLICATION_ID",
    "TIMELINE",
    "joint_entity",
    "link_entity",
    "pair_entity",
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


def link_entity(link: str) -> str:
    """``/robot/<link>``: the link's frame and its TF axes."""
    return f"/robot/{rr.escape_entity_path_part(link)}"


def visual_entity(link: str, index: int) -> str:
    """``/robot/<link>/visual_<index>``: the link's visual number ``index`` (document order)."""
    return f"{link_entity(link)}/visual_{index}"


def tf_entity(joint: str) -> str:
    """``/tf/<joint>``: the transforms of a moving joint over time."""
    return f"/tf/{rr.escape_entity_path_part(joint)}"


def tf_static_entity(joint: str) -> str:
    """``/tf_static/<joint>``: the transform of a fixed joint."""
    return f"/tf_static/{rr.escape_entity_path_part(joint)}"


def pair_entity(parent: str, child: str) -> str:
    """``/tf/<parent>/<child>``: a pair on /tf that is no joint of the robot."""
    return f"/tf/{rr.escape_entity_path_part(parent)}/{rr.escape_entity_path_part(child)}"


def static_pair_entity(parent: str, child: str) -> str:
    """``/tf_static/<parent>/<child>``: a pair on /tf_static that is no joint of the robot."""
    return f"/tf_static/{rr.escape_entity_path_part(parent)}/{rr.escape_entity_path_part(child)}"


def joint_entity(joint: str) -> str:
    """``/joints/<joint>``: the joint's position as a time series."""
    return f"/joints/{rr.escape_entity_path_part(joint)}"


def velocity_entity(joint: str) -> str:
    """``/joint_velocities/<joint>``: the joint's velocity as a time series."""
    return f"/joint_velocities/{rr.escape_entity_path_part(joint)}"
