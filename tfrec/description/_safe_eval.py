"""A safe evaluator for xacro's ``${…}`` and ``$(eval …)`` expressions.

xacro 2.1.1 evaluates expressions with Python's ``eval``. Its ``safe_eval`` refuses names
starting with ``__`` in the top-level code object only, so a lambda, comprehension or
generator expression hides them (``${(lambda: ().__class__)()}`` runs); ``$(eval …)`` runs with
all of Python's builtins (``open``, ``getattr``, ``eval``) and only refuses the text ``__``; and
nothing bounds the work (``${10**10**9}``, ``${'x' * 10**10}``). A description file is input from
others: expanding it must not run code, read files or exhaust the machine.

:func:`evaluate` keeps every legitimate expression working — xacro's symbols (math, ``pi``,
``radians``, ``xacro.*``, ``python.*``), literals, comprehensions, lambdas, string methods,
``%`` formatting, f-strings, YAML data with dotted access — and:

1. *checks* the syntax tree: no name, attribute, parameter or keyword starting with ``_``;
   then compiles it and checks every code object, nested ones (lambdas, comprehensions)
   included, again;
2. *rewrites* the tree so that what can reach Python's internals or grow without bound goes
   through a guard (:class:`~tfrec.description._eval_guard.Guard`) that checks it at run time:

   - attributes that reach frames, code and classes (``gi_frame``, ``f_globals``, ``mro``,
     ``fromkeys``, ``type``, …) only resolve on dictionaries (YAML data, xacro namespaces), and
     never to a forbidden function;
   - calls refuse ``type``, ``vars``, ``getattr``, ``eval``, ``open``, ``__import__``… however they
     were reached, as the function or as an argument (``map(f, …)``);
   - ``str.format``/``format_map`` refuse fields with attribute or item access
     (``'{0.__class__}'.format(x)``, ``'{0[os]}'``) and widths past the size bound;
   - ``+ * ** << %``, ``join``, ``replace``, ``ljust``…, ``range``, ``str``/``repr``, ``sum``,
     ``math.factorial``/``comb``/``perm``/``prod``/``lcm``, f-string fields: sizes are checked
     *before* the work is done;
   - comprehension steps, lambda calls and containers built are charged to a per-expression
     budget of steps;
3. evaluates it with no builtins, as the body of a function whose parameter is the guard (so
   that nothing reachable from an expression can replace it), and checks the result's size.

Bounds: :data:`MAX_SIZE` (text characters or container items, aliases counted in full),
:data:`MAX_INT_BITS`, :data:`MAX_STEPS`. A refusal raises :class:`ExpressionRefused` (one line,
without the file: the caller knows it).
"""

from __future__ import annotations

import ast
import builtins
import functools
from collections.abc import Mapping
from types import CodeType
from typing import Any

from tfrec.description._eval_guard import (
    MAX_INT_BITS,
    MAX_SIZE,
    MAX_STEPS,
    SENSITIVE_ATTRIBUTES,
    SIZED_METHODS,
    ExpressionRefused,
    Guard,
    check_size,
    refused_function,
)

__all__ = [
    "GUARD_NAME",
    "MAX_INT_BITS",
    "MAX_SIZE",
    "MAX_STEPS",
    "SAFE_BUILTINS",
    "ExpressionRefused",
    "check_size",
    "evaluate",
    "refused_function",
]

GUARD_NAME = "__tfrec__"
"""The name of the guard in the rewritten code: a function parameter, which no expression can
name (it starts with ``_``)."""


SAFE_BUILTINS: dict[str, Any] = {
    name: getattr(builtins, name)
    for name in ("abs", "all", "any", "bool", "chr", "complex", "dict", "divmod", "enumerate", "filter", "float",
                 "frozenset", "hash", "int", "isinstance", "issubclass", "len", "list", "map", "max", "min", "ord",
                 "range", "repr", "reversed", "round", "set", "slice", "sorted", "str", "sum", "tuple", "zip",
                 "True", "False", "None")
}
"""The builtins ``$(eval …)`` keeps: those xacro exposes to ``${…}`` (``python.*``) but ``type`` and
``vars``, and ``chr``. Stock xacro runs ``$(eval …)`` with every builtin, ``open`` included."""


_BINARY = {ast.Add: "+", ast.Mult: "*", ast.Pow: "**", ast.LShift: "<<", ast.Mod: "%"}


def evaluate(expr: str, globals: dict[str, Any], locals: Mapping[str, Any] | None = None) -> Any:
    """Evaluate one expression as xacro's ``safe_eval`` does, safely.

    Args:
        expr: the expression text (the inside of ``${…}`` or ``$(eval …)``).
        globals: the symbols (xacro's ``Table``, whose lookups go up its scopes); its
            ``__builtins__`` is set to ``{}``, as xacro sets it.
        locals: an optional mapping searched first (``$(eval …)``'s arguments and functions).

    Returns:
        The value, within the size bounds.

    Raises:
        ExpressionRefused: a refused name, attribute, call or format; too large a value; too
            much work.
        SyntaxError: not a Python expression (as xacro's own ``safe_eval``).
    """
    code = _compile(expr.strip())
    scope = globals if locals is None else _Scope(locals, globals)
    scope.update(__builtins__={})  # no builtins (xacro does the same)
    function = eval(code, scope)  # checked and rewritten: it makes the function below, nothing else
    result = function(Guard())
    check_size(result)
    return result


class _Scope(dict[str, Any]):
    """Names looked up in a mapping first, then in a dictionary (``$(eval …)``: its arguments and
    functions, then the safe builtins). The rewritten expression is a function's body, whose
    names are globals: looked up with ``__getitem__`` since this is not exactly a ``dict``."""

    def __init__(self, first: Mapping[str, Any], then: dict[str, Any]) -> None:
        super().__init__(then)
        self._first = first

    def __getitem__(self, name: str) -> Any:
        try:
            return self._first[name]
        except KeyError:
            return super().__getitem__(name)


@functools.lru_cache(maxsize=4096)
def _compile(expr: str) -> CodeType:
    """Parse, check, rewrite and compile one expression (cached: macros repeat expressions).

    The result evaluates to ``lambda __tfrec__: <rewritten expression>``: the guard is the
    parameter of a function (a cell for nested lambdas and comprehensions), not a global or a
    builtin, so nothing an expression can reach — symbol tables, ``__builtins__`` — replaces it.
    """
    tree = ast.parse(expr, "<expression>", "eval")
    _check_tree(tree)
    body = _Rewrite().visit(tree).body
    arguments = ast.arguments(posonlyargs=[], args=[ast.arg(arg=GUARD_NAME)], kwonlyargs=[], kw_defaults=[],
                              defaults=[])
    function = ast.Expression(body=ast.Lambda(args=arguments, body=body))
    code = compile(ast.fix_missing_locations(function), "<expression>", "eval")
    _check_code(code)
    return code


def _check_tree(tree: ast.AST) -> None:
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            name, what = node.id, "name"
        elif isinstance(node, ast.Attribute):
            name, what = node.attr, "attribute"
        elif isinstance(node, ast.arg):
            name, what = node.arg, "parameter"
        elif isinstance(node, ast.keyword) and node.arg is not None:
            name, what = node.arg, "keyword"
        else:
            continue
        if name.startswith("_"):
            raise ExpressionRefused(f"{what} '{name}' (names starting with '_' are refused)")


def _check_code(code: CodeType) -> None:
    """Every code object, nested ones included: no name starting with ``_`` but the guard's."""
    stack = [code]
    while stack:
        current = stack.pop()
        for name in (*current.co_names, *current.co_varnames, *current.co_freevars, *current.co_cellvars):
            if name.startswith("_") and name != GUARD_NAME:
                raise ExpressionRefused(f"name '{name}' (names starting with '_' are refused)")
        stack.extend(c for c in current.co_consts if isinstance(c, CodeType))


def _guard(method: str, args: list[ast.expr], keywords: list[ast.keyword] | None = None) -> ast.Call:
    func = ast.Attribute(value=ast.Name(id=GUARD_NAME, ctx=ast.Load()), attr=method, ctx=ast.Load())
    return ast.Call(func=func, args=args, keywords=keywords or [])


class _Rewrite(ast.NodeTransformer):
    """Route what can escape or grow through the guard (see the module's docstring)."""

    def visit_BinOp(self, node: ast.BinOp) -> ast.expr:
        self.generic_visit(node)
        symbol = _BINARY.get(type(node.op))
        if symbol is None:
            return node
        return _guard("op", [ast.Constant(symbol), node.left, node.right])

    def visit_Call(self, node: ast.Call) -> ast.expr:
        func = node.func
        if isinstance(func, ast.Attribute) and func.attr in SIZED_METHODS:
            owner = self.visit(func.value)
            self._visit_arguments(node)
            return _guard("method", [owner, ast.Constant(func.attr), *node.args], node.keywords)
        self.generic_visit(node)
        return _guard("call", [node.func, *node.args], node.keywords)

    def _visit_arguments(self, node: ast.Call) -> None:
        node.args = [self.visit(a) for a in node.args]
        node.keywords = [self.visit(k) for k in node.keywords]

    def visit_Attribute(self, node: ast.Attribute) -> ast.expr:
        self.generic_visit(node)
        if isinstance(node.ctx, ast.Load) and (node.attr in SENSITIVE_ATTRIBUTES or node.attr in SIZED_METHODS):
            return _guard("attr", [node.value, ast.Constant(node.attr)])
        return node

    def visit_Lambda(self, node: ast.Lambda) -> ast.expr:
        self.generic_visit(node)
        node.body = _guard("item", [node.body])
        return node

    def visit_comprehension(self, node: ast.comprehension) -> ast.comprehension:
        self.generic_visit(node)
        node.iter = _guard("each", [node.iter])
        return node

    def _element(self, node: ast.ListComp | ast.SetComp | ast.GeneratorExp) -> ast.expr:
        self.generic_visit(node)
        node.elt = _guard("item", [node.elt])
        return node

    visit_ListComp = visit_SetComp = visit_GeneratorExp = _element

    def visit_DictComp(self, node: ast.DictComp) -> ast.expr:
        self.generic_visit(node)
        node.key = _guard("item", [node.key])
        node.value = _guard("item", [node.value])
        return node

    def _display(self, node: ast.List | ast.Tuple | ast.Set) -> ast.expr:
        self.generic_visit(node)
        loaded = isinstance(node, ast.Set) or isinstance(node.ctx, ast.Load)
        if loaded and not all(isinstance(e, ast.Constant) for e in node.elts):
            return _guard("item", [node])
        return node

    visit_List = visit_Tuple = visit_Set = _display

    def visit_Dict(self, node: ast.Dict) -> ast.expr:
        self.generic_visit(node)
        if not all(isinstance(e, ast.Constant) for e in [*node.keys, *node.values]):
            return _guard("item", [node])
        return node

    def visit_FormattedValue(self, node: ast.FormattedValue) -> ast.expr:
        self.generic_visit(node)
        spec: ast.expr = node.format_spec if node.format_spec is not None else ast.Constant("")
        field = _guard("field", [node.value, ast.Constant(node.conversion), spec])
        return ast.FormattedValue(value=field, conversion=-1, format_spec=None)
