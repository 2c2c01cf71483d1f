"""The joint names of ``sensor_msgs/JointState`` messages when a message names a joint more than once.

robot_state_publisher fills a ``std::map`` from a message's names and positions with ``insert`` (ROS 1) or
``emplace`` (ROS 2): both keep a name's first value, so the first position of a repeated name is the one it
publishes TF for (Debian's robot_state_publisher 1.15.2, fed ``["j", "j"]`` with ``[0.5, 1.5]``, publishes the
TF of 0.5). Every reader of joint states takes the same one (:func:`first_positions`) and warns once per topic
(:func:`repeated_joints`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

__all__ = ["first_positions", "repeated_joints"]


def first_positions(names: Sequence[str]) -> tuple[tuple[str, ...], list[int] | None, tuple[str, ...]]:
    """The joints a JointState names, each once, and where each one's position is: the first time it is
    named — robot_state_publisher fills a ``std::map`` with ``insert`` (ROS 1) or ``emplace`` (ROS 2),
    which keep a name's first value.

    Returns:
        (the names in order of first appearance, the index of each one's position — None when no name is
        repeated, so that every index is its own —, the names given more than once).
    """
    if len(set(names)) == len(names):
        return tuple(names), None, ()
    first: dict[str, int] = {}
    repeated: dict[str, None] = {}
    for i, name in enumerate(names):
        if name in first:
            repeated[name] = None
        else:
            first[name] = i
    return tuple(first), list(first.values()), tuple(repeated)


def repeated_joints(where: str, topic: str, repeated: Mapping[str, int], messages: int | None = None, *,
                    first: bool = False) -> str:
    """The warning about joints that /joint_states messages name more than once.

    Args:
        where: the recording.
        topic: the joint states' topic.
        repeated: joint name → messages that name it more than once.
        messages: the messages read (None: not counted).
        first: only the first ``messages`` were read (a summary).
    """
    names = list(repeated)
    joints = f"joint '{names[0]}'" if len(names) == 1 else "joints " + ", ".join(f"'{n}'" for n in names[:5]) + (
        f" and {len(names) - 5} more" if len(names) > 5 else "")
    count = max(repeated.values())
    if messages is None:
        how_many = f"{count:,} message{'s' if count != 1 else ''}"
    else:
        how_many = f"{count:,} of the {'first ' if first else ''}{messages:,} message{'s' if messages != 1 else ''}"
    return (f"{where}: {topic} names {joints} more than once in a message ({how_many}): the first position is "
            "taken, as robot_state_publisher takes it")
