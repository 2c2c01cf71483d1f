"""``python -m tfrec``."""

from __future__ import annotations

import sys

from tfrec.cli import main

if __name__ == "__main__":
    sys.exit(main())
