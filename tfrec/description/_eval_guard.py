"""The run-time half of the xacro expression sandbox: the guard the rewritten code calls, and the bounds.

:mod:`tfrec.description._safe_eval` rewrites an expression so that every operation that can
reach Python's internals or make a large value calls a method of :class:`Guard` instead; the
guard checks sizes *before* the work is done, refuses forbidden functions by identity however
they were reached, and charges loops, lambda calls and containers built to a budget of steps.
"""

from __future__ import annotations

import builtins
import math
import re
import string
import types
import xml.dom
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any

from tfrec.errors import DescriptionError

__all__ = [
    "MAX_INT_BITS",
    "MAX_SIZE",
    "MAX_STEPS",
    "SENSITIVE_ATTRIBUTES",
    "SIZED_METHODS",
    "ExpressionRefused",
    "Guard",
    "check_size",
    "refused_function",
]

MAX_SIZE = 1_000_000
"""The largest value an expression may make: characters of text, or items of containers counted
recursively (a list holding the same 1,000-item list 1,000 times counts 1,000,000). Real
descriptions make values of a few hundred."""
MAX_INT_BITS = 4096
"""The largest integer an expression may make (a 1,234-digit number). Robot descriptions need 64."""
MAX_STEPS = 1_000_000
"""Work one evaluation may do: comprehension steps, lambda calls, ``range`` lengths and the
sizes of containers built. Reached in about a second; real expressions take a few dozen."""


class ExpressionRefused(DescriptionError):
    """An expression the sandbox does not evaluate; the message says why, without the file."""


_FORBIDDEN_NAMES = (
    "type", "vars", "getattr", "setattr", "delattr", "globals", "locals", "eval", "exec", "compile",
    "open", "__import__", "dir", "breakpoint", "input", "help", "memoryview", "super", "print",
    "exit", "quit", "classmethod", "staticmethod", "property", "object", "format",
)
_FORBIDDEN = {id(f): name for name in _FORBIDDEN_NAMES if (f := getattr(builtins, name, None)) is not None}
"""Functions no expression may call, by identity (however they were reached)."""

SENSITIVE_ATTRIBUTES = frozenset({
    # frames, code, generators, coroutines, tracebacks: the way out of eval's globals
    "gi_frame", "gi_code", "gi_yieldfrom", "gi_running", "gi_suspended",
    "cr_frame", "cr_code", "cr_await", "cr_origin", "cr_running", "cr_suspended",
    "ag_frame", "ag_code", "ag_await", "ag_running",
    "f_back", "f_globals", "f_locals", "f_builtins", "f_code", "f_trace", "f_lasti", "f_lineno",
    "tb_frame", "tb_next", "tb_lasti", "tb_lineno", "with_traceback",
    "co_code", "co_consts", "co_names", "co_varnames", "co_filename", "func_globals", "func_code",
    # classes and their dictionaries
    "mro", "fromkeys",
    # the forbidden functions, were they attributes of something
    *(n for n in _FORBIDDEN_NAMES if not n.startswith("_")),
})
"""Attributes allowed only on dictionaries (xacro namespaces, YAML data with dotted access:
``config.type`` is a key), and then never when they name a forbidden function."""

SIZED_METHODS = frozenset({"join", "replace", "ljust", "rjust", "center", "zfill", "expandtabs", "translate",
                            "format", "format_map", "extend", "to_bytes"})
"""Methods whose result can be much larger than their input: checked before the call."""
_UNBOUND_OWNERS = (str, bytes, bytearray, list, int)
"""Types whose methods can be called unbound (``str.join(sep, items)``): the instance comes first."""
_SIZED = (str, bytes, bytearray, list, tuple, set, frozenset, dict, range)
_LOOPING = {id(f): (f, which) for f, which in [
    (map, "after-function"), (filter, "after-function"), (min, "single"), (max, "single"), (dict, "pairs"),
    (list, "all"), (tuple, "all"), (set, "all"), (frozenset, "all"), (sorted, "all"), (any, "all"),
    (all, "all"), (zip, "all"), (enumerate, "all"),
]}
"""Builtins that loop over their iterables in C: their iterables are charged a step per item, so
that a loop over a list that grows as it goes (``map(l.append, l)``) ends."""

_TEXT = (str, bytes, bytearray)
_SCALARS = frozenset({int, float, bool, complex, type(None)})
_SEQUENCE = (str, bytes, bytearray, list, tuple)
_PERCENT_SPEC = re.compile(r"%(?:\([^)]*\))?[#0\- +]*(\*|\d+)?(?:\.(\*|\d+))?[hlL]?[a-zA-Z%]")
_DIGITS = re.compile(r"\d+")
_FIELD_NAME = re.compile(r"\d*|[A-Za-z]\w*")


def refused_function(name: str) -> Callable[..., Any]:
    """A stand-in for a function the sandbox removes from xacro's symbols (``python.type``)."""

    def refused(*args: object, **kwargs: object) -> Any:
        raise ExpressionRefused(f"{name}() is not available in tfrec's xacro sandbox")

    refused.__name__ = refused.__qualname__ = name.rsplit(".", 1)[-1]
    return refused


def check_size(value: object, limit: int = MAX_SIZE) -> int:
    """The size of a value: characters of text (at least 1), 1 for each container and each item
    in it counted recursively (shared items each time they appear, as ``str()`` would print
    them), 1 for anything else.

    Raises:
        ExpressionRefused: larger than ``limit``, or an integer of more than :data:`MAX_INT_BITS` bits.
    """
    if isinstance(value, (float, bool, complex)) or value is None:
        return 1
    total = 0
    stack: list[object] = [value]
    while stack:
        item = stack.pop()
        total += 1
        if isinstance(item, _TEXT):
            total += max(len(item) - 1, 0)  # text counts its characters
        elif isinstance(item, int):
            if item.bit_length() > MAX_INT_BITS:
                raise ExpressionRefused(f"an integer of {item.bit_length():,} bits (more than {MAX_INT_BITS:,})")
        elif isinstance(item, dict):
            if total + len(stack) + 2 * len(item) > limit:
                break
            stack.extend(dict.keys(item))
            stack.extend(dict.values(item))
        elif isinstance(item, (list, tuple, set, frozenset)):
            if total + len(stack) + len(item) > limit:
                break
            stack.extend(list.__iter__(item) if isinstance(item, list) else item)
        if total > limit:
            break
    else:
        return total
    raise ExpressionRefused(f"a value of more than {limit:,} characters or items")


class Guard:
    """The run-time checks of one evaluation, and its budget of steps.

    Its public methods are what the rewritten code calls; only the rewritten code holds it.
    """

    __slots__ = ("_steps",)

    def __init__(self) -> None:
        self._steps = 0

    def _charge(self, steps: int) -> None:
        self._steps += steps
        if self._steps > MAX_STEPS:
            raise ExpressionRefused(f"too much work (more than {MAX_STEPS:,} steps)")

    # -- operators

    def op(self, symbol: str, a: Any, b: Any) -> Any:
        """``a <symbol> b`` for ``+ * ** << %``, refused before it would be too large."""
        if symbol == "+":
            if isinstance(a, _SEQUENCE) and isinstance(b, _SEQUENCE):
                _bounded(len(a) + len(b), "'+'")
                self._charge(len(a) + len(b))
            return a + b
        if symbol == "*":
            return self._multiply(a, b)
        if symbol == "**":
            if _is_int(a) and _is_int(b) and b > 0 and abs(a) > 1 and (abs(a).bit_length() - 1) * b > MAX_INT_BITS:
                raise ExpressionRefused(f"'**' would make an integer of more than {MAX_INT_BITS:,} bits")
            return _int_bounded(a**b, "'**'")
        if symbol == "<<":
            if _is_int(a) and _is_int(b) and a != 0 and b > 0 and a.bit_length() + b > MAX_INT_BITS:
                raise ExpressionRefused(f"'<<' would make an integer of more than {MAX_INT_BITS:,} bits")
            return a << b
        if isinstance(a, _TEXT):  # '%' formatting
            _check_percent(a if isinstance(a, str) else a.decode("latin-1"))
            check_size(b)
        return a % b

    def _multiply(self, a: Any, b: Any) -> Any:
        if _is_int(a) and _is_int(b):
            if a.bit_length() + b.bit_length() > MAX_INT_BITS + 1:
                raise ExpressionRefused(f"'*' would make an integer of more than {MAX_INT_BITS:,} bits")
            return a * b
        sequence, count = (a, b) if _is_int(b) else (b, a)
        if isinstance(sequence, _SEQUENCE) and _is_int(count) and count > 1:
            size = len(sequence) if isinstance(sequence, _TEXT) else check_size(sequence)
            _bounded(size * count, "'*'")
            self._charge(len(sequence) * count)
        return a * b

    # -- calls and attributes

    def call(self, func: Any, /, *args: Any, **kwargs: Any) -> Any:
        """``func(*args, **kwargs)``, unless ``func`` or an argument is a forbidden function; the
        calls that can make large values are checked first, and the iterables given to the
        builtins that loop in C (``map``, ``list``, ``min``…) are charged a step per item."""
        _allowed(func)
        for value in (*args, *kwargs.values()):
            _allowed(value)
        looping = _LOOPING.get(id(func))
        if looping is not None and looping[0] is func:
            args = self._charged_iterables(looping[1], args)
        if func is str or func is repr or func is ascii:
            if args:
                check_size(args[0])
        elif func is sum:
            return self._sum(*args, **kwargs)
        elif func is math.factorial and args and _is_int(args[0]) and args[0] > 1000:
            raise ExpressionRefused("math.factorial() of more than 1000")
        elif (func is math.comb or func is math.perm) and args and _is_int(args[0]) and args[0] > 10_000:
            raise ExpressionRefused(f"math.{func.__name__}() of more than 10,000")
        elif func is math.prod:
            return self._fold(lambda x, y: self.op("*", x, y), args[0] if args else (), kwargs.get("start", 1))
        elif func is math.lcm:
            return self._fold(lambda x, y: _int_bounded(math.lcm(x, y), "math.lcm()"), args, 1)
        elif func is round and len(args) > 1 and _is_int(args[1]) and args[1] < -10_000:
            raise ExpressionRefused("round() to more than 10,000 digits")  # an int rounds by 10 ** -ndigits
        result = func(*args, **kwargs)
        what = f"{getattr(func, '__name__', 'a call')}()"
        if type(result) is range:  # xacro's deprecated global range() wraps the builtin
            self._charge(_length(result))
        elif isinstance(result, _SIZED) and len(result) > MAX_SIZE:  # x.encode('utf-32').hex()…: each step bounded
            raise ExpressionRefused(f"{what} made {len(result):,} characters or items (more than {MAX_SIZE:,})")
        return _int_bounded(result, what)

    def _charged_iterables(self, which: str, args: tuple[Any, ...]) -> tuple[Any, ...]:
        if which == "after-function":  # map(f, *iterables), filter(f, iterable)
            return (*args[:1], *(self.each(a) for a in args[1:]))
        if which == "single":  # min(iterable) and max(iterable), not min(a, b)
            return (self.each(args[0]),) if len(args) == 1 else args
        if which == "pairs":  # dict(iterable of pairs), not dict(mapping)
            return (self.each(args[0]),) if len(args) == 1 and not isinstance(args[0], Mapping) else args
        return tuple(self.each(a) for a in args)

    def _sum(self, iterable: Iterable[Any], /, start: Any = 0) -> Any:
        if isinstance(start, (int, float, complex)):
            return _int_bounded(sum(self.each(iterable), start), "sum()")
        return self._fold(lambda x, y: self.op("+", x, y), iterable, start)

    def _fold(self, step: Callable[[Any, Any], Any], items: Iterable[Any], start: Any) -> Any:
        total = start
        for item in self.each(items):
            total = step(total, item)
        return total

    def attr(self, owner: Any, name: str) -> Any:
        """``owner.name`` for a sensitive name, or a method that can make large values but is not
        called right away: only a key of a dictionary with dotted access (``config.type`` of
        YAML data, ``python.sorted``), and never a forbidden function."""
        if isinstance(owner, dict) and not hasattr(type(owner), name):
            value = getattr(owner, name)
            _allowed(value)
            return value
        if name in SIZED_METHODS:
            raise ExpressionRefused(f"'.{name}' is only allowed in a call (x.{name}(...))")
        raise ExpressionRefused(f"attribute '.{name}' is refused (it reaches Python's internals)")

    def method(self, owner: Any, name: str, /, *args: Any, **kwargs: Any) -> Any:
        """``owner.name(*args, **kwargs)`` for the methods that can make values much larger than
        their input (``join``, ``replace``, ``ljust``, ``format``, ``extend``, ``to_bytes``…)."""
        if owner in _UNBOUND_OWNERS and args and isinstance(args[0], owner):  # str.join(sep, items)
            owner, args = args[0], args[1:]
        if isinstance(owner, dict):
            return self.call(self.attr(owner, name), *args, **kwargs)
        for value in (*args, *kwargs.values()):
            _allowed(value)
        if isinstance(owner, _TEXT):
            if name in ("format", "format_map"):
                if not isinstance(owner, str):
                    raise ExpressionRefused(f"'.{name}' of bytes")
                _check_format(owner)
                for value in (*args, *kwargs.values()):
                    check_size(value)
                return getattr(owner, name)(*args, **kwargs)
            if name == "join" and len(args) == 1 and not kwargs:
                items = list(self.each(args[0]))
                size = sum(len(i) for i in items if isinstance(i, _TEXT)) + len(owner) * max(0, len(items) - 1)
                _bounded(size, "'.join'")
                return owner.join(items)
            self._check_text_method(owner, name, args, kwargs)
        elif name == "extend" and isinstance(owner, (list, bytearray)) and len(args) == 1 and not kwargs:
            more: Any = args[0] if isinstance(args[0], _SIZED) else list(self.each(args[0]))
            _bounded(len(owner) + len(more), "'.extend'")
            self._charge(len(more))
            return owner.extend(more)
        elif name == "to_bytes" and _is_int(owner):
            length = args[0] if args else kwargs.get("length", 1)
            if _is_int(length):
                _bounded(length, "'.to_bytes'")
        return self.call(getattr(owner, name), *args, **kwargs)

    def _check_text_method(self, owner: Any, name: str, args: tuple[Any, ...],
                           kwargs: dict[str, Any]) -> None:
        if name == "replace" and len(args) >= 2 and isinstance(args[0], _TEXT) and isinstance(args[1], _TEXT):
            old, new = args[0], args[1]
            count: int = owner.count(old) if old else len(owner) + 1
            if len(args) > 2 and _is_int(args[2]) and args[2] >= 0:
                count = min(count, args[2])
            _bounded(len(owner) + count * max(0, len(new) - len(old)), "'.replace'")
        elif name in ("ljust", "rjust", "center", "zfill") and args and _is_int(args[0]):
            _bounded(args[0], f"'.{name}'")
        elif name == "expandtabs":
            tabsize = args[0] if args else kwargs.get("tabsize", 8)
            if _is_int(tabsize):
                tabs = owner.count("\t") if isinstance(owner, str) else owner.count(b"\t")
                _bounded(len(owner) + tabs * tabsize, "'.expandtabs'")
        elif name == "translate" and args and isinstance(args[0], dict):
            longest = max((len(v) for v in args[0].values() if isinstance(v, _TEXT)), default=1)
            _bounded(len(owner) * max(1, longest), "'.translate'")

    # -- comprehensions, lambdas, displays, f-strings

    def each(self, iterable: Iterable[Any]) -> Iterator[Any]:
        """The items of a comprehension's ``for``, one step each."""
        for item in iterable:
            self._steps += 1
            if self._steps > MAX_STEPS:
                self._charge(0)
            yield item

    def item(self, value: Any) -> Any:
        """A comprehension's element, a lambda's result or a container built: charged its size."""
        if type(value) in _SCALARS:
            self._steps += 1
            if self._steps > MAX_STEPS:
                self._charge(0)
        else:
            self._charge(check_size(value))
        return value

    def field(self, value: Any, conversion: int, spec: str) -> str:
        """One f-string field, ``{value!conversion:spec}``, with its size and widths checked."""
        check_size(value)
        _check_widths(spec, "an f-string field")
        if conversion == ord("s"):
            value = str(value)
        elif conversion == ord("r"):
            value = repr(value)
        elif conversion == ord("a"):
            value = ascii(value)
        return format(value, spec)


def _length(numbers: range) -> int:
    try:
        return len(numbers)
    except OverflowError:
        raise ExpressionRefused("range() of more than 2**63 numbers") from None


def _is_int(value: object) -> bool:
    return isinstance(value, int)


def _allowed(value: object) -> None:
    name = _FORBIDDEN.get(id(value))
    if name is not None and value is getattr(builtins, name, None):
        raise ExpressionRefused(f"{name}() is refused in xacro expressions")
    if isinstance(value, types.MethodType) and isinstance(value.__self__, xml.dom.Node):
        # a macro's block parameter is a DOM element: copying or rewiring the document is xacro's job
        raise ExpressionRefused(f"the XML element method .{value.__func__.__name__}() is refused in xacro expressions")


def _bounded(size: int, what: str) -> None:
    if size > MAX_SIZE:
        raise ExpressionRefused(f"{what} would make {size:,} characters or items (more than {MAX_SIZE:,})")


def _int_bounded(value: Any, what: str) -> Any:
    if isinstance(value, int) and value.bit_length() > MAX_INT_BITS:
        raise ExpressionRefused(f"{what} made an integer of {value.bit_length():,} bits (more than {MAX_INT_BITS:,})")
    return value


def _check_widths(spec: str, what: str) -> None:
    if sum(int(d) for d in _DIGITS.findall(spec)) > MAX_SIZE:
        raise ExpressionRefused(f"{what} with a width past {MAX_SIZE:,}")


def _check_percent(template: str) -> None:
    total = 0
    for match in _PERCENT_SPEC.finditer(template):
        width, precision = match.group(1), match.group(2)
        if "*" in (width, precision):
            raise ExpressionRefused("'%' formatting with '*' widths")
        total += int(width or 0) + int(precision or 0)
    if total > MAX_SIZE:
        raise ExpressionRefused(f"'%' formatting with widths past {MAX_SIZE:,}")


def _check_format(template: str) -> None:
    """A ``str.format`` template: plain fields only (``{}``, ``{0}``, ``{name}``), bounded widths."""
    for _, field, spec, _ in string.Formatter().parse(template):
        if field is None:
            continue
        if not _FIELD_NAME.fullmatch(field):
            raise ExpressionRefused(f"format field '{{{field}}}' (attribute and item access in format strings "
                                    "are refused)")
        if spec and "{" in spec:
            raise ExpressionRefused("format fields nested in a format spec")
        _check_widths(spec or "", "a format field")
