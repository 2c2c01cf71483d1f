"""``tfrec diff``: two recordings (or robot descriptions) compared by meaning, not by bytes.

- :mod:`~tfrec.diff.compare`: :func:`compare` and :func:`assert_recordings_match`;
- :mod:`~tfrec.diff.report`: the :class:`DiffReport`, as text or JSON;
- :mod:`~tfrec.diff.urdf`: two URDFs compared element by element.

Imports formats, resample, kinematics, description and the base modules.
"""

from __future__ import annotations

from tfrec.diff.compare import assert_recordings_match, compare
from tfrec.diff.report import Difference, DiffReport
from tfrec.diff.urdf import diff_robots, diff_urdf_texts

__all__ = ["DiffReport", "Difference", "assert_recordings_match", "compare", "diff_robots", "diff_urdf_texts"]
