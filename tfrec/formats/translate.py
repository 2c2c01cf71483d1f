"""Messages carried between ROS 1 and ROS 2 for ``tfrec convert``: types, definitions, bytes.

:func:`translation` says how one :class:`~tfrec.formats.ros.connection.Connection` is written in a
serialization (``cdr`` or ``ros1``): kept as it is when the serialization stays, else converted
the way rosbags' ``rosbags.convert`` converts it —

- the type store is built from the file's own message definitions (``get_types_from_msg``,
  ``get_types_from_idl``; a connection without one falls back to ROS 2 Humble's or ROS 1 Noetic's
  store), with ``std_msgs/Header`` as the target has it (ROS 1's has ``seq``);
- the target's definition and hash are generated from it (``generate_msgdef``: the ROS 1 text and
  md5sum, or the ROS 2 text and ``hash_rihs01``); ``tf/tfMessage`` becomes ``tf2_msgs/TFMessage``;
  a ROS 1 type of Noetic's message packages with Noetic's md5sum gets genmsg's text, comments and
  all, as ``rosbag record`` writes it (:func:`~tfrec.formats.ros.types.ros1_definition_text`), so
  that ``rosbag check`` finds nothing to migrate;
- the messages are converted byte to byte (``ros1_to_cdr``, ``cdr_to_ros1``), without building
  message objects; a ROS 1 ``seq`` the target lacks is dropped, one it needs is 0.

TF and joint messages (``tf2_msgs/TFMessage``, ``sensor_msgs/JointState``) of a fixed layout —
the same frame or joint names in every message, as robot_state_publisher and joint state
publishers send them — are translated in bulk: one message is converted by rosbags, the byte
ranges that carry values (stamps, float64 blocks) are paired between the two layouts, and every
message of that layout becomes a row of the target template with those ranges copied in
(:mod:`tfrec.formats.ros.decode` finds the layouts). The result is the same bytes as rosbags'.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import lru_cache, partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.formats.ros.connection import Connection
from tfrec.formats.ros.decode import MessageLayout, RawMessages, match_layout, message_layout
from tfrec.formats.ros.definitions import DefinitionError, has_known_layout, parse_definition
from tfrec.formats.ros.encode import TFMessageEncoder, encode_string
from tfrec.formats.ros.types import (
    deserializer,
    genmsg_definition,
    known_ros1_typestore,
    ros1_definition_text,
    typestore,
)
from tfrec.formats.rosbag2.metadata import QOS_LATCHED, QOS_VOLATILE, qos_yaml

__all__ = [
    "Translation",
    "Untranslatable",
    "joint_states_in_order",
    "standard_connection",
    "string_message",
    "tf_message_rows",
    "translation",
]

RENAMED = {"tf/msg/tfMessage": "tf2_msgs/msg/TFMessage"}
"""Types a ROS 2 target names otherwise: ROS 1's old TF type is tf2's (the same wire format)."""
FAST_KINDS = {"tf2_msgs/msg/TFMessage": "tf", "sensor_msgs/msg/JointState": "joint_states"}
"""Types translated in bulk when their layout is fixed (the kinds of :func:`tfrec.formats.ros.decode.message_layout`)."""

Payload = NDArray[np.uint8] | Sequence[bytes | memoryview]
"""Messages for a writer: (n, size) rows of fixed-size messages, or the messages one by one."""


class Untranslatable(Exception):
    """A connection whose messages cannot be carried to the other serialization; ``reason`` says why."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


# -- type stores -------------------------------------------------------------------------------------


def _closure(store: Any, msgtype: str) -> dict[str, Any]:
    """``msgtype``'s field definitions and those of every type it uses, from ``store``."""
    out: dict[str, Any] = {}
    todo = [msgtype]
    while todo:
        name = todo.pop()
        if name in out or name.startswith("builtin_interfaces/"):
            continue
        out[name] = store.fielddefs[name]
        for _, desc in out[name][1]:
            sub = desc[1][0] if desc[0] in (3, 4) else desc  # ARRAY, SEQUENCE: their element
            if sub[0] == 2:  # NAME
                todo.append(sub[1])
    return out


def _types(msgtype: str, definition: str, definition_encoding: str, ros1: bool) -> dict[str, Any]:
    """The field definitions of a type and the types it uses: from the file's definition (parsed and
    checked, :func:`~tfrec.formats.ros.definitions.parse_definition`), else the distro's store
    (Noetic's for ROS 1, with ``tf2_msgs/TFMessage``; Humble's for ROS 2).

    Raises:
        Untranslatable: a definition that does not parse, defines a type that contains itself or is too
            large; or none and a type the distro does not know.
    """
    if definition:
        try:
            return dict(parse_definition(msgtype, definition, definition_encoding or ("ros1msg" if ros1 else "ros2msg")))
        except DefinitionError as err:
            raise Untranslatable(str(err)) from err
    store = known_ros1_typestore() if ros1 else typestore()
    if msgtype not in store.fielddefs:
        distro = "ROS 1 Noetic" if ros1 else "ROS 2 Humble"
        raise Untranslatable(f"the file has no message definition of {msgtype}, and {distro} does not know it")
    return _closure(store, msgtype)


def _store(types: dict[str, Any], *, ros1_header: bool, rename: tuple[str, str] | None = None) -> Any:
    """A type store of ``types``, with ``std_msgs/msg/Header`` as ROS 1 (with ``seq``) or ROS 2 has it."""
    from rosbags.typesys import Stores, get_typestore

    found = dict(types)
    found["std_msgs/msg/Header"] = typestore(ros1=ros1_header).fielddefs["std_msgs/msg/Header"]
    if rename is not None:
        found[rename[1]] = found[rename[0]]
    store = get_typestore(Stores.EMPTY)
    store.register(found)
    return store


@dataclass(frozen=True)
class _TypePlan:
    """A type carried to the other serialization: its name there, definition, hash, and the
    byte-to-byte converter."""

    msgtype: str
    definition: str
    type_hash: str
    convert: Callable[[bytes | memoryview], bytes | memoryview]


@lru_cache(maxsize=256)
def _plan(msgtype: str, definition: str, definition_encoding: str, ros1: bool) -> _TypePlan:
    """How a type of a ROS 1 (``ros1``) or ROS 2 file is carried to the other serialization.

    Raises:
        Untranslatable: see :func:`_types`; or a definition that uses types it does not define.
    """
    from rosbags.typesys.base import TypesysError

    types = _types(msgtype, definition, definition_encoding, ros1)
    try:
        if not ros1:  # CDR → ROS 1
            text, md5sum = _store(types, ros1_header=True).generate_msgdef(msgtype, ros_version=1)
            return _TypePlan(msgtype, ros1_definition_text(msgtype, md5sum, text), md5sum,
                             partial(_store(types, ros1_header=False).cdr_to_ros1, typename=msgtype))
        name = RENAMED.get(msgtype, msgtype)
        store = _store(types, ros1_header=False, rename=(msgtype, name) if name != msgtype else None)
        text, _ = store.generate_msgdef(name, ros_version=2)
        return _TypePlan(name, text, store.hash_rihs01(name), partial(store.ros1_to_cdr, typename=name))
    except (TypesysError, KeyError, ValueError) as err:
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise Untranslatable(f"its message definition is incomplete (rosbags: {first[:80]})") from err


def _type_plan(msgtype: str, definition: str, definition_encoding: str, ros1: bool) -> _TypePlan:
    """:func:`_plan`, shared by the types of one definition where the type's name changes nothing carried over:
    a ROS 2 type converted to ROS 1 that is not one of Noetic's (its md5sum and generated text do not name it)
    and whose definition names no type relative to its package. A file of 65,000 types of their own, each
    ``string data``, builds one type store, not 65,000 (~4 ms and 50 kB each)."""
    if ros1 or not definition or "idl" in definition_encoding or genmsg_definition(msgtype) is not None \
            or not _names_no_relative_type(definition):
        return _plan(msgtype, definition, definition_encoding, ros1)
    try:
        shared = _plan(_SHARED_TYPE, definition, definition_encoding, ros1)
    except Untranslatable:  # said again under the type's own name
        return _plan(msgtype, definition, definition_encoding, ros1)
    return replace(shared, msgtype=msgtype)


_SHARED_TYPE = "tfrec_shared/msg/Message"
"""The name a shared plan is built under (:func:`_type_plan`)."""
_ROS2_BUILTINS = frozenset({"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
                            "uint64", "float32", "float64", "string", "wstring"})


def _names_no_relative_type(definition: str) -> bool:
    """Whether every field of a ``ros2msg`` definition is of a built-in type or of a type named with its package
    (``pkg/Type``, ``pkg/msg/Type``): then the definition means the same whatever type it defines."""
    for raw in definition.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line or line.startswith(("MSG:", "===")):
            continue
        base = re.split(r"[\[<\s=]", line, maxsplit=1)[0]
        if base not in _ROS2_BUILTINS and "/" not in base:
            return False
    return True


# -- connections ------------------------------------------------------------------------------------


@dataclass
class Translation:
    """How a connection's messages are written in a serialization.

    Attributes:
        source: the connection read.
        target: the connection written (its type, definition, hash, latching or QoS).
        convert: one message from the source's serialization to the target's; None: as it is.
        kind: ``tf`` or ``joint_states`` for messages translated in bulk when their layout is fixed.
        failed: messages that could not be converted (left out), and ``reason``, the first error.
        note: something to tell about the connection (a definition replaced), or ``""``.
    """

    source: Connection
    target: Connection
    convert: Callable[[bytes | memoryview], bytes | memoryview] | None
    kind: str | None = None
    failed: int = 0
    reason: str = ""
    note: str = ""
    _layout: _Layout | None = field(default=None, repr=False)
    _tried: bool = field(default=False, repr=False)

    def apply(self, data: RawMessages) -> tuple[Payload, NDArray[np.intp] | None]:
        """The messages as the target serializes them.

        Returns:
            (the messages, the indices of those kept — None when all are; a message rosbags
            cannot convert is left out and counted in :attr:`failed`).
        """
        if self.convert is None:
            return data, None
        if self.kind is not None:
            rows, good, rest = self._fixed(data)
            if rows is not None and not rest:
                return rows, None
        else:
            rows, good, rest = None, np.zeros(0, np.intp), list(range(len(data)))
        out: list[bytes | memoryview | None] = [None] * len(data)
        if rows is not None:
            for k, i in enumerate(good.tolist()):
                out[i] = rows[k].data
        for i in rest:
            out[i] = self._one(data[i])
        kept = [i for i, message in enumerate(out) if message is not None]
        if len(kept) == len(out):
            return out, None  # type: ignore[return-value]  # none is None
        return [out[i] for i in kept], np.array(kept, dtype=np.intp)  # type: ignore[misc]

    def _one(self, message: bytes | memoryview) -> bytes | memoryview | None:
        from rosbags.serde import SerdeError

        assert self.convert is not None
        try:
            return self.convert(message)
        except (SerdeError, struct.error, IndexError, KeyError, ValueError, UnicodeDecodeError) as err:
            self.failed += 1
            self.reason = self.reason or f"{type(err).__name__}: {err}"
            return None

    def _fixed(self, data: RawMessages) -> tuple[NDArray[np.uint8] | None, NDArray[np.intp], list[int]]:
        """The messages of the learnt layout translated in bulk, their indices, and the others' indices."""
        if not self._tried and len(data):
            self._learn(data[0])
        if self._layout is None:
            return None, np.zeros(0, np.intp), list(range(len(data)))
        rows, good, rest = match_layout(self._layout.source, data)
        if len(rest) * 2 > len(data):  # most messages have another layout: learn it
            self._learn(data[rest[len(rest) // 2]])
            if self._layout is None:
                return None, np.zeros(0, np.intp), list(range(len(data)))
            rows, good, rest = match_layout(self._layout.source, data)
        if rows is None or not len(rows):
            return None, good, rest
        out = self._layout.translate(rows)
        if bytes(self._convert_checked(rows[-1].tobytes())) != out[-1].tobytes():  # the layout must not lie
            self._layout = None
            return None, np.zeros(0, np.intp), list(range(len(data)))
        return out, good, rest

    def _convert_checked(self, message: bytes) -> bytes | memoryview:
        assert self.convert is not None
        return self.convert(message)

    def _learn(self, message: bytes | memoryview) -> None:
        self._tried = True
        assert self.kind is not None and self.convert is not None
        try:
            source = message_layout(self.kind, message, ros1=self.source.ros1)
            target = message_layout(self.kind, bytes(self.convert(message)), ros1=self.target.ros1)
        except (ValueError, UnicodeDecodeError, struct.error, IndexError, KeyError):
            self._layout = None
            return
        pairs = list(zip(source.values, target.values))
        if len(source.values) != len(target.values) or any(a[1] - a[0] != b[1] - b[0] for a, b in pairs):
            self._layout = None
            return
        self._layout = _Layout(source, target.template, pairs)


@dataclass(frozen=True)
class _Layout:
    """A fixed source layout, the target's template, and the value ranges paired between them."""

    source: MessageLayout
    template: NDArray[np.uint8]
    pairs: list[tuple[tuple[int, int], tuple[int, int]]]

    def translate(self, rows: NDArray[np.uint8]) -> NDArray[np.uint8]:
        out = np.empty((len(rows), len(self.template)), dtype=np.uint8)
        out[:] = self.template
        for (a, b), (c, d) in self.pairs:
            if b > a:
                out[:, c:d] = rows[:, a:b]
        return out


def translation(connection: Connection, *, encoding: str, sample: bytes | memoryview | None = None) -> Translation:
    """How ``connection``'s messages are written serialized as ``encoding`` (``cdr`` or ``ros1``).

    Args:
        connection: the connection read.
        encoding: the output's serialization.
        sample: one of its messages: when the file's definition does not decode it and the
            distro's does, the distro's is used (:attr:`Translation.note` says so).

    Raises:
        Untranslatable: the serialization changes and the type cannot be carried over (a
            serialization that is neither CDR nor ROS 1, no definition for an unknown type, a
            definition that does not parse).
    """
    note = ""
    kept = connection.encoding == encoding or (encoding == "cdr" and connection.encoding != "ros1")
    if sample is not None and _replaceable(connection, sample, kept=kept):
        connection, note = _fitting(connection, sample)
    if kept:
        return Translation(connection, _completed(connection), None, note=note)  # an MCAP holds any encoding
    if {connection.encoding, encoding} != {"cdr", "ros1"}:
        raise Untranslatable(f"it is serialized as '{connection.encoding}', which tfrec carries only as it is "
                             "(into an MCAP)")
    if not connection.msgtype:
        raise Untranslatable("it has no message type")
    if "/srv/" in connection.msgtype:
        raise Untranslatable("a service event: ROS 1 bags record no services")
    plan = _type_plan(connection.msgtype, _uncommented(connection.definition, connection.definition_encoding),
                      connection.definition_encoding, connection.ros1)
    if encoding == "ros1":
        target = Connection(connection.topic, plan.msgtype, "ros1", plan.definition, "ros1msg", connection.latched,
                            "", plan.type_hash)
    else:
        qos = qos_yaml([QOS_LATCHED if connection.latched else QOS_VOLATILE])
        target = Connection(connection.topic, plan.msgtype, "cdr", plan.definition, "ros2msg", connection.latched,
                            qos, plan.type_hash)
    kind = FAST_KINDS.get(plan.msgtype) if has_known_layout(connection) else None
    return Translation(connection, target, plan.convert, kind, note=note)


def _replaceable(connection: Connection, sample: bytes | memoryview, *, kept: bool) -> bool:
    """Whether the distro's definition might replace the file's (:func:`_fitting`): the distro knows the type and,
    when the messages are copied as they are (``kept``), decodes ``sample``.

    Checking the file's definition builds a type store (milliseconds), so it is done only where the distro's could
    take its place — not for the 65,000 schemas of types the distro does not know that a file may hold — and for
    at most :data:`CHECKED_DEFINITIONS` definitions of one type (a file may hold as many as it has schemas)."""
    if not connection.definition or connection.encoding not in ("cdr", "ros1") or not connection.msgtype:
        return False
    full = connection.msgtype if "/msg/" in connection.msgtype else connection.msgtype.replace("/", "/msg/", 1)
    if full not in (known_ros1_typestore() if connection.ros1 else typestore()).fielddefs:
        return False
    if kept and _undecodable(replace(connection, definition="", definition_encoding="", type_hash=""), sample):
        return False  # the distro's does not decode them either: they are copied with the file's
    key = (full, connection.ros1)
    checked = _CHECKED.setdefault(key, set())
    definition = _uncommented(connection.definition, connection.definition_encoding)
    if definition not in checked and len(checked) >= CHECKED_DEFINITIONS:
        return False
    checked.add(definition)
    return True


CHECKED_DEFINITIONS = 64
"""How many distinct definitions of one type a conversion checks against its messages (:func:`_replaceable`)."""
_CHECKED: dict[tuple[str, bool], set[str]] = {}


def _undecodable(connection: Connection, sample: bytes | memoryview) -> str | None:
    """Why the connection's definition (its distro's without one) does not decode ``sample``; None when it does."""
    from rosbags.serde import SerdeError
    from rosbags.typesys.base import TypesysError

    decode = _decoder(connection.msgtype, _uncommented(connection.definition, connection.definition_encoding),
                      connection.definition_encoding, connection.ros1)
    if isinstance(decode, str):
        return decode
    try:
        decode(sample, connection.msgtype)
    except (TypesysError, SerdeError, struct.error, IndexError, KeyError, ValueError, UnicodeDecodeError):
        return _DOES_NOT_DECODE
    return None


_DOES_NOT_DECODE = "the message definition in the file does not decode its messages"


def _uncommented(definition: str, encoding: str) -> str:
    """A message definition without its comment lines and trailing blanks: the key of the per-type caches, so
    that schemas differing only in comments (thousands of them) parse once. What is carried over is generated
    from the parsed types, which have no comments."""
    if "#" not in definition or "idl" in encoding:  # IDL's '#' lines are directives
        return definition
    return "\n".join(line.rstrip() for line in definition.splitlines() if not line.lstrip().startswith("#"))


@lru_cache(maxsize=256)
def _decoder(msgtype: str, definition: str, definition_encoding: str, ros1: bool) -> Callable[[Any, str], Any] | str:
    """The deserializer of a type by its definition (the distro's without one), or why the definition gives none
    — once per type, not per connection: a file of 60,000 channels of one type builds one store."""
    from rosbags.typesys.base import TypesysError

    try:
        store = _store(_types(msgtype, definition, definition_encoding, ros1), ros1_header=ros1)
    except Untranslatable as err:
        return err.reason
    except (TypesysError, IndexError, KeyError, ValueError):
        return _DOES_NOT_DECODE
    decode: Callable[[Any, str], Any] = store.deserialize_ros1 if ros1 else store.deserialize_cdr
    return decode


def _fitting(connection: Connection, sample: bytes | memoryview) -> tuple[Connection, str]:
    """The connection with a definition that decodes its messages, and a note when it is not the file's.

    The distro's definition replaces the file's only for a type whose layout is not foreign
    (:func:`~tfrec.formats.ros.definitions.has_known_layout`): a /tf of another layout stays foreign data."""
    problem = _undecodable(connection, sample)
    if problem is None:
        return connection, ""
    plain = replace(connection, definition="", definition_encoding="", type_hash="")
    if has_known_layout(connection) and _undecodable(plain, sample) is None:
        distro = "ROS 1 Noetic" if connection.ros1 else "ROS 2 Humble"
        return plain, f"{problem}; {distro}'s is used"
    return connection, f"{problem} (they are copied as they are)"


def _completed(connection: Connection) -> Connection:
    """A connection kept as it is, with the definition its distro gives when the file has none; a ROS 1 type of
    Noetic's with Noetic's md5sum gets genmsg's text (:func:`_as_recorded`)."""
    if connection.definition and connection.ros1 and connection.msgtype:
        return _as_recorded(connection)
    if connection.definition or connection.encoding not in ("cdr", "ros1") or not connection.msgtype:
        return connection
    try:
        store = _distro_store(connection.msgtype, connection.ros1)
    except Untranslatable:
        return connection
    if connection.ros1:
        text, md5sum = store.generate_msgdef(connection.msgtype, ros_version=1)
        return replace(connection, definition=ros1_definition_text(connection.msgtype, md5sum, text),
                       definition_encoding="ros1msg", type_hash=md5sum)
    text, _ = store.generate_msgdef(connection.msgtype, ros_version=2)
    return replace(connection, definition=text, definition_encoding="ros2msg",
                   type_hash=connection.type_hash or store.hash_rihs01(connection.msgtype))


def _as_recorded(connection: Connection) -> Connection:
    """A ROS 1 connection with genmsg's text of its type, as ``rosbag record`` writes it, when the type is one of
    Noetic's and its md5sum (the file's, else the one of the file's definition) is Noetic's: the file's text of the
    same type (rosbags' generated text, another tool's spelling) makes ``rosbag check`` ask for migrations. Another
    type, or another md5sum, keeps the file's text; a connection without an md5sum (an MCAP's) gets its
    definition's."""
    md5sum = connection.type_hash
    if md5sum in ("", "*"):
        md5sum = _ros1_md5sum(connection.msgtype, _uncommented(connection.definition, connection.definition_encoding),
                              connection.definition_encoding) or md5sum
    text = connection.definition
    if genmsg_definition(connection.msgtype) is not None and md5sum not in ("", "*"):
        text = ros1_definition_text(connection.msgtype, md5sum, connection.definition)
    if (text, md5sum) == (connection.definition, connection.type_hash):
        return connection
    return replace(connection, definition=text, definition_encoding="ros1msg", type_hash=md5sum)


@lru_cache(maxsize=256)
def _ros1_md5sum(msgtype: str, definition: str, definition_encoding: str) -> str:
    """The md5sum of a ROS 1 definition; ``""`` when it does not give one."""
    from rosbags.typesys.base import TypesysError

    try:
        _, md5sum = _store(_types(msgtype, definition, definition_encoding, True),
                           ros1_header=True).generate_msgdef(msgtype, ros_version=1)
    except (Untranslatable, TypesysError, KeyError, ValueError):
        return ""
    return str(md5sum)


@lru_cache(maxsize=256)
def _distro_store(msgtype: str, ros1: bool) -> Any:
    """A store of a type the distro knows (for a file that does not define it)."""
    return _store(_types(msgtype, "", "", ros1), ros1_header=ros1)


# -- what convert adds: TF, descriptions ------------------------------------------------------------


def standard_connection(topic: str, msgtype: str, *, encoding: str, latched: bool, callerid: str = "") -> Connection:
    """A connection of a standard type (``tf2_msgs/msg/TFMessage``, ``std_msgs/msg/String``) as tfrec
    records it: ROS 2 Humble's definition and type hash with reliable QoS (transient_local when
    ``latched``), or ROS 1 Noetic's definition and md5sum with ``latching``."""
    if encoding == "ros1":
        from tfrec.formats.ros.types import ros1_message_definition

        text, md5sum = ros1_message_definition(msgtype)
        return Connection(topic, msgtype, "ros1", text, "ros1msg", latched, "", md5sum, callerid)
    from tfrec.formats.mcap.writer import message_definition

    text, type_hash = message_definition(msgtype)
    return Connection(topic, msgtype, "cdr", text, "ros2msg", latched,
                      qos_yaml([QOS_LATCHED if latched else QOS_VOLATILE]), type_hash)


def string_message(text: str, *, ros1: bool) -> bytes:
    """A ``std_msgs/String`` message, ROS 1 or CDR."""
    return encode_string(text, ros1=ros1)


def tf_message_rows(parents: Sequence[str], children: Sequence[str], time_ns: NDArray[np.int64],
                    translation: NDArray[np.float64], rotation: NDArray[np.float64], *, ros1: bool) -> NDArray[np.uint8]:
    """``tf2_msgs/TFMessage`` messages (N, size) of fixed frames, CDR or ROS 1, each transform
    stamped with its message's stamp, as robot_state_publisher publishes them."""
    return TFMessageEncoder(parents, children, ros1=ros1).encode(time_ns, translation, rotation)


def joint_states_in_order(data: RawMessages, *, ros1: bool, layout: MessageLayout | None = None
                          ) -> tuple[NDArray[np.int64], tuple[str, ...], NDArray[np.float64], dict[str, int]]:
    """The header stamps, joint names and positions of ``sensor_msgs/JointState`` messages, in
    their order: a message's row is NaN for a joint it does not name (or gives no position of).

    Args:
        data: the messages.
        ros1: ROS 1 serialization rather than CDR.
        layout: the fixed layout most messages have (else learnt from the first).

    Returns:
        (stamps, names, positions, repeated): ``repeated`` maps a joint that a message names more than
        once to how many messages do; the first position is taken (:func:`~tfrec.formats.ros.decode.first_positions`).

    Raises:
        ReadError: a message that is no JointState.
    """
    from tfrec.formats.ros.decode import stamp_ns
    from tfrec.formats.ros.encode import ns_from_stamps
    from tfrec.formats.ros.joint_names import first_positions

    n = len(data)
    if layout is None and n:
        try:
            layout = message_layout("joint_states", data[0], ros1=ros1)
        except (ValueError, UnicodeDecodeError):
            layout = None
    rows, good, rest = (None, np.zeros(0, np.intp), list(range(n))) if layout is None else match_layout(layout, data)
    repeated: dict[str, int] = {}
    names: dict[str, int] = {}
    if layout is not None:
        names = {name: k for k, name in enumerate(first_positions(layout.names)[0])}
    decoded = []
    if rest:
        decode = deserializer("sensor_msgs/msg/JointState", ros1=ros1)
        for i in rest:
            msg = decode(data[i])
            decoded.append((i, stamp_ns(msg.header.stamp), list(msg.name), np.asarray(msg.position, np.float64)))
            for name in msg.name:
                names.setdefault(name, len(names))
    stamps = np.zeros(n, np.int64)
    positions = np.full((n, len(names)), np.nan)
    if rows is not None and len(rows) and layout is not None:
        raw = np.ascontiguousarray(rows[:, layout.stamps[0] : layout.stamps[0] + 8]).view("<u4")
        sec = raw[:, 0].astype(np.int64) if ros1 else raw[:, 0].view("<i4").astype(np.int64)
        stamps[good] = ns_from_stamps(sec, raw[:, 1].astype(np.int64))
        if layout.floats[0] >= 0 and layout.names:
            at = layout.floats[0]
            block = np.ascontiguousarray(rows[:, at : at + 8 * len(layout.names)]).view("<f8")
            unique, keep, twice = first_positions(layout.names)
            if keep is not None:
                block = block[:, keep]
            for name in twice:
                repeated[name] = repeated.get(name, 0) + len(rows)
            columns = np.array([names[name] for name in unique], dtype=np.intp)
            positions[np.ix_(good, columns)] = block
    for i, stamp, message_names, position in decoded:
        stamps[i] = stamp
        unique, keep, twice = first_positions(message_names)
        for name in twice:
            repeated[name] = repeated.get(name, 0) + 1
        for k, name in zip(keep if keep is not None else range(len(unique)), unique):
            if k < len(position):
                positions[i, names[name]] = position[k]
    return stamps, tuple(names), positions, repeated

