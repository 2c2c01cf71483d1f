"""``tfrec diff``: two recordings (or robot descriptions) compared by meaning, not by bytes.

- :mod:`~tfrec.diff.compare`: :func:`compare` (:mod:`~tfrec.diff.topics`: topics paired across namespaces, type
  aliases); :mod:`~tfrec.diff.asserts`: :func:`assert_recordings_match`;
- :mod:`~tfrec.diff.report`: the :class:`DiffReport`, as text or JSON;
- :mod:`~tfrec.diff.urdf`: two URDFs compared element by element;
- :mod:`~tfrec.diff.inputs`: each input a description or a recording, and the motion descriptions follow;
- :mod:`~tfrec.diff.motion`: :func:`compare_descriptions` and :func:`assert_descriptions_match`: two
  descriptions driven along one motion, every link's world pose compared;
- :mod:`~tfrec.diff.motion_report`: the :class:`DescriptionDiffReport`, as text or JSON;
- :mod:`~tfrec.diff.overlay`: the two robots of a diff as one Rerun recording (``--rrd``).

Imports formats, resample, kinematics, description and the base modules.
"""

from __future__ import annotations

from tfrec.diff.asserts import assert_recordings_match
from tfrec.diff.compare import compare
from tfrec.diff.motion import MotionComparison, assert_descriptions_match, compare_descriptions, compare_motion
from tfrec.diff.motion_report import DescriptionDiffReport, LinkDelta
from tfrec.diff.report import Difference, DiffReport
from tfrec.diff.urdf import diff_robots, diff_urdf_texts

__all__ = [
    "DescriptionDiffReport",
    "DiffReport",
    "Difference",
    "LinkDelta",
    "MotionComparison",
    "assert_descriptions_match",
    "assert_recordings_match",
    "compare",
    "compare_descriptions",
    "compare_motion",
    "diff_robots",
    "diff_urdf_texts",
]
