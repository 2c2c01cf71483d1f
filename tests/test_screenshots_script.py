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


def _foxglove_script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("foxglove_screenshot", REPO / "scripts" / "foxglove_screenshot.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_foxglove_without_chromium_is_one_line(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
                                               tmp_path: Path) -> None:
    """The Foxglove picture asked for by name on a machine without Chromium: one line, exit 2, nothing made."""
    monkeypatch.delenv("CHROMIUM", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))  # no chromium, node nor npm to be found
    monkeypatch.setenv("TFREC_SCREENSHOT_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "out"
    assert _script().main(["--only", "live-foxglove", "--out", str(out)]) == 2
    got = capsys.readouterr()
    assert got.out == ""
    assert got.err == ("screenshots: live-foxglove skipped: no Chromium (apt-get install chromium, or set "
                       "CHROMIUM=/path/to/chrome)\n")
    assert not (out / "live-foxglove.png").exists()
    assert not (tmp_path / "cache").exists()


def test_foxglove_skipped_in_the_whole_run_is_no_failure(monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """In `make screenshots` (no --only) the missing Foxglove tools skip that one picture: the run still succeeds."""
    monkeypatch.delenv("CHROMIUM", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert _script()._foxglove(tmp_path / "live-foxglove.png", asked=False) == 0
    assert capsys.readouterr().err.startswith("screenshots: live-foxglove skipped: no Chromium")
    assert not (tmp_path / "live-foxglove.png").exists()


def test_foxglove_without_node_is_one_line(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
                                           tmp_path: Path) -> None:
    monkeypatch.setenv("CHROMIUM", sys.executable)  # a file that exists: Chromium is not what is missing
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    monkeypatch.setenv("TFREC_SCREENSHOT_CACHE", str(tmp_path / "cache"))
    assert _foxglove_script().main(["--out", str(tmp_path / "fox.png")]) == 2
    got = capsys.readouterr()
    assert got.err == ("live-foxglove: skipped: no node/npm on PATH (Foxglove Studio's web build and playwright-core "
                       "come from npm)\n")
    assert not (tmp_path / "fox.png").exists()
    assert not (tmp_path / "cache").exists()


def test_foxglove_relay_renames_the_subprotocol_only() -> None:
    """Studio 1.48 asks for ``foxglove.websocket.v1``, which foxglove-sdk's server refuses; through the script's
    relay a client asking for that name is served by a real ``tfrec serve``: it is told the name it asked for, and
    gets the server's hello and data (a subscription goes up, /tf messages come down)."""
    pytest.importorskip("foxglove")
    import json

    from websockets.exceptions import InvalidHandshake
    from websockets.sync.client import connect

    from tests.live.foxglove_client import serving

    relay = _foxglove_script().subprotocol_relay
    with serving(["robots/marm.xacro", "--traj", "sine", "--loop"]) as served:
        with pytest.raises(InvalidHandshake):  # why the relay exists
            connect(f"ws://127.0.0.1:{served.port}", subprotocols=["foxglove.websocket.v1"], open_timeout=20).close()
        with relay(served.port) as port, connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.websocket.v1"],
                                                 open_timeout=20, max_size=None) as ws:
            assert ws.subprotocol == "foxglove.websocket.v1"
            hello = [json.loads(ws.recv(timeout=20)) for _ in range(2)]
            assert hello[0]["op"] == "serverInfo"
            channels = {c["topic"]: c["id"] for m in hello if m["op"] == "advertise" for c in m["channels"]}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": channels["/tf"]}]}))
            for _ in range(1000):
                frame = ws.recv(timeout=20)
                if isinstance(frame, bytes) and frame[0] == 1:  # message data, subscription 7
                    assert int.from_bytes(frame[1:5], "little") == 7
                    break
            else:
                raise AssertionError("no /tf message through the relay")
