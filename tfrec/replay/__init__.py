"""``tfrec replay``: a recording played back as ``ros2 bag play`` + robot_state_publisher would, or re-simulated.

- :mod:`~tfrec.replay.load`: what is played (:func:`load_replay`): the robot, latched data, TF per frame pair;
- :mod:`~tfrec.replay.pacing`: when each batch is due on a live viewer;
- :mod:`~tfrec.replay.play`: playing into Rerun (spawned, connected, or an ``.rrd``);
- :mod:`~tfrec.replay.check`: re-simulation (:func:`check_replay`).

Imports formats, resample, kinematics, trajectory, description and the base modules.
"""

from __future__ import annotations

from tfrec.replay.check import CheckReport, FrameCheck, check_replay, format_check
from tfrec.replay.load import Replay, load_replay

__all__ = ["CheckReport", "FrameCheck", "Replay", "check_replay", "format_check", "load_replay"]
