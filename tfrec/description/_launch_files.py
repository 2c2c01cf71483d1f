"""Reading launch files safely: bounded in size, XML through expat with DOCTYPE and entity
declarations refused, ROS 2 YAML launch files turned into the same element tree, line numbers kept.
"""

from __future__ import annotations

import contextlib
import contextvars
import xml.parsers.expat
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from tfrec.description._confine import ReadRoots
from tfrec.errors import DescriptionError, display_path

MAX_LAUNCH_BYTES = 10 * 1024 * 1024
"""Launch files (and the YAML files they load) larger than this are refused."""
MAX_NESTING = 100
"""Elements nested deeper than this are refused."""


def where(file: Path, line: int | None) -> str:
    """``path:LINE`` for messages (just the path when the line is unknown, as in YAML)."""
    return f"{display_path(file)}:{line}" if line else display_path(file)


@dataclass(slots=True)
class Element:
    """One launch-file element: XML tag or YAML entity, with its line (None in YAML)."""

    tag: str
    attrs: dict[str, str]
    line: int | None
    children: list[Element] = field(default_factory=list)
    text_parts: list[str] = field(default_factory=list)

    @property
    def text(self) -> str:
        return "".join(self.text_parts)


_ROOTS: contextvars.ContextVar[ReadRoots | None] = contextvars.ContextVar("launch_read_roots", default=None)


@contextlib.contextmanager
def confined(roots: ReadRoots) -> Iterator[None]:
    """Within the block, :func:`read_bounded` reads only what ``roots`` allows: a launch file names files to
    include and load (``<include file>``, ``<rosparam file>``, parameter files) as xacro does, so they are held
    to the same places (:mod:`tfrec.description._confine`)."""
    token = _ROOTS.set(roots)
    try:
        yield
    finally:
        _ROOTS.reset(token)


def read_bounded(path: Path, *, site: str | None, what: str = "launch file") -> bytes:
    """The bytes of a file of at most :data:`MAX_LAUNCH_BYTES` (and, within :func:`confined`, one it allows).

    Args:
        site: ``file:line`` of the element that names this file, or None for the file given.
    """
    prefix = f"{site}: {what} " if site else ""
    roots = _ROOTS.get()
    if site is not None and roots is not None and not roots.allows(path):
        raise DescriptionError(f"{prefix}refused: {roots.refusal(path)}")
    if not path.is_file():
        raise DescriptionError(f"{prefix}{display_path(path)}: " + ("not a file" if path.exists() else "no such file"))
    try:
        with path.open("rb") as stream:
            data = stream.read(MAX_LAUNCH_BYTES + 1)
    except OSError as err:
        raise DescriptionError(f"{prefix}{display_path(path)}: cannot read: {err.strerror or err}") from None
    if len(data) > MAX_LAUNCH_BYTES:
        raise DescriptionError(f"{prefix}{display_path(path)}: larger than {MAX_LAUNCH_BYTES // (1024 * 1024)} MB; refused")
    return data


def decode(data: bytes, path: Path) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise DescriptionError(f"{display_path(path)}: not UTF-8 text (byte {err.start})") from None


def parse_xml(data: bytes, path: Path) -> Element:
    """Parse launch XML keeping line numbers; DOCTYPE and entity declarations are refused."""
    parser = xml.parsers.expat.ParserCreate()
    parser.SetParamEntityParsing(xml.parsers.expat.XML_PARAM_ENTITY_PARSING_NEVER)
    stack: list[Element] = []
    roots: list[Element] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        if len(stack) >= MAX_NESTING:
            raise DescriptionError(f"{where(path, parser.CurrentLineNumber)}: elements nested more than "
                                   f"{MAX_NESTING} deep; refused")
        elem = Element(tag, dict(attrs), parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(elem)
        stack.append(elem)

    def end(tag: str) -> None:
        stack.pop()

    def text(data: str) -> None:
        if stack:
            stack[-1].text_parts.append(data)

    def doctype(*_: object) -> None:
        raise DescriptionError(f"{where(path, parser.CurrentLineNumber)}: <!DOCTYPE> in a launch file is refused "
                               "(entity declarations can inflate XML)")

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = text
    parser.StartDoctypeDeclHandler = doctype
    parser.EntityDeclHandler = doctype
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as err:
        raise DescriptionError(f"{where(path, err.lineno)}: malformed XML: "
                               f"{xml.parsers.expat.ErrorString(err.code)}") from None
    except (LookupError, ValueError) as err:  # an encoding declaration expat cannot read (unknown, multi-byte)
        raise DescriptionError(f"{where(path, 1)}: unsupported XML encoding: {err}") from None
    root = roots[0]
    if root.tag != "launch":
        hint = ": it is a robot description, pass it as such" if root.tag == "robot" else ""
        raise DescriptionError(f"{where(path, root.line)}: root element is <{root.tag}>, not <launch>{hint}")
    return root


def _yaml_scalar(value: object, path: Path) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return ""
    text = str(value) if isinstance(value, (str, int, float)) else repr(value)
    if "\x00" in text:
        raise DescriptionError(f"{display_path(path)}: NUL character in a launch value")
    return text


def yaml_to_element(data: object, path: Path) -> Element:
    """A ROS 2 YAML launch file (``launch: [{tag: {attr: value, ...}}, ...]``) as an element tree."""
    if not isinstance(data, dict) or "launch" not in data or not isinstance(data["launch"], list):
        raise DescriptionError(f"{display_path(path)}: not a ROS 2 YAML launch file (no top-level 'launch:' list)")
    root = Element("launch", {}, None)
    root.children = [_yaml_entity(item, path, 1) for item in data["launch"]]
    return root


def _yaml_entity(item: object, path: Path, depth: int) -> Element:
    if depth > MAX_NESTING:
        raise DescriptionError(f"{display_path(path)}: entities nested more than {MAX_NESTING} deep; refused")
    if not isinstance(item, dict) or len(item) != 1:
        raise DescriptionError(f"{display_path(path)}: launch entity {str(item)[:60]!r} is not a one-key mapping")
    ((tag, body),) = item.items()
    return _yaml_body(str(tag), body, path, depth)


def _yaml_body(tag: str, body: object, path: Path, depth: int) -> Element:
    elem = Element(tag, {}, None)
    if isinstance(body, list):  # e.g. group: [children]
        elem.children = [_yaml_entity(child, path, depth + 1) for child in body]
    elif isinstance(body, dict):
        for key, value in body.items():
            if key == "children" and isinstance(value, list):
                elem.children += [_yaml_entity(child, path, depth + 1) for child in value]
            elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
                elem.children += [_yaml_body(str(key), v, path, depth + 1) for v in value]
            elif isinstance(value, list):
                elem.attrs[str(key)] = ",".join(_yaml_scalar(v, path) for v in value)
            else:
                elem.attrs[str(key)] = _yaml_scalar(value, path)
    elif body is not None:
        raise DescriptionError(f"{display_path(path)}: launch entity '{tag}' holds {str(body)[:60]!r}, not a mapping")
    return elem


def static_arg_names(root: Element) -> set[str]:
    """The names of the ``<arg>`` a launch file declares (outside ``<include>``), as written."""
    names: set[str] = set()
    stack = [root]
    while stack:
        elem = stack.pop()
        for child in elem.children:
            if child.tag == "arg" and "name" in child.attrs:
                names.add(child.attrs["name"])
            elif child.tag != "include":
                stack.append(child)
    return names
