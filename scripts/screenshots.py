"""Regenerate the viewer screenshots in docs/images/ from recordings made here.

For each robot it records a short ``sine`` trajectory to a ``.rrd`` (the same code path as
``tfrec record --no-mcap``), opens it in a headless Rerun viewer of the pinned rerun-sdk
(``rerun --headless --window-size 1280x800``), and through ``rerun.experimental.ViewerClient`` pauses
at a chosen instant, waits for the start-up notifications to fade and saves a screenshot of the whole
window. (``rerun --screenshot-to`` takes its picture at once, while the recording is still loading,
playing, and half covered by notifications.) One viewer per recording, each in its own process group
and temporary folder, ended when its picture is taken.

The viewer renders on a CPU with Mesa's Vulkan driver (Debian/Ubuntu: ``apt-get install
mesa-vulkan-drivers``); without a Vulkan driver it panics at start-up. Not part of the tests.

Usage::

    python scripts/screenshots.py                 # docs/images/mbot.png, docs/images/marm.png
    python scripts/screenshots.py --out /tmp/shots --keep-rrd
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tfrec.description import load_description
from tfrec.recorder import DEFAULT_START_TIME_NS, RecordingPlan, record
from tfrec.trajectory.generators import make_trajectory

REPO = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Shot:
    name: str
    robot: str
    amplitude: float
    at_s: float
    """The instant of the trajectory shown, in seconds from its start."""


SHOTS = (
    Shot("mbot", "robots/mbot.xacro", amplitude=0.8, at_s=2.5),
    Shot("marm", "robots/marm.xacro", amplitude=0.25, at_s=4.0),
)
WINDOW = "1280x800"


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _record(shot: Shot, folder: Path) -> Path:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # mbot uses legacy xacro macro calls on purpose
        robot = load_description(REPO / shot.robot)
    trajectory = make_trajectory(robot, "sine", duration_s=10.0, rate_hz=50.0, amplitude=shot.amplitude)
    rrd = folder / f"{shot.name}.rrd"
    record(robot, trajectory, RecordingPlan(mcap=None, rrd=rrd))
    return rrd


def _screenshot(rrd: Path, png: Path, *, at_ns: int, settle_s: float, scratch: Path) -> None:
    """Open ``rrd`` in a fresh headless viewer, pause at ``at_ns`` and save the window to ``png``."""
    from rerun.experimental import ViewerClient

    rerun_exe = Path(sys.executable).with_name("rerun")
    port = _free_port()
    # its own process group: the `rerun` launcher runs the viewer binary as a child, which must go too
    viewer = subprocess.Popen(
        [os.fspath(rerun_exe) if rerun_exe.exists() else "rerun", "--headless", "--hide-welcome-screen",
         "--port", str(port), "--window-size", WINDOW],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
        env={**os.environ, "TMPDIR": os.fspath(scratch)},  # the viewer's rerun-data-* folder goes there
    )
    try:
        deadline = time.monotonic() + 30.0
        while True:
            try:
                client = ViewerClient.connect(f"rerun+http://127.0.0.1:{port}/proxy")
                client.get_state()
                break
            except ConnectionError:  # not listening yet
                if time.monotonic() > deadline or viewer.poll() is not None:
                    raise SystemExit("the Rerun viewer did not start (is a Vulkan driver installed?)") from None
                time.sleep(0.2)
        client.open(os.fspath(rrd))
        client.set_time("ros_time", timestamp=np.datetime64(at_ns, "ns"), play_state="paused")
        time.sleep(settle_s)  # start-up notifications fade; chunks load; the paused frame is painted
        client.save_screenshot(os.fspath(png.resolve()))
    finally:
        _stop(viewer)


def _stop(viewer: subprocess.Popen[bytes]) -> None:
    """End the viewer's process group: SIGTERM, then SIGKILL after 10 s."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(viewer.pid, sig)
        except ProcessLookupError:
            return
        try:
            viewer.wait(timeout=10)
        except subprocess.TimeoutExpired:
            continue
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:  # the launcher is gone; wait for the binary too
            try:
                os.killpg(viewer.pid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images", help="folder for the PNG files")
    parser.add_argument("--keep-rrd", action="store_true", help="keep the recordings beside the PNG files")
    parser.add_argument("--settle-s", type=float, default=6.0,
                        help="seconds to wait before each screenshot, so start-up notifications fade")
    ns = parser.parse_args(argv)

    ns.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for shot in SHOTS:
            rrd = _record(shot, Path(tmp))
            png = ns.out / f"{shot.name}.png"
            # One viewer per recording: recordings of one application id share the active blueprint.
            _screenshot(rrd, png, at_ns=DEFAULT_START_TIME_NS + round(shot.at_s * 1e9), settle_s=ns.settle_s,
                        scratch=Path(tmp))
            print(png)
            if ns.keep_rrd:
                shutil.copy(rrd, ns.out / rrd.name)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
