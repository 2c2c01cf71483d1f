"""What the subcommands share: the robot arguments, argument types, the progress bar."""

from __future__ import annotations

import argparse
import os
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TextIO

from tfrec.conventions import NS_PER_S, STAMP_LIMIT_NS, STAMP_RANGE
from tfrec.errors import printable

if TYPE_CHECKING:
    from tfrec.description.launch import LaunchRobot
    from tfrec.model import Robot

__all__ = [
    "PROG",
    "Parser",
    "Progress",
    "add_naming_arguments",
    "add_robot_arguments",
    "add_xacro_arguments",
    "as_flags",
    "command",
    "fmt",
    "load_robot",
    "load_robot_and_launch",
    "load_robot_option",
    "number",
    "package_form",
    "show",
    "start_time",
    "tolerance",
]

PROG = "tfrec"


def add_robot_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("robot", metavar="ROBOT",
                        help="a .urdf, .xacro or .urdf.xacro file, a MuJoCo model (.xml with a <mujoco> root), or a "
                             "launch file that loads one (.launch, .launch.xml, .launch.yaml), or PKG FILE.launch as "
                             "for roslaunch")
    parser.add_argument("xacro_args", metavar="name:=value", nargs="*", default=[],
                        help="xacro arguments (launch arguments for a launch file), as for ROS")
    parser.add_argument(
        "--package-path", metavar="DIR", action="append", default=[],
        help="a package, or a folder of packages, for $(find pkg) and package:// (repeatable; searched "
             "before ROS_PACKAGE_PATH, AMENT_PREFIX_PATH and the input's own workspace)",
    )
    parser.add_argument(
        "--allow-path", metavar="DIR", action="append", default=[],
        help="a folder (or file) xacro and launch files may read besides the input's workspace, the packages "
             "found and --package-path folders (repeatable; see docs/security.md)",
    )
    add_xacro_arguments(parser)


def add_xacro_arguments(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """``--strict-xacro`` and ``--quiet-legacy``: what is done with the Kinetic-era xacro dialect (docs/xacro.md)."""
    parser.add_argument(
        "--strict-xacro", action="store_true",
        help="expand xacro exactly as ROS 2's (PyPI) xacro does: the Kinetic-era dialect (<property>, <macro>, "
             "<include>, macro calls ... without the 'xacro:' prefix) is left unexpanded, with a warning",
    )
    parser.add_argument("--quiet-legacy", action="store_true",
                        help="no warning when the Kinetic-era xacro dialect is expanded")


def add_naming_arguments(parser: argparse.ArgumentParser | argparse._ArgumentGroup, *, log_time: bool = True) -> None:
    """``--namespace``, ``--remap`` (and ``--use-log-time``): which robot topics are read, and how."""
    parser.add_argument("--namespace", metavar="NS",
                        help="only the robot(s) of this namespace (its NS/robot_description, NS/joint_states, "
                             "NS/tf, NS/tf_static); '/' for the root namespace")
    parser.add_argument("--remap", metavar="FROM:=TO", action="append", default=[],
                        help="rename a topic as ROS remapping does, before anything else (repeatable), "
                             "e.g. --remap /robot1/tf:=/tf")
    if log_time:
        parser.add_argument("--use-log-time", action="store_true",
                            help="take each message's log time for the stamps of /joint_states and /tf (a driver "
                                 "that stamps 0, stamps on another clock)")


def show(*lines: str, file: TextIO | None = None) -> None:
    """Print each of ``lines`` on a line of its own, on stdout (or ``file``): the one way the command line
    prints — results, reports, ``wrote …`` lines, errors and warnings. Whatever a line quotes (a file name
    found in a folder, a topic, frame or joint name), a character that would drive a terminal — ESC, CR, BEL,
    a right-to-left override, an undecodable byte of a file name, a line break — is shown escaped
    (:func:`tfrec.errors.printable`); tabs stay. A report of several lines comes as its lines
    (``show(*text.split("\\n"))``), each escaped by the formatter that laid it out."""
    (sys.stdout if file is None else file).write("".join(printable(line, keep="\t") + "\n" for line in lines))


class Parser(argparse.ArgumentParser):
    """argparse with usage errors as one line, like every other tfrec error (exit 2); what a ROS user types
    out of habit (``tfrec play``, ``-O out``, ``replay -r 2``) is answered with tfrec's own (:mod:`._habits`)."""

    _argv: Sequence[str] = ()

    def parse_args(self, args: Sequence[str] | None = None, namespace: Any = None) -> Any:  # type: ignore[override]
        self._argv = list(sys.argv[1:] if args is None else args)
        self._habits_first()
        ns, extras = self.parse_known_args(self._argv, namespace)
        if extras:
            self._unrecognized(getattr(ns, "command", None), extras)
        return ns

    def _habits_first(self) -> None:
        """A ROS tool's option that is no option of the command, answered before argparse reads it as an
        abbreviation of another (``record --all`` is not ``--allow-path``)."""
        commands = next((a.choices for a in self._actions if isinstance(a, argparse._SubParsersAction)), {})
        command = next((token for token in self._argv if not token.startswith("-")), None)
        parser = commands.get(command) if command is not None else None
        if parser is None:
            return
        unknown = [token for token in self._argv
                   if token.startswith("-") and token.partition("=")[0] not in parser._option_string_actions]
        if not unknown:
            return
        from tfrec.cli._habits import answer_options

        if answer_options(command, unknown, self._argv) is not None:
            self._unrecognized(command, unknown)

    def _unrecognized(self, command: str | None, extras: Sequence[str]) -> NoReturn:
        from tfrec.cli._habits import answer_options

        message = f"unrecognized arguments: {' '.join(extras)}"
        answer = answer_options(command, extras, self._argv)
        if answer is not None:
            message += f": {answer}"
        elif ":=" in message:
            message += " (xacro arguments name:=value go right after ROBOT)"
        show(f"{PROG}: error: {printable(message)} (see '{PROG}{' ' + command if command else ''} --help')",
             file=sys.stderr)
        self.exit(2)

    def error(self, message: str) -> NoReturn:
        if message.startswith("argument COMMAND: invalid choice"):
            from tfrec.cli._habits import answer_command

            answer = answer_command(self._argv)
            word = message.partition("invalid choice: ")[2].partition(" (choose from")[0]
            if answer is not None:
                message = f"{word} is not a tfrec command: {answer}"
        show(f"{PROG}: error: {printable(message)} (see '{self.prog} --help')", file=sys.stderr)
        self.exit(2)


_PACKAGE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
"""A ROS package name (REP 144: letters, digits and underscores, a letter first; upper case let through)."""


def package_form(tokens: Sequence[str], package_paths: Sequence[str]) -> list[str]:
    """``ROBOT [name:=value ...]`` with roslaunch's ``PKG FILE`` form resolved: when the first token is
    no file but a package name and the second names a launch file (``marm_description view_marm.launch``),
    the two become the file found in the package (:func:`tfrec.description.packages.find_in_package`).

    Raises:
        DescriptionError: no such package, no such file in it, or several.
    """
    from tfrec.description.launch import is_launch_file

    if (len(tokens) >= 2 and _PACKAGE_NAME.fullmatch(tokens[0]) and not Path(tokens[0]).is_file()
            and ":=" not in tokens[1] and is_launch_file(Path(tokens[1]).name)):
        from tfrec.description.packages import find_in_package

        return [os.fspath(find_in_package(tokens[0], tokens[1], package_paths=package_paths)), *tokens[2:]]
    return list(tokens)


def load_robot_option(ns: argparse.Namespace) -> Robot | None:
    """``--robot FILE [name:=value ...]`` (or ``--robot PKG FILE.launch ...``) loaded; None without it."""
    if not ns.robot:
        return None
    from tfrec.description import load_description, parse_xacro_args

    ns.robot = package_form(ns.robot, ns.package_path)
    return load_description(ns.robot[0], args=parse_xacro_args(ns.robot[1:]), package_paths=ns.package_path,
                            strict_xacro=getattr(ns, "strict_xacro", False))


def load_robot(ns: argparse.Namespace) -> Robot:
    """The ROBOT argument (with its ``name:=value`` arguments) loaded."""
    return load_robot_and_launch(ns)[0]


def load_robot_and_launch(ns: argparse.Namespace) -> tuple[Robot, LaunchRobot | None]:
    """The ROBOT argument loaded, and what its launch file says when it is one (its ``name:=value``
    arguments are then launch arguments, as for roslaunch). ``PKG FILE.launch`` (roslaunch's form) is
    the launch file found in the package."""
    from tfrec.description import load_description, load_launch, parse_xacro_args
    from tfrec.description.launch import is_launch_file

    ns.robot, *ns.xacro_args = package_form([ns.robot, *ns.xacro_args], ns.package_path)
    args = parse_xacro_args(ns.xacro_args)
    if is_launch_file(ns.robot):
        return load_launch(ns.robot, args=args, package_paths=ns.package_path, strict_xacro=ns.strict_xacro,
                           allow_paths=ns.allow_path)
    return load_description(ns.robot, args=args, package_paths=ns.package_path, strict_xacro=ns.strict_xacro,
                            allow_paths=ns.allow_path), None


def fmt(x: float) -> str:
    return f"{x:.6g}"


def number(x: float) -> str:
    """A default in help texts, as a user would type it: ``1e-9``, not ``1e-09``."""
    mantissa, _, exponent = f"{x:g}".partition("e")
    return f"{mantissa}e{int(exponent)}" if exponent else mantissa


class Progress:
    """A progress bar on stderr, shown only on a terminal and once a recording takes over a second."""

    def __init__(self, stream: TextIO, *, clock: Callable[[], float] | None = None) -> None:
        import time

        self._clock = time.monotonic if clock is None else clock
        self._start = self._clock()
        self._enabled = stream.isatty()
        self._stream = stream
        self._shown = False

    def __call__(self, done: int, total: int) -> None:
        if not self._enabled or (not self._shown and self._clock() - self._start < 1.0):
            return
        self._shown = True
        width = 30
        filled = int(width * done / max(total, 1))
        self._stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {100 * done // max(total, 1):3d}% "
                           f"{done}/{total} samples")
        self._stream.flush()

    def close(self) -> None:
        if self._shown:
            self._stream.write("\n")
            self._stream.flush()


def start_time(text: str) -> int:
    """argparse type of --start-time: decimal seconds since the epoch → exact integer nanoseconds."""
    import decimal

    try:
        seconds = decimal.Decimal(text.strip())
    except decimal.InvalidOperation:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number of seconds")
    if not seconds.is_finite() or seconds < 0:
        raise argparse.ArgumentTypeError(f"{text} is not a time since the epoch in seconds")
    if seconds >= STAMP_LIMIT_NS // NS_PER_S:
        raise argparse.ArgumentTypeError(f"{text}: {STAMP_RANGE}")
    return int((seconds * NS_PER_S).to_integral_value(rounding=decimal.ROUND_HALF_EVEN))


def tolerance(text: str) -> float:
    """argparse type of the tolerances of diff and replay --check: a finite number >= 0."""
    import math

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number")
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text} is not a tolerance (a number >= 0)")
    return value


_FLAGS = {
    "start_s": "--start",
    "end_s": "--end",
    "out": "-o",
    "package_paths": "--package-path",
    "allow_paths": "--allow-path",
    "robot": "--robot",
    "bag": "--bag DIR",
    "frame_prefix": "--frame-prefix",
    "overrides": "--set",
    "ray_timeout_s": "--ray-timeout",
}
"""Library parameters whose flag is not ``--`` + the name with dashes."""

_PARAMETER = re.compile(r"`([A-Za-z_][A-Za-z0-9_]*)`")


def as_flags(message: str) -> str:
    """A library message as the command line says it: each parameter named in backquotes
    (```no_mcap```) becomes its flag (``--no-mcap``)."""
    return _PARAMETER.sub(lambda m: _FLAGS.get(m[1], "--" + m[1].replace("_", "-")), message)


def command(name: str) -> str:
    """How to type the command ``name`` (``rerun``, ``tfrec``) that came with this installation: the bare
    name when it is what the shell finds, else its path (``.venv/bin/rerun`` before the virtual
    environment is activated), so that printed hints work as typed."""
    import os
    import shutil

    installed = Path(sys.executable).parent / name
    found = shutil.which(name)
    if not installed.exists() or (found is not None and Path(found).resolve() == installed.resolve()):
        return name
    try:
        relative = os.path.relpath(installed)
    except ValueError:  # another drive
        return str(installed)
    return str(installed) if relative.startswith("..") else relative
