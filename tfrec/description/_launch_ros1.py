"""ROS 1 roslaunch XML, read with roslaunch's rules and without running anything.

Followed from roslaunch (``xmlloader.py``, ``loader.py``, ``substitution_args.py``):

* ``<arg name default=>`` may be overridden (command line, ``<include>``), ``<arg name value=>``
  may not, an ``<arg>`` with neither must be given a value before ``$(arg)`` reads it;
  args are scoped to their file and group, and ``<include>`` starts a new scope holding only the
  args it passes (all of them with ``pass_all_args="true"``); passing an arg the included file
  does not declare is an error;
* substitutions resolve in two passes: ``$(arg)``, ``$(env)``, ``$(optenv)``, ``$(dirname)``,
  ``$(anon)`` first, then ``$(find)`` (so an arg whose value holds ``$(find pkg)`` works);
  ``$(eval ...)`` must be the whole attribute;
* ``if``/``unless`` take true/false/1/0 (any case) after substitution.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from tfrec.description._launch_common import (
    MAX_INCLUDE_DEPTH,
    MAX_INCLUDES,
    NODE_PARAM_KEYS,
    Candidate,
    DeferredValues,
    DescriptionKind,
    DescriptionSource,
    ElementReader,
    Failure,
    LaunchModel,
    Node,
    Param,
    YamlLoader,
    YamlText,
    auto_value,
    child_ns,
    description_from_command,
    description_from_text,
    flatten,
    load_yaml_text,
    ns_join,
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
)
from tfrec.description.packages import PackageFinder
from tfrec.errors import DescriptionError, display_path, suggest

__all__ = ["Ros1Reader"]

_CMDLINE = "the command line"
_COMMANDS = ("arg", "env", "optenv", "find", "dirname", "anon", "eval")
_OUT, _DOLLAR, _LP, _IN = range(4)


class _Scope:
    """roslaunch's LoaderContext: namespace, args and ~params of a file or group."""

    __slots__ = ("args", "declared", "file", "ns", "origins", "pass_all_args", "private", "site")

    def __init__(self, file: Path, ns: str, args: dict[str, str], origins: dict[str, str], site: str | None,
                 private: dict[str, Param], *, declared: list[str] | None = None, pass_all_args: bool = False) -> None:
        self.file = file
        self.ns = ns
        self.args = args
        self.declared = declared if declared is not None else []
        self.origins = origins
        self.site = site  # the <include> that loaded this file; None for the file given
        self.private = private
        self.pass_all_args = pass_all_args

    def child(self, ns: str | None) -> _Scope:
        return _Scope(self.file, child_ns(self.ns, ns), dict(self.args), dict(self.origins), self.site,
                      dict(self.private), declared=list(self.declared), pass_all_args=self.pass_all_args)


def _collect(text: str) -> list[tuple[int, int, str]]:
    """The ``$(...)`` spans of text as roslaunch's ``_collect_args`` finds them: (start, end, inner)."""
    spans: list[tuple[int, int, str]] = []
    state, start, inner_start = _OUT, 0, 0
    for i, c in enumerate(text):
        if c == "$":
            if state in (_OUT, _DOLLAR):
                state, start = _DOLLAR, i
            else:
                raise ValueError("'$' inside a substitution")
        elif c == "(":
            if state == _DOLLAR:
                state = _LP
            elif state != _OUT:
                raise ValueError("'(' inside a substitution")
        elif c == ")":
            if state == _IN:
                spans.append((start, i + 1, text[inner_start:i]))
            state = _OUT
        elif state == _DOLLAR:
            state = _OUT
        elif state == _LP:
            state, inner_start = _IN, i
    return spans


class Ros1Reader(ElementReader):
    """Reads one roslaunch XML file and its includes into a :class:`LaunchModel`."""

    def __init__(self, *, finder: PackageFinder, environ: Mapping[str, str], yaml_loader: YamlLoader | None,
                 deferred: DeferredValues) -> None:
        self.finder = finder
        self.environ = environ
        self.yaml_loader = yaml_loader
        self.deferred = deferred
        self.model = LaunchModel(ros_version=1)
        self.declared: set[str] = set()  # command-line args reach only the file given: see static_arg_names
        self._stack: list[Path] = []
        self._includes = 0

    def read(self, path: Path, root: Element, args: Mapping[str, str]) -> LaunchModel:
        scope = _Scope(path, "/", dict(args), {name: _CMDLINE for name in args}, None, {})
        self.model.files.append(path)
        self._stack.append(path.resolve())
        self._children(root, scope)
        self.model.launch_args = {name: self.deferred.render(scope.args[name])
                                  for name in [*scope.declared, *sorted(self.model.used_args)] if name in scope.args}
        return self.model

    # ---- substitutions -------------------------------------------------------------------------

    def resolve(self, text: str, scope: _Scope, at: str) -> str:
        """An attribute value with its substitution args resolved (roslaunch's ``resolve_args``)."""
        if "$" not in text:
            return text
        if text.startswith("$(eval ") and text.endswith(")"):
            return self._eval(text[7:-1], scope, at)
        first = self._pass(text, scope, at, ("arg", "env", "optenv", "dirname", "anon"))
        return self._pass(first, scope, at, ("find",))

    def _pass(self, text: str, scope: _Scope, at: str, commands: tuple[str, ...]) -> str:
        try:
            spans = _collect(text)
        except ValueError as err:
            raise DescriptionError(f"{at}: {err} in '{self.deferred.render(text)}'") from None
        out: list[str] = []
        pos = 0
        for start, end, inner in spans:
            words = [w for w in inner.split(" ") if w]
            command = words[0] if words else ""
            if command == "eval":
                raise DescriptionError(f"{at}: $(eval ...) must be the whole attribute value")
            if command not in _COMMANDS:
                raise DescriptionError(f"{at}: unknown substitution $({inner}); roslaunch has "
                                       + ", ".join(f"$({c})" for c in _COMMANDS))
            if command in commands:
                out += [text[pos:start], self._substitute(command, words[1:], f"$({inner})", scope, at)]
                pos = end
        out.append(text[pos:])
        return "".join(out)

    def _substitute(self, command: str, args: list[str], source: str, scope: _Scope, at: str) -> str:
        if command == "optenv":
            if not args:
                raise DescriptionError(f"{at}: {source} names no environment variable")
            return self.environ.get(args[0], " ".join(args[1:]))
        if command == "dirname":
            return os_dirname(scope.file)
        if len(args) != 1:
            raise DescriptionError(f"{at}: {source} takes one argument")
        if command == "arg":
            return self.arg(args[0], scope, at)
        if command == "env":
            if args[0] not in self.environ:
                raise DescriptionError(f"{at}: {source}: environment variable '{args[0]}' is not set")
            return self.environ[args[0]]
        if command == "anon":
            return f"{args[0]}_tfrec"
        return self._find(args[0], source)

    def _find(self, pkg: str, source: str) -> str:
        try:
            return str(self.finder.find(pkg))
        except DescriptionError as err:
            return self.deferred.token(Failure(source, f"{source}: {err}"))

    def arg(self, name: str, scope: _Scope, at: str) -> str:
        """``$(arg name)``: its value, or the error roslaunch would give, said plainly."""
        if name in scope.args:
            if scope.origins.get(name) == _CMDLINE:
                self.model.used_args.add(name)
            return scope.args[name]
        if name in scope.declared:
            if scope.site is None:
                raise DescriptionError(f"{at}: arg '{name}' is required: pass {name}:=VALUE")
            raise DescriptionError(f"{at}: arg '{name}' has no value: the <include> at {scope.site} does not pass it")
        raise DescriptionError(f"{at}: $(arg {name}): no <arg name=\"{name}\"> is declared"
                               + suggest(name, scope.declared))

    def _eval(self, expr: str, scope: _Scope, at: str) -> str:
        def env(name: str) -> str:
            return self._substitute("env", [name], f"$(env {name})", scope, at)

        def find(pkg: str) -> str:
            return self.deferred.plain(self._find(pkg, f"$(find {pkg})"), at)

        functions: dict[str, Callable[..., object]] = {
            "arg": lambda name: auto_value(self.arg(name, scope, at)),
            "env": env,
            "optenv": lambda name, default="": self.environ.get(name, default),
            "find": find,
            "dirname": lambda: os_dirname(scope.file),
            "anon": lambda name: f"{name}_tfrec",
        }
        try:
            return str(safe_eval(expr, lambda name: auto_value(self.arg(name, scope, at)), functions))
        except EvalRefused as err:
            source = f"$(eval {expr})"
            return self.deferred.token(Failure(source, f"{source} is not supported ({err}); tfrec evaluates only "
                                               + EVAL_SUBSET))

    # ---- elements ------------------------------------------------------------------------------

    def _resolve(self, text: str, scope: _Scope, at: str) -> str:
        return self.resolve(text, scope, at)

    def _children(self, parent: Element, scope: _Scope) -> None:
        for elem in parent.children:
            handler = {"arg": self._arg_tag, "group": self._group, "node": self._node, "param": self._param,
                       "rosparam": self._rosparam, "include": self._include}.get(elem.tag)
            if handler is not None and self._enabled(elem, scope):
                handler(elem, scope)

    def _arg_tag(self, elem: Element, scope: _Scope) -> None:
        at = self._at(elem, scope)
        name = self._attr(elem, "name", scope)
        value, default = self._opt(elem, "value", scope), self._opt(elem, "default", scope)
        if value is not None and default is not None:
            raise DescriptionError(f"{at}: <arg name=\"{name}\"> has both value= and default=")
        if name in scope.declared and not scope.pass_all_args:
            raise DescriptionError(f"{at}: arg '{name}' is declared twice")
        scope.declared.append(name)
        if value is not None:
            if name in scope.args and not scope.pass_all_args:
                raise DescriptionError(f"{at}: arg '{name}' has a fixed value= and cannot be set by "
                                       f"{scope.origins.get(name, 'an earlier declaration')}")
            scope.args[name], scope.origins[name] = value, at
        elif default is not None and name not in scope.args:
            scope.args[name], scope.origins[name] = default, at

    def _group(self, elem: Element, scope: _Scope) -> None:
        ns = self._opt(elem, "ns", scope)
        if ns is not None and not ns:
            raise DescriptionError(f"{self._at(elem, scope)}: <group> has an empty ns=")
        self._children(elem, scope.child(ns))

    def _node(self, elem: Element, scope: _Scope) -> None:
        at = self._at(elem, scope)
        pkg, exe, name = (self._attr(elem, key, scope) for key in ("pkg", "type", "name"))
        node = Node(pkg, exe, name, child_ns(scope.ns, self._opt(elem, "ns", scope)), at, params=dict(scope.private))
        self.model.nodes.append(node)
        for child in elem.children:
            if child.tag in ("param", "rosparam") and self._enabled(child, scope):
                (self._param if child.tag == "param" else self._rosparam)(child, scope, node)

    def _param(self, elem: Element, scope: _Scope, node: Node | None = None) -> None:
        at = self._at(elem, scope)
        name = self._attr(elem, "name", scope).strip()
        kinds = [k for k in ("value", "textfile", "binfile", "command") if k in elem.attrs]
        if len(kinds) != 1:
            raise DescriptionError(f"{at}: <param name=\"{name}\"> needs exactly one of value=, textfile=, "
                                   "binfile=, command=")
        kind = kinds[0]
        private = node is not None or name.startswith("~")
        key = name.lstrip("~")
        if key.rstrip("/").rsplit("/", 1)[-1] == "robot_description":
            source = self._description(elem, kind, scope, at)
            if node is not None:
                index = len(self.model.nodes) - 1
                self.model.candidates.append(Candidate(source, ns_join(node.private_ns, key), node.ns, at, index))
            else:
                full = ns_join(scope.ns, key)
                self.model.candidates.append(Candidate(source, full, full.rsplit("/", 1)[0] + "/", at))
            return
        if kind != "value":
            param = Param(None, at)  # set by a command or file tfrec does not run or read
        else:
            param = Param(self._typed(self.resolve(elem.attrs["value"], scope, at),
                                      elem.attrs.get("type", "auto").strip().lower()), at)
        if node is not None:
            node.params[key] = param
        elif private:
            scope.private[key] = param
        else:
            self.model.params[ns_join(scope.ns, key)] = param

    def _typed(self, value: str, ptype: str) -> object:
        if "\x00" in value or ptype in ("str", "string"):
            return value
        if ptype == "yaml":
            return YamlText(value)
        converted = auto_value(value.strip())
        if ptype == "int" and isinstance(converted, (int, float)) and not isinstance(converted, bool):
            return int(converted)
        if ptype == "double" and isinstance(converted, (int, float)) and not isinstance(converted, bool):
            return float(converted)
        if ptype in ("bool", "boolean") and value.strip().lower() in ("true", "1", "false", "0"):
            return value.strip().lower() in ("true", "1")
        return converted if ptype == "auto" else value

    def _description(self, elem: Element, kind: str, scope: _Scope, at: str) -> DescriptionSource:
        value = self.resolve(elem.attrs[kind], scope, at)
        if kind == "command":
            return description_from_command(value, at, self.deferred)
        if kind == "textfile":
            return DescriptionSource(DescriptionKind.URDF_FILE, file=Path(self.deferred.plain(value, at).strip()))
        if kind == "value":
            return description_from_text(self.deferred.plain(value, at), at)
        raise DescriptionError(f"{at}: robot_description from binfile= is not a URDF tfrec can read")

    def _rosparam(self, elem: Element, scope: _Scope, node: Node | None = None) -> None:
        at = self._at(elem, scope)
        if (self._opt(elem, "command", scope) or "load") != "load":
            return  # dump and delete set nothing
        ns_attr, param_attr = self._opt(elem, "ns", scope) or "", self._opt(elem, "param", scope) or ""
        param = f"{ns_attr.rstrip('/')}/{param_attr}".strip("/") if ns_attr and param_attr else ns_attr or param_attr
        if node is not None:
            if not (node.is_jsp or node.is_rsp):
                return
        elif param.startswith("~") or param.rstrip("/").rsplit("/", 1)[-1] not in NODE_PARAM_KEYS:
            return  # a global block tfrec has no use for (controller gains, ...): not read
        file = self._opt(elem, "file", scope)
        subst = (self._opt(elem, "subst_value", scope) or "false").lower() == "true"
        if file is not None:
            path = Path(self.deferred.plain(file, at))
            if subst:
                text = decode(read_bounded(path, site=at, what="rosparam file"), path)
                data = load_yaml_text(self.resolve(text, scope, at), display_path(path), at, self.yaml_loader)
            else:
                data = read_param_file(path, at, self.yaml_loader, "rosparam file")
        else:
            text = self.resolve(elem.text, scope, at) if subst else elem.text
            data = load_yaml_text(text, at, at, self.yaml_loader)
        if data is None:
            data = {}
        if not param and not isinstance(data, dict):
            raise DescriptionError(f"{at}: <rosparam> without param= must hold a mapping")
        if node is not None:
            node.params.update(_flat(param.lstrip("~").strip("/"), data, at))
        else:
            self.model.params.update(_flat(ns_join(scope.ns, param).rstrip("/"), data, at))

    def _include(self, elem: Element, scope: _Scope) -> None:
        at = self._at(elem, scope)
        path = Path(self.deferred.plain(self._attr(elem, "file", scope), at))
        pass_all = (self._opt(elem, "pass_all_args", scope) or "false").lower() == "true"
        ns = self._opt(elem, "ns", scope)
        child = _Scope(path, child_ns(scope.ns, ns), dict(scope.args) if pass_all else {},
                       {name: f"pass_all_args of the <include> at {at}" for name in scope.args} if pass_all else {},
                       at, dict(scope.private), pass_all_args=pass_all)
        passed: list[str] = []
        for arg in elem.children:
            if arg.tag != "arg" or not self._enabled(arg, scope):
                continue
            arg_at = self._at(arg, scope)
            name = self._attr(arg, "name", scope)
            value, default = self._opt(arg, "value", scope), self._opt(arg, "default", scope)
            if (value is None) == (default is None):
                raise DescriptionError(f"{arg_at}: <arg name=\"{name}\"> in an <include> needs one of value= "
                                       "and default=")
            if name in passed:
                raise DescriptionError(f"{arg_at}: <include> passes arg '{name}' twice")
            passed.append(name)
            if value is not None or name not in child.args:
                child.args[name] = value if value is not None else str(default)
                child.origins[name] = f"the <include> at {at}"
        self._load(path, child, at)
        if not pass_all:
            for name in passed:
                if name not in child.declared:
                    raise DescriptionError(f"{at}: <include> passes arg '{name}', which {display_path(path)} "
                                           "does not declare" + suggest(name, child.declared))

    def _load(self, path: Path, scope: _Scope, site: str) -> None:
        resolved = path.resolve()
        if resolved in self._stack:
            chain = " -> ".join(display_path(p) for p in [*self._stack[self._stack.index(resolved):], resolved])
            raise DescriptionError(f"{site}: include cycle: {chain}")
        if len(self._stack) > MAX_INCLUDE_DEPTH:
            raise DescriptionError(f"{site}: includes nested more than {MAX_INCLUDE_DEPTH} deep; refused")
        self._includes += 1
        if self._includes > MAX_INCLUDES:
            raise DescriptionError(f"{site}: more than {MAX_INCLUDES} included launch files; refused")
        if path.name.endswith(".py"):
            raise DescriptionError(f"{site}: roslaunch cannot include the Python launch file {display_path(path)}")
        root = parse_xml(read_bounded(path, site=site), path)
        self.model.files.append(path)
        self._stack.append(resolved)
        try:
            self._children(root, scope)
        finally:
            self._stack.pop()


def _flat(prefix: str, data: object, at: str) -> dict[str, Param]:
    out: dict[str, Param] = {}
    flatten(prefix, data, "/", out, at)
    return out
