"""The per-file functions of a fleet run: :func:`check_recording` and :func:`diff_pair`.

Each takes paths and plain options (so that it pickles, to a process pool or a Ray cluster),
reads what it needs itself, and returns report rows (:class:`tfrec.fleet.row.Row`): first the
summary, which holds the verdict, then one row per finding. They never raise for a bad
recording: what :class:`tfrec.errors.TfrecError` says about it becomes an ``error`` row, and
warnings become notes in the summary; a bug still raises (the engine reports it as that file's
``error`` row, traceback included).

:func:`check_recording` is ``tfrec replay --check`` (:func:`tfrec.replay.load_replay` and
:func:`tfrec.replay_check.check_replay`) plus the health checks of :mod:`tfrec.fleet.health`,
on one read of the recording. :func:`diff_pair` is ``tfrec diff`` (:func:`tfrec.diff.compare`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import re
import time
import warnings
import zlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import CHECK_POS_TOL, CHECK_ROT_TOL, DIFF_JOINT_TOL, DIFF_POS_TOL, DIFF_ROT_TOL
from tfrec.errors import FleetError, TfrecError, one_line
from tfrec.fleet.fingerprint import Fingerprint, fingerprint
from tfrec.fleet.health import DEFAULT_GAP_PERIODS, Finding, StampFold, series_findings
from tfrec.fleet.row import ERROR, FAIL, PASS, Row

if TYPE_CHECKING:
    from tfrec.model import Robot
    from tfrec.replay.check import CheckReport, FrameCheck
    from tfrec.replay.motion_checks import MotionChecker
    from tfrec.replay.pieces import ReplayPiece
    from tfrec.replay.prepared import Replay

__all__ = ["Row", "check_recording", "diff_pair"]

_NOT_RECORDED = "not in the recording"
"""How :func:`tfrec.replay_check.check_replay` starts the problem of a frame the recording lacks."""


def _row(base: Mapping[str, object], **fields: object) -> Row:
    return Row(**{**base, **fields})  # type: ignore[arg-type]


def _finding_row(base: Mapping[str, object], finding: Finding) -> Row:
    return _row(base, check=finding.check, topic=finding.topic, frame=finding.frame, max_error=finding.max_error,
                unit=finding.unit, first_exceed_s=finding.first_exceed_s, verdict=FAIL, detail=finding.detail)


def _notes(caught: Sequence[warnings.WarningMessage], skip: Sequence[str] = ()) -> list[str]:
    """The warnings caught, one line each and each once, leaving out those that say ``skip``."""
    out: list[str] = []
    for warning in caught:
        text = one_line(str(warning.message))
        if text not in out and not any(s and s in text for s in skip):
            out.append(text)
    return out


@functools.lru_cache(maxsize=8)
def _robot(path: str, args: tuple[str, ...], package_paths: tuple[str, ...], strict_xacro: bool,
           stamp: tuple[int, int]) -> Robot:
    """The robot of a description file, loaded once per worker (``stamp``: the file's size and
    time, so that an edited file is loaded again); its URDF text left out, so that a replay's
    ``robot_description`` is the recording's own."""
    from tfrec.description import load_description, parse_xacro_args

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # legacy xacro calls: the driver saw them when it loaded the file first
        robot = load_description(path, args=parse_xacro_args(args), package_paths=package_paths,
                                 strict_xacro=strict_xacro)
    return dataclasses.replace(robot, urdf="")


def _file_stamp(path: str) -> tuple[int, int]:
    try:
        stat = os.stat(path)
    except OSError:
        return (-1, -1)
    return (stat.st_size, stat.st_mtime_ns)


def _fixed(value: float) -> str:
    return "0" if value == 0 else f"{value:.3g}"


# -- tfrec check ---------------------------------------------------------------------------------


def check_recording(
    path: str | os.PathLike[str],
    *,
    robot_path: str | os.PathLike[str] | None = None,
    robot_args: Sequence[str] = (),
    package_paths: Sequence[str | os.PathLike[str]] = (),
    strict_xacro: bool = False,
    pos_tol: float = CHECK_POS_TOL,
    rot_tol: float = CHECK_ROT_TOL,
    gap_periods: float = DEFAULT_GAP_PERIODS,
    config: str = "",
    max_accel: float | None = None,
) -> list[Row]:
    """Check one recording as a fleet needs it: re-simulation, health and motion.

    Findings (``fail`` rows), in this order:

    - ``read``: the file is damaged; what was readable is checked.
    - ``description``: no /robot_description in the recording and no ``robot_path`` (with one it
      is no finding: ROS 1 keeps the description as a parameter, so a bag ``rosbag record`` wrote
      never has it), or one that is not a usable URDF (then nothing is re-simulated unless
      ``robot_path`` is given).
    - ``stamps``, ``rate``: zero or repeated header stamps, gaps (:mod:`tfrec.fleet.health`), per
      /joint_states and /tf frame pair.
    - ``frames``: a frame of the robot on neither /tf nor /tf_static.
    - ``resim``: a recorded transform further than ``pos_tol`` (``unit`` m) or ``rot_tol``
      (rad) from TF re-simulated from the joint states, with the time it first exceeds it; a
      frame that cannot be compared (wrong parent, moving joint on /tf_static); or a recording
      that cannot be re-simulated (no /joint_states, no /tf).
    - ``motion``: what the robot could not have done (:mod:`tfrec.replay.motion_checks`): a joint beyond its
      limits or soft limits, faster than its velocity limit, accelerating over ``max_accel``, jumping, a
      non-finite position, a mimic joint not following its master; ``frame`` is the joint.

    Args:
        path: a recording (``.mcap``, rosbag2 folder, ROS 1 ``.bag``, ``.rrd``).
        robot_path: re-simulate with this description instead of the recording's own.
        robot_args: xacro arguments of ``robot_path``, ``name:=value``.
        package_paths: folders searched first for ``$(find pkg)`` in ``robot_path``.
        strict_xacro: refuse legacy macro calls in ``robot_path``.
        pos_tol, rot_tol: the re-simulation's tolerances (m, rad), as ``replay --check``'s.
        gap_periods: a gap longer than this many median periods is a finding.
        config: the run's :func:`tfrec.fleet.plan.check_config`, copied to every row.
        max_accel: the largest joint acceleration (rad/s² or m/s²); None: not checked.

    Returns:
        The summary row (verdict ``pass``, ``fail``, or ``error`` when the recording cannot
        be read at all), then the findings.
    """
    file = os.fspath(path)
    base: dict[str, object] = {"file": file, "config": config}
    try:
        stamp = fingerprint(path)
    except FleetError as err:
        return [_row(base, verdict=ERROR, detail=str(err))]
    base.update(size=stamp.size, mtime_ns=stamp.mtime_ns, fingerprint=stamp.key)
    robot = None
    if robot_path is not None:
        where = os.fspath(robot_path)
        try:
            robot = _robot(where, tuple(robot_args), tuple(os.fspath(p) for p in package_paths), strict_xacro,
                           _file_stamp(where))
        except TfrecError as err:
            return [_row(base, verdict=ERROR, detail=f"robot_path: {one_line(str(err))}")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        started = time.perf_counter()
        try:
            # one read, piece by piece: each piece re-simulated, its stamps kept for the health checks
            replay, stamps, checked = _check_pieces(path, robot, pos_tol=pos_tol, rot_tol=rot_tol,
                                                    max_accel=max_accel)
        except _Unreadable as err:
            return [_row(base, verdict=ERROR, detail=one_line(str(err.error)), read_s=time.perf_counter() - started)]
        read_s = stamps.read_s
        examined = _examine(replay, stamps, checked, gap_periods=gap_periods)
    notes = _notes(caught, skip=[replay.read_error or "", "/robot_description"])
    base["robot"] = replay.robot.name if replay.robot is not None else ""
    findings = examined.findings
    detail = examined.summary + (f"; {len(findings)} finding{'s' if len(findings) != 1 else ''}" if findings else "")
    if notes:
        detail += "; notes: " + "; ".join(notes)
    times = [f.first_exceed_s for f in findings if f.first_exceed_s is not None]
    compared = [f for f in examined.frames if f.problem is None and f.samples]
    largest: dict[str, object] = {}
    if compared:
        worst = max(compared, key=lambda f: f.translation_m)
        largest = {"max_error": worst.translation_m, "unit": "m", "frame": worst.frame}
    head = _row(base, verdict=FAIL if findings else PASS, detail=detail, read_s=read_s,
                first_exceed_s=min(times) if times else None, **largest)
    return [head, *(_finding_row(base, f) for f in findings)]


@dataclass
class _Examined:
    """What :func:`_examine` found: the findings, the summary's text, the frames re-simulated."""

    findings: list[Finding]
    summary: str
    frames: list[FrameCheck] = field(default_factory=list)


class _Unreadable(Exception):
    """What reading a recording raised (not re-simulating it)."""

    def __init__(self, error: TfrecError) -> None:
        super().__init__(str(error))
        self.error = error


class _Stamps(Mapping[tuple[str, str], StampFold]):
    """The stamps of the first robot's /joint_states and recorded /tf pairs, piece by piece, folded for the health
    checks (:class:`tfrec.fleet.health.StampFold`) and kept compressed (the differences between consecutive stamps,
    zlib): a series is whole again (sorted by stamp, as a reader gives it) only when its fold cannot tell (stamps that
    go back from one piece to the next, or a clock with more distinct periods than the fold keeps)."""

    def __init__(self) -> None:
        self.joint_states: list[tuple[int, bytes]] = []
        self.joint_fold = StampFold()
        self.tf: dict[tuple[str, str], list[tuple[int, bytes]]] = {}
        self.tf_folds: dict[tuple[str, str], StampFold] = {}
        self.first_joint_ns: int | None = None
        self.last_joint_ns: int | None = None
        self.joint_count = 0
        self.read_s = 0.0  # spent reading and preparing the pieces
        self.motion: MotionChecker | None = None  # the joint states against the robot's limits
        self._motion_fed: int | None = None  # the last stamp fed to it

    def feed_motion(self, replay: Replay, max_accel: float | None) -> None:
        """Feed the piece's joint states that are its own (later than those fed: a piece begins with the last
        positions of the piece before it) to the motion checks."""
        js = replay.joint_states
        if replay.robot is None or js is None or not len(js):
            return
        if self.motion is None:
            from tfrec.replay.motion_checks import MotionChecker

            self.motion = MotionChecker(replay.robot, max_accel=max_accel)
        rows = slice(None) if self._motion_fed is None else slice(
            int(np.searchsorted(js.time_ns, self._motion_fed, side="right")), None)
        self.motion.feed(js.names, js.time_ns[rows], js.positions[rows])
        self._motion_fed = int(js.time_ns[-1])

    @staticmethod
    def _packed(stamps: NDArray[np.int64]) -> tuple[int, bytes]:
        return len(stamps), zlib.compress(np.diff(stamps, prepend=np.int64(0)).tobytes(), 1)

    @staticmethod
    def _whole(parts: Sequence[tuple[int, bytes]]) -> NDArray[np.int64]:
        out = np.empty(sum(n for n, _ in parts), dtype=np.int64)
        at = 0
        for n, data in parts:  # each piece's stamps in place, without a copy of the whole series
            np.cumsum(np.frombuffer(zlib.decompress(data), dtype=np.int64), out=out[at : at + n])
            at += n
        if len(out) > 1 and not bool((out[1:] >= out[:-1]).all()):
            out.sort()  # a stamp that arrived after a later piece's
        return out

    def _folded(self, fold: StampFold, parts: Sequence[tuple[int, bytes]]) -> StampFold:
        return fold if fold.exact else StampFold.of(self._whole(parts))

    def add(self, piece: ReplayPiece) -> None:
        robot = piece.replay.robots[0]
        own = piece.joint_stamps.get(robot.joint_states_namespace)
        if robot.joint_states is not None and own is not None and len(own):
            self.joint_states.append(self._packed(own))
            self.joint_fold.add(own)
            self.joint_count += len(own)
            first, last = int(own.min()), int(own.max())
            self.first_joint_ns = first if self.first_joint_ns is None else min(first, self.first_joint_ns)
            self.last_joint_ns = last if self.last_joint_ns is None else max(last, self.last_joint_ns)
        for pair, series in robot.tf.items():
            if pair not in robot.derived_dynamic and len(series):
                self.tf.setdefault(pair, []).append(self._packed(series.time_ns))
                self.tf_folds.setdefault(pair, StampFold()).add(series.time_ns)

    def joint_stamps(self) -> StampFold | None:
        return self._folded(self.joint_fold, self.joint_states) if self.joint_states else None

    def __getitem__(self, pair: tuple[str, str]) -> StampFold:
        return self._folded(self.tf_folds[pair], self.tf[pair])

    def __iter__(self) -> Iterator[tuple[str, str]]:
        return iter(self.tf)

    def __len__(self) -> int:
        return len(self.tf)


def _check_pieces(path: str | os.PathLike[str], robot: Robot | None, *, pos_tol: float, rot_tol: float,
                  max_accel: float | None = None) -> tuple[Replay, _Stamps, CheckReport | TfrecError | None]:
    """Read a recording piece by piece (:func:`tfrec.replay.pieces.replay_pieces`), re-simulating each
    (:func:`tfrec.replay.check.check_pieces`) when it has a usable robot model, keeping the stamps and feeding
    each piece's own joint states to the motion checks (``stamps.motion``).

    Returns:
        (the last piece's replay, the stamps, the re-simulation: its report, why it could not be done, or None
        without a robot model).

    Raises:
        _Unreadable: what reading said.
    """
    from tfrec.replay.check import check_pieces
    from tfrec.replay.pieces import replay_pieces

    stamps = _Stamps()
    last: list[Replay] = []

    def watched() -> Iterator[ReplayPiece]:
        pieces = replay_pieces(path, robot=robot)
        while True:
            started = time.perf_counter()
            try:
                piece = next(pieces, None)
            except TfrecError as err:
                raise _Unreadable(err) from err
            finally:
                stamps.read_s += time.perf_counter() - started
            if piece is None:
                return
            stamps.add(piece)
            stamps.feed_motion(piece.replay, max_accel)
            last[:] = [piece.replay]
            yield piece

    checked: CheckReport | TfrecError | None
    try:
        checked = check_pieces(watched(), pos_tol=pos_tol, rot_tol=rot_tol)[0]
    except _Unreadable:
        raise
    except TfrecError as err:
        checked = err
        if not last:  # a bad tolerance, said before reading: read for the health checks
            for _ in watched():
                pass
    replay = last[0]
    return replay, stamps, None if replay.robot is None else checked


def _examine(replay: Replay, stamps: _Stamps, checked: CheckReport | TfrecError | None, *,
             gap_periods: float) -> _Examined:
    """The findings about a recording read, and the summary's text."""
    findings: list[Finding] = []
    if replay.read_error is not None:
        findings.append(Finding("read", "", "", replay.read_error))
    if replay.robot_description is None:
        if replay.robot is None:  # else it came from robot_path: ROS 1's description is a parameter, not a topic
            findings.append(Finding("description", "/robot_description", "", "no /robot_description in the recording"))
    elif replay.robot is None:
        findings.append(Finding("description", "/robot_description", "", _unusable(replay.robot_description)))
    health = series_findings(stamps.joint_stamps(), stamps, replay.origin_ns, gap_periods=gap_periods)
    parts = []
    count, first, last = stamps.joint_count, stamps.first_joint_ns, stamps.last_joint_ns
    if count > 1 and first is not None and last is not None and last > first:
        span_s = (last - first) / 1e9
        parts.append(f"{count:,} joint states over {span_s:.3f} s ({(count - 1) / span_s:.4g} Hz)")
    frames: list[Finding] = []
    resim: list[Finding] = []
    compared: list[FrameCheck] = []
    if replay.robot is None:
        parts.insert(0, "nothing re-simulated (no usable robot description)")
    elif isinstance(checked, TfrecError):
        resim.append(Finding("resim", "", "", f"cannot re-simulate: {one_line(str(checked))}"))
    elif checked is not None:
        compared = checked.frames
        frames, resim = _frame_findings(replay, checked)
        parts.insert(0, _check_summary(checked))
        parts.extend(checked.notes)
    motion = _motion_findings(stamps.motion, replay.origin_ns) if replay.robot is not None else []
    return _Examined([*findings, *health, *frames, *resim, *motion], "; ".join(parts), compared)


def _motion_findings(checker: MotionChecker | None, origin_ns: int) -> list[Finding]:
    """What the motion checks found (:class:`tfrec.replay.motion_checks.MotionChecker`), as findings."""
    if checker is None:
        return []
    return [Finding("motion", "/joint_states", f.joint, f.detail(origin_ns), f.value if math.isfinite(f.value) else None,
                    f.unit, (f.first_ns - origin_ns) / 1e9) for f in checker.findings()]


def _unusable(description: str) -> str:
    from tfrec.description import parse_urdf

    try:
        parse_urdf(description, source=None, user_lines=False)
    except TfrecError as err:
        return f"/robot_description is not a usable robot description: {one_line(str(err))}"
    return "/robot_description is not a usable robot description"


def _check_summary(report: CheckReport) -> str:
    compared = [f for f in report.frames if f.problem is None and f.samples]
    text = f"{len(compared)} of {len(report.frames)} frames re-simulated"
    if compared:
        t = max(compared, key=lambda f: f.translation_m)
        r = max(compared, key=lambda f: f.rotation_rad)
        text += (f" (largest errors {_fixed(t.translation_m)} m at {t.frame}, {_fixed(r.rotation_rad)} rad at "
                 f"{r.frame}; tolerances {report.pos_tol:g} m, {report.rot_tol:g} rad)")
    return text


def _frame_findings(replay: Replay, report: CheckReport) -> tuple[list[Finding], list[Finding]]:
    """(``frames`` findings, ``resim`` findings) of a re-simulation's frames."""
    frames: list[Finding] = []
    resim: list[Finding] = []
    for f in report.frames:
        if f.problem is not None:
            kind = "frames" if f.problem.startswith(_NOT_RECORDED) else "resim"
            (frames if kind == "frames" else resim).append(Finding(kind, f.topic, f.frame, f"{f.frame}: {f.problem}"))
            continue
        over_t, over_r = f.translation_m > report.pos_tol, f.rotation_rad > report.rot_tol
        if not (over_t or over_r):
            continue
        first_t, first_r = _first_exceed(f, report.pos_tol, report.rot_tol, report.origin_ns)
        if over_t:
            resim.append(Finding(
                "resim", f.topic, f.frame,
                f"{f.frame}: translation off by up to {_fixed(f.translation_m)} m"
                + ("" if f.translation_time_s is None else f" at t={f.translation_time_s:.3f} s")
                + ("" if first_t is None else f"; first above {report.pos_tol:g} m at t={first_t:.3f} s"),
                f.translation_m, "m", first_t))
        if over_r:
            resim.append(Finding(
                "resim", f.topic, f.frame,
                f"{f.frame}: rotation off by up to {_fixed(f.rotation_rad)} rad"
                + ("" if f.rotation_time_s is None else f" at t={f.rotation_time_s:.3f} s")
                + ("" if first_r is None else f"; first above {report.rot_tol:g} rad at t={first_r:.3f} s"),
                f.rotation_rad, "rad", first_r))
    return frames, resim


def _first_exceed(frame: FrameCheck, pos_tol: float, rot_tol: float, origin_ns: int) -> tuple[float | None, float | None]:
    """When a failing /tf frame's translation and rotation errors first exceed the tolerances (seconds
    since the recording's start), from the errors the check kept; None for latched transforms."""
    errors = frame.errors
    if errors is None or frame.topic == "/tf_static":
        return None, None
    return (_first_over(errors.translation_m, pos_tol, errors.time_ns, origin_ns),
            _first_over(errors.rotation_rad, rot_tol, errors.time_ns, origin_ns))


def _first_over(error: NDArray[np.float64], tol: float, stamps: NDArray[np.int64], origin_ns: int) -> float | None:
    over = ~(error <= tol)  # NaN counts as over
    if not over.any():
        return None
    return (int(stamps[int(np.argmax(over))]) - origin_ns) / 1e9


# -- tfrec diff DIR_A DIR_B ----------------------------------------------------------------------

_TOPIC_OF_KIND = {"tf": "/tf", "tf_static": "/tf_static", "joint_states": "/joint_states",
                  "description": "/robot_description"}

_ROBOT_NAME = re.compile(r"<robot\b[^>]*?\bname\s*=\s*[\"']([^\"']*)[\"']")


def _robot_name(description: str | None) -> str:
    found = None if description is None else _ROBOT_NAME.search(description)
    return found.group(1) if found else ""


def _pair_fingerprint(prints: Sequence[Fingerprint | None]) -> dict[str, object]:
    present = [p for p in prints if p is not None]
    return {
        "size": sum(p.size for p in present),
        "mtime_ns": max(p.mtime_ns for p in present) if present else None,
        "fingerprint": "|".join("-" if p is None else p.key for p in prints),
    }


def diff_pair(
    a: str | os.PathLike[str] | None,
    b: str | os.PathLike[str] | None,
    *,
    key: str | None = None,
    pos_tol: float = DIFF_POS_TOL,
    rot_tol: float = DIFF_ROT_TOL,
    joint_tol: float = DIFF_JOINT_TOL,
    topics: Sequence[str] | None = None,
    absolute: bool = False,
    config: str = "",
) -> list[Row]:
    """Compare two recordings as ``tfrec diff`` does; one side missing is a finding.

    Args:
        a, b: the recordings at one relative path under the two folders (None: none there).
        key: the report's ``file`` (the relative path); default: ``a``'s path, else ``b``'s.
        pos_tol, rot_tol, joint_tol, topics, absolute: as :func:`tfrec.diff.compare`'s.
        config: the run's :func:`tfrec.fleet.plan.diff_config`, copied to every row.

    Returns:
        The summary row (``pass`` when equal within tolerance, ``fail`` with differences or a
        missing side, ``error`` when a recording cannot be read), then one row per difference
        (``check`` is the difference's kind; ``missing`` for a recording on one side only).
    """
    started = time.perf_counter()
    if a is None and b is None:
        raise ValueError("diff_pair needs a or b")
    file = key if key is not None else os.fspath(a if a is not None else b)  # type: ignore[arg-type]
    base: dict[str, object] = {"file": file, "config": config}
    prints: list[Fingerprint | None] = []
    for side in (a, b):
        try:
            prints.append(None if side is None else fingerprint(side))
        except FleetError as err:
            return [_row(base, verdict=ERROR, detail=str(err))]
    base.update(_pair_fingerprint(prints))
    if a is None or b is None:
        present, absent = ("B", "A") if a is None else ("A", "B")
        where = os.fspath(b if a is None else a)  # type: ignore[arg-type]
        detail = f"only in {present} ({where}); no recording at this path in {absent}"
        return [_row(base, verdict=FAIL, detail=detail),
                _row(base, check="missing", verdict=FAIL, detail=detail)]
    from tfrec.diff.compare import compare

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            report = compare(a, b, pos_tol=pos_tol, rot_tol=rot_tol, joint_tol=joint_tol, topics=topics,
                             absolute=absolute)
        except TfrecError as err:
            return [_row(base, verdict=ERROR, detail=one_line(str(err)), read_s=time.perf_counter() - started)]
    notes = [*report.notes, *_notes(caught, skip=[n for n in (report.a.read_error, report.b.read_error) if n])]
    base["robot"] = _robot_name(report.a.robot_description) or _robot_name(report.b.robot_description)
    rows = [_difference_row(base, d.kind, d.what, d.detail, d.value, d.time_s) for d in report.differences]
    detail = report.verdict
    largest = report.largest.get("translation")
    rotation = report.largest.get("rotation")
    if largest is not None or rotation is not None:
        shown = [f"{q} {_fixed(v.value)} {u}" for q, u, v in (("translation", "m", largest), ("rotation", "rad", rotation))
                 if v is not None]
        detail += "; largest " + ", ".join(shown)
    if notes:
        detail += "; notes: " + "; ".join(dict.fromkeys(one_line(n) for n in notes))
    head = _row(base, verdict=FAIL if rows else PASS, detail=detail,
                first_exceed_s=min((r.first_exceed_s for r in rows if r.first_exceed_s is not None), default=None),
                **({} if largest is None else {"max_error": largest.value, "unit": "m", "frame": largest.what}))
    return [head, *rows]


def _difference_row(base: Mapping[str, object], kind: str, what: str, detail: str, value: float | None,
                    time_s: float | None) -> Row:
    unit = ""
    if value is not None:
        if kind == "joint_states":
            unit = "joint"
        elif detail.startswith(f"{what}: translation"):
            unit = "m"
        elif detail.startswith(f"{what}: rotation"):
            unit = "rad"
    topic = what if kind == "topic" else _TOPIC_OF_KIND.get(kind, "")
    if value is not None and not math.isfinite(value):
        value = math.inf
    return _row(base, check=kind, topic=topic, frame="" if kind == "topic" else what, max_error=value, unit=unit,
                first_exceed_s=time_s, verdict=FAIL, detail=detail)

