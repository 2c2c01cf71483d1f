"""YAML, in one place: the one loader of tfrec (``yaml.SafeLoader`` with bounds, for files tfrec did not write)
and the one writer (:func:`yaml_dump`, as yaml-cpp writes rosbag2's ``metadata.yaml``).

The only module that imports PyYAML (ruff's banned-api keeps it so). It sits in the base, below every stage:
the formats stage reads ``metadata.yaml`` and QoS texts with it, the description stage ``xacro.load_yaml``
and launch files' ``<rosparam>``.

YAML that tfrec reads comes from others: a rosbag2 folder's ``metadata.yaml``, the QoS text in
MCAP channel metadata, the configuration files a xacro description loads with
``xacro.load_yaml``. Plain ``yaml.safe_load`` constructs no objects but is open to two cheap
denials of service:

* *alias bombs* ("billion laughs"): ``a: &a [x, x, …]``, ``b: &b [*a, *a, …]`` … — a few hundred
  bytes whose expanded structure has billions of nodes. ``safe_load`` itself returns quickly
  (aliases share objects), but whoever walks the result (``str()``, xacro, JSON) does not;
* *deep nesting*: ``[[[[…]]]]`` 20,000 levels deep makes the pure-Python composer hit
  ``RecursionError`` (a traceback, not a message) and libyaml's parser slow down quadratically.

:func:`load_yaml` first streams the parser's events (libyaml's when available) and refuses, as
soon as a bound is passed, a document that is too large, nests too deeply, uses too many
aliases or expands (aliases counted at full size) to too many nodes. Only then is it
constructed, by the same safe constructor as ``yaml.safe_load``, so what loads gives identical
results. Errors are one line that starts with ``where``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import yaml

__all__ = ["MAX_ALIASES", "MAX_BYTES", "MAX_DEPTH", "MAX_NODES", "load_yaml", "yaml_dump"]

MAX_BYTES = 16 * 1024 * 1024
"""Largest document accepted (bytes, or characters of a ``str``): a rosbag2 ``metadata.yaml`` of a
bag with thousands of files is a few hundred kB; robot configuration files are a few kB."""
MAX_DEPTH = 64
"""Deepest nesting of collections accepted. rosbag2 metadata nests 6 levels, ros2_control and
robot configuration files under 10; the pure-Python composer and constructor recurse about three
Python frames per level, so 64 levels stay far from the interpreter's recursion limit."""
MAX_ALIASES = 10_000
"""Most ``*alias`` nodes accepted in one document. yaml-cpp (rosbag2) writes none."""
MAX_NODES = 2_000_000
"""Most nodes in the document with every alias expanded to the full size of what it names: as
many as 16 MB of plain YAML could hold, far fewer than an alias bomb expands to."""

_BaseLoader: type[Any] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""libyaml's parser with PyYAML's safe constructor when PyYAML was built with it (it parses
deep documents ~20x faster); the pure-Python SafeLoader otherwise. Both construct alike."""


class _Refused(Exception):
    """A bound passed while streaming the events; the message is the reason."""


def load_yaml(
    data: str | bytes,
    *,
    where: str,
    max_bytes: int = MAX_BYTES,
    max_aliases: int = MAX_ALIASES,
    max_depth: int = MAX_DEPTH,
    max_nodes: int = MAX_NODES,
    error: type[Exception] = ValueError,
    constructors: Mapping[str, Callable[[str], Any]] | None = None,
) -> Any:
    """One YAML document, constructed as ``yaml.safe_load`` does, within bounds.

    Args:
        data: the document: text, or bytes (UTF-8, or UTF-16/32 with a byte order mark).
        where: what the document is, for messages (a path, ``path:offered_qos_profiles``).
        max_bytes: the largest ``data`` accepted (bytes, or characters of a ``str``).
        max_aliases: the most ``*alias`` nodes accepted.
        max_depth: the deepest nesting of sequences and mappings accepted.
        max_nodes: the most nodes accepted, every alias counted at the full size of its anchor.
        error: the exception raised (``tfrec.errors.ReadError``, ``DescriptionError``, …);
            it is called with one message.
        constructors: extra constructors of tagged scalars, tag (``!degrees``) → function of the
            scalar's text. They apply to this call only (``yaml.SafeLoader`` is not changed).

    Returns:
        The document as Python data (``None`` for an empty document).

    Raises:
        error: a document that is not valid YAML (``where:line: not valid YAML: …``), that is
            larger, deeper, has more aliases or expands to more nodes than allowed, or that uses
            an alias inside the collection it names (a recursive structure).
    """
    size = len(data)
    if size > max_bytes:
        unit = "characters" if isinstance(data, str) else "bytes"
        raise error(f"{where}: YAML document of {size:,} {unit} is larger than the {max_bytes:,} allowed")
    try:
        _check_events(data, max_aliases=max_aliases, max_depth=max_depth, max_nodes=max_nodes)
        return yaml.load(data, Loader=_loader_class(constructors))  # a subclass of the safe loader
    except _Refused as err:
        raise error(f"{where}: {err}") from err
    except yaml.YAMLError as err:
        raise error(f"{where}{_describe(_as_python_reports(err, data, constructors))}") from err


def _as_python_reports(err: yaml.YAMLError, data: str | bytes, constructors: Mapping[str, Any] | None) -> Any:
    """The error PyYAML's pure-Python loader reports for the same document — libyaml's messages
    are terser ("found undefined alias" without its name) — or ``err`` itself."""
    if _BaseLoader is yaml.SafeLoader or isinstance(err, yaml.constructor.ConstructorError):
        return err  # the constructor is Python code in both loaders
    try:
        yaml.load(data, Loader=_loader_class(constructors, base=yaml.SafeLoader))  # within the bounds checked
    except yaml.YAMLError as python_err:
        return python_err
    except RecursionError:
        pass
    return err


def _describe(err: Any) -> str:
    """``:line: not valid YAML: problem``, as ``tfrec`` has always reported YAML errors."""
    if not isinstance(err, yaml.MarkedYAMLError):
        return f": not valid YAML: {_one_line(str(err))}"
    mark = err.problem_mark or err.context_mark
    line = f":{mark.line + 1}" if mark is not None else ""
    problem = err.problem or str(err)
    if err.context and problem.startswith("but "):  # "expected a single document in the stream, but found another"
        problem = f"{err.context}, {problem}"
    return f"{line}: not valid YAML: {_one_line(problem)}"


def _check_events(data: str | bytes, *, max_aliases: int, max_depth: int, max_nodes: int) -> None:
    """Stream the parser's events and raise :class:`_Refused` as soon as a bound is passed.

    Each open collection keeps the expanded size of what it holds so far; an anchored node's
    size is remembered when it closes and an alias adds that size, so the count is that of the
    document with every alias replaced by a copy of its anchor — without making the copies.
    """
    open_sizes: list[int] = []  # expanded node count of each open collection
    open_anchors: list[str | None] = []
    anchored: dict[str, int] = {}
    aliases = 0
    total = 0
    for event in yaml.parse(data, Loader=_BaseLoader):
        if isinstance(event, yaml.CollectionStartEvent):
            if len(open_sizes) >= max_depth:
                raise _Refused(f"YAML nested more than {max_depth} levels deep")
            open_sizes.append(1)
            open_anchors.append(event.anchor)
            continue
        if isinstance(event, yaml.CollectionEndEvent):
            size = open_sizes.pop()
            anchor = open_anchors.pop()
            if anchor is not None:
                anchored[anchor] = size
        elif isinstance(event, yaml.ScalarEvent):
            size = 1
            if event.anchor is not None:
                anchored[event.anchor] = size
        elif isinstance(event, yaml.AliasEvent):
            aliases += 1
            if aliases > max_aliases:
                raise _Refused(f"YAML uses more than {max_aliases:,} aliases")
            if event.anchor in open_anchors:
                raise _Refused(f"YAML alias *{event.anchor} refers to a collection that holds it (a recursive structure)")
            found = anchored.get(event.anchor)
            if found is None:
                continue  # an undefined alias: the loader reports it, with its line
            size = found
        else:
            continue  # stream and document boundaries
        if open_sizes:
            open_sizes[-1] += size
            size = open_sizes[-1]
        else:
            total += size
            size = total
        if size > max_nodes:
            raise _Refused(f"YAML expands to more than {max_nodes:,} nodes (aliases counted in full)")


def _loader_class(constructors: Mapping[str, Callable[[str], Any]] | None, base: type[Any] = _BaseLoader) -> type[Any]:
    """A fresh subclass of the safe loader, so that neither this call's constructors nor those
    others registered on ``yaml.SafeLoader`` (xacro registers ``!degrees`` there) leak across."""
    loader: type[Any] = type("_TfrecYamlLoader", (base,), {})
    loader.yaml_constructors = dict(yaml.constructor.SafeConstructor.yaml_constructors)
    for tag, construct in (constructors or {}).items():
        loader.add_constructor(tag, _scalar_constructor(construct))
    return loader


def _scalar_constructor(construct: Callable[[str], Any]) -> Callable[[Any, Any], Any]:
    def constructor(loader: Any, node: Any) -> Any:
        return construct(str(loader.construct_scalar(node)))

    return constructor


def _one_line(text: str) -> str:
    return " ".join(text.split())


def yaml_dump(data: Any) -> str:
    """Block-style YAML with indented sequences, ``~`` and ``""``, as yaml-cpp (rosbag2) writes it."""

    def indent_sequences(self: Any, flow: bool = False, indentless: bool = False) -> None:
        yaml.SafeDumper.increase_indent(self, flow, False)

    dumper: Any = type("_RosbagDumper", (yaml.SafeDumper,), {
        "increase_indent": indent_sequences,
        "ignore_aliases": lambda self, data: True,  # a mapping used twice is written twice, not as &id001
    })
    dumper.add_representer(type(None), lambda d, _: d.represent_scalar("tag:yaml.org,2002:null", "~"))
    dumper.add_representer(str, lambda d, v: d.represent_scalar("tag:yaml.org,2002:str", v, style='"' if v == "" else None))
    return str(yaml.dump(data, Dumper=dumper, sort_keys=False, default_flow_style=False, width=1 << 16))
