"""``python -m tfrec``."""

from __future__ import annotations

from tfrec.cli import main_exit

if __name__ == "__main__":
    main_exit()
