"""`make screenshots` (scripts/screenshots.py): what it needs is checked first, and a machine without it
gets one line naming the Debian package to install — no traceback."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

from tests.conftest import REPO


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("screenshots", REPO / "scripts" / "screenshots.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_no_vulkan_driver_is_one_line(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
                                      tmp_path: Path) -> None:
    screenshots = _script()
    monkeypatch.setattr(screenshots.glob, "glob", lambda pattern: [])  # no Vulkan ICD on this machine
    assert screenshots.main(["--out", str(tmp_path)]) == 2
    out = capsys.readouterr()
    assert out.out == ""
    assert out.err == ("screenshots: the headless Rerun viewer needs a Vulkan driver (it renders on the CPU with "
                       "Mesa's); install it: apt-get install -y mesa-vulkan-drivers\n")
    assert not list(tmp_path.iterdir())


def test_the_makefile_has_the_target() -> None:
    assert "\nscreenshots:" in (REPO / "Makefile").read_text()
