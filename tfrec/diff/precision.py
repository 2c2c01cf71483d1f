"""What a float32 value can tell apart: the tolerance of a comparison with an ``.rrd``.

Rerun stores transforms as float32; a float64 value rounds to the nearest float32, off by up to
half a float32 epsilon of its magnitude. Compared with such a value, a difference below
:func:`float32_tolerance` is rounding, not a difference.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["FLOAT32_EPS", "FLOAT32_ULPS", "float32_tolerance"]

FLOAT32_EPS = float(np.finfo(np.float32).eps)
"""2⁻²³ ≈ 1.19e-7: the spacing of float32 values between 1 and 2."""

FLOAT32_ULPS = 4
"""A float32 transform is compared within this many float32 epsilons of its magnitude."""


def float32_tolerance(tol: float, magnitude: NDArray[np.float64]) -> NDArray[np.float64]:
    """``max(tol, 4·eps32·|magnitude|)``: the smallest difference float32 values of that magnitude
    tell apart (with margin for rounding on either side and in the composition), or ``tol`` when larger."""
    out: NDArray[np.float64] = np.maximum(tol, FLOAT32_ULPS * FLOAT32_EPS * np.abs(magnitude))
    return out
