"""ROS facts and tfrec defaults shared by every stage: time base, topic names, compressions, tolerances.

Cheap to import (no numpy), at the top of the data flow, so writers and readers agree on one
definition of each.
"""

from __future__ import annotations

__all__ = [
    "CHECK_POS_TOL",
    "CHECK_ROT_TOL",
    "COMPRESSIONS",
    "DEFAULT_START_TIME_NS",
    "DIFF_JOINT_TOL",
    "DIFF_POS_TOL",
    "DIFF_ROT_TOL",
    "FLOAT32_TOL",
    "JOINT_STATES",
    "NS_PER_S",
    "RECORDED_TOPICS",
    "ROBOT_DESCRIPTION",
    "ROS1_COMPRESSIONS",
    "STAMP_LIMIT_NS",
    "STAMP_RANGE",
    "TF",
    "TF_STATIC",
]

NS_PER_S = 1_000_000_000

STAMP_LIMIT_NS = 2**31 * NS_PER_S
"""Stamps must be below this: ROS 2's builtin_interfaces/Time holds int32 seconds."""

STAMP_RANGE = f"ROS 2 stamps hold less than {STAMP_LIMIT_NS // NS_PER_S} s"
"""How messages about out-of-range times end."""

DEFAULT_START_TIME_NS = 1_700_000_000 * NS_PER_S
"""Stamps start here unless ``--start-time`` says otherwise: 2023-11-14T22:13:20Z. A fixed epoch
makes the same command give byte-identical files."""

ROBOT_DESCRIPTION = "/robot_description"
TF_STATIC = "/tf_static"
JOINT_STATES = "/joint_states"
TF = "/tf"
RECORDED_TOPICS = (ROBOT_DESCRIPTION, TF_STATIC, JOINT_STATES, TF)
"""The topics tfrec records, in channel order; replay and diff read these."""

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
