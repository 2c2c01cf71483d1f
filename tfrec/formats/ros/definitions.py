"""The message definitions a recording carries: parsed, checked, and compared with the layouts tfrec reads.

A recording names each topic's type and (usually) carries the type's definition: a ROS 1 connection
record its ``message_definition`` and ``md5sum``, an MCAP schema its ``ros2msg`` or ``ros2idl`` text, a
rosbag2 topic its RIHS01 type hash. tfrec decodes four types itself — ``tf2_msgs/TFMessage`` (and ROS 1's
``tf/tfMessage``) on /tf and /tf_static, ``sensor_msgs/JointState`` on /joint_states, ``std_msgs/String``
on /robot_description — with the layouts ROS gives them. :func:`foreign_layout` says whether a recording's
type has that layout:

- ROS 1: its ``md5sum`` is ROS's (the check roscpp and rospy make before they decode a message). A
  connection whose md5sum is ``*`` or missing is compared by its definition's fields, and taken by its
  type name when it carries no definition either.
- ROS 2: its definition parses to the same fields as ROS's, field by field — names, types, array kinds
  and sizes, nested types by their content (comments, constants, default values and whitespace do not
  count). Without a definition its RIHS01 type hash is compared; without either, the type name is taken.

A topic whose type has another layout is foreign data: counted and listed, copied as it is by
``tfrec convert``, never read as TF, joint states or a description.

:func:`parse_definition` parses a definition with rosbags' parsers and checks it before anything else
uses it: a type that contains itself (directly, through another type, through an array) has no finite
layout, and rosbags recurses forever on it; a definition past :data:`MAX_DEFINITION_CHARS`, with more
than :data:`MAX_DEFINITION_TYPES` types or nesting deeper than :data:`MAX_DEFINITION_DEPTH` is refused.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cache, lru_cache
from typing import Any

from tfrec.formats.ros.connection import Connection
from tfrec.formats.ros.types import ROS2_DEFINITIONS, known_ros1_typestore, typestore

__all__ = [
    "INTERPRETED",
    "MAX_DEFINITION_CHARS",
    "MAX_DEFINITION_DEPTH",
    "MAX_DEFINITION_TYPES",
    "DefinitionError",
    "foreign_layout",
    "has_known_layout",
    "parse_definition",
]

MAX_DEFINITION_CHARS = 1 << 20
"""The longest message definition parsed (rosbags parses about 1 MB a second); real ones, every
dependency included, are under 50 kB."""

MAX_DEFINITION_TYPES = 1000
"""The most types one definition may define; real ones use a few dozen."""

MAX_DEFINITION_DEPTH = 64
"""The deepest nesting of types in a definition; real ones nest under 10 (rosbags recurses a few Python
frames a level)."""

INTERPRETED = {
    "tf2_msgs/msg/TFMessage": "tf2_msgs/msg/TFMessage",
    "tf/msg/tfMessage": "tf2_msgs/msg/TFMessage",
    "sensor_msgs/msg/JointState": "sensor_msgs/msg/JointState",
    "std_msgs/msg/String": "std_msgs/msg/String",
}
"""The types tfrec decodes, each with the type whose layout it has (ROS 1's ``tf/tfMessage`` is tf2's)."""

Fields = tuple[list[Any], list[tuple[str, Any]]]
"""rosbags' field definitions of one type: (constants, [(name, (node type, details))])."""

_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4  # rosbags' Nodetype values
_SEPARATOR = "=" * 80 + "\n"


class DefinitionError(ValueError):
    """A message definition that cannot be used: it does not parse, a type contains itself, or it is too large."""


def _full(msgtype: str) -> str:
    return msgtype if "/msg/" in msgtype or msgtype.count("/") != 1 else msgtype.replace("/", "/msg/", 1)


@lru_cache(maxsize=32)
def parse_definition(msgtype: str, definition: str, encoding: str) -> Mapping[str, Fields]:
    """The types a message definition defines, as rosbags' field definitions, once checked.

    Args:
        msgtype: the type it defines (``pkg/msg/Type``).
        definition: its text: a ROS 1 or ROS 2 ``.msg`` with its dependencies (``ros1msg``,
            ``ros2msg``), or ``ros2idl``.
        encoding: ``ros1msg``, ``ros2msg`` or ``ros2idl``.

    Raises:
        DefinitionError: a definition that does not parse, does not define ``msgtype``, defines a type
            that contains itself, or passes a bound (:data:`MAX_DEFINITION_CHARS`, :data:`MAX_DEFINITION_TYPES`,
            :data:`MAX_DEFINITION_DEPTH`).
    """
    from rosbags.typesys import get_types_from_idl, get_types_from_msg
    from rosbags.typesys.base import TypesysError

    if len(definition) > MAX_DEFINITION_CHARS:
        raise DefinitionError(f"its message definition has {len(definition):,} characters, more than the "
                              f"{MAX_DEFINITION_CHARS:,} tfrec reads")
    sections = definition.count("\nMSG: ") if encoding != "ros2idl" else definition.count("struct ")
    if sections >= MAX_DEFINITION_TYPES:  # refused before parsing: rosbags parses about 10,000 types a second
        raise DefinitionError(f"its message definition defines {sections + 1:,} types, more than the "
                              f"{MAX_DEFINITION_TYPES:,} tfrec reads")
    try:
        if encoding == "ros2idl":
            parts = [part.split("\n", 1)[-1] for part in definition.split(_SEPARATOR)[1:]] \
                if definition.startswith(_SEPARATOR + "IDL: ") else [definition]
            found: dict[str, Fields] = {}
            for part in parts:
                found.update(get_types_from_idl(part))
        else:
            found = dict(get_types_from_msg(definition, msgtype))
    except RecursionError as err:
        raise DefinitionError("its message definition nests too deeply to parse") from err
    except (TypesysError, ValueError, IndexError, KeyError) as err:
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise DefinitionError(f"its message definition does not parse (rosbags: {first[:80]})") from err
    if msgtype not in found:
        raise DefinitionError(f"its message definition does not define {msgtype}")
    _check_graph(found)
    return found


def _uses(fields: Fields) -> list[str]:
    """The types the fields of one type name (array elements included)."""
    out = []
    for _, desc in fields[1]:
        while desc[0] in (_ARRAY, _SEQUENCE):
            desc = desc[1][0]
        if desc[0] == _NAME:
            out.append(str(desc[1]))
    return out


def _check_graph(types: Mapping[str, Fields]) -> None:
    """No type contains itself, and the types are few and shallow enough.

    Raises:
        DefinitionError: a cycle (named, ``a/msg/A → b/msg/B → a/msg/A``) or a bound passed.
    """
    if len(types) > MAX_DEFINITION_TYPES:
        raise DefinitionError(f"its message definition defines {len(types):,} types, more than the "
                              f"{MAX_DEFINITION_TYPES:,} tfrec reads")
    done: set[str] = set()
    for root in types:
        if root in done:
            continue
        path: list[str] = [root]  # an iterative depth-first walk: a definition may nest deeper than Python recurses
        pending: list[list[str]] = [[t for t in _uses(types[root]) if t in types]]
        while path:
            if not pending[-1]:
                done.add(path.pop())
                pending.pop()
                continue
            child = pending[-1].pop()
            if child in path:
                cycle = " → ".join(path[path.index(child):] + [child])
                raise DefinitionError(f"its message definition has a type that contains itself ({cycle})")
            if child in done:
                continue
            path.append(child)
            pending.append([t for t in _uses(types[child]) if t in types])
            if len(path) > MAX_DEFINITION_DEPTH:
                raise DefinitionError(f"its message definition nests types more than {MAX_DEFINITION_DEPTH} deep "
                                      f"({path[0]} → … → {path[-1]})")


# -- the layouts tfrec reads ------------------------------------------------------------------------


@cache
def _reference(*, ros1: bool) -> Mapping[str, Fields]:
    """ROS's field definitions: Noetic's (with tf2_msgs/TFMessage) or Humble's."""
    store = known_ros1_typestore() if ros1 else typestore()
    return dict(store.fielddefs)


ROS_LAYOUTS = {
    "tf2_msgs/msg/TFMessage": ("94810edda583a504dfda3829e70d7eec",
                               "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"),
    "sensor_msgs/msg/JointState": ("3066dcd76a6cfaef579bd0f34173e9fd",
                                   "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"),
    "std_msgs/msg/String": ("992ce8a1687cec8c8bd883ec73ca41d1",
                            "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"),
}
"""Each type tfrec reads → its ROS 1 md5sum and its ROS 2 RIHS01 type hash, as rosbags' type stores compute them
(tests compare), known without loading the stores: a ROS 1 bag's connections are checked by their md5sum, tfrec's
own MCAP schemas by their text (:data:`~tfrec.formats.ros.types.ROS2_DEFINITIONS`), with none of rosbags' stores."""


def _ros1_md5(reference: str) -> str:
    return ROS_LAYOUTS[reference][0]


def _rihs01(reference: str) -> str:
    return ROS_LAYOUTS[reference][1]


def _written_by_tfrec(msgtype: str, definition: str, encoding: str) -> bool:
    """Whether a definition is the ``ros2msg`` text tfrec writes for the type: ROS 2's layout, known without parsing
    (a ROS 1 connection's layout has the Header's ``seq``: it is compared field by field)."""
    return encoding == "ros2msg" and definition == ROS2_DEFINITIONS.get(msgtype)


def _describe(desc: Any) -> str:
    """A field's type as a .msg would write it: ``float64[]``, ``geometry_msgs/msg/TransformStamped``."""
    if desc[0] == _BASE:
        name, bound = desc[1]
        return f"{name}<={bound}" if bound else str(name)
    if desc[0] == _NAME:
        return str(desc[1])
    inner, size = desc[1]
    if desc[0] == _ARRAY:
        return f"{_describe(inner)}[{size}]"
    return f"{_describe(inner)}[{f'<={size}' if size else ''}]"


def _difference(found: Mapping[str, Fields], msgtype: str, reference: Mapping[str, Fields], known: str) -> str | None:
    """Where ``msgtype`` of ``found`` differs from ``known`` of ``reference``: ``field 'x.y' is …, not …``;
    None when every field matches. A type ``found`` names but does not define is taken from ``reference``.

    The walk follows ``known``'s fields, which are few and nest a few levels: it ends on any ``found``,
    one whose types contain themselves included.
    """
    todo: list[tuple[str, str, str]] = [(msgtype, known, "")]
    compared: set[tuple[str, str]] = set()
    while todo:
        mine, theirs, prefix = todo.pop()
        if (mine, theirs) in compared:
            continue
        compared.add((mine, theirs))
        got, want = found.get(mine, reference.get(mine)), reference[theirs]
        if got is None:
            return f"{prefix or 'its type'} is {mine}, which it does not define"
        got_fields, want_fields = got[1], want[1]
        for k, (name, desc) in enumerate(want_fields):
            where = f"{prefix}{name}"
            if k >= len(got_fields):
                return f"it lacks field '{where}'"
            got_name, got_desc = got_fields[k]
            if got_name != name:
                return f"field {k + 1}{f' of {prefix[:-1]}' if prefix else ''} is '{got_name}', not '{name}'"
            a, b = got_desc, desc
            while a[0] == b[0] and a[0] in (_ARRAY, _SEQUENCE) and a[1][1] == b[1][1]:
                a, b = a[1][0], b[1][0]
            if a[0] != b[0] or a[0] in (_ARRAY, _SEQUENCE) or (a[0] == _BASE and a[1] != b[1]):
                return f"field '{where}' is {_describe(got_desc)}, not {_describe(desc)}"
            if a[0] == _NAME:
                todo.append((str(a[1]), str(b[1]), where + "."))
        if len(got_fields) > len(want_fields):
            return f"it has a field '{prefix}{got_fields[len(want_fields)][0]}' more"
    return None


def foreign_layout(msgtype: str, *, ros1: bool, definition: str = "", definition_encoding: str = "",
                   type_hash: str = "") -> str | None:
    """Why a recording's type is not the layout tfrec reads for it, or None when it is (or when tfrec
    does not read the type itself: any layout is then the recording's business).

    Args:
        msgtype: the type as the recording names it (``pkg/msg/Type`` or ``pkg/Type``).
        ros1: a ROS 1 connection (else ROS 2).
        definition: the definition the recording gives; ``""`` when none.
        definition_encoding: ``ros1msg``, ``ros2msg`` or ``ros2idl``.
        type_hash: ROS 1's md5sum or ROS 2's RIHS01 type hash; ``""`` when none.

    Returns:
        A phrase for a warning (``its md5sum is …, not ROS's …``), or None.
    """
    known = INTERPRETED.get(_full(msgtype))
    if known is None:
        return None
    if ros1 and type_hash not in ("", "*"):
        expected = _ros1_md5(known)
        return None if type_hash == expected else f"its md5sum is {type_hash!r}, not ROS's {expected}"
    if definition.strip():
        encoding = definition_encoding or ("ros1msg" if ros1 else "ros2msg")
        if not ros1 and _written_by_tfrec(_full(msgtype), definition, encoding):
            return None
        try:
            found = parse_definition(_full(msgtype), definition, encoding)
        except DefinitionError as err:
            return str(err)
        difference = _difference(found, _full(msgtype), _reference(ros1=ros1), known)
        return None if difference is None else f"its definition is not ROS's: {difference}"
    if not ros1 and type_hash.startswith("RIHS01_") and known == _full(msgtype):
        expected = _rihs01(known)
        return None if type_hash == expected else f"its type hash is {type_hash}, not ROS's {expected}"
    return None


def has_known_layout(connection: Connection) -> bool:
    """Whether a connection of a type tfrec reads has the layout tfrec reads (:func:`foreign_layout`)."""
    return foreign_layout(connection.msgtype, ros1=connection.ros1, definition=connection.definition,
                          definition_encoding=connection.definition_encoding, type_hash=connection.type_hash) is None
