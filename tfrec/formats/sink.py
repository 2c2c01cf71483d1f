"""What ``tfrec record`` writes through: the :class:`RecordSink` protocol every output of a recording follows.

The MCAP sink (:class:`tfrec.formats.mcap.sink.McapSink`), the ROS 1 bag sink
(:class:`tfrec.formats.rosbag1.sink.Ros1BagSink`) — each a thin layer over its format's one writer — and the Rerun
sink (:class:`tfrec.viewer.sink.RerunSink`) take the same calls, so :func:`tfrec.recorder.record` streams a
trajectory through any of them the same way, chunk by chunk, in bounded memory.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from tfrec.recording import Transforms

__all__ = ["RecordSink"]


@runtime_checkable
class RecordSink(Protocol):
    """A recording being written: :meth:`begin` once, :meth:`write_chunk` for consecutive pieces of a trajectory,
    then :meth:`finish`; after an error, :meth:`abort` (the caller deletes the output)."""

    def begin(self, *, robot_description: str, static: Transforms, start_time_ns: int) -> None:
        """Start the output: the robot's description and its static transforms (N = 1), stamped ``start_time_ns``
        (ns since the epoch)."""

    def write_chunk(self, *, stamp_ns: NDArray[np.int64], joint_names: Sequence[str], positions: NDArray[np.float64],
                    velocities: NDArray[np.float64], transforms: Transforms) -> None:
        """Add N samples: joint states (N, J) and the dynamic transforms (N, K), stamped ``stamp_ns`` (int64 (N,),
        increasing across calls)."""

    def finish(self) -> None:
        """Write what is left (an index, a summary) and close the output."""

    def abort(self) -> None:
        """Give the output up after an error (safe in any state)."""
