"""The ``tfrec`` command line: the only package that parses argv, prints and picks exit codes."""

from __future__ import annotations

from tfrec.cli._main import main, main_exit

__all__ = ["main", "main_exit"]
