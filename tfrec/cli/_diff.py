"""``tfrec diff``: compare two recordings, or two robot descriptions (or one of each), by meaning."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Sequence
from typing import Any

from tfrec.cli._common import (
    add_naming_arguments,
    add_xacro_arguments,
    as_flags,
    number,
    show,
    tolerance,
)
from tfrec.conventions import (
    DIFF_JOINT_TOL,
    DIFF_POS_TOL,
    DIFF_ROT_TOL,
)
from tfrec.errors import DiffError

__all__ = ["add_parser", "split_inputs"]


def add_parser(sub: Any) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers)."""
    diff = sub.add_parser(
        "diff", help="compare two recordings or robot descriptions by meaning (description, TF, joints)",
        usage="tfrec diff A [name:=value ...] B [name:=value ...] [options]",
        description="Compare two recordings — MCAP, rosbag2 folder, ROS 1 bag or tfrec .rrd — by meaning: the "
                    "robot description as URDF, topics, joint positions and transforms, aligned by the time "
                    "since each recording's start (its first /joint_states or /tf stamp). A or B may also be a "
                    "robot description (.urdf, .xacro, a MuJoCo .xml), with its xacro arguments right after it: descriptions "
                    "are driven along one motion (--traj, or --joints REC; a recording's own /joint_states) and "
                    "every link's world pose is compared. Exit 0 when identical within tolerance, 1 when "
                    "different, 2 on error.",
    )
    diff.add_argument("inputs", metavar="A [name:=value ...] B [name:=value ...]", nargs="+",
                      help="two recordings (.mcap, rosbag2 folder, ROS 1 .bag, .rrd) or descriptions (.urdf, "
                           ".xacro); xacro arguments belong to the input they follow")
    diff.add_argument("--pos-tol", metavar="M", type=tolerance, default=DIFF_POS_TOL,
                      help=f"translations within M metres are equal (default {number(DIFF_POS_TOL)})")
    diff.add_argument("--rot-tol", metavar="RAD", type=tolerance, default=DIFF_ROT_TOL,
                      help=f"rotations within RAD radians are equal (default {number(DIFF_ROT_TOL)})")
    diff.add_argument("--joint-tol", metavar="X", type=tolerance, default=DIFF_JOINT_TOL,
                      help=f"joint positions within X (rad or m) are equal (default {number(DIFF_JOINT_TOL)})")
    diff.add_argument("--topics", metavar="TOPIC", nargs="+", help="compare only these topics (recordings; default: all)")
    diff.add_argument("--absolute", action="store_true",
                      help="align samples on their stamps, not on the time since each recording's start (recordings)")
    diff.add_argument("--json", action="store_true", help="print the report as JSON")
    add_naming_arguments(diff.add_argument_group("recordings: robots and topics"))
    motion = diff.add_argument_group("descriptions")
    motion.add_argument("--traj", metavar="KIND", default=None,
                        help="the trajectory both descriptions follow: random (default; seeded, a new configuration "
                             "every 0.5 s), sweep, sine, center or a CSV file")
    motion.add_argument("--duration", metavar="S", type=float, default=10.0, help="seconds (default 10)")
    motion.add_argument("--rate", metavar="HZ", type=float, default=50.0, help="samples per second (default 50)")
    motion.add_argument("--seed", metavar="N", type=int, default=0, help="seed of --traj random (default 0)")
    motion.add_argument("--joints", metavar="REC", default=None,
                        help="follow the /joint_states of this recording instead (with a recording as A or B: "
                             "that one, the default)")
    motion.add_argument("--package-path", metavar="DIR", action="append", default=[],
                        help="a package, or a folder of packages, for $(find pkg) and package:// (repeatable)")
    motion.add_argument("--map", metavar="A_NAME:=B_NAME", action="append", default=[], type=_mapping,
                        help="a joint or frame named A_NAME in A is B_NAME in B (repeatable): e.g. a URDF and the "
                             "MuJoCo model made from it with renamed joints")
    add_xacro_arguments(motion)
    out = diff.add_argument_group("output")
    out.add_argument("--rrd", metavar="OUT.rrd", default=None,
                     help="also write both robots moving together as one Rerun recording: A solid and coloured "
                          "by its error, B a translucent ghost, the error over time with the tolerance")
    out.add_argument("--plot", metavar="OUT",
                     help="draw the errors over time, worst first, with the tolerance and the first time it is "
                          "exceeded: each TF frame's for two recordings, each link's world displacement over the "
                          "shared motion for a description (OUT.png, .svg or .pdf)")
    out.add_argument("--force", action="store_true",
                     help="replace an existing --rrd, --plot or --report file tfrec would write there (never another file, nor an input)")
    diff.formatter_class = argparse.RawDescriptionHelpFormatter
    diff.epilog = ("examples:\n  tfrec diff golden.mcap new.mcap\n"
                   "  tfrec diff a.mcap b.bag --pos-tol 1e-6 --json\n"
                   "  tfrec diff before.mcap after.mcap --plot diff.png\n"
                   "  tfrec diff arm.xacro arm-v2.xacro --rrd diff.rrd\n"
                   "  tfrec diff arm.xacro arm.xacro hand:=true --traj sweep\n"
                   "  tfrec diff robot.urdf robot.xml --pos-tol 1e-5 --rot-tol 1e-5     (a URDF and its MuJoCo model)\n"
                   "  tfrec diff robot_log.mcap arm-v2.xacro\n"
                   "  tfrec diff goldens/ tonight/ --report diff.parquet --jobs 8     (folders: pairs by relative path)")
    from tfrec.cli._fleet import add_ci_arguments, add_engine_arguments

    add_engine_arguments(diff)
    add_ci_arguments(diff)
    diff.set_defaults(handler=_cmd_diff)


def _mapping(text: str) -> tuple[str, str]:
    """``--map a:=b`` → ``("a", "b")``."""
    old, sep, new = text.partition(":=")
    if not sep or not old or not new:
        raise argparse.ArgumentTypeError(f"'{text}' is not A_NAME:=B_NAME")
    return old, new


def split_inputs(tokens: list[str], package_paths: Sequence[str] = ()) -> tuple[tuple[str, dict[str, str]],
                                                                           tuple[str, dict[str, str]]]:
    """``A [name:=value ...] B [name:=value ...]`` → ((A, A's arguments), (B, B's arguments)); A or B may be
    given in roslaunch's form ``PKG FILE.launch`` (:func:`tfrec.cli._common.package_form`).

    Raises:
        DiffError: not exactly two inputs, arguments before the first input, or a malformed argument.
        DescriptionError: a ``PKG FILE`` whose file is not found.
    """
    from tfrec.cli._common import package_form
    from tfrec.description import parse_xacro_args

    resolved: list[str] = []
    rest = list(tokens)
    while rest:
        first, *rest = package_form(rest, package_paths)
        resolved.append(first)
    groups: list[tuple[str, list[str]]] = []
    for token in resolved:
        if ":=" in token:
            if not groups:
                raise DiffError(f"xacro argument '{token}' before A: arguments follow the input they belong to")
            groups[-1][1].append(token)
        else:
            groups.append((token, []))
    if len(groups) != 2:
        found = ", ".join(path for path, _ in groups) or "none"
        raise DiffError(f"diff takes two inputs, A and B, each followed by its xacro arguments; got {len(groups)} "
                        f"({found})")
    (a, args_a), (b, args_b) = groups
    return (a, parse_xacro_args(args_a)), (b, parse_xacro_args(args_b))


def _folder_of_recordings(path: str) -> bool:
    """A folder that is not itself one rosbag2 recording: ``tfrec diff DIR_A DIR_B`` pairs the recordings
    in two of them by relative path."""
    from pathlib import Path

    from tfrec.errors import ReadError
    from tfrec.formats import recording_format

    if not Path(path).is_dir():
        return False
    try:
        recording_format(path)  # a rosbag2 bag (with its metadata.yaml, or split files of one bag)
    except ReadError:
        return True
    return False


def _check_outputs(ns: argparse.Namespace, inputs: list[str | None]) -> None:
    """``--rrd`` and ``--plot``, checked together before anything is read (:func:`tfrec._outputs.check_outputs`);
    ``inputs``: A, B, ``--joints`` and ``--traj`` (a CSV file unless it names a kind of trajectory)."""
    from pathlib import Path

    from tfrec._outputs import OutputKind, check_outputs
    from tfrec.formats.kinds import RRD
    from tfrec.trajectory.types import TrajectoryKind

    outputs: list[tuple[Path, OutputKind]] = []
    if ns.rrd is not None:
        outputs.append((Path(ns.rrd), RRD))
    if ns.plot is not None:
        from tfrec.plots import picture_kind, plot_format

        plot_format(ns.plot)
        outputs.append((Path(ns.plot), picture_kind(ns.plot)))
    from tfrec.cli._fleet import ci_targets

    outputs += ci_targets(ns)
    check_outputs(outputs, force=ns.force, inputs=[path for path in inputs
                                                   if path not in TrajectoryKind._value2member_map_])


def _refuse(options: Iterable[tuple[object, str]], why: str) -> None:
    """Raise for the first option given (not None) that does not apply: ```flag` <why>``.

    Raises:
        DiffError: such an option.
    """
    for given, flag in options:
        if given is not None:
            raise DiffError(f"`{flag}` {why}")


def _cmd_diff(ns: argparse.Namespace) -> int:
    from tfrec.diff.revision import Revisions

    with Revisions() as revisions:  # REV:PATH inputs: the revision's files in a temporary folder, removed after
        return _diff(ns, revisions)


def _diff(ns: argparse.Namespace, revisions: Any) -> int:
    from tfrec.diff.inputs import is_recording_path

    (given_a, args_a), (given_b, args_b) = split_inputs(ns.inputs, ns.package_path)
    a, b = revisions.path(given_a), revisions.path(given_b)
    if ns.joints is not None:
        ns.joints = revisions.path(ns.joints)
    if _folder_of_recordings(a) and _folder_of_recordings(b) and not args_a and not args_b:
        from tfrec.cli._fleet import run_diff_folders

        _refuse(((ns.rrd, "rrd"), (ns.plot, "plot"), (ns.traj, "traj"), (ns.joints, "joints"),
                 (ns.json or None, "json")), f"compares two recordings; {a} and {b} are folders of recordings "
                "(use `report` for the results)")
        ns.a, ns.b = a, b
        return run_diff_folders(ns)
    _check_outputs(ns, [a, b, ns.joints, ns.traj])
    tolerances = {"pos_tol": ns.pos_tol, "rot_tol": ns.rot_tol, "joint_tol": ns.joint_tol}
    recordings = is_recording_path(a) and is_recording_path(b) and not args_a and not args_b
    if recordings:
        _refuse(((ns.traj, "traj"), (ns.joints, "joints")), f"drives descriptions; {a} and {b} are both recordings")
        from tfrec.diff.compare import compare

        report: Any = compare(a, b, topics=ns.topics, absolute=ns.absolute, namespace=ns.namespace, remap=ns.remap,
                              use_log_time=ns.use_log_time, whole=ns.plot is not None,
                              **tolerances)
    else:
        _refuse(((ns.topics, "topics"), (ns.absolute or None, "absolute")),
                f"compares two recordings; {a} or {b} is a robot description")
    comparison = None
    if not recordings or ns.rrd is not None:
        from tfrec.diff.motion import compare_motion

        comparison = compare_motion(a, b, args_a=args_a, args_b=args_b, traj=ns.traj, duration_s=ns.duration,
                                    rate_hz=ns.rate, seed=ns.seed, joints=ns.joints, package_paths=ns.package_path,
                                    strict_xacro=ns.strict_xacro, names=dict(ns.map), **tolerances)
        if not recordings:
            report = comparison.report
    if ns.rrd is not None and comparison is not None:
        from tfrec.diff.overlay import write_overlay

        write_overlay(comparison, ns.rrd, force=ns.force, package_paths=ns.package_path)
    show(*revisions.shown(report.to_json() if ns.json else as_flags(report.to_text()).rstrip("\n")).split("\n"))
    if ns.plot is not None and recordings:
        from tfrec.plots import plot_diff

        plot_diff(report, ns.plot, force=ns.force)
    elif ns.plot is not None and comparison is not None:  # descriptions: each link's world displacement
        from tfrec.plots import plot_motion

        plot_motion(comparison, ns.plot, force=ns.force)
    if ns.plot is not None:
        show(f"wrote {ns.plot}", file=sys.stderr if ns.json else sys.stdout)
    if ns.rrd is not None:
        show(f"wrote {ns.rrd}   (open with: rerun {ns.rrd})", file=sys.stderr if ns.json else sys.stdout)
    if ns.junit is not None or ns.summary is not None or ns.format != "text":
        from tfrec.cli._fleet import emit_ci
        from tfrec.fleet.ci import case_from_diff

        files = [None if recordings or is_recording_path(path) or path != given else path
                 for path, given in ((a, given_a), (b, given_b))]  # a REV:PATH side has no line to point at
        artefacts = [path for path in (ns.rrd, ns.plot) if path is not None]
        emit_ci(ns, [case_from_diff(report, a=given_a, b=given_b, files=files, artefacts=artefacts)], suite="diff",
                title=f"tfrec diff {given_a} {given_b}", artefacts=[])
    return 0 if report.equal else 1
