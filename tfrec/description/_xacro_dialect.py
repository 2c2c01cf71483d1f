"""The Kinetic-era xacro dialect, told apart from valid modern xacro; and where each element of an
expansion comes from.

xacro <= 1.13 (ROS Kinetic and Melodic, the course's packages) accepted its tags without the
``xacro:`` prefix, with a deprecation warning: ``<property>``, ``<macro>``, ``<include>``, ``<arg>``,
``<if>``, ``<unless>`` and ``<insert_block>`` (``check_deprecated_tag`` and ``is_include`` in its
``__init__.py``; the fix-it ``sed`` line of its warning lists the same seven), and took any element
named like a defined macro for a call of that macro. xacro >= 1.14 (PyPI xacro 2.x, ROS 2) copies
them all to its output as ordinary elements. :class:`DialectHooks` patches xacro for one expansion:

* :attr:`Mode.STRICT` expands as PyPI xacro does and notes each legacy form it meets;
  :attr:`Mode.PROBE` does the same but stops at the first (:class:`LegacyFound`);
  :attr:`Mode.LEGACY` expands them as xacro <= 1.13 did (each renamed ``xacro:…`` before xacro
  looks at it, so that xacro's own code expands it, in order);
* it keeps the stack of the elements being expanded (:meth:`DialectHooks.location` gives the
  file and line of an error) and what was in scope (properties, macros) for suggestions.

Never a legacy form, whatever its name:

* anything outside a robot description: the input's root element must be ``<robot>`` (a document
  of another kind is PyPI xacro's alone);
* anything inside ``<gazebo>``, ``<ros2_control>``, ``<transmission>`` or ``<sensor>`` (SDF and
  controller content) — both counted where a macro body, block or included file ends up;
* an ``<include>`` holding anything but text (Gazebo's ``<include><uri>…``: xacro 1.13's rule), and
  a tag without the attributes xacro 1.13 required of it (``<include>`` without ``filename``;
  ``<property>``, ``<macro>`` or ``<insert_block>`` without ``name``; ``<arg>`` without ``name`` and
  ``default``; ``<if>`` or ``<unless>`` without ``value``): xacro 1.13 stopped on those, so they are
  somebody else's elements;
* an element named like a URDF element (``<origin>``, ``<cylinder>``, ``<link>``…) even where a
  macro has that name (xacro 1.13 took ``<cylinder>`` in the body of a ``cylinder`` macro for a call,
  and recursed without end), and an element inside the expansion of the macro it is named after.
"""

from __future__ import annotations

import contextlib
import enum
import xml.dom
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from tfrec.description._xml_bytes import Origin, origin

__all__ = ["FOREIGN_BLOCKS", "LEGACY_TAGS", "URDF_ELEMENTS", "DialectHooks", "LegacyForm", "LegacyFound", "Mode"]

LEGACY_TAGS: dict[str, tuple[str, ...]] = {
    "property": ("name",), "macro": ("name",), "include": ("filename",), "arg": ("name", "default"),
    "if": ("value",), "unless": ("value",), "insert_block": ("name",),
}
"""The tags xacro <= 1.13 accepted without the ``xacro:`` prefix, and the attributes it required of each."""

URDF_ELEMENTS = frozenset({
    "robot", "link", "joint", "visual", "collision", "inertial", "origin", "geometry", "box", "cylinder", "sphere",
    "capsule", "mesh", "material", "color", "texture", "mass", "inertia", "parent", "child", "axis", "limit",
    "dynamics", "calibration", "mimic", "safety_controller", "gazebo", "transmission", "ros2_control", "sensor",
    "actuator", "hardwareInterface", "mechanicalReduction", "type", "camera", "ray", "image",
})
"""Elements a URDF holds: never a legacy macro call, even beside a macro of that name."""

FOREIGN_BLOCKS = frozenset({"gazebo", "ros2_control", "transmission", "sensor"})
"""Elements whose content is for other tools (SDF, controllers): nothing inside is a legacy form."""

_ELEMENT = xml.dom.Node.ELEMENT_NODE
_TEXT = xml.dom.Node.TEXT_NODE


class Mode(enum.Enum):
    """What an expansion does with the legacy forms it meets."""

    STRICT = "strict"
    """Expand as PyPI xacro does; note them (:attr:`DialectHooks.forms`)."""
    PROBE = "probe"
    """Expand as PyPI xacro does; stop at the first (:class:`LegacyFound`)."""
    LEGACY = "legacy"
    """Expand them as xacro <= 1.13 did; note them."""


@dataclass(frozen=True, slots=True)
class LegacyForm:
    """One legacy form met by an expansion.

    Attributes:
        tag: the tag as written: ``property`` (a xacro tag), or a macro's name (a call).
        call: whether it is a macro call.
        where: the file and line it was written at.
    """

    tag: str
    call: bool
    where: Origin | None


class LegacyFound(Exception):
    """Raised by a :attr:`Mode.PROBE` expansion at the first legacy form."""

    def __init__(self, form: LegacyForm) -> None:
        super().__init__(form.tag)
        self.form = form


class DialectHooks:
    """xacro's functions, patched for one expansion (:meth:`installed`); see the module's docstring.

    Attributes:
        mode: what is done with legacy forms.
        forms: the legacy forms met (all but :attr:`Mode.PROBE`).
        symbols: the properties in scope at the last expression evaluated (for suggestions).
        macros: the macros in scope at the last element expanded (for suggestions).
        documents: the documents parsed (the input and each included file).
    """

    def __init__(self, xacro: Any, mode: Mode) -> None:
        self._xacro = xacro
        self.mode = mode
        self.forms: list[LegacyForm] = []
        self.symbols: Any = None
        self.macros: Any = None
        self.documents: list[Any] = []
        self._stack: list[Any] = []  # the elements being expanded, innermost last
        self._roots: dict[int, tuple[Any, bool]] = {}  # detached subtrees: may they hold legacy forms?

    @contextlib.contextmanager
    def installed(self) -> Iterator[DialectHooks]:
        """Patch xacro (inside :func:`~tfrec.description._sandbox.xacro_sandbox`, whose patches these
        wrap); everything is restored on exit."""
        xacro = self._xacro
        hooks: dict[str, Callable[[Any], Any]] = {
            "eval_all": self._eval_all, "handle_macro_call": self._handle_macro_call, "check_attrs": self._marking,
            "reqd_attrs": self._marking, "replace_node": self._replace_node, "safe_eval": self._safe_eval,
            "parse": self._parse,
        }
        saved = {name: getattr(xacro, name) for name in hooks}
        for name, hook in hooks.items():
            setattr(xacro, name, hook(saved[name]))
        try:
            yield self
        finally:
            for name, value in saved.items():
                setattr(xacro, name, value)

    # -- where an error is

    def location(self) -> Origin | None:
        """The file and line of the innermost element being expanded (where an error was raised)."""
        for node in reversed(self._stack):
            found = origin(node)
            if found is not None:
                return found
        return None

    def current(self) -> Any:
        """The innermost element being expanded, or None."""
        return self._stack[-1] if self._stack else None

    # -- the hooks

    def _eval_all(self, original: Callable[..., Any]) -> Callable[..., Any]:
        def eval_all(node: Any, macros: Any, symbols: Any) -> None:
            self._enter(node)
            for child in node.childNodes:
                if child.nodeType == _ELEMENT and self._is_legacy_tag(child, node):
                    self._met(child, LegacyForm(child.tagName, False, origin(child)))
            original(node, macros, symbols)
            if self._stack and self._stack[-1] is node:
                self._stack.pop()

        return eval_all

    def _handle_macro_call(self, original: Callable[..., Any]) -> Callable[..., Any]:
        def handle_macro_call(node: Any, macros: Any, symbols: Any) -> bool:
            self._stack.append(node)
            self.macros = macros
            if self._is_legacy_call(node, macros, symbols):
                self._met(node, LegacyForm(node.tagName, True, origin(node)))
            expanded = bool(original(node, macros, symbols))
            self._pop(node)
            return expanded

        return handle_macro_call

    def _marking(self, original: Callable[..., Any]) -> Callable[..., Any]:
        """``check_attrs`` / ``reqd_attrs``: the first thing xacro does with a xacro tag; it is then
        where an error is, until it is replaced."""
        def marked(tag: Any, *args: Any) -> Any:
            self._stack.append(tag)
            return original(tag, *args)

        return marked

    def _replace_node(self, original: Callable[..., Any]) -> Callable[..., Any]:
        def replace_node(node: Any, by: Any, content_only: bool = False) -> Any:
            result = original(node, by, content_only)
            self._pop(node)
            return result

        return replace_node

    def _safe_eval(self, original: Callable[..., Any]) -> Callable[..., Any]:
        def safe_eval(expr: str, globals: Any, locals: Any = None) -> Any:
            self.symbols = globals
            return original(expr, globals, locals)

        return safe_eval

    def _parse(self, original: Callable[..., Any]) -> Callable[..., Any]:
        def parse(inp: Any, filename: Any = None) -> Any:
            document = original(inp, filename)
            self.documents.append(document)
            return document

        return parse

    # -- legacy forms

    def _is_legacy_tag(self, node: Any, parent: Any) -> bool:
        needed = LEGACY_TAGS.get(node.tagName)
        if needed is None or not all(node.hasAttribute(a) for a in needed) or not self._may_hold_legacy(parent):
            return False
        if node.tagName == "include":  # xacro 1.13's is_include: nothing but text inside
            return not node.childNodes or (len(node.childNodes) == 1 and node.firstChild.nodeType == _TEXT)
        return True

    def _is_legacy_call(self, node: Any, macros: Any, symbols: Any) -> bool:
        tag = node.tagName
        if ":" in tag or tag in URDF_ELEMENTS:
            return False
        try:
            macro = self._xacro.resolve_macro(tag, macros, symbols)[2]
        except (KeyError, TypeError, AttributeError):
            return False  # not a macro: an ordinary element
        if not isinstance(macro, self._xacro.Macro) or any(m is macro for m in self._xacro.macrostack or ()):
            return False  # a namespace, or an element the macro of that name writes
        return self._may_hold_legacy(node.parentNode)

    def _met(self, node: Any, form: LegacyForm) -> None:
        if self.mode is Mode.PROBE:
            raise LegacyFound(form)
        self.forms.append(form)
        if self.mode is Mode.LEGACY:
            node.tagName = node.nodeName = "xacro:" + node.tagName

    def _may_hold_legacy(self, node: Any) -> bool:
        """Whether the children of ``node`` may be legacy forms, judged where ``node`` is (or will be) in
        the output: under the input's ``<robot>`` root, outside foreign blocks."""
        while node is not None and node.nodeType == _ELEMENT:
            if node.tagName in FOREIGN_BLOCKS:
                return False
            parent = node.parentNode
            if parent is None or parent.nodeType != _ELEMENT:  # a macro body, block or file being expanded
                known = self._roots.get(id(node))
                if known is not None and known[0] is node:
                    return known[1]
                return bool(node.tagName == "robot")  # the input's root
            node = parent
        return False

    # -- the stack

    def _enter(self, node: Any) -> None:
        parent = node.parentNode
        if self._stack and (parent is None or parent.nodeType != _ELEMENT):
            # a macro body, a block or an included file: it goes where the element expanded now is
            host = next((n for n in reversed(self._stack) if getattr(n, "nodeType", None) == _ELEMENT), None)
            self._roots[id(node)] = (node, host is not None and self._may_hold_legacy(host))
        self._stack.append(node)

    def _pop(self, node: Any) -> None:
        while self._stack and self._stack[-1] is node:
            self._stack.pop()
