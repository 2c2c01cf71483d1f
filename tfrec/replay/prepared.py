"""What a replay plays: a recording's robots (:class:`~tfrec.recording.RecordedRobot`), each with its model, latched
data and TF, cut to a window.

:func:`tfrec.replay.load.load_replay` builds a :class:`Replay`; :mod:`tfrec.replay.play` plays it
and :mod:`tfrec.replay.check` re-simulates it.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import NS_PER_S
from tfrec.errors import TfrecWarning
from tfrec.model import Robot
from tfrec.recording import FrameSeries, JointStates, RecordedRobot

__all__ = ["Replay"]

Array = NDArray[np.float64]
Pair = tuple[str, str]


@dataclass
class Replay:
    """A recording prepared for playing: its robots, each with its data.

    Attributes:
        path: the recording read.
        format: ``mcap``, ``rosbag2``, ``rosbag1`` or ``rrd``.
        robots: each robot of the recording (:func:`tfrec.robots.find_robots`) prepared for playing: a
            :class:`~tfrec.recording.RecordedRobot` with its model, its data within the cut and what the model adds
            (``derived_static``, ``derived_dynamic``).
        origin_ns: the recording's start, its first /joint_states or /tf stamp: ``start_s`` and
            reported times count from it.
        start_ns, end_ns: the first and last stamp replayed (None when no sample is left).
        read_error: where reading a damaged file stopped, or None.
        time_base: ``header`` (stamps) or ``log`` (``use_log_time``): what the times are.

    The attributes ``robot``, ``robot_description``, ``frame_prefix``, ``static``, ``tf``,
    ``joint_states``, ``derived_static`` and ``derived_dynamic`` are the first robot's (the only
    robot of most recordings).
    """

    path: str
    format: str
    robots: list[RecordedRobot]
    origin_ns: int
    start_ns: int | None
    end_ns: int | None
    read_error: str | None = None
    time_base: str = "header"
    _damage_reported: bool = field(default=False, repr=False)

    @property
    def robot(self) -> Robot | None:
        return self.robots[0].model

    @property
    def robot_description(self) -> str | None:
        return self.robots[0].robot_description

    @property
    def frame_prefix(self) -> str:
        return self.robots[0].frame_prefix

    @property
    def static(self) -> dict[Pair, tuple[Array, Array]]:
        return self.robots[0].tf_static

    @property
    def tf(self) -> dict[Pair, FrameSeries]:
        return self.robots[0].tf

    @property
    def joint_states(self) -> JointStates | None:
        return self.robots[0].joint_states

    @property
    def derived_static(self) -> frozenset[Pair]:
        return self.robots[0].derived_static

    @property
    def derived_dynamic(self) -> frozenset[Pair]:
        return self.robots[0].derived_dynamic

    @property
    def derived(self) -> frozenset[Pair]:
        """Every pair that robot_state_publisher's part of the replay added, of every robot."""
        return frozenset().union(*(robot.derived for robot in self.robots))

    def derived_summary(self) -> str:
        """What the models added, for the replay's summary line, or ``""`` when nothing.

        ``TF of 7 frames computed from the joint states and of 12 fixed frames taken from the
        robot description``.
        """
        parts = []
        dynamic = sum(len(robot.derived_dynamic) for robot in self.robots)
        fixed = sum(len(robot.derived_static) for robot in self.robots)
        if dynamic:
            parts.append(f"{dynamic} frame{'s' if dynamic != 1 else ''} computed from the joint states")
        if fixed:
            source = "robot descriptions" if len(self.robots) > 1 else "robot description"
            parts.append(f"{fixed} fixed frame{'s' if fixed != 1 else ''} taken from the {source}")
        return "TF of " + " and of ".join(parts) if parts else ""

    def seconds(self, time_ns: int) -> float:
        """A stamp as seconds from the recording's start (``origin_ns``)."""
        return (time_ns - self.origin_ns) / NS_PER_S

    def frames(self) -> list[str]:
        """Every frame id of the first robot's transforms, in order of appearance."""
        return self.robots[0].frames()

    def root_frame(self) -> str | None:
        """The frame the first robot's 3D view is drawn in."""
        return self.robots[0].root_frame()

    def report_damage(self) -> None:
        """Warn once, for a damaged file, where reading stopped and how far the replay went."""
        if self.read_error is None or self._damage_reported:
            return
        self._damage_reported = True
        upto = "" if self.end_ns is None else f"; replayed up to t={self.seconds(self.end_ns):.3f} s"
        warnings.warn(self.read_error + upto, TfrecWarning, stacklevel=2)
