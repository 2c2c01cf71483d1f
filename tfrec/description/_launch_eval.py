"""``$(eval ...)`` without Python: the small, side-effect-free subset launch files use, walked on
the expression's syntax tree; everything else is refused."""

from __future__ import annotations

import ast
import operator
from collections.abc import Callable, Mapping
from typing import Any

MAX_EVAL_CHARS = 1000
"""``$(eval ...)`` expressions longer than this are refused."""


class EvalRefused(Exception):
    """An ``$(eval ...)`` expression outside the supported subset."""


_COMPARE: dict[type[ast.cmpop], Callable[[Any, Any], Any]] = {
    ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le,
    ast.Gt: operator.gt, ast.GtE: operator.ge,
    ast.In: lambda a, b: operator.contains(b, a), ast.NotIn: lambda a, b: not operator.contains(b, a),
}
_ARITH: dict[type[ast.operator], Callable[[Any, Any], Any]] = {
    ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
}
EVAL_SUBSET = ("names, literals, ==, !=, <, >, in, and/or/not, +, -, *, /, "
               "'a if c else b' and calls of arg/env/optenv/find/dirname")


def safe_eval(  # noqa: C901 - one evaluator of the expressions launch files use
        expr: str, names: Callable[[str], object], functions: Mapping[str, Callable[..., object]]) -> object:
    """Evaluate the small, side-effect-free subset of Python that launch files use in ``$(eval)``.

    Raises:
        EvalRefused: anything else (attributes, subscripts, lambdas, other calls, ``__``).
    """
    if len(expr) > MAX_EVAL_CHARS:
        raise EvalRefused(f"longer than {MAX_EVAL_CHARS} characters")
    if "__" in expr:
        raise EvalRefused("double underscores are not allowed")
    try:
        tree = ast.parse(expr.strip(), mode="eval")
    except SyntaxError as err:
        raise EvalRefused(f"not an expression: {err.msg}") from None
    except (RecursionError, MemoryError):
        raise EvalRefused("nested too deeply") from None

    def ev(node: ast.AST) -> object:  # noqa: C901, PLR0912 - a branch per kind of node it evaluates
        if isinstance(node, ast.Constant) and (node.value is None or isinstance(node.value, (str, int, float))):
            return node.value
        if isinstance(node, ast.Name):
            return names(node.id)
        if isinstance(node, ast.BoolOp):
            result = ev(node.values[0])
            for value in node.values[1:]:
                if bool(result) == isinstance(node.op, ast.Or):
                    break
                result = ev(value)
            return result
        if isinstance(node, ast.UnaryOp):
            operand = ev(node.operand)
            if isinstance(node.op, ast.Not):
                return not operand
            if isinstance(operand, (int, float)) and isinstance(node.op, (ast.USub, ast.UAdd)):
                return -operand if isinstance(node.op, ast.USub) else +operand
        if isinstance(node, ast.Compare):
            left = ev(node.left)
            for op, right_node in zip(node.ops, node.comparators):
                right = ev(right_node)
                if type(op) not in _COMPARE:
                    break
                if isinstance(op, (ast.In, ast.NotIn)) and not isinstance(right, str):
                    raise EvalRefused("'in' needs a string on its right")
                if not _COMPARE[type(op)](left, right):
                    return False
                left = right
            else:
                return True
        if isinstance(node, ast.BinOp):
            left, right = ev(node.left), ev(node.right)
            if isinstance(node.op, ast.Add) and (isinstance(left, str) and isinstance(right, str)
                                                 or _number(left) and _number(right)):
                return operator.add(left, right)
            if type(node.op) in _ARITH and _number(left) and _number(right):
                if isinstance(node.op, ast.Div) and right == 0:
                    raise EvalRefused("division by zero")
                return _ARITH[type(node.op)](left, right)
            raise EvalRefused(f"unsupported operation {type(node.op).__name__} on {type(left).__name__} "
                              f"and {type(right).__name__}")
        if isinstance(node, ast.IfExp):
            return ev(node.body) if ev(node.test) else ev(node.orelse)
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in functions
                and not node.keywords and not any(isinstance(a, ast.Starred) for a in node.args)):
            values = [ev(a) for a in node.args]
            if not all(isinstance(v, str) for v in values):
                raise EvalRefused(f"{node.func.id}() takes strings")
            return functions[node.func.id](*values)
        raise EvalRefused(f"unsupported {type(node).__name__}: {ast.unparse(node)[:60]}")

    try:
        return ev(tree.body)
    except TypeError as err:
        raise EvalRefused(str(err)) from None
    except RecursionError:
        raise EvalRefused("nested too deeply") from None


def _number(value: object) -> bool:
    return isinstance(value, (int, float))
