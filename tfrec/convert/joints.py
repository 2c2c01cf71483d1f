"""TF from joint states (``--tf-from-joints``): what robot_state_publisher would have published.

A real robot's bag often has /joint_states and /robot_description but no /tf (robot_state_publisher
was not running), or a /tf that lacks some joints. :func:`plan_derivations` decides, robot by robot
(:func:`tfrec.robots.find_robots` on the input's summary), which joints get TF computed: the
moving joints whose child frame is on neither the recorded /tf nor /tf_static, and the fixed ones
likewise — the replay's rule (:mod:`tfrec.replay.load`). :class:`Derivation` then turns each batch
of joint state messages into /tf messages with :func:`tfrec.replay.load.derive_transforms` (the
replay's forward kinematics, robot_state_publisher's semantics: a joint is placed at the stamps of
the messages that give its position, mimic joints follow their master), stamped like the joint
states and logged when they were.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.errors import ConvertError
from tfrec.formats.ros.decode import RawMessages
from tfrec.formats.translate import joint_states_in_order, tf_message_rows
from tfrec.kinematics.fk import static_transforms
from tfrec.model import Robot
from tfrec.recording import JointStates, Recording
from tfrec.replay.load import derive_transforms, joint_positions
from tfrec.robots import detect_frame_prefix, find_robots

__all__ = ["Derivation", "plan_derivations"]

Pair = tuple[str, str]


@dataclass
class Derivation:
    """One robot whose TF is computed from its joint states.

    Attributes:
        key: the robot's key (``""`` for the only robot, ``/robot1``…), for messages.
        model: its robot model.
        prefix: its frame prefix.
        joints: the moving joints whose TF is computed (none: only fixed frames are added).
        joint_topic: the joint states it reads (``/joint_states``, ``/robot1/joint_states``).
        tf_topic: where the computed /tf goes: the /tf the robot's TF is read from (its
            namespace's, or the root's for robots sharing /tf with prefixed frames).
        static_topic: where the fixed frames go, latched: the /tf_static beside it.
        static: the fixed frames not recorded: (parent, child) → (translation, rotation).
        description_topic: its ``/robot_description``.
        description: a description given instead of the recorded one (``robot``), or None.
        messages: /tf messages computed so far.
        repeated: joint → joint state messages that name it more than once (the first position is taken).
        warned: the joints of ``repeated`` the input's summary already warned about.
    """

    key: str
    model: Robot
    prefix: str
    joints: tuple[str, ...]
    joint_topic: str
    tf_topic: str
    static_topic: str
    static: dict[Pair, tuple[NDArray[np.float64], NDArray[np.float64]]]
    description_topic: str
    description: str | None = None
    messages: int = 0
    repeated: dict[str, int] = field(default_factory=dict)
    warned: tuple[str, ...] = ()

    def transforms(self, data: RawMessages, *, ros1: bool, out_ros1: bool) -> Iterator[tuple[NDArray[np.intp], NDArray[np.uint8]]]:
        """The /tf messages of a batch of joint state messages: (which joint state message each
        follows, the serialized messages as rows), a group of messages with the same frames at a time.

        Args:
            data: JointState messages.
            ros1: they are ROS 1 serialized (else CDR).
            out_ros1: serialize the TF messages as ROS 1 (else CDR).
        """
        if not self.joints or not len(data):
            return
        stamps, names, positions, repeated = joint_states_in_order(data, ros1=ros1)
        for name, count in repeated.items():
            self.repeated[name] = self.repeated.get(name, 0) + count
        states = JointStates(stamps, names, positions)
        model_names, model_positions = joint_positions(self.model, states)
        wanted = [k for k, name in enumerate(model_names) if name in self.joints]
        given = np.isfinite(model_positions[:, wanted])
        patterns, groups = np.unique(given, axis=0, return_inverse=True)
        for g, pattern in enumerate(patterns):
            if not pattern.any():
                continue
            rows = np.flatnonzero(groups.reshape(-1) == g)
            part = JointStates(stamps[rows], names, positions[rows])
            series = derive_transforms(self.model, part, frame_prefix=self.prefix, joints=self.joints)
            if not series:
                continue
            pairs = list(series)
            translation = np.stack([series[pair].translation for pair in pairs], axis=1)
            rotation = np.stack([series[pair].rotation for pair in pairs], axis=1)
            self.messages += len(rows)
            yield rows, tf_message_rows([p for p, _ in pairs], [c for _, c in pairs], stamps[rows], translation,
                                        rotation, ros1=out_ros1)

    def static_message(self, *, stamp_ns: int, out_ros1: bool) -> NDArray[np.uint8] | None:
        """The fixed frames as one /tf_static message stamped ``stamp_ns``, or None without any."""
        if not self.static:
            return None
        pairs = list(self.static)
        translation = np.stack([self.static[pair][0] for pair in pairs])[np.newaxis]
        rotation = np.stack([self.static[pair][1] for pair in pairs])[np.newaxis]
        return tf_message_rows([p for p, _ in pairs], [c for _, c in pairs], np.array([stamp_ns], np.int64),
                               translation, rotation, ros1=out_ros1)


def plan_derivations(summary: Recording, *, mode: bool | None, robot: Robot | None,
                     namespace: str | None) -> list[Derivation]:
    """The robots whose TF is computed, and which joints.

    Args:
        summary: the input read as ``tfrec info`` reads it (descriptions, /tf_static, the first
            /tf and /joint_states messages of every namespace).
        mode: True (``tf_from_joints``): every joint not on the recorded TF; False: none; None
            (default): only when a robot has joint states and a description and its TF lacks
            some of its moving joints.
        robot: a model that replaces the recorded description of the only robot (or of the
            one ``namespace`` picks); its URDF is written as that robot's description.
        namespace: only the robots of this namespace.

    Raises:
        ConvertError: ``robot`` for a recording of several robots; ``tf_from_joints`` and no
            robot with both a description (or ``robot``) and joint states.
    """
    where = summary.path
    found = [r for r in find_robots(summary, namespace=namespace) if not r.unclaimed]
    if robot is not None and len(found) > 1:
        raise ConvertError(f"{where}: `robot` is one model, and the recording holds {len(found)} robots "
                           f"({', '.join(r.key for r in found)}): pick one with `namespace`")
    if robot is not None and not found:
        raise ConvertError(f"{where}: no /joint_states, /tf or {ROBOT_DESCRIPTION} in the recording for `robot` to go with")
    out: list[Derivation] = []
    missing: list[str] = []
    for r in found:
        model = robot if robot is not None else r.model
        if model is None:
            missing.append(f"{r.label} has no usable {r.namespace}{ROBOT_DESCRIPTION} (give `robot` FILE)")
            continue
        recorded = list(r.tf_static) + list(r.tf)
        prefix = r.frame_prefix if robot is None else detect_frame_prefix(
            model, [frame for pair in recorded for frame in pair], namespace=r.namespace)
        covered = {child for _, child in recorded}
        moving = tuple(j.name for j in model.moving_joints if prefix + j.child not in covered)
        if r.joint_states is None:
            if moving and mode:
                missing.append(f"{r.label} has no {r.joint_states_namespace}{JOINT_STATES}")
            moving = ()
        fixed = {pair: pose for pair, pose in static_transforms(model, frame_prefix=prefix).poses().items()
                 if pair[1] not in covered}
        derive = bool(moving or fixed) if mode else (mode is None and bool(moving))
        if derive or robot is not None:
            out.append(Derivation(r.key, model, prefix, moving if derive else (),
                                  r.joint_states_namespace + JOINT_STATES, r.tf_namespace + TF, r.tf_namespace + TF_STATIC,
                                  fixed if derive else {}, r.namespace + ROBOT_DESCRIPTION,
                                  robot.urdf if robot is not None else None,
                                  warned=r.joint_states.repeated if r.joint_states is not None else ()))
    if mode and not found:
        raise ConvertError(f"{where}: `tf_from_joints`: no {JOINT_STATES} or {ROBOT_DESCRIPTION} in the recording")
    if mode and not any(d.joints or d.static for d in out) and missing:
        raise ConvertError(f"{where}: `tf_from_joints`: {'; '.join(missing)}")
    return out
