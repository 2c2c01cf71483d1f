"""``tfrec convert``: a recording cut, filtered and written as another format, nothing latched lost.

- :mod:`~tfrec.convert.run`: :func:`convert` — options, the input's summary, the cut, atomic output;
- :mod:`~tfrec.convert.stream`: the copy, batch by batch (:class:`~tfrec.convert.stream.Copier`):
  selection, the cut with latched topics re-emitted at it, messages carried between ROS 1 and ROS 2;
- :mod:`~tfrec.convert.joints`: TF computed from joint states, as robot_state_publisher would.

Imports replay (its TF derivation and ``--save``), formats and below.
"""

from __future__ import annotations

from tfrec.convert.run import ConvertResult, check_convert_target, convert, output_kind
from tfrec.convert.stream import CopyReport

__all__ = ["ConvertResult", "CopyReport", "check_convert_target", "convert", "output_kind"]
