"""What the ROS 1 and ROS 2 launch readers share: deferred values, the command a description
param runs, typed parameter values, and the model a reader hands over.

Nothing here runs a command or a Python expression from a launch file.
"""

from __future__ import annotations

import math
import os
import re
import shlex
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any

from tfrec.description._launch_files import MAX_NESTING, Element, decode, read_bounded, where
from tfrec.errors import DescriptionError, display_path

MAX_INCLUDE_DEPTH = 32
"""Includes nested deeper than this are refused."""
MAX_INCLUDES = 256
"""More included files than this in one launch (counting repeats) are refused."""

YamlLoader = Callable[[str, str], Any]
"""``yaml_loader(text, source)``: the parsed YAML (``source`` names the text in messages).
Raises a :class:`tfrec.errors.TfrecError` on bad YAML."""


# ---- deferred values -------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Failure:
    """A substitution that could not be resolved; an error only if its value is needed."""

    source: str  # the substitution as written, e.g. "$(find rviz)"
    message: str


@dataclass(frozen=True, slots=True)
class CommandOutput:
    """The output of ROS 2 ``$(command 'CMD')``: never run, only read as a description source."""

    command: str


@dataclass(frozen=True, slots=True)
class FileContent:
    """ROS 2 ``$(file-content PATH)``."""

    path: str


Deferred = Failure | CommandOutput | FileContent
_TOKEN = re.compile("\x00([0-9]+)\x00")


class DeferredValues:
    """Values that stand in a string as ``\\x00N\\x00`` tokens until someone needs them.

    A launch file may name packages that are not installed here (``$(find rviz)``) in places tfrec
    never reads: those resolve to a token, and reading a token where a value is needed raises.
    """

    def __init__(self) -> None:
        self._items: list[Deferred] = []

    def token(self, item: Deferred) -> str:
        self._items.append(item)
        return f"\x00{len(self._items) - 1}\x00"

    def items(self, text: str) -> list[Deferred]:
        return [self._items[int(m.group(1))] for m in _TOKEN.finditer(text)]

    def only(self, text: str) -> Deferred | None:
        """The deferred value text is made of alone (surrounding whitespace aside), or None."""
        match = _TOKEN.fullmatch(text.strip())
        return self._items[int(match.group(1))] if match else None

    def plain(self, text: str, at: str) -> str:
        """text when it holds no deferred value, else the DescriptionError the first one stands for."""
        for item in self.items(text):
            raise self.error(item, at)
        return text

    def error(self, item: Deferred, at: str) -> DescriptionError:
        if isinstance(item, Failure):
            return DescriptionError(f"{at}: {item.message}")
        if isinstance(item, CommandOutput):
            return DescriptionError(f"{at}: needs the output of $(command '{item.command}'), which tfrec does not run")
        return DescriptionError(f"{at}: needs the content of $(file-content {item.path}) here, which tfrec does not read")

    def render(self, text: str) -> str:
        """text with each token written back as the substitution it stands for."""
        def back(match: re.Match[str]) -> str:
            item = self._items[int(match.group(1))]
            if isinstance(item, Failure):
                return item.source
            if isinstance(item, CommandOutput):
                return f"$(command '{item.command}')"
            return f"$(file-content {item.path})"

        return _TOKEN.sub(back, text)


# ---- the description a param names ---------------------------------------------------------------


class DescriptionKind(Enum):
    """Where a launch file's ``robot_description`` comes from."""

    XACRO = "xacro"
    """A xacro run: ``command="$(find xacro)/xacro FILE a:=b"`` or ``$(command 'xacro FILE')``."""
    URDF_FILE = "urdf"
    """A URDF file read as is: ``textfile=``, ``cat FILE``, ``$(file-content FILE)``."""
    URDF_TEXT = "text"
    """URDF written inline in the launch file (``value="<robot ...>"``)."""


@dataclass(frozen=True, slots=True)
class DescriptionSource:
    """The description one ``robot_description`` parameter holds."""

    kind: DescriptionKind
    file: Path | None = None
    xacro_args: Mapping[str, str] = field(default_factory=dict)
    xacro_flags: tuple[str, ...] = ()
    text: str | None = None


_XACRO_EXES = {"xacro", "xacro.py"}
_XACRO_NOOP_FLAGS = {"--inorder", "-i", "--check-order", "-q", "--xacro-ns", "-v", "-vv", "-vvv"}
_XACRO_FLAGS_WITH_VALUE = {"--verbosity"}


def _exe_name(token: str) -> str:
    return token.rsplit("/", 1)[-1]


def description_from_command(command: str, at: str, deferred: DeferredValues) -> DescriptionSource:
    """The description a command would print: ``xacro [flags] FILE [a:=b ...]`` or ``cat FILE``.

    The command is split like roslaunch and ROS 2 launch do (``shlex.split``) and never run.

    Raises:
        DescriptionError: another command, an unknown xacro flag, not exactly one input file.
    """
    shown = deferred.render(command).strip()
    try:
        words = shlex.split(command)
    except ValueError as err:
        raise DescriptionError(f"{at}: cannot split command '{shown}': {err}") from None
    if not words:
        raise DescriptionError(f"{at}: robot_description runs an empty command")
    words = _unwrapped(words)
    exe = _exe_name(words[0])
    if exe == "cat":
        if len(words) != 2 or words[1].startswith("-"):
            raise DescriptionError(f"{at}: robot_description runs '{shown}': tfrec reads 'cat FILE' of one file only")
        return DescriptionSource(DescriptionKind.URDF_FILE, file=Path(deferred.plain(words[1], at)))
    if exe not in _XACRO_EXES:
        raise DescriptionError(f"{at}: robot_description runs '{shown}', which is not xacro; tfrec does not run "
                               "commands: pass the description file instead")
    files, args, flags = _xacro_words(words[1:], shown, at, deferred)
    if len(files) != 1:
        raise DescriptionError(f"{at}: '{shown}' names {len(files)} input files; xacro takes one")
    return DescriptionSource(DescriptionKind.XACRO, file=Path(deferred.plain(files[0], at)),
                             xacro_args=args, xacro_flags=tuple(flags))


def _unwrapped(words: list[str]) -> list[str]:
    """A command without its wrapper: ``rosrun xacro xacro``, ``ros2 run xacro xacro``, ``python[3] .../xacro.py``."""
    if len(words) >= 3 and _exe_name(words[0]) == "rosrun" and words[1] == "xacro":
        return words[2:]
    if len(words) >= 4 and _exe_name(words[0]) == "ros2" and words[1:3] == ["run", "xacro"]:
        return words[3:]
    if len(words) >= 2 and re.fullmatch(r"python[0-9.]*", _exe_name(words[0])):
        return words[1:]
    return words


def _xacro_words(words: list[str], shown: str, at: str,
                 deferred: DeferredValues) -> tuple[list[str], dict[str, str], list[str]]:
    """A xacro command's words after the executable: (input files, ``name:=value`` arguments, flags).

    Raises:
        DescriptionError: an argument without a name, an unsupported flag.
    """
    files: list[str] = []
    args: dict[str, str] = {}
    flags: list[str] = []
    rest = iter(words)
    for word in rest:
        if ":=" in word:
            name, _, value = word.partition(":=")
            if not name:
                raise DescriptionError(f"{at}: xacro argument '{word}' has no name")
            if not name.startswith("__"):  # ROS remapping keys (__ns:=, __name:=) are not xacro args
                args[name] = deferred.plain(value, at)
        elif word in _XACRO_NOOP_FLAGS:
            flags.append(word)
        elif word.split("=", 1)[0] in _XACRO_FLAGS_WITH_VALUE:
            flags.append(word if "=" in word else f"{word}={next(rest, '')}")
        elif word.startswith("-") and word != "-":
            raise DescriptionError(f"{at}: xacro option '{word}' in '{shown}' is not supported "
                                   "(supported: --inorder, --check-order, -q, --verbosity, --xacro-ns)")
        else:
            files.append(word)
    return files, args, flags


def description_from_text(text: str, at: str) -> DescriptionSource:
    """Inline URDF given as a param's value."""
    if not text.lstrip().startswith("<"):
        shown = text.strip()[:60]
        raise DescriptionError(f"{at}: robot_description value '{shown}' is neither URDF text nor a command "
                               "running xacro")
    return DescriptionSource(DescriptionKind.URDF_TEXT, text=text)


# ---- parameter values ------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Param:
    """A parameter a launch file sets: its value (typed by the launch file's rules) and where."""

    value: object  # str, int, float, bool, list; None when set by command=/textfile= (unknown)
    at: str


def auto_value(text: str) -> object:
    """roslaunch's ``type="auto"``: int, float, bool or the string."""
    try:
        return float(text) if "." in text else int(text)
    except ValueError:
        pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


def positive_number(param: Param, what: str) -> float:
    value = auto_value(param.value.strip()) if isinstance(param.value, str) else param.value
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0 or value == float("inf"):
        raise DescriptionError(f"{param.at}: {what} is {param.value!r}, not a positive number")
    return float(value)


def number(param: Param, what: str) -> float:
    value = auto_value(param.value.strip()) if isinstance(param.value, str) else param.value
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise DescriptionError(f"{param.at}: {what} is {param.value!r}, not a number")
    return float(value)


def boolean(param: Param, what: str) -> bool:
    value = param.value
    if isinstance(value, str):
        value = {"true": True, "1": True, "false": False, "0": False}.get(value.strip().lower(), value)
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    raise DescriptionError(f"{param.at}: {what} is {param.value!r}, not true or false")


def text_value(param: Param) -> str:
    value = param.value
    if isinstance(value, bool):
        return "true" if value else "false"
    return "" if value is None else str(value)


def read_param_file(path: Path, at: str, yaml_loader: YamlLoader | None, what: str) -> object:
    """A YAML file a launch file loads, through the injected loader."""
    text = decode(read_bounded(path, site=at, what=what), path)
    return load_yaml_text(text, display_path(path), at, yaml_loader)


def load_yaml_text(text: str, source: str, at: str, yaml_loader: YamlLoader | None) -> object:
    if yaml_loader is None:
        raise DescriptionError(f"{at}: reading YAML ({source}) needs a YAML loader, and none was given")
    return yaml_loader(text, source)


def flatten(prefix: str, data: object, sep: str, out: dict[str, Param], at: str, depth: int = 0) -> None:
    """Unroll nested mappings into ``prefix{sep}key`` leaves, as rosparam and ROS 2 param files do."""
    if depth > MAX_NESTING:
        raise DescriptionError(f"{at}: parameters nested more than {MAX_NESTING} deep")
    if isinstance(data, dict):
        for key, value in data.items():
            flatten(f"{prefix}{sep}{key}" if prefix else str(key), value, sep, out, at, depth + 1)
    else:
        out[prefix] = Param(data, at)


def subtree(params: Mapping[str, Param], prefix: str) -> dict[str, Param]:
    """The leaves under ``prefix`` (which ends with its separator), keyed by the rest of their name."""
    return {name[len(prefix):]: p for name, p in params.items() if name.startswith(prefix) and len(name) > len(prefix)}


def ns_join(ns: str, name: str) -> str:
    """A ROS 1 name resolved in namespace ns (``/a/``): ``/a/name``; absolute names stay."""
    if name.startswith("/"):
        return name
    return (ns if ns.endswith("/") else ns + "/") + name


def os_dirname(file: Path) -> str:
    """The folder of a launch file as ``$(dirname)`` gives it (absolute, links kept)."""
    return os.path.dirname(os.path.abspath(file))


@dataclass(frozen=True, slots=True)
class YamlText:
    """A ROS 1 ``<param type="yaml">`` value, parsed only if tfrec needs it."""

    text: str


# ---- what a reader hands over ----------------------------------------------------------------------

JSP_PACKAGES = {"joint_state_publisher", "joint_state_publisher_gui"}
RSP_EXECUTABLES = {"robot_state_publisher", "state_publisher"}
NODE_PARAM_KEYS = {"use_gui", "rate", "zeros", "publish_frequency", "tf_prefix", "frame_prefix"}


@dataclass(slots=True)
class Node:
    """A node a launch file starts, with the private parameters it is given."""

    pkg: str
    exe: str
    name: str
    ns: str  # "/" or "/a/b/"
    at: str
    params: dict[str, Param] = field(default_factory=dict)

    @property
    def is_jsp(self) -> bool:
        return self.pkg in JSP_PACKAGES

    @property
    def is_rsp(self) -> bool:
        return self.pkg == "robot_state_publisher" and self.exe in RSP_EXECUTABLES

    @property
    def private_ns(self) -> str:
        return f"{self.ns}{self.name}/"


@dataclass(frozen=True, slots=True)
class Candidate:
    """One ``robot_description`` parameter a launch file sets."""

    source: DescriptionSource
    name: str  # the parameter's full name, e.g. /robot_description, /r1/robot_state_publisher/robot_description
    ns: str
    at: str
    node: int | None = None  # index in LaunchModel.nodes when the parameter is a node's own


@dataclass(slots=True)
class LaunchModel:
    """What a reader found: descriptions, nodes and parameters, before tfrec picks one robot."""

    ros_version: int
    files: list[Path] = field(default_factory=list)
    candidates: list[Candidate] = field(default_factory=list)
    nodes: list[Node] = field(default_factory=list)
    params: dict[str, Param] = field(default_factory=dict)  # ROS 1 parameter server (full names)
    launch_args: dict[str, str] = field(default_factory=dict)
    used_args: set[str] = field(default_factory=set)  # command-line args the launch read


def child_ns(ns: str, sub: str | None) -> str:
    """Namespace ``sub`` entered from ``ns`` (both as ``/a/b/``); absolute subs replace."""
    if not sub:
        return ns
    joined = sub if sub.startswith("/") else ns + sub
    parts = [p for p in joined.split("/") if p]
    return "/" + "".join(p + "/" for p in parts)


class ElementReader:
    """What the ROS 1 and ROS 2 readers share about an element: where it is, its attributes with their
    substitutions resolved, and whether its ``if``/``unless`` lets it in."""

    deferred: DeferredValues

    def _resolve(self, text: str, scope: Any, at: str) -> str:
        """``text`` with its substitutions resolved (the reader's own syntax)."""
        raise NotImplementedError

    def _at(self, elem: Element, scope: Any) -> str:
        return where(scope.file, elem.line)

    def _attr(self, elem: Element, name: str, scope: Any) -> str:
        if name not in elem.attrs:
            raise DescriptionError(f"{self._at(elem, scope)}: <{elem.tag}> has no {name}=")
        return self._resolve(elem.attrs[name], scope, self._at(elem, scope))

    def _opt(self, elem: Element, name: str, scope: Any) -> str | None:
        return self._attr(elem, name, scope) if name in elem.attrs else None

    def _enabled(self, elem: Element, scope: Any) -> bool:
        at = self._at(elem, scope)
        if "if" in elem.attrs and "unless" in elem.attrs:
            raise DescriptionError(f"{at}: <{elem.tag}> has both if= and unless=")
        key = "if" if "if" in elem.attrs else "unless" if "unless" in elem.attrs else None
        if key is None:
            return True
        value = self.deferred.plain(self._resolve(elem.attrs[key], scope, at), at)
        truth = {"true": True, "1": True, "false": False, "0": False}.get(value.strip().lower())
        if truth is None:
            raise DescriptionError(f"{at}: {key}=\"{elem.attrs[key]}\" is '{value}', not true, false, 1 or 0")
        return truth if key == "if" else not truth
