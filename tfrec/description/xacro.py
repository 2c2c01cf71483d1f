"""Running the PyPI ``xacro`` 2.x library in-process, without ROS.

Three things stock xacro does not do for us, done here for the duration of one expansion:

* ``$(find pkg)`` goes to :class:`tfrec.description.packages.PackageFinder` instead of
  ``ament_index_python`` (not on PyPI);
* calls to defined macros written without the ``xacro:`` prefix (the dialect of
  xacro <= 1.13, used by ROS Kinetic/Melodic course packages) are expanded, with one
  warning naming them, or rejected with ``strict=True``. Stock xacro >= 1.14 copies them
  to the output unexpanded, silently;
* xacro's global file and include stacks are reset, its stderr chatter becomes Python
  warnings, and its exceptions become one-line :class:`DescriptionError` naming the file.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import threading
import warnings
import xml.parsers.expat
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from tfrec.description._sandbox import SandboxLimits, describe_xacro_failure, xacro_sandbox
from tfrec.description.packages import PackageFinder
from tfrec.errors import DescriptionError, display_path, one_line

__all__ = ["expand_xacro"]

_LOCK = threading.Lock()  # xacro keeps module-level state: one expansion at a time


class _LegacyCall(Exception):
    """Raised inside xacro for an un-prefixed macro call under strict mode."""


@contextlib.contextmanager
def _patched_xacro(finder: PackageFinder, *, strict: bool, legacy: list[tuple[str, str]]) -> Iterator[Any]:
    import xacro.substitution_args as subst

    import xacro

    original_find = subst._eval_find
    original_eval_find = subst._eval_dict.get("find")
    original_handle = xacro.handle_macro_call

    def find(pkg: str) -> str:
        return str(finder.find(pkg))

    def handle_macro_call(node: Any, macros: Any, symbols: Any) -> bool:
        tag = node.tagName
        if ":" not in tag and not _inside_foreign_block(node):
            try:
                _, _, macro = xacro.resolve_macro(tag, macros, symbols)
            except KeyError:
                macro = None  # not a macro: an ordinary element
            # an element named like a macro is a call, as in xacro <= 1.13 (whose errors for missing or
            # unknown parameters it then gets), unless it is also a URDF element that does not fit the
            # macro (a literal <inertial> beside an "inertial" macro)
            if macro is not None and (tag not in _URDF_ELEMENTS or _fits(node, macro)):
                where = _call_site(xacro)
                if strict:
                    raise _LegacyCall(
                        f"{display_path(where)}: macro call <{tag}> without the 'xacro:' prefix "
                        f"(legacy xacro dialect refused by `strict_xacro`; write <xacro:{tag} .../>)"
                    )
                legacy.append((tag, display_path(where)))
                node.tagName = node.nodeName = "xacro:" + tag
        return bool(original_handle(node, macros, symbols))

    subst._eval_find = find
    subst._eval_dict["find"] = find
    xacro.handle_macro_call = handle_macro_call
    try:
        yield xacro
    finally:
        subst._eval_find = original_find
        if original_eval_find is not None:
            subst._eval_dict["find"] = original_eval_find
        xacro.handle_macro_call = original_handle
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
    """Expand a xacro file to URDF text, in the sandbox (:mod:`tfrec.description._sandbox`): expressions
    cannot reach Python's internals or builtins, files are read only inside the input's workspace, the
    packages found, ``package_paths`` and ``allow_paths``, and the expansion is bounded by ``limits``.

    Args:
        path: the ``.xacro`` / ``.urdf.xacro`` file.
        args: xacro arguments (``name:=value`` on a command line), as strings.
        finder: resolves ``$(find pkg)``.
        strict: refuse legacy un-prefixed macro calls instead of expanding them.
        package_paths: ``--package-path`` folders (may be read).
        allow_paths: further folders or files that may be read (``--allow-path``).
        limits: bounds of the expansion (output, expansion steps, XML depth, file sizes).

    Returns:
        The expanded URDF document as text.

    Raises:
        DescriptionError: any xacro, XML or package error, naming the file.
    """
    mappings = _Args({str(k): str(v) for k, v in (args or {}).items()})
    legacy: list[tuple[str, str]] = []
    chatter = io.StringIO()
    with _LOCK, xacro_sandbox(path, finder=finder, package_paths=package_paths, allow_paths=allow_paths,
                              limits=limits or SandboxLimits()), _patched_xacro(finder, strict=strict, legacy=legacy) as xacro:
        filename = os.fspath(path)
        message: str | None = None
        try:
            with contextlib.redirect_stderr(chatter):
                xacro.init_stacks(filename)
                doc = xacro.parse(None, filename)
                xacro.process_doc(doc, mappings=mappings)
        except RecursionError as err:
            message = (f"{display_path(filename)}: xacro recursion too deep: a file includes itself or a macro "
                       "calls itself without end")
            cause: BaseException = err
        except _LegacyCall as err:
            message, cause = str(err), err
        except DescriptionError as err:  # a refusal of the sandbox, $(find) of an unknown package
            message = (describe_xacro_failure(err, filename=filename, filestack=xacro.filestack)
                       or f"{_where(xacro, filename)}: {err}")
            cause = err
        except xml.parsers.expat.ExpatError as err:
            message = (f"{_where(xacro, filename)}:{err.lineno}:{err.offset}: malformed XML: "
                       f"{xml.parsers.expat.ErrorString(err.code)}")
            cause = err
        except xacro.XacroException as err:
            message = (describe_xacro_failure(err, filename=filename, filestack=xacro.filestack)
                       or f"{_where(xacro, filename)}: {_xacro_message(err)}")
            cause = err
        except RuntimeError as err:  # xacro's bare RuntimeError for an element missing an attribute
            message = describe_xacro_failure(err, filename=filename, filestack=xacro.filestack)
            if message is None:
                raise
            cause = err
        except (NameError, TypeError, ValueError, ZeroDivisionError, SyntaxError, KeyError, IndexError) as err:
            # xacro lets some evaluation errors through unwrapped
            message, cause = f"{_where(xacro, filename)}: xacro: {err}", err
        except OSError as err:
            message, cause = f"{_where(xacro, filename)}: {err.strerror or err}: {err.filename}", err
        if message is not None:
            raise DescriptionError(_with_twins(message, finder)) from cause
        text: str = doc.toprettyxml(indent="  ")
    finder.warn_twins()
    _warn_unused_args(filename, mappings)
    for line in chatter.getvalue().splitlines():
        if line.strip():
            warnings.warn(f"{display_path(filename)}: xacro: {line.strip()}", stacklevel=2)
    if legacy:
        names = sorted({name for name, _ in legacy})
        files = sorted({where for _, where in legacy})
        warnings.warn(
            f"{', '.join(files)}: expanded legacy macro calls without the 'xacro:' prefix: "
            f"{', '.join('<' + n + '>' for n in names)} (xacro >= 1.14 leaves them unexpanded; "
            "`strict_xacro` refuses them)",
            stacklevel=2,
        )
    return text


_URDF_ELEMENTS = frozenset({
    "robot", "link", "joint", "visual", "collision", "inertial", "origin", "geometry", "box", "cylinder", "sphere",
    "mesh", "material", "color", "texture", "mass", "inertia", "parent", "child", "axis", "limit", "dynamics",
    "calibration", "mimic", "safety_controller", "gazebo", "transmission", "ros2_control", "sensor",
})
"""Elements a URDF holds: one of them is a legacy macro call only when it fits the macro."""

_FOREIGN_BLOCKS = frozenset({"gazebo", "ros2_control", "transmission"})
"""Elements whose content is for other tools (SDF, controllers): never legacy macro calls."""


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
                      f"description, and is ignored{hint}", stacklevel=3)


def _inside_foreign_block(node: Any) -> bool:
    parent = node.parentNode
    while parent is not None and getattr(parent, "tagName", None) is not None:
        if parent.tagName in _FOREIGN_BLOCKS:
            return True
        parent = parent.parentNode
    return False


def _fits(node: Any, macro: Any) -> bool:
    """Whether an un-prefixed element can be a call of ``macro``, as xacro <= 1.13 would expand it.

    Its attributes must be parameters of the macro, every parameter without a default must be
    given, and its child elements must match the block parameters (``*name``, ``**name``) one to
    one. An element that does not fit (a Gazebo ``<camera>`` with children beside a ``camera``
    macro) is an ordinary element, left alone as xacro >= 1.14 does.
    """
    params = list(macro.params)
    plain = {p for p in params if not p.startswith("*")}
    blocks = [p for p in params if p.startswith("*")]
    attributes = set(node.attributes.keys())
    if not attributes <= plain:
        return False
    if any(p not in attributes and p not in macro.defaultmap for p in plain):
        return False
    children = [c for c in node.childNodes if c.nodeType == c.ELEMENT_NODE]
    return len(children) == len(blocks)


def _call_site(xacro: Any) -> str | None:
    """The file holding the element being expanded: the current macro's, else the current file."""
    if xacro.macrostack:
        history = xacro.macrostack[-1].history
        if history and history[-1] and history[-1][-1]:
            return str(history[-1][-1])
    return xacro.filestack[-1] if xacro.filestack else None


def _where(xacro: Any, filename: str) -> str:
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
