"""``tfrec serve`` speed: a 50-frame robot served live at 100 Hz (or ``--rate``) to 0 and to 4 Foxglove clients.

The robot: a serial chain of 49 revolute joints plus a fixed tool frame (50 frames below the base), so every
sample is one /joint_states message of 49 joints and one /tf message of 49 transforms. ``tfrec serve ROBOT --traj
sine --rate HZ --duration S`` runs in a child process; each client is a thread with a WebSocket connection
(subprotocol ``foxglove.sdk.v1``, the ``websockets`` package) subscribed to all four topics, reading everything.

Reported, per run: the samples served (the server's own count), the /tf messages each client received, the rate
they arrived at (messages over the span of their stamps), the loop's lag (server log time minus the sample's due
stamp: median and worst), and the server's CPU time (``RUSAGE_CHILDREN``); CPU per client is the difference
between the runs with clients and without, divided by the clients. Target: >= 100 Hz to 4 clients.

Run from the repository root:

    .venv/bin/python benchmarks/bench_serve.py
"""

from __future__ import annotations

import argparse
import json
import resource
import struct
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np
from _common import machine
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect


def chain_urdf(joints: int = 49) -> str:
    parts = ['<robot name="chain50">', '<link name="link0"/>']
    for i in range(1, joints + 1):
        axis = ("0 0 1", "0 1 0", "1 0 0")[i % 3]
        parts.append(
            f'<link name="link{i}"/><joint name="joint{i}" type="revolute"><parent link="link{i - 1}"/>'
            f'<child link="link{i}"/><origin xyz="0 0 0.1" rpy="0 0 0.3"/><axis xyz="{axis}"/>'
            f'<limit lower="-2.5" upper="2.5" effort="10" velocity="2"/></joint>')
    parts.append(f'<link name="tool0"/><joint name="tool_joint" type="fixed"><parent link="link{joints}"/>'
                 '<child link="tool0"/><origin xyz="0 0 0.05"/></joint></robot>')
    return "".join(parts)


def client(port: int, out: list[tuple[int, int]], ready: threading.Barrier) -> None:
    """Subscribe to everything; keep (log time, first stamp) of every /tf message."""
    with connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], open_timeout=30, max_size=None) as ws:
        channels: dict[str, int] = {}
        while len(channels) < 4:
            message = json.loads(ws.recv(timeout=30))
            if message["op"] == "advertise":
                channels.update({c["topic"]: c["id"] for c in message["channels"]})
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": channel} for i, channel in enumerate(channels.values())]}))
        tf = list(channels).index("/tf")
        ready.wait()
        try:
            while True:
                frame = ws.recv(timeout=60)
                if isinstance(frame, bytes) and frame[0] == 1:
                    sub, log_time = struct.unpack_from("<IQ", frame, 1)
                    if sub == tf:  # CDR header, u32 count, then the first header's stamp (int32 sec, uint32 nsec)
                        sec, nsec = struct.unpack_from("<iI", frame, 13 + 8)
                        out.append((log_time, sec * 1_000_000_000 + nsec))
        except (ConnectionClosed, TimeoutError):
            return


def run(urdf: Path, clients: int, rate: float, duration: float) -> dict[str, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.Popen([sys.executable, "-m", "tfrec", "serve", str(urdf), "--traj", "sine", "--rate", str(rate),
                             "--duration", str(duration), "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    port = int(line.split("ws://", 1)[1].split()[0].rsplit(":", 1)[1])
    received: list[list[tuple[int, int]]] = [[] for _ in range(clients)]
    ready = threading.Barrier(clients + 1)
    threads = [threading.Thread(target=client, args=(port, received[i], ready)) for i in range(clients)]
    for thread in threads:
        thread.start()
    if clients:
        ready.wait()
    _, err = proc.communicate(timeout=duration + 120)
    for thread in threads:
        thread.join(timeout=60)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    served = int(err.split("served ")[1].split()[0])
    result = {"samples": served, "cpu_s": cpu}
    if clients:
        counts = [len(r) for r in received]
        rates = []
        lags = []
        for r in received:
            stamps = np.array([s for _, s in r])
            rates.append((len(stamps) - 1) / ((stamps[-1] - stamps[0]) / 1e9))
            lags.extend((np.array([t for t, _ in r]) - stamps).tolist())
        lag = np.array(lags) - min(lags)  # relative to the best: the clocks of stamps and log times agree here
        result.update(min_received=min(counts), rate_hz=min(rates), lag_median_ms=float(np.median(lag)) / 1e6,
                      lag_worst_ms=float(lag.max()) / 1e6)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--clients", type=int, default=4)
    args = parser.parse_args()
    print(machine("foxglove-sdk", "websockets"))
    with tempfile.TemporaryDirectory() as folder:
        urdf = Path(folder) / "chain50.urdf"
        urdf.write_text(chain_urdf())
        alone = run(urdf, 0, args.rate, args.duration)
        print(f"0 clients: {alone['samples']} samples at {args.rate:g} Hz over {args.duration:g} s, "
              f"server CPU {alone['cpu_s']:.2f} s ({100 * alone['cpu_s'] / args.duration:.1f} % of a core)")
        busy = run(urdf, args.clients, args.rate, args.duration)
        per_client = (busy["cpu_s"] - alone["cpu_s"]) / args.clients
        print(f"{args.clients} clients: {busy['samples']} samples; each client received >= {busy['min_received']} /tf "
              f"at >= {busy['rate_hz']:.1f} Hz; lag median {busy['lag_median_ms']:.2f} ms, worst "
              f"{busy['lag_worst_ms']:.1f} ms; server CPU {busy['cpu_s']:.2f} s "
              f"({100 * busy['cpu_s'] / args.duration:.1f} % of a core), "
              f"{per_client:.3f} s per client ({100 * per_client / args.duration:.2f} % of a core)")


if __name__ == "__main__":
    main()
