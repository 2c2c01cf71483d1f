"""A sandbox around one in-process xacro expansion: no code run, no file read outside, bounded work.

A robot description is input from others, and xacro 2.1.1 trusts it: expressions can run
code (:mod:`tfrec.description._safe_eval` says how), ``<xacro:include>`` and
``xacro.load_yaml`` read any file, and a few lines of macros or properties can expand
exponentially. :func:`xacro_sandbox` patches xacro for the duration of one expansion:

* ``xacro.safe_eval`` (``${…}``, and the ``!degrees``-style YAML units) and
  ``substitution_args._eval`` (``$(eval …)``) become :func:`~tfrec.description._safe_eval.evaluate`;
  ``python.type`` and ``python.vars`` are removed from xacro's symbols;
* ``xacro.parse`` (the input and every include) and ``xacro.load_yaml`` read only what
  :class:`~tfrec.description._confine.ReadRoots` allows, at most ``max_file_bytes`` a file,
  as bytes: XML in UTF-16 or latin-1 with a correct declaration loads (stock xacro reads text
  as UTF-8); YAML goes through :func:`tfrec._yaml.load_yaml` (alias bombs, depth);
* elements nested deeper than ``max_xml_depth`` are refused when parsed ("XML nested too
  deeply"), not left to end in a ``RecursionError``;
* element copies made by macro calls and ``<xacro:insert_block>`` (``max_element_copies``), the
  sibling searches minidom does for each insertion (``max_sibling_work``: xacro is quadratic in
  elements side by side) and the size of all expression results (``max_expression_output``)
  are counted over the expansion: exponential expansion is refused, naming the macro.

A refusal is a :class:`SandboxRefusal`: one line naming the file (and the element) that asked,
never the content of a refused file. xacro wraps errors raised inside it;
:func:`describe_xacro_failure` finds them again, and gives one line for xacro's bare
``RuntimeError`` on a missing attribute.
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from tfrec._yaml import load_yaml
from tfrec.description._confine import ReadRoots, read_capped
from tfrec.description._safe_eval import SAFE_BUILTINS, ExpressionRefused, check_size, evaluate, refused_function
from tfrec.description._xml_bytes import decode_xml, parse_xml
from tfrec.description.packages import PackageFinder
from tfrec.errors import DescriptionError, display_path, one_line

__all__ = [
    "Sandbox",
    "SandboxLimits",
    "SandboxRefusal",
    "decode_xml",
    "describe_xacro_failure",
    "parse_xml",
    "xacro_sandbox",
]


class SandboxRefusal(DescriptionError):
    """What the sandbox refused, as one complete line (file, element, reason)."""


@dataclass(frozen=True, slots=True)
class Sandbox:
    """What :func:`xacro_sandbox` gives the expansion it guards.

    Attributes:
        roots: the places the expansion may read.
        count_macro_call: ``(node, macros, symbols) -> None``, to call from a patch of xacro's
            ``handle_macro_call`` before expanding, when the sandbox was told not to wrap it
            (``wrap_macro_calls=False``): one Python frame less per level of macro recursion.
    """

    roots: ReadRoots
    count_macro_call: Callable[[Any, Any, Any], None]


@dataclass(frozen=True, slots=True)
class SandboxLimits:
    """The bounds of one expansion.

    Attributes:
        max_file_bytes: the largest file an include or ``xacro.load_yaml`` may read. Real
            description files are under 1 MB; generated URDFs a few MB.
        max_xml_depth: the deepest element nesting of a file. URDFs nest under 15 levels; xacro
            expands recursively (about one Python frame a level, more in macros), so 200 keeps
            clear of Python's recursion limit of 1,000.
        max_element_copies: element nodes copied by macro calls and block insertions, over the
            expansion. A UR5 makes 407, a Panda with its hand 807; xacro copies ~30,000 elements
            a second, so a macro bomb (each level calling the next twice) is refused in ~3 s.
        max_sibling_work: steps of minidom's linear search for the place of each insertion
            and removal (the siblings of the element expanded), over the expansion. A UR5 takes
            61,000, a Panda 66,000; xacro is quadratic in elements side by side (2**16 of them
            take 3 minutes), and this refuses a flat macro bomb in ~1 s.
        max_expression_output: characters and items of all expression results together (a
            UR5's come to 11,000). Bounds property doubling and text the size of the machine.
    """

    max_file_bytes: int = 64 * 1024 * 1024
    max_xml_depth: int = 200
    max_element_copies: int = 100_000
    max_sibling_work: int = 10_000_000
    max_expression_output: int = 64_000_000


_MISSING_ATTRIBUTE = re.compile(r"(\S+): missing attribute '([^']*)'")
"""xacro's ``reqd_attrs`` error: ``RuntimeError("xacro:include: missing attribute 'filename'")``."""


@contextlib.contextmanager
def xacro_sandbox(
    input_path: str | os.PathLike[str],
    *,
    finder: PackageFinder,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    allow_paths: Sequence[str | os.PathLike[str]] = (),
    limits: SandboxLimits = SandboxLimits(),
    wrap_macro_calls: bool = True,
) -> Iterator[Sandbox]:
    """Patch xacro for one expansion of ``input_path`` (see the module's docstring).

    Use it around ``init_stacks`` / ``parse`` / ``process_doc`` / ``toprettyxml``, under the
    lock that serializes xacro, and outside other patches of ``handle_macro_call`` (enter it
    first): then the legacy un-prefixed macro calls they rename reach it as ``xacro:`` calls
    and are counted too. Its wrapper costs one Python frame per level of macro recursion (a
    recursive macro 164 levels deep becomes 141); a caller that patches ``handle_macro_call``
    anyway can pass ``wrap_macro_calls=False`` and call :attr:`Sandbox.count_macro_call` from
    its own patch. Everything it patches is restored on exit, also on error.

    Args:
        input_path: the description file given by the user.
        finder: resolves ``$(find pkg)``; the packages it resolves may be read.
        package_paths: ``--package-path`` folders, which may be read.
        allow_paths: more folders or files that may be read.
        limits: the bounds of the expansion.
        wrap_macro_calls: patch ``handle_macro_call`` to count macro expansions; False when the
            caller's own patch calls :attr:`Sandbox.count_macro_call` instead.

    Yields:
        The places the expansion may read, and the macro-call counter.
    """
    import xacro.substitution_args as subst

    import xacro

    roots = ReadRoots(input_path, finder=finder, package_paths=package_paths, allow_paths=allow_paths)
    state = _Expansion(xacro, roots, limits)
    symbols = xacro._global_symbols
    namespaces = {name: dict.__getitem__(symbols, name) for name in ("xacro", "python")}
    saved_modules: list[tuple[Any, str, Any]] = [
        (xacro, "safe_eval", xacro.safe_eval),
        (xacro, "parse", xacro.parse),
        (xacro, "process_include", xacro.process_include),
        *([(xacro, "handle_macro_call", xacro.handle_macro_call)] if wrap_macro_calls else []),
        (xacro, "replace_node", xacro.replace_node),
        (subst, "_eval", subst._eval),
    ]
    # xacro's global symbols outlive an expansion and expressions can reach (and mutate) them:
    # all of them, with their namespaces (python, xacro, math), are restored on exit
    saved_tables = [(table, dict(table), set(getattr(table, "unevaluated", ())), list(getattr(table, "recursive", ())))
                    for table in _symbol_tables(symbols)]
    original = {name: value for _, name, value in saved_modules}

    xacro.safe_eval = state.safe_eval
    subst._eval = state.eval_substitution
    xacro.parse = state.parse_hook(original["parse"])
    xacro.process_include = state.include_hook(original["process_include"])
    if wrap_macro_calls:
        xacro.handle_macro_call = state.macro_hook(original["handle_macro_call"])
    xacro.replace_node = state.replace_hook(original["replace_node"])
    xacro.open = _no_open  # a backstop: xacro's own open() is used by parse and load_yaml only
    dict.__setitem__(symbols, "load_yaml", state.deprecated_load_yaml)
    dict.__setitem__(namespaces["xacro"], "load_yaml", state.load_yaml)
    dict.__setitem__(namespaces["python"], "type", refused_function("python.type"))
    dict.__setitem__(namespaces["python"], "vars", refused_function("python.vars"))
    try:
        yield Sandbox(roots, state.count_macro_call)
    finally:
        for module, name, value in reversed(saved_modules):
            setattr(module, name, value)
        with contextlib.suppress(AttributeError):
            del xacro.open
        for table, content, unevaluated, recursive in saved_tables:
            dict.clear(table)
            dict.update(table, content)
            if hasattr(table, "unevaluated"):  # a xacro Table: its lazily evaluated names
                setattr(table, "unevaluated", unevaluated)  # noqa: B010 - a Table's, not a dict's
                setattr(table, "recursive", recursive)  # noqa: B010


def _symbol_tables(symbols: dict[str, Any]) -> list[dict[str, Any]]:
    """xacro's global symbol table, its namespaces, and the (empty) parents they fall back on."""
    found: dict[int, dict[str, Any]] = {}
    todo = [symbols]
    while todo:
        table = todo.pop()
        if id(table) in found:
            continue
        found[id(table)] = table
        todo += [v for v in dict.values(table) if isinstance(v, dict)]
        todo += [v for v in (getattr(table, "parent", None), getattr(table, "root", None)) if isinstance(v, dict)]
    return list(found.values())


def describe_xacro_failure(
    err: BaseException, *, filename: str | os.PathLike[str] | None, filestack: Sequence[str | None] | None = None,
    where: str | None = None,
) -> str | None:
    """One line for an error of a sandboxed expansion, or None for one this module does not know.

    Finds a :class:`SandboxRefusal` (complete already) or another ``DescriptionError`` (then
    named by the file that asked) however xacro wrapped it, and turns xacro's bare
    ``RuntimeError`` for a missing attribute into ``file: <xacro:include> has no 'filename' attribute``.

    Args:
        err: what the expansion raised.
        filename: the input file.
        filestack: ``xacro.filestack`` when the error was raised: its last file is named.
        where: the place to name instead (``file:line`` of the element at fault).
    """
    where = where or display_path(next((f for f in reversed(filestack or []) if f), filename))
    refusal = _cause(err, SandboxRefusal)
    if refusal is not None:
        return str(refusal)
    refused = _cause(err, ExpressionRefused)
    if refused is not None:
        return f"{where}: expression refused: {refused}"
    other = _cause(err, DescriptionError)  # $(find) of an unknown package, a YAML file that does not load
    if other is not None:
        return f"{where}: {other}"
    if isinstance(err, RuntimeError) and not isinstance(err, RecursionError):
        match = _MISSING_ATTRIBUTE.fullmatch(str(err))
        if match is not None:
            return f"{where}: <{match.group(1)}> has no '{match.group(2)}' attribute"
    return None


def _no_open(file: object, *args: object, **kwargs: object) -> Any:
    raise SandboxRefusal(f"{file}: xacro tried to open a file outside tfrec's sandbox")


def _cause(err: BaseException, kind: type[DescriptionError]) -> DescriptionError | None:
    """``err`` or what it wraps (xacro's ``.exc``, ``__cause__``, ``__context__``) of type ``kind``."""
    seen: set[int] = set()
    todo: list[BaseException | None] = [err]
    while todo:
        current = todo.pop()
        if current is None or id(current) in seen:
            continue
        seen.add(id(current))
        if isinstance(current, kind):
            return current
        wrapped = getattr(current, "exc", None)
        todo += [wrapped if isinstance(wrapped, BaseException) else None, current.__cause__, current.__context__]
    return None


def _short(text: str, limit: int = 80) -> str:
    flat = one_line(text)
    return flat if len(flat) <= limit else flat[: limit - 1] + "…"


class _Expansion:
    """The hooks of one sandboxed expansion and its counters."""

    def __init__(self, xacro: Any, roots: ReadRoots, limits: SandboxLimits) -> None:
        self._xacro = xacro
        self._roots = roots
        self._limits = limits
        self._includes: list[Any] = []  # the <xacro:include> elements being processed
        self._copies = 0
        self._sizes: dict[int, tuple[Any, int]] = {}  # element count of each macro body (kept alive)
        self._work = 0
        self._output = 0

    def _where(self, skip: int = 0) -> str:
        stack = [f for f in (self._xacro.filestack or [])[: len(self._xacro.filestack or []) - skip] if f]
        return display_path(stack[-1]) if stack else "<string>"

    # -- expressions

    def safe_eval(self, expr: str, globals: dict[str, Any], locals: Any = None) -> Any:
        """xacro's ``safe_eval``: ``${…}`` and YAML unit values."""
        try:
            value = evaluate(expr, globals, locals)
        except ExpressionRefused as err:
            raise SandboxRefusal(f"{self._where()}: expression ${{{_short(expr)}}} refused: {err}") from err
        self._count_output(value, f"${{{_short(expr)}}}")
        return value

    def eval_substitution(self, text: str, context: dict[str, Any]) -> str:
        """``substitution_args._eval``: ``$(eval …)``, with xacro's functions and safe builtins only."""
        import xacro.substitution_args as subst

        args = context.setdefault("arg", {})

        def arg(name: str) -> Any:
            return subst.convert_value(subst._eval_arg(name, args=args), "auto")

        def dirname() -> str:
            return str(subst._eval_dirname(context.get("filename")))

        functions = {"arg": arg, "dirname": dirname}
        functions.update((k, v) for k, v in subst._eval_dict.items() if not k.startswith("_"))
        try:
            value = evaluate(text, dict(SAFE_BUILTINS), subst._DictWrapper(args, functions))
        except ExpressionRefused as err:
            raise SandboxRefusal(f"{self._where()}: $(eval {_short(text)}) refused: {err}") from err
        self._count_output(value, f"$(eval {_short(text)})")
        return str(value)

    def _count_output(self, value: object, what: str) -> None:
        self._output += check_size(value)
        if self._output > self._limits.max_expression_output:
            raise SandboxRefusal(f"{self._where()}: {what}: expressions made more than "
                                 f"{self._limits.max_expression_output:,} characters in this expansion")

    # -- files

    def parse_hook(self, parse: Any) -> Any:
        def confined_parse(inp: Any, filename: str | None = None) -> Any:
            if inp is not None:
                return parse(inp, filename)
            xacro = self._xacro
            path = os.path.join(xacro.root_dir, str(filename))
            if not self._roots.allows(path):
                element = self._includes[-1] if self._includes else None
                asked = (f'<xacro:include filename="{element.getAttribute("filename")}">' if element is not None
                         else "reading")
                raise SandboxRefusal(f"{self._where(skip=1)}: {asked} refused: {self._roots.refusal(path)}")
            try:
                data = read_capped(os.path.realpath(path), self._limits.max_file_bytes)
            except OSError as err:  # as xacro's parse: the file is not "in" the stack, and optional includes skip it
                err.filename = path
                xacro.filestack.pop()
                raise xacro.XacroException(f"{err.strerror}: {path}", exc=err) from err
            except DescriptionError as err:
                raise SandboxRefusal(f"{self._where(skip=1)}: {err}") from err
            doc = parse_xml(data, source=path)  # each element knows its file and line
            _check_depth(doc, self._limits.max_xml_depth, path)
            return doc

        return confined_parse

    def include_hook(self, process_include: Any) -> Any:
        def include(elt: Any, macros: Any, symbols: Any, func: Any) -> Any:
            self._includes.append(elt)
            try:
                return process_include(elt, macros, symbols, func)
            finally:
                self._includes.pop()

        return include

    def load_yaml(self, filename: str) -> Any:
        """``xacro.load_yaml``: confined, bounded, with xacro's units (``!degrees 90``)."""
        xacro = self._xacro
        path = xacro.abs_filename_spec(filename)
        if not self._roots.allows(path):
            raise SandboxRefusal(f"{self._where()}: xacro.load_yaml('{filename}') refused: {self._roots.refusal(path)}")
        try:
            data = read_capped(os.path.realpath(path), self._limits.max_file_bytes)
        except OSError as err:  # as xacro's load_yaml: named as asked
            err.filename = path
            raise
        except DescriptionError as err:
            raise SandboxRefusal(f"{self._where()}: xacro.load_yaml('{filename}'): {err}") from err
        xacro.filestack.append(path)
        try:
            document = load_yaml(data, where=display_path(path), error=DescriptionError, constructors=self._units())
            return xacro.YamlListWrapper.wrap(document)
        finally:
            xacro.filestack.pop()
            xacro.all_includes.append(path)

    def deprecated_load_yaml(self, filename: str) -> Any:
        """The global ``load_yaml()`` xacro still exposes, with its deprecation message."""
        self._xacro.warning("Using load_yaml() directly is deprecated. Use xacro.load_yaml() instead.")
        return self.load_yaml(filename)

    def _units(self) -> dict[str, Any]:
        xacro = self._xacro

        def unit(factor: float) -> Any:
            def construct(text: str) -> float:
                try:
                    return float(self.safe_eval(text, xacro._global_symbols)) * factor
                except SyntaxError:
                    raise xacro.XacroException(f"invalid expression: {text}") from None

            return construct

        return {u.value.tag: unit(u.value.conversion_constant) for u in xacro.ConstructUnits}

    # -- expansion size

    def count_macro_call(self, node: Any, macros: Any, symbols: Any) -> None:
        """Count the element copies a macro call is about to make (before xacro's
        ``handle_macro_call`` expands it)."""
        tag = node.tagName
        if tag.startswith("xacro:") and tag != "xacro:call":  # xacro:call comes back renamed
            name = tag.removeprefix("xacro:")
            try:
                macro = self._xacro.resolve_macro(name, macros, symbols)[2]
            except (KeyError, TypeError, AttributeError):
                macro = None  # xacro reports it
            if macro is not None and macro.body is not None:
                self._count_copies(macro.body, f"macro '{name}'")

    def macro_hook(self, handle_macro_call: Any) -> Any:
        def counted_macro_call(node: Any, macros: Any, symbols: Any) -> Any:
            self.count_macro_call(node, macros, symbols)
            return handle_macro_call(node, macros, symbols)

        return counted_macro_call

    def replace_hook(self, replace_node: Any) -> Any:
        def counted_replace(node: Any, by: Any, content_only: bool = False) -> Any:
            blocks = [] if by is None else by if isinstance(by, list) else [by]
            if getattr(node, "tagName", None) == "xacro:insert_block":
                what = f"<xacro:insert_block name=\"{node.getAttribute('name')}\">"
                for block in blocks:
                    self._count_copies(block, what, cache=False)  # a fresh copy each time
            else:
                what = f"<{getattr(node, 'tagName', '?')}>"
            # minidom finds the place of each insertion and removal by a linear search of the siblings
            inserted = sum(len(b.childNodes) for b in blocks) if content_only else len(blocks)
            self._count_work((inserted + 1) * len(node.parentNode.childNodes), what)
            return replace_node(node, by, content_only)

        return counted_replace

    def _count_work(self, steps: int, what: str) -> None:
        self._work += steps
        if self._work > self._limits.max_sibling_work:
            raise SandboxRefusal(f"{self._where()}: {what} expands past {self._limits.max_sibling_work:,} steps of "
                                 "sibling insertion in this expansion (too many elements side by side)")

    def _count_copies(self, root: Any, what: str, *, cache: bool = True) -> None:
        if cache:
            known = self._sizes.get(id(root))
            if known is None or known[0] is not root:
                known = (root, _elements(root))
                self._sizes[id(root)] = known
            self._copies += known[1]
        else:
            self._copies += _elements(root)
        if self._copies > self._limits.max_element_copies:
            raise SandboxRefusal(f"{self._where()}: {what} expands past {self._limits.max_element_copies:,} element "
                                 "copies in this expansion (exponential macro expansion?)")


def _elements(root: Any) -> int:
    count = 0
    stack = [root]
    while stack:
        node = stack.pop()
        if node.nodeType == node.ELEMENT_NODE:
            count += 1
            stack.extend(node.childNodes)
    return count


def _check_depth(doc: Any, max_depth: int, path: str) -> None:
    stack = [(doc.documentElement, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > max_depth:
            raise SandboxRefusal(f"{display_path(path)}: XML nested too deeply (more than {max_depth} levels)")
        stack.extend((child, depth + 1) for child in node.childNodes if child.nodeType == child.ELEMENT_NODE)
