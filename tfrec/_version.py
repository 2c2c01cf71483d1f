"""tfrec's version: one place, read by the package face, the writers (an MCAP header's ``library``, a report's
metadata) and the build (``pyproject.toml``), without importing any stage."""

from __future__ import annotations

__all__ = ["__version__"]

__version__ = "0.1.0"
