"""Recordings compared in a test: :func:`assert_recordings_match`."""

from __future__ import annotations

import os
from typing import Any

from tfrec.diff.compare import compare
from tfrec.diff.report import DiffReport
from tfrec.recording import Recording

__all__ = ["assert_recordings_match"]


def assert_recordings_match(
    a: Recording | str | os.PathLike[str],
    b: Recording | str | os.PathLike[str],
    **options: Any,
) -> DiffReport:
    """Fail a test, with the readable report, unless the recordings match.

    Args:
        a, b: recordings or paths.
        **options: :func:`compare`'s keyword arguments (tolerances, topics, absolute).

    Returns:
        The report, when the recordings match.

    Raises:
        AssertionError: the recordings differ; the message is :meth:`DiffReport.to_text`.

    A or B may be a robot description too (a :class:`~tfrec.model.Robot`, or a path that is no
    recording): then it is :func:`tfrec.diff.assert_descriptions_match`.
    """
    __tracebackhide__ = True  # pytest: show the report, not this frame
    from tfrec.diff.inputs import is_description

    if is_description(a) or is_description(b):
        from tfrec.diff.motion import assert_descriptions_match

        return assert_descriptions_match(a, b, **options)  # type: ignore[return-value]
    report = compare(a, b, **options)
    if not report.equal:
        raise AssertionError("recordings differ: " + report.to_text())
    return report
