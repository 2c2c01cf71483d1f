"""rosbags' type stores and message deserializers: the one place tfrec's readers get them.

A type store generates the code of a type's (de)serializer the first time the type is used and
keeps it, so there is one store per ROS distro for the whole process: ROS 2 Humble (CDR) and
ROS 1 Noetic. rosbags is imported when a store is first needed.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from functools import cache
from typing import Any

from tfrec.errors import ReadError, RecordingError

__all__ = [
    "TF_MESSAGE_DEFINITION",
    "UndecodableMessage",
    "deserializer",
    "known_ros1_typestore",
    "ros1_message_definition",
    "topic_deserializer",
    "typestore",
]

Deserialize = Callable[[bytes | memoryview], Any]


class UndecodableMessage(ValueError):
    """rosbags cannot decode a message as its type.

    Attributes:
        reason: rosbags' error message.
    """

    def __init__(self, err: Exception) -> None:
        super().__init__(f"{type(err).__name__}: {err}")
        self.reason = str(err)


@cache
def typestore(*, ros1: bool = False) -> Any:
    """rosbags' type store of ROS 2 Humble, or of ROS 1 Noetic."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)


@cache
def known_ros1_typestore() -> Any:
    """rosbags' type store of ROS 1 Noetic with the TF types Noetic's store lacks: ``tf2_msgs/TFMessage``
    and ROS 1's ``tf/tfMessage`` (the same layout). The messages tfrec decodes are decoded with it — never
    with a recording's own definitions, which decide only whether a topic has this layout
    (:func:`tfrec.formats.ros.definitions.foreign_layout`)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    for msgtype in ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage"):
        store.register(get_types_from_msg(TF_MESSAGE_DEFINITION, msgtype))
    return store


def deserializer(msgtype: str, *, ros1: bool = False, store: Any = None) -> Deserialize:
    """rosbags' deserializer of one message type.

    Args:
        msgtype: ``tf2_msgs/msg/TFMessage`` or ``tf2_msgs/TFMessage``.
        ros1: ROS 1 serialization rather than CDR.
        store: the type store; None for the distro's (:func:`typestore`).

    Returns:
        A function of the serialized message that returns rosbags' message object and raises
        :class:`UndecodableMessage` for bytes that are no such message.
    """
    from rosbags.serde import SerdeError

    if store is None:
        store = typestore(ros1=ros1)
    full = msgtype if "/msg/" in msgtype else msgtype.replace("/", "/msg/", 1)
    decode = store.deserialize_ros1 if ros1 else store.deserialize_cdr
    errors = (SerdeError, struct.error, IndexError, KeyError, ValueError, UnicodeDecodeError)

    def deserialize(raw: bytes | memoryview) -> Any:
        try:
            return decode(raw, full)
        except errors as err:
            raise UndecodableMessage(err) from err

    return deserialize


def topic_deserializer(msgtype: str, *, where: str, topic: str, ros1: bool = False, store: Any = None) -> Deserialize:
    """Like :func:`deserializer`, for the messages of one topic of a recording: a message that
    cannot be decoded is a :class:`ReadError` naming the recording, the topic and the type."""
    deserialize = deserializer(msgtype, ros1=ros1, store=store)

    def checked(raw: bytes | memoryview) -> Any:
        try:
            return deserialize(raw)
        except UndecodableMessage as err:
            raise ReadError(f"{where}: a {topic} message cannot be decoded as {msgtype}: {err.reason}") from err

    return checked


TF_MESSAGE_DEFINITION = "geometry_msgs/TransformStamped[] transforms\n"
"""``tf2_msgs/TFMessage``: rosbags' Noetic store has no tf2_msgs; its md5sum with this text is
``94810edda583a504dfda3829e70d7eec``, ROS's."""


@cache
def ros1_message_definition(msgtype: str) -> tuple[str, str]:
    """The ROS 1 message definition of a type (its .msg, then each dependency once) and its md5sum,
    from rosbags' Noetic type store with ``tf2_msgs/TFMessage`` added.

    Args:
        msgtype: ``sensor_msgs/JointState`` or ``sensor_msgs/msg/JointState``.

    Raises:
        RecordingError: a type the store does not know.
    """
    from rosbags.typesys.base import TypesysError

    store: Any = known_ros1_typestore()
    try:
        text, md5sum = store.generate_msgdef(_full_type(msgtype), ros_version=1)
    except TypesysError as err:
        raise RecordingError(f"message type '{msgtype}' has no ROS 1 definition: {err}") from err
    return str(text), str(md5sum)


def _full_type(msgtype: str) -> str:
    """``pkg/msg/Type`` of ``pkg/Type`` or ``pkg/msg/Type``."""
    return msgtype if "/msg/" in msgtype else msgtype.replace("/", "/msg/", 1)
