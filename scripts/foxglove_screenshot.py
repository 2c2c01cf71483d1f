"""A Foxglove screenshot of ``tfrec serve robots/marm.xacro --traj sine``, made by code: docs/images/live-foxglove.png.

The Foxglove app is no package, but Foxglove Studio's web app, as last published on npm, is: the package
``@foxglove/studio-base`` (1.48.0, MPL-2.0) holds its webpack build — the ``App`` component, its panels and data
sources, React left to the page. This script installs it with npm into a cache folder (``~/.cache/tfrec-
screenshots``, or ``$TFREC_SCREENSHOT_CACHE``; nothing goes into the repository), with React and playwright-core,
and then:

1. serves a small page on 127.0.0.1 that renders Studio's ``App`` with its Foxglove WebSocket data source and one
   layout — a 3D panel showing ``/robot_description`` (the URDF) placed by ``/tf``, following ``link0``, and a Plot
   of ``/joint_states`` — and the URL parameters ``?ds=foxglove-websocket&ds.url=ws://…`` that make it connect;
2. starts ``tfrec serve robots/marm.xacro --traj sine --duration 60 --loop --port 0`` (a child process);
3. opens the page in headless Chromium (driven by playwright-core; rendered on the CPU by SwiftShader), waits until
   the topics are listed and the robot has moved for a few seconds, and saves the window.

One thing stands between the two: Studio 1.48 (and, by its source, Lichtblick, its fork) asks for the WebSocket
subprotocol ``foxglove.websocket.v1``, and foxglove-sdk 0.30's server accepts ``foxglove.sdk.v1`` (a client asking
only for the old name is refused at the handshake). The messages are the same. So the page connects through a relay on
127.0.0.1 that renames the subprotocol in the HTTP upgrade (request and answer) and then passes the bytes through
unchanged, both ways.

Needs node and npm on PATH and a Chromium (``apt-get install chromium``; or ``$CHROMIUM``); without them it says so
in one line and makes nothing (``make screenshots`` goes on). Not part of the tests.

Usage::

    python scripts/foxglove_screenshot.py                     # docs/images/live-foxglove.png
    python scripts/foxglove_screenshot.py --out /tmp/fox.png --settle-s 8
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import functools
import http.server
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
NAME = "live-foxglove"
# exact versions: the page below is written against this build of Studio
PACKAGES = {"@foxglove/studio-base": "1.48.0", "react": "18.2.0", "react-dom": "18.2.0", "playwright-core": "1.65.1"}
CHROMIUMS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
OLD_SUBPROTOCOL = b"foxglove.websocket.v1"  # what Studio 1.48 and Lichtblick ask for
SDK_SUBPROTOCOL = b"foxglove.sdk.v1"  # what foxglove-sdk 0.30's server accepts
WINDOW = (1280, 800)
# one sine 60 s long: the picture (taken ~15 s in) shows no wrap of --loop, whose restart is a jump in the plot
SERVED = ("robots/marm.xacro", "--traj", "sine", "--duration", "60", "--loop")


class Skipped(Exception):
    """What this machine lacks for the picture, in one line."""


def find_chromium() -> str:
    exe = os.environ.get("CHROMIUM") or next(filter(None, map(shutil.which, CHROMIUMS)), None)
    if exe is None or not Path(exe).exists():
        raise Skipped("no Chromium (apt-get install chromium, or set CHROMIUM=/path/to/chrome)")
    return exe


def cache_folder() -> Path:
    return Path(os.environ.get("TFREC_SCREENSHOT_CACHE") or Path.home() / ".cache" / "tfrec-screenshots")


def install(cache: Path) -> Path:
    """``npm install`` the pinned packages into ``cache`` (once); returns its node_modules."""
    if shutil.which("node") is None or shutil.which("npm") is None:
        raise Skipped("no node/npm on PATH (Foxglove Studio's web build and playwright-core come from npm)")
    modules = cache / "node_modules"
    wanted = {"name": "tfrec-screenshots", "private": True, "dependencies": PACKAGES}
    manifest = cache / "package.json"
    if manifest.exists() and json.loads(manifest.read_text(encoding="utf-8")) == wanted and modules.is_dir():
        return modules
    cache.mkdir(parents=True, exist_ok=True)
    manifest.write_text(json.dumps(wanted, indent=2), encoding="utf-8")
    print(f"{NAME}: npm install {' '.join(f'{k}@{v}' for k, v in PACKAGES.items())} into {cache}", file=sys.stderr)
    done = subprocess.run(["npm", "install", "--no-audit", "--no-fund", "--loglevel", "error"], cwd=cache,
                          capture_output=True, text=True, timeout=900, check=False)
    if done.returncode != 0:
        manifest.unlink()
        raise Skipped(f"npm install failed: {done.stderr.strip().splitlines()[-1:]}")
    return modules


# ---- the page: Studio's App with one data source and one layout -------------------------------------------------

LAYOUT = {
    "configById": {
        "3D!tfrec": {
            "followTf": "link0",
            "followMode": "follow-pose",
            "cameraState": {"distance": 1.0, "perspective": True, "phi": 62, "thetaOffset": 40, "fovy": 45,
                            "target": [0, 0, 0], "targetOffset": [0, 0, 0.18], "targetOrientation": [0, 0, 0, 1],
                            "near": 0.01, "far": 100},
            "scene": {"transforms": {"showLabel": False, "axisScale": 0.3}},
            "topics": {"/robot_description": {"visible": True}},
            "layers": {"grid": {"visible": True, "frameLocked": True, "label": "Grid", "instanceId": "grid",
                                "layerId": "foxglove.Grid", "size": 1, "divisions": 10, "lineWidth": 1,
                                "color": "#248eff", "position": [0, 0, 0], "rotation": [0, 0, 0], "order": 1}},
        },
        "Plot!tfrec": {
            "title": "Plot",
            "paths": [{"value": f"/joint_states.position[{i}]", "enabled": True, "timestampMethod": "headerStamp"}
                      for i in range(3)],
            "showXAxisLabels": True, "showYAxisLabels": True, "showLegend": True, "legendDisplay": "floating",
            "showPlotValuesInLegend": False, "isSynced": True, "xAxisVal": "timestamp",
        },
    },
    "globalVariables": {}, "userNodes": {}, "playbackConfig": {"speed": 1},
    "layout": {"first": "3D!tfrec", "second": "Plot!tfrec", "direction": "column", "splitPercentage": 68},
}

INDEX_HTML = """<!doctype html>
<html><head><meta charset="utf-8"><title>Foxglove Studio</title>
<style>html, body, #root { margin: 0; height: 100%; }</style></head>
<body><div id="root"></div>
<script src="react.production.min.js"></script>
<script src="react-dom.production.min.js"></script>
<script>window["react"] = window.React; window["react-dom"] = window.ReactDOM;  // the bundle's UMD externals</script>
<script src="studio/index.js"></script>
<script src="boot.js"></script>
</body></html>
"""

# What studio-web's entry point gives App: settings, a layout store (in memory, holding our layout, selected through
# the user profile), the data sources. Deep links (?ds=…) open the connection.
BOOT_JS = """
(async () => {
  localStorage.setItem("studio.profile-data", JSON.stringify({
    currentLayoutId: "tfrec", onboarding: { settingsTooltipShownForPanelTypes: ["3D"] } }));
  const settings = new Map(), listeners = new Map();
  const appConfiguration = {
    get: (key) => settings.get(key),
    set: async (key, value) => { settings.set(key, value); (listeners.get(key) || []).forEach((cb) => cb(value)); },
    addChangeListener: (key, cb) => { listeners.set(key, (listeners.get(key) || new Set()).add(cb)); },
    removeChangeListener: (key, cb) => { listeners.get(key)?.delete(cb); },
  };
  const spaces = new Map();
  const space = (name) => { if (!spaces.has(name)) spaces.set(name, new Map()); return spaces.get(name); };
  space("local").set("tfrec", { id: "tfrec", name: "tfrec", permission: "CREATOR_WRITE",
    baseline: { data: LAYOUT, savedAt: new Date().toISOString() }, working: undefined, syncInfo: undefined });
  const layoutStorage = {
    list: async (name) => [...space(name).values()],
    get: async (name, id) => space(name).get(id),
    put: async (name, layout) => { space(name).set(layout.id, layout); return layout; },
    delete: async (name, id) => { space(name).delete(id); },
    importLayouts: async () => {},
    migrateUnnamespacedLayouts: async () => {},
  };
  await initI18n();
  ReactDOM.createRoot(document.getElementById("root")).render(React.createElement(App, {
    appConfiguration, layoutStorage, extensionLoaders: [], enableGlobalCss: true,
    dataSources: [new FoxgloveWebSocketDataSourceFactory()], deepLinks: [window.location.href] }));
})().catch((error) => { document.body.innerText = "boot failed: " + error; });
"""

# The browser side: open, wait for the connection (the topic list names /tf_static), let the robot move, save.
SHOT_CJS = """
const { chromium } = require(process.env.PLAYWRIGHT_CORE);
const [url, out, settleMs, width, height] = process.argv.slice(2);
(async () => {
  const browser = await chromium.launch({ executablePath: process.env.CHROMIUM, headless: true,
    args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"] });
  try {
    const page = await browser.newPage({ viewport: { width: Number(width), height: Number(height) } });
    page.on("pageerror", (error) => console.error("page error:", String(error).slice(0, 300)));
    await page.goto(url);
    await page.getByText("/tf_static", { exact: true }).first().waitFor({ timeout: 60000 });
    await page.waitForTimeout(Number(settleMs));
    if (await page.getByText("boot failed").count()) throw new Error(await page.innerText("body"));
    await page.screenshot({ path: out });
  } finally {
    await browser.close();
  }
})().catch((error) => { console.error(String(error)); process.exit(1); });
"""


def write_page(folder: Path, modules: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "index.html").write_text(INDEX_HTML, encoding="utf-8")
    (folder / "boot.js").write_text(f"const LAYOUT = {json.dumps(LAYOUT)};\n{BOOT_JS}", encoding="utf-8")
    (folder / "studio").symlink_to(modules / "@foxglove" / "studio-base" / "assets")
    for package in ("react", "react-dom"):
        (folder / f"{package}.production.min.js").symlink_to(modules / package / "umd" / f"{package}.production.min.js")


@contextlib.contextmanager
def http_server(folder: Path) -> Iterator[int]:
    """``folder`` over HTTP on 127.0.0.1 (a thread); yields the port."""

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args: object) -> None:
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=os.fspath(folder)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield int(server.server_address[1])
    finally:
        server.shutdown()
        server.server_close()


# ---- the relay: foxglove.websocket.v1 in, foxglove.sdk.v1 out, bytes unchanged after the upgrade ------------------

async def _handshake(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, old: bytes, new: bytes) -> None:
    """Copy one HTTP header block from ``reader`` to ``writer`` with the subprotocol ``old`` named ``new``."""
    head = await reader.readuntil(b"\r\n\r\n")
    lines = head.split(b"\r\n")
    for i, line in enumerate(lines):
        if line.lower().startswith(b"sec-websocket-protocol:"):
            lines[i] = line.replace(old, new)
    writer.write(b"\r\n".join(lines))
    await writer.drain()


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    with contextlib.suppress(ConnectionError):
        while data := await reader.read(1 << 16):
            writer.write(data)
            await writer.drain()
    writer.close()


async def _relay_one(port: int, client_r: asyncio.StreamReader, client_w: asyncio.StreamWriter) -> None:
    server_w = None
    try:
        server_r, server_w = await asyncio.open_connection("127.0.0.1", port)
        await _handshake(client_r, server_w, OLD_SUBPROTOCOL, SDK_SUBPROTOCOL)
        await _handshake(server_r, client_w, SDK_SUBPROTOCOL, OLD_SUBPROTOCOL)
        await asyncio.gather(_pipe(client_r, server_w), _pipe(server_r, client_w))
    except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, ConnectionError):
        pass
    finally:
        for writer in (client_w, server_w):
            if writer is not None:
                writer.close()


async def _shutdown(server: asyncio.Server) -> None:
    server.close()
    tasks = [task for task in asyncio.all_tasks() if task is not asyncio.current_task()]
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)


@contextlib.contextmanager
def subprotocol_relay(server_port: int) -> Iterator[int]:
    """A TCP relay on 127.0.0.1 to ``server_port`` (a thread with its own event loop); yields its port."""
    loop = asyncio.new_event_loop()
    server = loop.run_until_complete(
        asyncio.start_server(functools.partial(_relay_one, server_port), "127.0.0.1", 0))
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        yield int(server.sockets[0].getsockname()[1])
    finally:
        asyncio.run_coroutine_threadsafe(_shutdown(server), loop).result(timeout=30)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout=30)
        loop.close()


# ---- tfrec serve ------------------------------------------------------------------------------------------------

@contextlib.contextmanager
def tfrec_serve(*args: str, log: Path) -> Iterator[int]:
    """``tfrec serve ARGS --port 0`` as a child process, its stderr into ``log``; yields the port it prints.
    Ctrl-C'd (then killed) at the end."""
    with log.open("w", encoding="utf-8") as err:
        proc = subprocess.Popen([sys.executable, "-m", "tfrec", "serve", *args, "--port", "0"], cwd=REPO,
                                stdout=subprocess.PIPE, stderr=err, text=True, start_new_session=True)
    try:
        assert proc.stdout is not None
        first = proc.stdout.readline()  # "serving marm on ws://127.0.0.1:PORT  (…)"
        if "ws://" not in first:
            proc.kill()
            proc.wait(timeout=30)
            raise SystemExit(f"{NAME}: tfrec serve did not start: {first}{log.read_text(encoding='utf-8')}")
        yield int(first.split("ws://", 1)[1].split()[0].rsplit(":", 1)[1])
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.communicate(timeout=30)


def take(out: Path, *, settle_s: float = 6.0) -> Path:
    """Make the picture at ``out`` (PNG). Raises :class:`Skipped` when node, npm or Chromium is missing."""
    chromium = find_chromium()
    modules = install(cache_folder())
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        page = Path(tmp) / "page"
        write_page(page, modules)
        driver = Path(tmp) / "shot.cjs"
        driver.write_text(SHOT_CJS, encoding="utf-8")
        partial = Path(tmp) / f"{NAME}.png"
        serve = tfrec_serve(*SERVED, log=Path(tmp) / "serve.log")
        with http_server(page) as http_port, serve as port, subprotocol_relay(port) as relay_port:
            url = f"http://127.0.0.1:{http_port}/index.html?ds=foxglove-websocket&ds.url=ws://127.0.0.1:{relay_port}"
            env = {**os.environ, "CHROMIUM": chromium, "PLAYWRIGHT_CORE": os.fspath(modules / "playwright-core")}
            done = subprocess.run(["node", os.fspath(driver), url, os.fspath(partial), str(round(settle_s * 1000)),
                                   *map(str, WINDOW)], env=env, capture_output=True, text=True, timeout=300,
                                  check=False)
        if done.returncode != 0 or not partial.exists():
            raise SystemExit(f"{NAME}: the browser did not make the picture: {done.stderr.strip()}")
        shutil.move(partial, out)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images" / f"{NAME}.png", help="the PNG file")
    parser.add_argument("--settle-s", type=float, default=6.0,
                        help="seconds between the connection and the picture (the robot moves, the plot fills)")
    ns = parser.parse_args(argv)
    try:
        print(take(ns.out, settle_s=ns.settle_s))
    except Skipped as why:
        print(f"{NAME}: skipped: {why}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
