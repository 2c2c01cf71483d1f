"""Regenerate the viewer screenshots in docs/images/ from recordings made here, with the current code.

It records (the code path of ``tfrec record``), replays (``tfrec replay --save``) and diffs
(``tfrec diff A B --rrd``) the repository's robots, opens each ``.rrd`` in a headless Rerun viewer of
the pinned rerun-sdk (``rerun --headless --window-size 1200x800``: no X server needed) and, through
``rerun.experimental.ViewerClient``, pauses at a chosen instant, waits for the start-up notifications
to fade and saves a screenshot of the whole window. (``rerun --screenshot-to`` takes its picture at
once, while the recording is still loading and half covered by notifications.) One viewer per
recording, each in its own process group and temporary folder, ended when its picture is taken.

The viewer renders on the CPU with Mesa's Vulkan driver; without one it panics at start-up, so the
script checks first and says in one line what to install (Debian/Ubuntu: ``mesa-vulkan-drivers``).
Not part of the tests (``make screenshots``).

Then ``live-foxglove``: Foxglove Studio's web app (npm's last build, 1.48) showing ``tfrec serve`` in headless Chromium
(scripts/foxglove_screenshot.py). It needs node, npm and Chromium; without them it is skipped with a one-line
reason and the other pictures are made all the same.

Usage::

    python scripts/screenshots.py                 # every picture, into docs/images/
    python scripts/screenshots.py --only diff-overlay --out /tmp/shots --keep-rrd
    python scripts/screenshots.py --only live-foxglove
"""

from __future__ import annotations

import argparse
import glob
import importlib.util
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tfrec.conventions import DEFAULT_START_TIME_NS
from tfrec.description import load_description
from tfrec.recorder import RecordingPlan, record
from tfrec.trajectory.generators import make_trajectory

REPO = Path(__file__).resolve().parents[1]
ROBOTS = REPO / "robots"
WINDOW = "1200x800"
FOXGLOVE = "live-foxglove"  # the picture scripts/foxglove_screenshot.py makes
VULKAN_ICDS = ("/usr/share/vulkan/icd.d/*.json", "/etc/vulkan/icd.d/*.json", "/usr/local/share/vulkan/icd.d/*.json")


@dataclass(frozen=True)
class Shot:
    name: str
    make: Callable[[Path], Path]
    """Writes the .rrd into the folder given and returns it."""
    at_s: float
    """The instant shown, in seconds from the recording's start."""
    timeline: str = "time"
    """The timeline shown: ``time`` (seconds from the start, the recordings' default) or ``ros_time`` (a date: the
    diff overlay's plots are on it)."""


def _robot(name: str, **args: str):  # type: ignore[no-untyped-def]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # mbot uses legacy xacro macro calls on purpose
        return load_description(ROBOTS / f"{name}.xacro", args=args)


def _record(name: str, traj: str, **options: float) -> Callable[[Path], Path]:
    def make(folder: Path) -> Path:
        robot = _robot(name)
        rrd = folder / f"{name}-{traj}.rrd"
        mcap = folder / f"{name}-{traj}.mcap"
        record(robot, make_trajectory(robot, traj, duration_s=10.0, rate_hz=50.0, **options),
               RecordingPlan(mcap=mcap, rrd=rrd))
        return rrd
    return make


def _replay(name: str, traj: str) -> Callable[[Path], Path]:
    def make(folder: Path) -> Path:
        from tfrec.replay.load import load_replay
        from tfrec.replay.play import replay_to_rerun

        _record(name, traj)(folder)
        out = folder / f"{name}-replayed.rrd"
        replay_to_rerun(load_replay(folder / f"{name}-{traj}.mcap"), save=out)
        return out
    return make


def _diff(folder: Path) -> Path:
    """marm against a copy whose joint2 sits 3 cm higher: every link from link2 on moves by 3 cm."""
    from tfrec.diff.motion import compare_motion
    from tfrec.diff.overlay import write_overlay

    text = (ROBOTS / "marm.xacro").read_text(encoding="utf-8")
    moved = text.replace('<origin xyz="${-link1_length} 0 0" rpy="0 ${-M_PI/2} 0"/>',
                         '<origin xyz="${-link1_length} 0 0.03" rpy="0 ${-M_PI/2} 0"/>')
    assert moved != text, "robots/marm.xacro's joint2 origin changed: update scripts/screenshots.py"
    (folder / "marm-moved.xacro").write_text(moved, encoding="utf-8")
    comparison = compare_motion(ROBOTS / "marm.xacro", folder / "marm-moved.xacro", traj="random")
    return write_overlay(comparison, folder / "diff-overlay.rrd", force=True)


def _mjcf(folder: Path) -> Path:
    """gymnasium's MuJoCo humanoid (its MJCF asset; the test extra installs gymnasium) along --traj sine."""
    spec = importlib.util.find_spec("gymnasium")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("screenshots: the MJCF picture needs gymnasium's assets: pip install -e '.[test]'")
    model = Path(next(iter(spec.submodule_search_locations))) / "envs" / "mujoco" / "assets" / "humanoid.xml"
    robot = load_description(model)
    rrd = folder / "mjcf-humanoid.rrd"
    record(robot, make_trajectory(robot, "sine", duration_s=10.0, rate_hz=50.0, amplitude=0.6),
           RecordingPlan(mcap=folder / "mjcf-humanoid.mcap", rrd=rrd))
    return rrd


def _served(folder: Path) -> Path:
    """What a Rerun viewer receives from ``tfrec serve robots/marm.xacro --traj sine --connect URL``: the real
    ``rerun`` as a gRPC server saving what it gets (``rerun --port P --save out.rrd``), the server a child process."""
    out = folder / "served.rrd"
    port = _free_port()
    rerun_exe = Path(sys.executable).with_name("rerun")
    saver = subprocess.Popen([os.fspath(rerun_exe) if rerun_exe.exists() else "rerun", "--port", str(port), "--save",
                              os.fspath(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
    try:
        deadline = time.monotonic() + 30.0
        while socket.socket().connect_ex(("127.0.0.1", port)) != 0:
            if time.monotonic() > deadline:
                raise SystemExit("screenshots: rerun --save did not listen")
            time.sleep(0.2)
        subprocess.run([sys.executable, "-m", "tfrec", "serve", os.fspath(ROBOTS / "marm.xacro"), "--traj", "sine",
                        "--duration", "6", "--port", "0", "--start-time", str(DEFAULT_START_TIME_NS // 10**9),
                        "--connect", f"rerun+http://127.0.0.1:{port}/proxy"], check=True, timeout=120,
                       stdout=subprocess.DEVNULL)
    finally:
        saver.send_signal(signal.SIGINT)
        try:
            saver.wait(timeout=30)
        except subprocess.TimeoutExpired:
            _stop(saver)  # type: ignore[arg-type]
    return out


SHOTS = (
    Shot("marm", _record("marm", "random"), at_s=3.2),
    Shot("mbot", _record("mbot", "sine", amplitude=0.8), at_s=2.5),
    Shot("simple_cube", _record("simple_cube", "center"), at_s=1.0),
    Shot("replay-marm", _replay("marm", "sine"), at_s=4.0),
    Shot("diff-overlay", _diff, at_s=3.2, timeline="ros_time"),
    Shot("mjcf-humanoid", _mjcf, at_s=2.0),
    Shot("live-rerun", _served, at_s=2.3),
)


def missing_requirements() -> str | None:
    """One line naming the Debian packages to install, or None when everything is there."""
    packages = []
    if not any(glob.glob(pattern) for pattern in VULKAN_ICDS):
        packages.append("mesa-vulkan-drivers")
    if not Path(sys.executable).with_name("rerun").exists() and shutil.which("rerun") is None:
        return "no 'rerun' viewer beside this Python or on PATH: install the project (pip install -e .)"
    if packages:
        return (f"the headless Rerun viewer needs a Vulkan driver (it renders on the CPU with Mesa's); "
                f"install it: apt-get install -y {' '.join(packages)}")
    return None


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _screenshot(rrd: Path, png: Path, *, at_ns: int, settle_s: float, scratch: Path, timeline: str = "time") -> None:
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
                    raise SystemExit("screenshots: the Rerun viewer did not start (is Mesa's Vulkan driver, "
                                     "mesa-vulkan-drivers, installed?)") from None
                time.sleep(0.2)
        client.open(os.fspath(rrd))
        deadline = time.monotonic() + 10.0
        while True:
            try:
                if timeline == "ros_time":
                    client.set_time("ros_time", timestamp=np.datetime64(at_ns, "ns"), play_state="paused")
                else:  # seconds from the start
                    client.set_time(timeline, duration=np.timedelta64(at_ns - DEFAULT_START_TIME_NS, "ns"),
                                    play_state="paused")
                break
            except ConnectionError as err:  # "has no timelines yet": still loading, or all static
                if time.monotonic() > deadline:
                    if "no timelines" in str(err):
                        break  # a robot without moving joints: nothing moves, any time shows it
                    raise
                time.sleep(0.3)
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
    parser.add_argument("--only", nargs="+", choices=[shot.name for shot in SHOTS] + [FOXGLOVE],
                        help="just these pictures")
    parser.add_argument("--keep-rrd", action="store_true", help="keep the recordings beside the PNG files")
    parser.add_argument("--settle-s", type=float, default=7.0,
                        help="seconds to wait before each screenshot, so start-up notifications fade")
    ns = parser.parse_args(argv)

    shots = [shot for shot in SHOTS if not ns.only or shot.name in ns.only]
    problem = missing_requirements() if shots else None
    if problem is not None:
        print(f"screenshots: {problem}", file=sys.stderr)
        return 2
    ns.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for shot in shots:
            folder = Path(tmp) / shot.name
            folder.mkdir()
            rrd = shot.make(folder)
            png = ns.out / f"{shot.name}.png"
            # One viewer per recording: recordings of one application id share the active blueprint.
            _screenshot(rrd, png, at_ns=DEFAULT_START_TIME_NS + round(shot.at_s * 1e9), settle_s=ns.settle_s,
                        scratch=folder, timeline=shot.timeline)
            print(png)
            if ns.keep_rrd:
                shutil.copy(rrd, ns.out / f"{shot.name}.rrd")
    if not ns.only or FOXGLOVE in ns.only:
        return _foxglove(ns.out / f"{FOXGLOVE}.png", asked=bool(ns.only))
    return 0


def _foxglove(png: Path, *, asked: bool) -> int:
    """The optional Foxglove picture (scripts/foxglove_screenshot.py): skipped, with the reason, where node, npm or
    Chromium is missing — an error only when it was asked for by name."""
    spec = importlib.util.spec_from_file_location("foxglove_screenshot", Path(__file__).with_name(
        "foxglove_screenshot.py"))
    assert spec is not None and spec.loader is not None
    foxglove = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(foxglove)
    try:
        print(foxglove.take(png))
    except foxglove.Skipped as why:
        print(f"screenshots: {FOXGLOVE} skipped: {why}", file=sys.stderr)
        return 2 if asked else 0
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
