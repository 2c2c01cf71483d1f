"""``tfrec diff --rrd``: the two robots of a comparison as one Rerun recording, a ghost overlay.

:func:`write_overlay` hands what :func:`tfrec.diff.motion.compare_motion` computed — each side's
transforms at the compared instants and each link's errors — to
:func:`tfrec.viewer.overlay.write_overlay`, atomically (a temporary file beside the target,
renamed when complete). The recording id is derived from the inputs, so the same diff gives the
same recording.
"""

from __future__ import annotations

import hashlib
import os
import uuid
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tfrec._address_space import check_rerun_address_space
from tfrec._atomic import AtomicOutputs
from tfrec._outputs import check_target
from tfrec.conventions import DEFAULT_START_TIME_NS
from tfrec.diff.motion import MotionComparison, Posed
from tfrec.errors import printable
from tfrec.formats.kinds import RRD
from tfrec.recording import Transforms
from tfrec.resample import data_start_ns
from tfrec.viewer.overlay import OverlayErrors, OverlayRobot
from tfrec.viewer.overlay import write_overlay as write_rrd

__all__ = ["write_overlay"]


def write_overlay(
    comparison: MotionComparison,
    path: str | os.PathLike[str],
    *,
    force: bool = False,
    package_paths: Sequence[str | os.PathLike[str]] = (),
) -> Path:
    """Write the ghost overlay of a comparison to the ``.rrd`` file ``path``.

    A solid, each link coloured by its current error; B a translucent ghost; the largest error
    over time with the tolerance; the moments links first exceed it. Stamps are those of the
    recording compared (from its start), or start at tfrec's default start time for two
    descriptions.

    Raises:
        WriteError: ``path`` is not an ``.rrd``, exists (without ``force``), or cannot be written.
    """
    target = Path(path)
    c = comparison
    check_target(target, RRD, force=force, inputs=[c.a.side.path, c.b.side.path])
    check_rerun_address_space(os.fspath(target))
    recordings = [side.side.recording for side in (c.a, c.b) if side.side.recording is not None]
    origin = (data_start_ns(recordings[0]) or 0) if recordings else DEFAULT_START_TIME_NS
    errors = OverlayErrors(c.links, c.position_error, c.rotation_error, c.position_tol, c.rotation_tol)
    with AtomicOutputs(replace=force) as outputs:
        write_rrd(outputs.path(target, kind=RRD), a=_robot(c.a), b=_robot(c.b), stamp_ns=c.time_ns + origin,
                  errors=errors, recording_id=_recording_id(c),
                  name=f"diff {printable(c.a.side.title)} ↔ {printable(c.b.side.title)}",
                  package_paths=package_paths)
        outputs.commit()
    return target


def _robot(posed: Posed) -> OverlayRobot:
    side = posed.side
    description = side.robot.urdf if side.robot is not None else None
    return OverlayRobot(side.robot, posed.static, _filled(posed.dynamic), description or None)


def _filled(tfs: Transforms) -> Transforms:
    """Transforms with the instants a pair has no value (NaN) holding its nearest known value
    (the viewer shows the pair there; the errors keep it unknown)."""
    translation, rotation = tfs.translation.copy(), tfs.rotation.copy()
    for k in range(len(tfs.children)):
        known = np.all(np.isfinite(translation[:, k]), axis=1) & np.all(np.isfinite(rotation[:, k]), axis=1)
        if known.all() or not known.any():
            if not known.any():
                translation[:, k], rotation[:, k] = 0.0, (0.0, 0.0, 0.0, 1.0)
            continue
        index = np.where(known, np.arange(len(known)), 0)
        np.maximum.accumulate(index, out=index)
        index[: int(np.argmax(known))] = int(np.argmax(known))
        translation[:, k], rotation[:, k] = translation[index, k], rotation[index, k]
    return Transforms(tfs.parents, tfs.children, translation, rotation)


def _recording_id(c: MotionComparison) -> str:
    """The same comparison gives the same id."""
    digest = hashlib.sha256()
    for posed in (c.a, c.b):
        shown = posed.side.robot.urdf if posed.side.robot is not None else posed.side.path
        digest.update(shown.encode("utf-8", "surrogateescape") + b"\0")  # a file name that is not UTF-8 too
    digest.update(np.ascontiguousarray(c.time_ns).tobytes())
    digest.update(np.ascontiguousarray(c.position_error).tobytes())
    digest.update(np.ascontiguousarray(c.rotation_error).tobytes())
    return str(uuid.UUID(bytes=digest.digest()[:16], version=5))
