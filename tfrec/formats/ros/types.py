"""rosbags' type stores and message deserializers: the one place tfrec's readers get them; and the
ROS 1 message definitions tfrec writes.

A type store generates the code of a type's (de)serializer the first time the type is used and
keeps it, so there is one store per ROS distro for the whole process: ROS 2 Humble (CDR) and
ROS 1 Noetic. rosbags is imported when a store is first needed.

A ROS 1 bag carries each connection's message definition as genmsg wrote it: the .msg files'
text, comments and all. ``rosbag check`` compares that text with the installed type's, so a bag
with rosbags' generated text (no comments) "needs migrations" although the md5sum is the same.
``noetic.msg`` beside this module holds the .msg texts of the message packages Debian's ROS 1
ships (std_msgs, geometry_msgs, sensor_msgs, tf2_msgs, nav_msgs, ..., taken from their generated
classes by ``scripts/ros1_definitions.py``), and :func:`genmsg_definition` composes genmsg's text
from them.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable
from functools import cache
from typing import Any

from tfrec.errors import ReadError, RecordingError

__all__ = [
    "ROS2_DEFINITIONS",
    "TF_MESSAGE_DEFINITION",
    "UndecodableMessage",
    "deserializer",
    "genmsg_definition",
    "known_ros1_typestore",
    "reading_typestore",
    "ros1_definition_text",
    "ros1_message_definition",
    "topic_deserializer",
    "typestore",
]

Deserialize = Callable[[bytes | memoryview], Any]


ROS2_DEFINITIONS = {
    "tf2_msgs/msg/TFMessage": (
        'geometry_msgs/TransformStamped[] transforms\n'
        '================================================================================\n'
        'MSG: geometry_msgs/TransformStamped\n'
        'std_msgs/Header header\n'
        'string child_frame_id\n'
        'geometry_msgs/Transform transform\n'
        '================================================================================\n'
        'MSG: std_msgs/Header\n'
        'builtin_interfaces/Time stamp\n'
        'string frame_id\n'
        '================================================================================\n'
        'MSG: builtin_interfaces/Time\n'
        'int32 sec\n'
        'uint32 nanosec\n'
        '================================================================================\n'
        'MSG: geometry_msgs/Transform\n'
        'geometry_msgs/Vector3 translation\n'
        'geometry_msgs/Quaternion rotation\n'
        '================================================================================\n'
        'MSG: geometry_msgs/Vector3\n'
        'float64 x\n'
        'float64 y\n'
        'float64 z\n'
        '================================================================================\n'
        'MSG: geometry_msgs/Quaternion\n'
        'float64 x\n'
        'float64 y\n'
        'float64 z\n'
        'float64 w\n'
    ),
    "sensor_msgs/msg/JointState": (
        'std_msgs/Header header\n'
        'string[] name\n'
        'float64[] position\n'
        'float64[] velocity\n'
        'float64[] effort\n'
        '================================================================================\n'
        'MSG: std_msgs/Header\n'
        'builtin_interfaces/Time stamp\n'
        'string frame_id\n'
        '================================================================================\n'
        'MSG: builtin_interfaces/Time\n'
        'int32 sec\n'
        'uint32 nanosec\n'
    ),
    "std_msgs/msg/String": (
        'string data\n'
    ),
}
"""The ``ros2msg`` text of each ROS 2 type tfrec reads, as rosbags' Humble store generates it and tfrec's MCAP
files carry it (tests compare): a store of these types alone (:func:`reading_typestore`) is built in a few
milliseconds, Humble's whole store in ~80 ms — most of ``tfrec info``'s time on a small file."""


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
def reading_typestore() -> Any:
    """rosbags' type store of the ROS 2 types tfrec reads (:data:`ROS2_DEFINITIONS`) and their fields' types."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    for msgtype, text in ROS2_DEFINITIONS.items():
        store.register(get_types_from_msg(text, msgtype))
    return store


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
        store: the type store; None for the distro's: :func:`reading_typestore` for the ROS 2 types tfrec reads,
            else :func:`typestore`, and for ROS 1 :func:`known_ros1_typestore` (Noetic's, with the TF types).

    Returns:
        A function of the serialized message that returns rosbags' message object and raises
        :class:`UndecodableMessage` for bytes that are no such message.
    """
    full = msgtype if "/msg/" in msgtype else msgtype.replace("/", "/msg/", 1)
    loaded: list[Any] = []  # rosbags and its store, loaded at the first message: most are decoded in bulk

    def deserialize(raw: bytes | memoryview) -> Any:
        if not loaded:
            from rosbags.serde import SerdeError

            chosen = store if store is not None else known_ros1_typestore() if ros1 else (
                reading_typestore() if full in ROS2_DEFINITIONS else typestore())
            loaded.extend((chosen.deserialize_ros1 if ros1 else chosen.deserialize_cdr,
                           (SerdeError, struct.error, IndexError, KeyError, ValueError, UnicodeDecodeError)))
        decode, errors = loaded
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


_SEPARATOR = "=" * 80 + "\n"
_BUILTINS = frozenset({"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
                       "uint64", "float32", "float64", "string", "time", "duration"})
_FIELD_TYPE = re.compile(r"\s*([A-Za-z][\w/]*)")


@cache
def _noetic_texts() -> dict[str, str]:
    """``pkg/Type`` → the type's own .msg text, from ``noetic.msg`` (genmsg's form: each type after a
    line of 80 ``=`` and ``MSG: pkg/Type``, its text, a newline)."""
    from importlib import resources

    data = resources.files(__package__).joinpath("noetic.msg").read_text(encoding="utf-8")
    texts = {}
    for part in data.split(_SEPARATOR)[1:]:
        head, text = part.split("\n", 1)
        texts[head.removeprefix("MSG: ")] = text[:-1]
    return texts


def _depends(msgtype: str, text: str) -> list[str]:
    """The message types a .msg text's fields use, in field order, resolved as genmsg resolves them
    (``Header`` is ``std_msgs/Header``; a name without a package is in the type's own)."""
    package = msgtype.split("/", 1)[0]
    found = []
    for line in text.splitlines():
        match = _FIELD_TYPE.match(line.split("#", 1)[0])
        if match is None:
            continue
        name = match.group(1)
        if name in _BUILTINS:
            continue
        found.append("std_msgs/Header" if name == "Header" else name if "/" in name else f"{package}/{name}")
    return found


@cache
def genmsg_definition(msgtype: str) -> str | None:
    """genmsg's full text of a type, as ``rosbag record`` writes it into a bag's connection record
    (genmsg's ``compute_full_text``): the type's .msg text, then each type it uses (depth first, in
    field order, each once) after a line of 80 ``=`` and ``MSG: pkg/Type``.

    Args:
        msgtype: ``sensor_msgs/JointState`` or ``sensor_msgs/msg/JointState``.

    Returns:
        The text, or None for a type outside the packages of ``noetic.msg``.
    """
    texts = _noetic_texts()
    name = msgtype.replace("/msg/", "/", 1)
    if name not in texts:
        return None
    order: list[str] = []
    todo = list(reversed(_depends(name, texts[name])))
    while todo:  # depth first, pre-order: genmsg's get_all_depends, then its _unique_deps
        dep = todo.pop()
        if dep not in texts:
            return None
        if dep not in order:
            order.append(dep)
        todo.extend(reversed(_depends(dep, texts[dep])))
    parts = [texts[name] + "\n"] + [f"{_SEPARATOR}MSG: {dep}\n{texts[dep]}\n" for dep in order]
    return "".join(parts)[:-1]


def ros1_definition_text(msgtype: str, md5sum: str, text: str) -> str:
    """The message definition to write for a ROS 1 connection: genmsg's text (:func:`genmsg_definition`)
    when the type is one of Noetic's and ``md5sum`` is Noetic's md5sum of it, else ``text``.

    Args:
        msgtype: ``pkg/Type`` or ``pkg/msg/Type``.
        md5sum: the md5sum the connection is written with.
        text: the definition otherwise written (rosbags' generated text).
    """
    genmsg = genmsg_definition(msgtype)
    if genmsg is None:
        return text
    try:
        _, noetic_md5sum = ros1_message_definition(msgtype)
    except RecordingError:
        return text
    return genmsg if md5sum == noetic_md5sum else text


@cache
def ros1_message_definition(msgtype: str) -> tuple[str, str]:
    """The ROS 1 message definition of a type and its md5sum: genmsg's text, as ``rosbag record``
    writes it (:func:`genmsg_definition`), or for a type outside Noetic's message packages rosbags'
    (its .msg without comments, then each dependency once); the md5sum from rosbags' Noetic type
    store with ``tf2_msgs/TFMessage`` added.

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
    return genmsg_definition(msgtype) or str(text), str(md5sum)


def _full_type(msgtype: str) -> str:
    """``pkg/msg/Type`` of ``pkg/Type`` or ``pkg/msg/Type``."""
    return msgtype if "/msg/" in msgtype else msgtype.replace("/", "/msg/", 1)
