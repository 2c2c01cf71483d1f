"""The joint trajectory type: positions of the actuated joints on an integer-nanosecond clock.

:class:`JointTrajectory` holds its arrays; :class:`GeneratedTrajectory` (what the generators of
:mod:`tfrec.trajectory.generators` return) holds only the times and evaluates each chunk from
its own times when it is streamed, so memory stays flat whatever the duration.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "GeneratedTrajectory",
    "JointTrajectory",
    "Sampler",
    "TrajectoryKind",
]

Array = NDArray[np.float64]


Floats = NDArray[np.floating[Any]]


class TrajectoryKind(str, Enum):
    """The generated trajectory kinds (``--traj``); anything else names a CSV file."""

    CENTER = "center"
    RANDOM = "random"
    SINE = "sine"
    SWEEP = "sweep"


@dataclass(frozen=True, slots=True)
class JointTrajectory:
    """Positions of the actuated joints of a robot over time.

    Attributes:
        joint_names: the actuated joints, in URDF document order.
        time_ns: int64 (N,), strictly increasing nanoseconds from the start of the
            recording (0 for the first sample of the generated kinds).
        positions: float64 (N, J), radians or metres.
        velocities: float64 (N, J), the time derivative of ``positions``.
    """

    joint_names: tuple[str, ...]
    time_ns: NDArray[np.int64]
    positions: Array
    velocities: Array

    def __post_init__(self) -> None:
        n, j = len(self.time_ns), len(self.joint_names)
        if self.time_ns.dtype != np.int64 or self.time_ns.shape != (n,):
            raise ValueError(f"time_ns must be int64 of shape (N,), got {self.time_ns.dtype} {self.time_ns.shape}")
        for name in ("positions", "velocities"):
            array = getattr(self, name)
            if array.dtype != np.float64 or array.shape != (n, j):
                raise ValueError(f"{name} must be float64 of shape {(n, j)}, got {array.dtype} {array.shape}")

    def __len__(self) -> int:
        return len(self.time_ns)

    def chunks(self, size: int) -> Iterator[JointTrajectory]:
        """Consecutive pieces of at most ``size`` samples (views, no copies)."""
        if size < 1:
            raise ValueError(f"chunk size must be at least 1, got {size}")
        for start in range(0, len(self), size):
            stop = start + size
            yield JointTrajectory(
                self.joint_names,
                self.time_ns[start:stop],
                self.positions[start:stop],
                self.velocities[start:stop],
            )


Sampler = Callable[[NDArray[np.int64]], tuple[Array, Array]]
"""Positions and velocities (float64 (n, J)) of a generated trajectory at the given times."""


class GeneratedTrajectory(JointTrajectory):
    """A generated trajectory (``center``, ``random``, ``sine``, ``sweep``), evaluated lazily.

    Only ``time_ns`` is held; :meth:`chunks` evaluates each piece from its own times, so
    streaming a long trajectory never holds its positions and velocities whole. The
    ``positions`` and ``velocities`` attributes evaluate the whole trajectory on first use (and
    keep it). Every sample depends only on its own time, so a piece's values are exactly those
    of the whole.
    """

    __slots__ = ("_sample", "_whole")
    _sample: Sampler
    _whole: tuple[Array, Array] | None

    def __init__(self, joint_names: tuple[str, ...], time_ns: NDArray[np.int64], sample: Sampler) -> None:
        if time_ns.dtype != np.int64 or time_ns.ndim != 1:
            raise ValueError(f"time_ns must be int64 of shape (N,), got {time_ns.dtype} {time_ns.shape}")
        object.__setattr__(self, "joint_names", joint_names)
        object.__setattr__(self, "time_ns", time_ns)
        object.__setattr__(self, "_sample", sample)
        object.__setattr__(self, "_whole", None)

    @property
    def positions(self) -> Array:
        return self._evaluate()[0]

    @property
    def velocities(self) -> Array:
        return self._evaluate()[1]

    def _evaluate(self) -> tuple[Array, Array]:
        whole: tuple[Array, Array] | None = self._whole
        if whole is None:
            whole = self._sample(self.time_ns)
            object.__setattr__(self, "_whole", whole)
        return whole

    def chunks(self, size: int) -> Iterator[JointTrajectory]:
        """Consecutive pieces of at most ``size`` samples, each evaluated on its own."""
        if size < 1:
            raise ValueError(f"chunk size must be at least 1, got {size}")
        if self._whole is not None:
            yield from super().chunks(size)
            return
        for start in range(0, len(self), size):
            time_ns = self.time_ns[start:start + size]
            yield JointTrajectory(self.joint_names, time_ns, *self._sample(time_ns))
