"""ROS facts and tfrec defaults shared by every stage: time base, topic names, compressions, tolerances.

Cheap to import (no numpy), at the top of the data flow, so writers and readers agree on one
definition of each.
"""

from __future__ import annotations

import math

__all__ = [
    "CHECK_POS_TOL",
    "CHECK_ROT_TOL",
    "CLOCK_GAP_NS",
    "COMPRESSIONS",
    "DEFAULT_START_TIME_NS",
    "DIFF_JOINT_TOL",
    "DIFF_POS_TOL",
    "DIFF_ROT_TOL",
    "FLOAT32_TOL",
    "JOINT_STATES",
    "MAX_OFFSET_S",
    "NS_PER_S",
    "RECORDED_TOPICS",
    "ROBOT_DESCRIPTION",
    "ROS1_COMPRESSIONS",
    "STAMP_LIMIT_NS",
    "STAMP_RANGE",
    "TF",
    "TF_STATIC",
    "global_topic",
    "namespace_name",
    "offset_ns",
    "robot_topic_kind",
    "split_topic",
]

NS_PER_S = 1_000_000_000

STAMP_LIMIT_NS = 2**31 * NS_PER_S
"""Stamps must be below this: ROS 2's builtin_interfaces/Time holds int32 seconds."""

STAMP_RANGE = f"ROS 2 stamps hold less than {STAMP_LIMIT_NS // NS_PER_S} s"
"""How messages about out-of-range times end."""

CLOCK_GAP_NS = 3600 * NS_PER_S
"""Header stamps further than this from their messages' log times are on another clock than the
recorder's: sim time (``use_sim_time``: seconds since the simulator started), or a driver's own."""

DEFAULT_START_TIME_NS = 1_700_000_000 * NS_PER_S
"""Stamps start here unless ``--start-time`` says otherwise: 2023-11-14T22:13:20Z. A fixed epoch
makes the same command give byte-identical files."""

ROBOT_DESCRIPTION = "/robot_description"
TF_STATIC = "/tf_static"
JOINT_STATES = "/joint_states"
TF = "/tf"
RECORDED_TOPICS = (ROBOT_DESCRIPTION, TF_STATIC, JOINT_STATES, TF)
"""The topics tfrec records, in channel order; replay and diff read these (in every namespace:
``/robot1/tf`` is robot1's /tf)."""

COMPRESSIONS = ("none", "lz4", "zstd")
"""MCAP chunk compressions ``--compression`` accepts."""
ROS1_COMPRESSIONS = ("none", "bz2", "lz4")
"""ROS 1 bag chunk compressions (``-o out.bag --compression …``), as ``rosbag record`` offers them."""

DIFF_POS_TOL = 1e-9
"""``tfrec diff``'s default translation tolerance (m): two float64 recordings of one computation."""
DIFF_ROT_TOL = 1e-9
"""``tfrec diff``'s default rotation tolerance (rad)."""
DIFF_JOINT_TOL = 1e-9
"""``tfrec diff``'s default joint-position tolerance (rad or m)."""
FLOAT32_TOL = 1e-5
"""A tolerance for comparing with a ``.rrd``, which stores transforms as float32."""
CHECK_POS_TOL = 1e-6
"""``tfrec replay --check``'s default translation tolerance (m)."""
CHECK_ROT_TOL = 1e-6
"""``tfrec replay --check``'s default rotation tolerance (rad)."""


# -- topic names ------------------------------------------------------------------------------------


def global_topic(name: str) -> str:
    """A recorded topic name as a player in the root namespace publishes it.

    ``rosbag play`` and ``ros2 bag play`` resolve a relative name (``joint_states``, which
    robot_state_publisher's own ROS 1 test bag records) in the root namespace: ``/joint_states``.
    Repeated and trailing slashes are dropped, as ROS's name resolution drops them.
    """
    return "/" + "/".join(part for part in name.split("/") if part)


def split_topic(name: str) -> tuple[str, str]:
    """A topic's namespace and base name: ``/robot1/tf`` → ``("/robot1", "/tf")``,
    ``/tf`` → ``("", "/tf")``, ``joint_states`` → ``("", "/joint_states")``."""
    namespace, _, base = global_topic(name).rpartition("/")
    return namespace, "/" + base


def robot_topic_kind(name: str) -> tuple[str, str] | None:
    """(namespace, kind) of one of a robot's topics — kind one of :data:`RECORDED_TOPICS`, in any
    namespace: ``/robot1/tf`` → ``("/robot1", "/tf")``; None for any other topic."""
    namespace, base = split_topic(name)
    return (namespace, base) if base in RECORDED_TOPICS else None


def namespace_name(text: str) -> str:
    """A namespace as given by a user (``robot1``, ``/robot1/``, ``/``) in tfrec's form:
    ``/robot1``, and ``""`` for the root namespace."""
    return "" if global_topic(text) == "/" else global_topic(text)


MAX_OFFSET_S = 4e9
"""|offsets| from a recording's start (``start_s``, ``end_s``) are taken up to this (127 years: past
any recording's end, and within int64 nanoseconds once added to a time since the epoch)."""


def offset_ns(seconds: float) -> int:
    """An offset in seconds from a recording's start as integer nanoseconds, clamped to
    ±:data:`MAX_OFFSET_S` (``1e308`` is simply past the end).

    Raises:
        ValueError: NaN.
    """
    if math.isnan(seconds):
        raise ValueError("an offset of NaN seconds")
    return round(max(-MAX_OFFSET_S, min(MAX_OFFSET_S, seconds)) * NS_PER_S)
