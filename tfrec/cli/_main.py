"""The ``tfrec`` command line: the only package that parses argv, prints and picks exit codes.

Exit codes: 0 ok, 1 differences found, 2 user error (``tfrec: error: ...`` on stderr).
Heavy libraries (xacro, numpy, rerun, rosbags, yourdfpy) are imported inside the handlers,
so ``tfrec --help`` stays fast.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import signal
import sys
import warnings
from collections.abc import Iterator, Sequence
from types import ModuleType
from typing import TextIO

from tfrec._address_space import economize, limit_phrase
from tfrec._version import __version__
from tfrec.cli._common import (
    PROG,
    Parser,
    as_flags,
    show,
)
from tfrec.errors import LegacyXacroWarning, TfrecError, printable

__all__ = ["main", "main_exit"]


COMMANDS = ("inspect", "record", "serve", "info", "diff", "replay", "convert", "plot", "check")
"""The subcommands, in the order ``tfrec --help`` lists them."""


def _build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser. When ``argv`` starts with a subcommand, only that subcommand's parser is built
    (building and importing all of them is ~10 % of ``tfrec info``'s time on a small file): what it parses and
    prints is the same, as nothing before the subcommand asks for the others (``--help``, ``--version``, a usage
    error does)."""
    parser = Parser(
        prog=PROG,
        description="Record, replay and compare what a robot description does — headless, without ROS.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  tfrec record robots/mbot.xacro --traj sine     (then: rerun recordings/<name>.rrd)\n"
               "  tfrec replay --check recordings/<name>.mcap\n"
               "  tfrec diff golden.mcap new.mcap --plot diff.png\n"
               "  tfrec convert robot.bag robot.mcap --start 60\n\n"
               "'tfrec COMMAND --help' describes each command. Without an activated virtual environment, type "
               "the commands as .venv/bin/tfrec and .venv/bin/rerun.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    first = list(sys.argv[1:] if argv is None else argv)[:1]
    for name in first if first and first[0] in COMMANDS else COMMANDS:
        _command_module(name).add_parser(sub)
    return parser


def _command_module(name: str) -> ModuleType:
    """The module that adds subcommand ``name``'s parser and runs it."""
    if name == "inspect":
        from tfrec.cli import _inspect

        return _inspect
    if name == "record":
        from tfrec.cli import _record

        return _record
    if name == "serve":
        from tfrec.cli import _serve

        return _serve
    if name == "info":
        from tfrec.cli import _info

        return _info
    if name == "diff":
        from tfrec.cli import _diff

        return _diff
    if name == "replay":
        from tfrec.cli import _replay

        return _replay
    if name == "convert":
        from tfrec.cli import _convert

        return _convert
    if name == "plot":
        from tfrec.cli import _plot

        return _plot
    assert name == "check", name
    from tfrec.cli import _fleet

    return _fleet


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: TextIO | None = None, line: str | None = None) -> None:
    text = str(message)
    if issubclass(category, LegacyXacroWarning):
        text = text.replace(LegacyXacroWarning.SILENCE, "--quiet-legacy")
    show(f"{PROG}: warning: {printable(as_flags(text))}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    # Rerun's Rust logger writes to stderr on its own (a full disk gives WARN and ERROR lines before
    # tfrec's one-line error): quiet unless the user asks for it with RUST_LOG
    os.environ.setdefault("RUST_LOG", "off")
    # OpenBLAS starts a thread per core, each with its buffer, when numpy is loaded (a third of `import numpy`'s
    # CPU time on 2 cores, more with more); tfrec multiplies no matrix larger than 4×4, which one thread does
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    economize()  # under ulimit -v: before numpy and rerun are loaded
    parser = _build_parser(argv)
    try:
        ns = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help, --version, or a usage error (exit 2)
        return int(exc.code or 0)
    with warnings.catch_warnings(), _terminate_as_interrupt():
        warnings.simplefilter("default")
        if getattr(ns, "quiet_legacy", False):
            warnings.filterwarnings("ignore", category=LegacyXacroWarning)
        warnings.showwarning = _show_warning
        try:
            return int(ns.handler(ns))
        except TfrecError as err:
            show(f"{PROG}: error: {printable(as_flags(str(err)))}", file=sys.stderr)
            return 2
        except _Terminated:
            show(f"{PROG}: terminated", file=sys.stderr)
            return 143
        except KeyboardInterrupt:
            show(f"{PROG}: interrupted", file=sys.stderr)
            return 130
        except BrokenPipeError:
            return 0
        except MemoryError:  # a limit on the process's memory (ulimit -v, a container) met by a valid input
            show(f"{PROG}: error: {printable(_inputs(ns))}out of memory (the process's memory limit was reached)",
                  file=sys.stderr)
            return 2
        except OSError as err:
            if err.errno != errno.ENAMETOOLONG:
                raise
            # a path the system cannot take (a name over 255 bytes, a path over PATH_MAX), met wherever it is used
            where = f"{os.fsdecode(err.filename)}: " if err.filename is not None else _inputs(ns)
            show(f"{PROG}: error: {printable(where)}{err.strerror or 'File name too long'} (a name has at most 255 "
                 "bytes, a path 4095)", file=sys.stderr)
            return 2
        except ImportError as err:  # a library that cannot load: not installed, or no address space left to map it
            limit = f" ({limit_phrase()})" if limit_phrase() else ""
            show(f"{PROG}: error: cannot load {err.name or 'a library'}: {printable(' '.join(str(err).split()))}{limit}",
                  file=sys.stderr)
            return 2
        except RuntimeError as err:
            if "can't start new thread" not in str(err):
                raise
            # a thread that cannot start: the address space is used up (ulimit -v), or the threads a user may have
            show(f"{PROG}: error: {printable(_inputs(ns))}cannot start a thread ({limit_phrase() or 'ulimit -u'} "
                 "reached)", file=sys.stderr)
            return 2


def _inputs(ns: argparse.Namespace) -> str:
    """``FILE: `` for the input of a command (its first), for errors that do not know it."""
    for name in ("file", "robot", "inputs", "paths"):
        value = getattr(ns, name, None)
        if isinstance(value, (list, tuple)):
            value = value[0] if value else None
        if isinstance(value, str) and value:
            return f"{value}: "
    return ""


class _Terminated(KeyboardInterrupt):
    """SIGTERM (``kill``, ``timeout``), raised like Ctrl-C so that outputs are cleaned up the same way."""


@contextlib.contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    def handler(signum: int, frame: object) -> None:
        raise _Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def main_exit() -> None:
    """Console-script entry point: ``sys.exit(main())``.

    When Rerun's file writer died (a full disk), Rerun's own exit handler would wait for it forever:
    the process then ends at once, its output flushed, without the exit handlers."""
    code = main()
    writer = sys.modules.get("tfrec.viewer._flush")
    if writer is not None and getattr(writer, "STUCK", False):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
