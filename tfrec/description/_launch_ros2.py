"""ROS 2 XML and YAML launch files (the launch frontend), read without running anything.

Followed from ros2/launch: substitutions parse as its frontend grammar does (nested ``$(...)``,
space-separated arguments, single- or double-quoted templates, backslash escapes);
``<arg>`` declares a launch argument (required when it has no default), ``<let>`` sets one,
``<group>`` scopes them (unless ``scoped="false"``), ``<push-ros-namespace>`` enters a namespace,
``if``/``unless`` take true/false/1/0 (any case, surrounding space ignored). ``$(command ...)`` is
never run: it stands for its command, which a ``robot_description`` parameter may hold.

One deliberate difference: an ``<include>`` gets a copy of the including file's launch
configurations, so what it sets does not leak back (ROS 2 before Jazzy lets it leak).
"""

from __future__ import annotations

import fnmatch
import math
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from tfrec.description._launch_common import (
    MAX_INCLUDE_DEPTH,
    MAX_INCLUDES,
    Candidate,
    CommandOutput,
    DeferredValues,
    DescriptionKind,
    DescriptionSource,
    ElementReader,
    Failure,
    FileContent,
    LaunchModel,
    Node,
    Param,
    YamlLoader,
    child_ns,
    description_from_command,
    description_from_text,
    flatten,
    load_yaml_text,
    os_dirname,
    read_param_file,
)
from tfrec.description._launch_eval import (
    EVAL_SUBSET,
    EvalRefused,
    safe_eval,
)
from tfrec.description._launch_files import (
    Element,
    decode,
    parse_xml,
    read_bounded,
    yaml_to_element,
)
from tfrec.description.packages import PackageFinder
from tfrec.errors import DescriptionError, display_path, suggest

__all__ = ["Ros2Reader"]

_ESCAPED = re.compile(r"\\(.)")
_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")
_KNOWN = ("var", "env", "find-pkg-share", "find-pkg-prefix", "find-exec", "exec-in-pkg", "command", "file-content",
          "dirname", "filename", "anon", "eval", "not", "and", "or", "any", "all", "equals", "not-equals", "if")


@dataclass(frozen=True, slots=True)
class _Sub:
    """``$(name arg arg ...)``; each argument a list of fragments."""

    name: str
    args: tuple[tuple[_Frag, ...], ...]


_Frag = str | _Sub


class _Parser:
    """The launch frontend's substitution grammar, by hand."""

    def __init__(self, text: str) -> None:
        self.s = text
        self.i = 0

    def fail(self, message: str) -> ValueError:
        return ValueError(f"{message} at character {self.i + 1} of '{self.s}'")

    def template(self) -> list[_Frag]:
        return self._fragments(None, top=True)

    def _fragments(self, quote: str | None, *, top: bool = False) -> list[_Frag]:
        out: list[_Frag] = []
        buf: list[str] = []
        s = self.s
        while self.i < len(s):
            c = s[self.i]
            if s.startswith("$(", self.i):
                out += ["".join(buf)] if buf else []
                buf = []
                out.append(self._substitution(quote))
            elif not top and c == quote:
                self.i += 1
                break
            elif c == "\\" and self.i + 1 < len(s):
                buf.append(s[self.i + 1])
                self.i += 2
            else:
                buf.append(c)
                self.i += 1
        else:
            if not top:
                raise self.fail(f"unterminated {quote}")
        out += ["".join(buf)] if buf else []
        return out

    def _substitution(self, quote: str | None) -> _Sub:
        self.i += 2
        match = _IDENTIFIER.match(self.s, self.i)
        if match is None:
            raise self.fail("a substitution name must follow '$('")
        self.i = match.end()
        args: list[tuple[_Frag, ...]] = []
        while True:
            if self.i >= len(self.s):
                raise self.fail(f"unterminated $({match.group()}")
            if self.s[self.i] == ")":
                self.i += 1
                return _Sub(match.group(), tuple(args))
            if self.s[self.i] != " ":
                raise self.fail("expected ' ' or ')'")
            while self.s.startswith(" ", self.i):
                self.i += 1
            if self.s.startswith(")", self.i):
                continue
            args.append(tuple(self._value(quote)))

    def _value(self, quote: str | None) -> list[_Frag]:
        s = self.s
        if quote is None and self.i < len(s) and s[self.i] in "'\"":
            q = s[self.i]
            self.i += 1
            return self._fragments(q)
        out: list[_Frag] = []
        buf: list[str] = []
        while self.i < len(s):
            c = s[self.i]
            if s.startswith("$(", self.i):
                out += ["".join(buf)] if buf else []
                buf = []
                out.append(self._substitution(quote))
            elif c in " )":
                break
            elif c == "(" or c == quote:
                raise self.fail(f"unexpected {c}")
            elif c == "\\" and self.i + 1 < len(s):
                buf.append(s[self.i + 1])
                self.i += 2
            else:
                buf.append(c)
                self.i += 1
        out += ["".join(buf)] if buf else []
        return out


def _truth(text: str) -> bool | None:
    return {"true": True, "1": True, "false": False, "0": False}.get(text.strip().lower())


class _Scope:
    __slots__ = ("configs", "file", "ns", "set_params", "site")

    def __init__(self, file: Path, configs: dict[str, str], ns: str, set_params: dict[str, Param],
                 site: str | None) -> None:
        self.file = file
        self.configs = configs  # launch configurations
        self.ns = ns
        self.set_params = set_params  # <set_parameter>: given to every later node in scope
        self.site = site

    def copy(self) -> _Scope:
        return _Scope(self.file, dict(self.configs), self.ns, dict(self.set_params), self.site)


class Ros2Reader(ElementReader):
    """Reads one ROS 2 XML or YAML launch file and its includes into a :class:`LaunchModel`."""

    def __init__(self, *, finder: PackageFinder, environ: Mapping[str, str], yaml_loader: YamlLoader | None,
                 deferred: DeferredValues, python_hint: Callable[[Path, str], DescriptionError]) -> None:
        self.finder = finder
        self.environ = environ
        self.yaml_loader = yaml_loader
        self.deferred = deferred
        self.python_hint = python_hint
        self.model = LaunchModel(ros_version=2)
        self._cmdline: set[str] = set()
        self._declared: list[str] = []  # by the file given
        self.declared: set[str] = set()  # by any file: command-line args reach every included file
        self._stack: list[Path] = []
        self._includes = 0

    def read(self, path: Path, root: Element, args: Mapping[str, str]) -> LaunchModel:
        self._cmdline = set(args)
        scope = _Scope(path, dict(args), "/", {}, None)
        self.model.files.append(path)
        self._stack.append(path.resolve())
        self._children(root, scope)
        self.model.launch_args = {name: self.deferred.render(scope.configs[name])
                                  for name in [*self._declared, *sorted(self.model.used_args)] if name in scope.configs}
        return self.model

    # ---- substitutions -------------------------------------------------------------------------

    def text(self, raw: str, scope: _Scope, at: str) -> str:
        """An attribute value with its substitutions performed."""
        if "$(" not in raw:
            return _ESCAPED.sub(r"\1", raw) if "\\" in raw else raw
        try:
            frags = _Parser(raw).template()
        except ValueError as err:
            raise DescriptionError(f"{at}: bad substitution: {err}") from None
        return self._join(frags, scope, at)

    def _join(self, frags: tuple[_Frag, ...] | list[_Frag], scope: _Scope, at: str) -> str:
        return "".join(f if isinstance(f, str) else self._perform(f, scope, at) for f in frags)

    def _perform(self, sub: _Sub, scope: _Scope, at: str) -> str:  # noqa: C901, PLR0912, PLR0915 - a branch per substitution
        name, n = sub.name, len(sub.args)

        def arg(i: int) -> str:
            return self._join(sub.args[i], scope, at)

        def count(low: int, high: int) -> None:
            if not low <= n <= high:
                want = str(low) if low == high else f"{low} to {high}"
                raise DescriptionError(f"{at}: $({name}) takes {want} arguments, not {n}")

        def truth(i: int) -> bool:
            value = self.deferred.plain(arg(i), at)
            result = _truth(value)
            if result is None:
                raise DescriptionError(f"{at}: $({name}) argument '{value}' is not true, false, 1 or 0")
            return result

        if name == "var":
            count(1, 2)
            var = arg(0)
            if var in scope.configs:
                if var in self._cmdline:
                    self.model.used_args.add(var)
                return scope.configs[var]
            if n == 2:
                return arg(1)
            raise DescriptionError(f"{at}: $(var {var}): launch argument '{var}' is not set"
                                   + suggest(var, scope.configs))
        if name == "env":
            count(1, 2)
            var = arg(0)
            if var in self.environ:
                return self.environ[var]
            if n == 2:
                return arg(1)
            raise DescriptionError(f"{at}: $(env {var}): environment variable '{var}' is not set")
        if name in ("find-pkg-share", "find-pkg-prefix"):
            count(1, 1)
            pkg = arg(0)
            try:
                share = self.finder.find(pkg)
            except DescriptionError as err:
                return self.deferred.token(Failure(f"$({name} {pkg})", f"$({name} {pkg}): {err}"))
            if name == "find-pkg-share":
                return str(share)
            if share.parent.name != "share":
                return self.deferred.token(Failure(f"$({name} {pkg})", f"$({name} {pkg}): {share} is not an "
                                                   "installed package (<prefix>/share/<pkg>)"))
            return str(share.parent.parent)
        if name in ("find-exec", "exec-in-pkg"):
            count(1, 1) if name == "find-exec" else count(2, 2)
            return arg(0)  # only ever used as a command's name: never looked up
        if name == "command":
            count(1, 2)
            return self.deferred.token(CommandOutput(arg(0)))
        if name == "file-content":
            count(1, 1)
            return self.deferred.token(FileContent(arg(0)))
        if name in ("dirname", "filename"):
            count(0, 0)
            return os_dirname(scope.file) if name == "dirname" else os.path.abspath(scope.file)
        if name == "anon":
            count(1, 1)
            return f"{arg(0)}_tfrec"
        if name == "eval":
            count(1, 2)
            expr = self.deferred.plain(arg(0), at)
            try:
                return str(safe_eval(expr, _no_names, {}))
            except EvalRefused as err:
                shown = f"$(eval '{expr}')"
                return self.deferred.token(Failure(shown, f"{shown} is not supported ({err}); tfrec evaluates only "
                                                   + EVAL_SUBSET.replace(" and calls of arg/env/optenv/find/dirname",
                                                                         "")))
        if name == "not":
            count(1, 1)
            return str(not truth(0)).lower()
        if name in ("and", "or"):
            count(2, 2)
            return str(truth(0) and truth(1) if name == "and" else truth(0) or truth(1)).lower()
        if name in ("any", "all"):
            values = (truth(i) for i in range(n))
            return str(any(values) if name == "any" else all(values)).lower()
        if name in ("equals", "not-equals"):
            count(2, 2)
            equal = _equals(arg(0), arg(1))
            return str(equal if name == "equals" else not equal).lower()
        if name == "if":
            count(2, 3)
            return arg(1) if truth(0) else (arg(2) if n == 3 else "")
        raise DescriptionError(f"{at}: unknown substitution $({name}){suggest(name, _KNOWN)}")

    # ---- elements ------------------------------------------------------------------------------

    def _resolve(self, text: str, scope: _Scope, at: str) -> str:
        return self.text(text, scope, at)

    def _children(self, parent: Element, scope: _Scope) -> None:
        for elem in parent.children:
            tag = elem.tag.replace("_", "-")
            handler = {"arg": self._arg_tag, "let": self._let, "group": self._group, "node": self._node,
                       "include": self._include, "push-ros-namespace": self._push_ns,
                       "set-parameter": self._set_parameter}.get(tag)
            if handler is not None and self._enabled(elem, scope):
                handler(elem, scope)

    def _arg_tag(self, elem: Element, scope: _Scope) -> None:
        at = self._at(elem, scope)
        name = self._attr(elem, "name", scope)
        if scope.site is None:
            self._declared.append(name)
        self.declared.add(name)
        if name not in scope.configs:
            default = self._opt(elem, "default", scope)
            if default is None:
                if scope.site is None:
                    raise DescriptionError(f"{at}: launch argument '{name}' is required: pass {name}:=VALUE")
                raise DescriptionError(f"{at}: launch argument '{name}' is required: the <include> at {scope.site} "
                                       "does not pass it")
            scope.configs[name] = default
        choices = [self._attr(c, "value", scope) for c in elem.children if c.tag == "choice"]
        if choices and scope.configs[name] not in choices:
            raise DescriptionError(f"{at}: launch argument '{name}' is '{scope.configs[name]}', not one of "
                                   + ", ".join(choices))

    def _let(self, elem: Element, scope: _Scope) -> None:
        scope.configs[self._attr(elem, "name", scope)] = self._attr(elem, "value", scope)

    def _push_ns(self, elem: Element, scope: _Scope) -> None:
        scope.ns = child_ns(scope.ns, self._attr(elem, "namespace", scope))

    def _set_parameter(self, elem: Element, scope: _Scope) -> None:
        scope.set_params[self._attr(elem, "name", scope)] = Param(self._attr(elem, "value", scope),
                                                                  self._at(elem, scope))

    def _group(self, elem: Element, scope: _Scope) -> None:
        scoped = _truth(self._opt(elem, "scoped", scope) or "true")
        if scoped is False:
            inner = _Scope(scope.file, scope.configs, scope.ns, scope.set_params, scope.site)
            self._children(elem, inner)
            scope.ns = inner.ns
        else:
            self._children(elem, scope.copy())

    def _node(self, elem: Element, scope: _Scope) -> None:
        at = self._at(elem, scope)
        pkg, exe = self._attr(elem, "pkg", scope), self._attr(elem, "exec", scope)
        name = self._opt(elem, "name", scope) or exe
        ns = self._opt(elem, "namespace", scope)
        node = Node(pkg, exe, name, child_ns(scope.ns, ns), at, params=dict(scope.set_params))
        self.model.nodes.append(node)
        for child in elem.children:
            if child.tag == "param" and self._enabled(child, scope):
                self._param(child, scope, node, "")

    def _param(self, elem: Element, scope: _Scope, node: Node, prefix: str) -> None:
        at = self._at(elem, scope)
        if "from" in elem.attrs:
            if node.is_jsp or node.is_rsp:
                path = Path(self.deferred.plain(self._attr(elem, "from", scope), at))
                self._param_file(path, at, node)
            return
        name = prefix + self._attr(elem, "name", scope)
        nested = [c for c in elem.children if c.tag == "param"]
        if nested and "value" not in elem.attrs:
            for child in nested:
                if self._enabled(child, scope):
                    self._param(child, scope, node, name + ".")
            return
        value = self._attr(elem, "value", scope)
        if name == "robot_description":
            source = self._description(value, at)
            self.model.candidates.append(Candidate(source, node.private_ns + name, node.ns, at,
                                                   len(self.model.nodes) - 1))
        else:
            node.params[name] = Param(value, at)

    def _description(self, value: str, at: str) -> DescriptionSource:
        item = self.deferred.only(value)
        if isinstance(item, CommandOutput):
            return description_from_command(item.command, at, self.deferred)
        if isinstance(item, FileContent):
            return DescriptionSource(DescriptionKind.URDF_FILE, file=Path(self.deferred.plain(item.path, at).strip()))
        if any(isinstance(i, (CommandOutput, FileContent)) for i in self.deferred.items(value)):
            raise DescriptionError(f"{at}: robot_description '{self.deferred.render(value).strip()}' mixes text with "
                                   "$(command ...); tfrec reads a value that is one $(command 'xacro ...') alone")
        return description_from_text(self.deferred.plain(value, at), at)

    def _param_file(self, path: Path, at: str, node: Node) -> None:
        data = read_param_file(path, at, self.yaml_loader, "parameter file")
        if not isinstance(data, dict):
            raise DescriptionError(f"{at}: parameter file {display_path(path)} does not hold a mapping")
        full = node.private_ns.rstrip("/")
        for key, body in data.items():
            pattern = str(key) if str(key).startswith("/") else "/" + str(key)
            matches = (fnmatch.fnmatchcase(full, pattern.replace("**", "*"))
                       or str(key).lstrip("/") == node.name)
            if matches and isinstance(body, dict) and isinstance(body.get("ros__parameters"), dict):
                flatten("", body["ros__parameters"], ".", node.params, display_path(path))

    def _include(self, elem: Element, scope: _Scope) -> None:
        at = self._at(elem, scope)
        path = Path(self.deferred.plain(self._attr(elem, "file", scope), at))
        child = scope.copy()
        child.file, child.site = path, at
        for arg in elem.children:
            if arg.tag == "arg" and self._enabled(arg, scope):
                child.configs[self._attr(arg, "name", scope)] = self._attr(arg, "value", scope)
        resolved = path.resolve()
        if resolved in self._stack:
            chain = " -> ".join(display_path(p) for p in [*self._stack[self._stack.index(resolved):], resolved])
            raise DescriptionError(f"{at}: include cycle: {chain}")
        if len(self._stack) > MAX_INCLUDE_DEPTH:
            raise DescriptionError(f"{at}: includes nested more than {MAX_INCLUDE_DEPTH} deep; refused")
        self._includes += 1
        if self._includes > MAX_INCLUDES:
            raise DescriptionError(f"{at}: more than {MAX_INCLUDES} included launch files; refused")
        if path.name.endswith(".py"):
            raise self.python_hint(path, at)
        data = read_bounded(path, site=at)
        if path.suffix in (".yaml", ".yml"):
            root = yaml_to_element(load_yaml_text(decode(data, path), display_path(path), at, self.yaml_loader), path)
        else:
            root = parse_xml(data, path)
        self.model.files.append(path)
        self._stack.append(resolved)
        try:
            self._children(root, child)
        finally:
            self._stack.pop()


def _no_names(name: str) -> object:
    raise EvalRefused(f"unknown name '{name}'")


def _equals(left: str, right: str) -> bool:
    """ROS 2 ``$(equals)``: booleans and numbers compare by value, the rest as text."""
    bools = ("true", "false", "1", "0")
    if left.lower() in bools and right.lower() in bools:
        return (left.lower() in ("true", "1")) == (right.lower() in ("true", "1"))
    try:
        return math.isclose(float(left), float(right))
    except ValueError:
        return left == right
