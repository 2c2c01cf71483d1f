"""Running the PyPI ``xacro`` 2.x library in-process, without ROS.

What stock xacro does not do for us, done here for the duration of one expansion:

* ``$(find pkg)`` goes to :class:`tfrec.description.packages.PackageFinder` instead of
  ``ament_index_python`` (not on PyPI);
* the Kinetic-era dialect (xacro <= 1.13, the course's packages: ``<property>``, ``<macro>``,
  ``<include>``, ``<arg>``, ``<if>``, ``<unless>``, ``<insert_block>`` and macro calls without the
  ``xacro:`` prefix) is expanded as ROS Kinetic/Melodic's xacro did, with one
  :class:`~tfrec.errors.LegacyXacroWarning` (docs/xacro.md). A file is first expanded exactly as
  PyPI xacro does; only when that expansion meets a legacy form is it expanded again in the legacy
  dialect (:mod:`tfrec.description._xacro_dialect`), so a valid modern file comes out as ROS 2's
  xacro makes it. ``strict=True`` is PyPI xacro alone;
* xacro's global file and include stacks are reset, its stderr chatter becomes Python warnings, and
  its exceptions become one-line :class:`DescriptionError` naming the file and line of the element
  at fault, with the closest defined name for a typo.
"""

from __future__ import annotations

import contextlib
import io
import os
import threading
import warnings
import xml.parsers.expat
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from tfrec.description._sandbox import SandboxLimits, xacro_sandbox
from tfrec.description._xacro_dialect import DialectHooks, LegacyForm, LegacyFound, Mode
from tfrec.description._xacro_errors import describe_error
from tfrec.description._xml_bytes import origin
from tfrec.description.packages import PackageFinder
from tfrec.errors import DescriptionError, LegacyXacroWarning, TfrecWarning, display_path

__all__ = ["XacroExpansion", "expand_xacro", "xacro_expansion"]

_LOCK = threading.Lock()  # xacro keeps module-level state: one expansion at a time


@dataclass(frozen=True, slots=True)
class XacroExpansion:
    """A xacro file expanded.

    Attributes:
        text: the URDF document.
        origins: ``file:line`` each element of ``text`` was written at (in document order), or None.
        legacy: the legacy forms expanded (or, with ``strict``, left unexpanded).
    """

    text: str
    origins: tuple[str | None, ...] = ()
    legacy: tuple[LegacyForm, ...] = ()


@contextlib.contextmanager
def _patched_xacro(finder: PackageFinder) -> Iterator[Any]:
    """xacro with ``$(find)`` going to ``finder``; its global state is reset on exit."""
    import xacro.substitution_args as subst

    import xacro

    original_find = subst._eval_find
    original_eval_find = subst._eval_dict.get("find")

    def find(pkg: str) -> str:
        return str(finder.find(pkg))

    subst._eval_find = find
    subst._eval_dict["find"] = find
    try:
        yield xacro
    finally:
        subst._eval_find = original_find
        if original_eval_find is not None:
            subst._eval_dict["find"] = original_eval_find
        xacro.init_stacks(None)
        xacro.all_includes = []
        xacro.substitution_args_context.clear()


def expand_xacro(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None = None,
    finder: PackageFinder,
    strict: bool = False,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    allow_paths: Sequence[str | os.PathLike[str]] = (),
    limits: SandboxLimits | None = None,
) -> str:
    """Expand a xacro file to URDF text: :func:`xacro_expansion`'s text."""
    return xacro_expansion(path, args=args, finder=finder, strict=strict, package_paths=package_paths,
                           allow_paths=allow_paths, limits=limits).text


def xacro_expansion(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None = None,
    finder: PackageFinder,
    strict: bool = False,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    allow_paths: Sequence[str | os.PathLike[str]] = (),
    limits: SandboxLimits | None = None,
) -> XacroExpansion:
    """Expand a xacro file to URDF, in the sandbox (:mod:`tfrec.description._sandbox`): expressions
    cannot reach Python's internals or builtins, files are read only inside the input's workspace, the
    packages found, ``package_paths`` and ``allow_paths``, and the expansion is bounded by ``limits``.

    A file is expanded as PyPI xacro expands it; one that holds the Kinetic-era dialect (legacy
    forms that PyPI xacro would copy to its output) is then expanded as xacro <= 1.13 did, with one
    :class:`~tfrec.errors.LegacyXacroWarning` (docs/xacro.md).

    Args:
        path: the ``.xacro`` / ``.urdf.xacro`` file.
        args: xacro arguments (``name:=value`` on a command line), as strings.
        finder: resolves ``$(find pkg)``.
        strict: expand as PyPI xacro does, legacy forms left as they are (with a warning).
        package_paths: ``--package-path`` folders (may be read).
        allow_paths: further folders or files that may be read (``--allow-path``).
        limits: bounds of the expansion (output, expansion steps, XML depth, file sizes).

    Raises:
        DescriptionError: any xacro, XML or package error, naming the file and line.
    """
    job = _Job(path, dict(args or {}), finder, package_paths, allow_paths, limits or SandboxLimits())
    with _LOCK:
        run = job.run(Mode.STRICT if strict else Mode.PROBE)
        if run.found is not None:
            run = job.run(Mode.LEGACY)
    if run.error is not None:
        raise run.error
    finder.warn_twins()
    _warn_unused_args(job.filename, run.mappings)
    for line in run.chatter.splitlines():
        if line.strip():
            warnings.warn(f"{display_path(job.filename)}: xacro: {line.strip()}", TfrecWarning, stacklevel=3)
    legacy = tuple(run.hooks.forms)
    if legacy:
        warnings.warn(LegacyXacroWarning(_legacy_message(legacy, expanded=not strict)), stacklevel=3)
    return XacroExpansion(run.text, run.origins, legacy)


@dataclass
class _Run:
    """One expansion of a :class:`_Job`, in one :class:`Mode`."""

    hooks: DialectHooks
    mappings: _Args
    chatter: str = ""
    text: str = ""
    origins: tuple[str | None, ...] = ()
    error: DescriptionError | None = None
    found: LegacyForm | None = None


@dataclass
class _Job:
    path: str | os.PathLike[str]
    args: dict[str, str]
    finder: PackageFinder
    package_paths: Sequence[str | os.PathLike[str]]
    allow_paths: Sequence[str | os.PathLike[str]]
    limits: SandboxLimits
    filename: str = field(init=False)

    def __post_init__(self) -> None:
        self.filename = os.fspath(self.path)

    def run(self, mode: Mode) -> _Run:
        chatter = io.StringIO()
        with xacro_sandbox(self.path, finder=self.finder, package_paths=self.package_paths,
                           allow_paths=self.allow_paths, limits=self.limits), \
                _patched_xacro(self.finder) as xacro, DialectHooks(xacro, mode).installed() as hooks:
            run = _Run(hooks, _Args(self.args))
            try:
                with contextlib.redirect_stderr(chatter):
                    xacro.init_stacks(self.filename)
                    doc = xacro.parse(None, self.filename)
                    xacro.process_doc(doc, mappings=run.mappings)
            except LegacyFound as found:
                run.found = found.form
                return run
            except (RecursionError, DescriptionError, xml.parsers.expat.ExpatError, xacro.XacroException,
                    RuntimeError, NameError, TypeError, ValueError, ZeroDivisionError, SyntaxError, KeyError,
                    IndexError, OSError) as err:
                message = describe_error(err, xacro=xacro, hooks=hooks, filename=self.filename)
                run.error = DescriptionError(_with_twins(message, self.finder))
                run.error.__cause__ = err
                return run
            run.text = doc.toprettyxml(indent="  ")
            run.origins = _origins(doc.documentElement)
        run.chatter = chatter.getvalue()
        return run


def _origins(root: Any) -> tuple[str | None, ...]:
    """``file:line`` of each element under ``root``, in document order (each file displayed once)."""
    shown: dict[str, str] = {}
    out: list[str | None] = []
    for node in _elements(root):
        where = origin(node)
        if where is None:
            out.append(None)
            continue
        file = shown.get(where[0])
        if file is None:
            file = shown[where[0]] = display_path(where[0])
        out.append(f"{file}:{where[1]}")
    return tuple(out)


def _elements(root: Any) -> Iterator[Any]:
    """The elements under ``root`` (itself first), in document order."""
    stack = [root]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed([c for c in node.childNodes if c.nodeType == c.ELEMENT_NODE]))


def _legacy_message(forms: Sequence[LegacyForm], *, expanded: bool) -> str:
    """The one warning about the legacy forms of an expansion."""
    files = ", ".join(dict.fromkeys(display_path(f.where[0]) for f in forms if f.where is not None)) or "<string>"
    tags = ", ".join(sorted({f"<{f.tag}>" for f in forms if not f.call}, key=str.lower))
    calls = ", ".join(sorted({f"<{f.tag}>" for f in forms if f.call}, key=str.lower))
    if tags and calls:
        what = f"legacy tags and macro calls without the 'xacro:' prefix: {tags}; calls of {calls}"
    else:
        what = f"legacy {'tags' if tags else 'macro calls'} without the 'xacro:' prefix: {tags or calls}"
    if not expanded:
        return (f"{files}: left {what} unexpanded, as ROS 2's xacro does (`strict_xacro`); they are the course's "
                "Kinetic-era dialect (xacro <= 1.13), which ROS 1's xacro expanded")
    return (f"{files}: the course's Kinetic-era xacro dialect (xacro <= 1.13): expanded {what}, as ROS "
            "Kinetic/Melodic's xacro did (ROS 2's xacro leaves them unexpanded); write the prefix, or silence "
            f"this warning with {LegacyXacroWarning.SILENCE}")


class _Args(dict[str, str]):
    """The ``name:=value`` arguments, noting which names the expansion declares (``<xacro:arg>``
    asks whether a value was given) or reads (``$(arg name)``)."""

    def __init__(self, given: dict[str, str]) -> None:
        super().__init__(given)
        self.given = tuple(given)
        self.known: set[str] = set()

    def __contains__(self, name: object) -> bool:
        if isinstance(name, str):
            self.known.add(name)
        return super().__contains__(name)

    def __getitem__(self, name: str) -> str:
        self.known.add(name)
        return super().__getitem__(name)


def _with_twins(message: str, finder: PackageFinder) -> str:
    """``message``, saying which copy of a package with twins was taken when it names a file in one
    (an include missing from an older copy is otherwise a plain "No such file")."""
    notes = [note for name, (found, _) in finder.twins.items()
             if str(found) in message and (note := finder.taken(found)) is not None]
    return f"{message} ({'; '.join(notes)})" if notes else message


def _warn_unused_args(filename: str, args: _Args) -> None:
    """Warn about a ``name:=value`` that no ``<xacro:arg>`` declares and no ``$(arg)`` reads (a typo:
    ``hnad:=true`` silently gives another robot), naming the closest declared argument."""
    import difflib

    declared = sorted(args.known - set(args.given))
    for name in args.given:
        if name in args.known:
            continue
        close = difflib.get_close_matches(name, declared, n=1)
        hint = f"; did you mean '{close[0]}'?" if close else (
            f" (its arguments: {', '.join(declared)})" if declared else " (it declares none)")
        warnings.warn(f"{display_path(filename)}: xacro argument {name}:={args[name]} is not an argument of this "
                      f"description, and is ignored{hint}", TfrecWarning, stacklevel=4)
