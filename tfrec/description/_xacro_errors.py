"""One line for an error of a xacro expansion.

The line starts with the file and line of the element at fault (:meth:`DialectHooks.location
<tfrec.description._xacro_dialect.DialectHooks.location>`: an element copied out of a macro body or
an included file says where it was written), says in tfrec's words what xacro's errors about macro
calls mean, and names the closest defined property or macro for a typo (``lnk1`` → ``link1``?).
"""

from __future__ import annotations

import os
import re
import xml.parsers.expat
from typing import Any

from tfrec.description._sandbox import describe_xacro_failure
from tfrec.description._xacro_dialect import DialectHooks, Mode
from tfrec.description._xml_bytes import Origin, origin
from tfrec.errors import DescriptionError, display_path, one_line, suggest

__all__ = ["describe_error", "located"]

_UNDEFINED_NAME = re.compile(r"name '([^']+)' is not defined")
_INVALID_PARAMETER = re.compile(r'Invalid parameter "([^"]*)"')
_UNDEFINED_PARAMETERS = re.compile(r"Undefined parameters \[([^\]]*)\]")
_UNKNOWN_MACRO = re.compile(r"unknown macro name: (?:xacro:)?(\S+)")


def located(where: Origin | None) -> str | None:
    """``file:line`` of an origin, the file as messages show it."""
    return f"{display_path(where[0])}:{where[1]}" if where is not None else None


def describe_error(err: BaseException, *, xacro: Any, hooks: DialectHooks, filename: str | os.PathLike[str]) -> str:
    """The one line for what an expansion raised.

    Raises:
        RuntimeError: ``err`` itself, a bare RuntimeError xacro does not raise on bad input (a bug).
    """
    here = located(hooks.location()) or _where(xacro, filename)
    if isinstance(err, RecursionError):
        return f"{here}: xacro recursion too deep: a file includes itself or a macro calls itself without end"
    if isinstance(err, xml.parsers.expat.ExpatError):
        return (f"{_where(xacro, filename)}:{err.lineno}:{err.offset}: malformed XML: "
                f"{xml.parsers.expat.ErrorString(err.code)}")
    known = describe_xacro_failure(err, filename=filename, filestack=xacro.filestack, where=here)
    if known is not None:  # a refusal of the sandbox, $(find) of an unknown package, a missing attribute
        return known
    if isinstance(err, xacro.XacroException):
        return f"{here}: {_explain(err, hooks) or _xacro_message(err) + _name_hint(err.exc, hooks)}"
    if isinstance(err, OSError):
        return f"{here}: {err.strerror or err}: {err.filename}"
    if isinstance(err, DescriptionError):
        return f"{here}: {err}"
    if isinstance(err, RuntimeError) and not isinstance(err, (RecursionError, NameError)):
        raise err
    # xacro lets some evaluation errors through unwrapped
    return f"{here}: xacro: {one_line(str(err))}{_name_hint(err, hooks)}"


def _explain(err: Any, hooks: DialectHooks) -> str | None:
    """tfrec's words for xacro's errors about a macro call (the element at fault is the call)."""
    message = one_line(str(err.args[0])) if err.args and err.args[0] else ""
    macro = err.macros[0] if getattr(err, "macros", None) else None
    name = _macro_name(macro)
    missing = _UNDEFINED_PARAMETERS.fullmatch(message)
    if missing and macro is not None and name is not None:
        params = [p.strip() for p in missing.group(1).split(",") if p.strip()]
        return (f"the call of macro '{name}' lacks parameter{'s' if len(params) > 1 else ''} "
                f"{', '.join(repr(p) for p in params)}{_defined_at(macro)}")
    invalid = _INVALID_PARAMETER.fullmatch(message)
    if invalid and macro is not None and name is not None:
        plain = [p for p in macro.params if not p.startswith("*")]
        hint = suggest(invalid.group(1), plain) or (
            f" (its parameters: {', '.join(plain)})" if plain else " (it has none)")
        return f"the call of macro '{name}' gives parameter '{invalid.group(1)}', which it does not have{hint}"
    unknown = _UNKNOWN_MACRO.fullmatch(message)
    if unknown:
        return f"unknown macro '{unknown.group(1)}'{suggest(unknown.group(1), _names(hooks.macros))}"
    return None


def _macro_name(macro: Any) -> str | None:
    body = getattr(macro, "body", None)
    return str(body.getAttribute("name")).removeprefix("xacro:") if body is not None else None


def _defined_at(macro: Any) -> str:
    where = located(origin(macro.body))
    return f" (the macro is defined at {where})" if where else ""


def _name_hint(exc: BaseException | None, hooks: DialectHooks) -> str:
    """For ``name 'x' is not defined``: the closest name in scope, or where ``x`` is defined out of
    reach (later in the file; or as a legacy ``<property>`` that strict expansion leaves alone)."""
    found = _UNDEFINED_NAME.search(str(exc)) if isinstance(exc, NameError) else None
    if found is None:
        return ""
    name = found.group(1)
    definition = _property_definition(name, hooks)
    if definition is not None:
        tag, where = definition
        if tag == "property" and hooks.mode is Mode.STRICT:
            return (f" (<property name=\"{name}\"> at {where} is the Kinetic-era dialect, which `strict_xacro` "
                    "leaves unexpanded)")
        return f" (it is defined later, at {where}: xacro evaluates in order)"
    return suggest(name, _names(hooks.symbols))


def _property_definition(name: str, hooks: DialectHooks) -> tuple[str, str] | None:
    """A property ``name`` not yet expanded in a parsed file: (tag, ``file:line``)."""
    for document in hooks.documents:
        for tag in ("xacro:property", "property"):
            for element in document.getElementsByTagName(tag):
                where = located(origin(element))
                if element.getAttribute("name") == name and where is not None:
                    return tag, where
    return None


def _names(table: Any) -> set[str]:
    """The names a xacro symbol or macro table (and the tables it falls back on) defines."""
    names: set[str] = set()
    seen: set[int] = set()
    while isinstance(table, dict) and id(table) not in seen:
        seen.add(id(table))
        names.update(k for k in dict.keys(table) if isinstance(k, str) and not k.startswith(("_", "*")))
        table = getattr(table, "parent", None)
    return names


def _where(xacro: Any, filename: str | os.PathLike[str]) -> str:
    stack = [f for f in (xacro.filestack or []) if f]
    return display_path(stack[-1] if stack else filename)


def _xacro_message(err: Exception) -> str:
    cause = getattr(err, "exc", None)
    if isinstance(cause, OSError) and cause.filename:  # xacro appends the OSError to its own text of it
        message = f"{cause.strerror or cause}: {cause.filename}"
    else:
        message = one_line(str(err))
        # xacro's text of an exception it wraps: "<class 'xacro.…Exception'>: TEXT TEXT"
        message = re.sub(r"^<class '[\w.]+'>: ", "", message)
        half = (len(message) - 1) // 2
        if len(message) % 2 == 1 and message[half] == " " and message[:half] == message[half + 1:]:
            message = message[:half]
    undefined = re.search(r"Undefined substitution argument (\S+)", message)
    if undefined:  # an <xacro:arg> without a default that the caller must give
        message += f" (give it as {undefined.group(1)}:=VALUE after the description)"
    macros = getattr(err, "macros", None)
    if macros:
        names = [m.body.getAttribute("name") for m in macros if getattr(m, "body", None) is not None]
        if names:
            message += f" (in macro {' < '.join(names)})"
    return message
