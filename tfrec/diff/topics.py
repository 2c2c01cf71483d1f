"""Topic names and types as ``diff`` pairs them across two recordings."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from tfrec.conventions import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.robots import RecordedRobot

__all__ = ["renamed_b_topics", "same_type"]

_TYPE_ALIASES = {"tf/tfMessage": "tf2_msgs/TFMessage"}
"""Types that hold the same messages under two names: ROS 1's old ``tf/tfMessage`` of /tf, which
``tfrec convert`` writes as ``tf2_msgs/msg/TFMessage``."""


def same_type(name: str) -> str:
    """A message type as compared: ``pkg/msg/Name`` and ``pkg/Name`` alike, aliases resolved."""
    plain = name.replace("/msg/", "/")
    return _TYPE_ALIASES.get(plain, plain)


def renamed_b_topics(found_a: Sequence[RecordedRobot], found_b: Sequence[RecordedRobot],
                     b_topics: Mapping[str, object]) -> dict[str, str]:
    """B's robot topics under A's names when each recording has one robot, in different namespaces
    (``/robot1/tf`` in A, ``/tf`` in B): they are compared as the same topics, as their robots are."""
    if len(found_a) != 1 or len(found_b) != 1:
        return {}
    ra, rb = found_a[0], found_b[0]
    renamed: dict[str, str] = {}
    for na, nb, kinds in ((ra.namespace, rb.namespace, (ROBOT_DESCRIPTION,)),
                          (ra.tf_namespace, rb.tf_namespace, (TF, TF_STATIC)),
                          (ra.joint_states_namespace, rb.joint_states_namespace, (JOINT_STATES,))):
        if na != nb:
            renamed.update({nb + kind: na + kind for kind in kinds if nb + kind in b_topics})
    return renamed
