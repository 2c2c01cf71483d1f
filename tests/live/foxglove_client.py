"""A Foxglove WebSocket client for the tests, written from the protocol (subprotocol ``foxglove.sdk.v1``, which
foxglove-sdk's server accepts) on the ``websockets`` package: nothing of tfrec nor of the SDK is used to read what
``tfrec serve`` sends. Messages are decoded with rosbags' CDR deserializer.

Also :func:`serving`: ``tfrec serve`` in a child process on 127.0.0.1 and a free port, stopped (SIGINT, then SIGKILL)
in all cases, under a CPU-time limit (the hang guard).
"""

from __future__ import annotations

import contextlib
import json
import os
import resource
import signal
import struct
import subprocess
import sys
import threading
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from rosbags.typesys import Stores, get_typestore
from websockets.sync.client import ClientConnection, connect

from tests.conftest import REPO

SUBPROTOCOL = "foxglove.sdk.v1"
CPU_LIMIT_S = 30
TYPES = get_typestore(Stores.ROS2_HUMBLE)


@dataclass
class Served:
    """A running ``tfrec serve``: its process, port, and stdout lines so far."""

    proc: subprocess.Popen[str]
    port: int
    lines: list[str] = field(default_factory=list)

    def stop(self, timeout: float = 30.0, *, interrupt: bool = True) -> tuple[int, str, str]:
        """Ctrl-C (unless ``interrupt`` is False: the server ends on its own), then its exit code, stdout and
        stderr."""
        if interrupt and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        out, err = self.proc.communicate(timeout=timeout)
        return self.proc.returncode, "".join(self.lines) + out, err


@contextlib.contextmanager
def serving(args: Sequence[str], *, cwd: str | os.PathLike[str] = REPO) -> Iterator[Served]:
    """``tfrec serve ARGS --port 0`` started; yields once it listens. Killed in the end whatever happened."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "tfrec", "serve", *args, "--port", "0", "--quiet-legacy"], cwd=cwd,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )
    try:
        resource.prlimit(proc.pid, resource.RLIMIT_CPU, (CPU_LIMIT_S, CPU_LIMIT_S + 5))  # the hang guard
        lines: list[str] = []
        ready = threading.Event()

        def first_line() -> None:
            assert proc.stdout is not None
            lines.append(proc.stdout.readline())
            ready.set()

        threading.Thread(target=first_line, daemon=True).start()
        ready.wait(60)
        if not lines or "ws://" not in lines[0]:
            proc.kill()
            _, err = proc.communicate(timeout=30)
            raise AssertionError(f"tfrec serve did not start: {lines} {err}")
        port = int(lines[0].split("ws://", 1)[1].split()[0].rsplit(":", 1)[1])
        yield Served(proc, port, lines)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=20)
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()


@dataclass
class Message:
    topic: str
    log_time_ns: int
    data: bytes

    def decode(self, msgtype: str) -> Any:
        return TYPES.deserialize_cdr(self.data, msgtype)


class Client:
    """One connection: the server's hello read (serverInfo, advertise, advertiseServices), then what it asks."""

    def __init__(self, port: int) -> None:
        self.ws: ClientConnection = connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], open_timeout=20,
                                            max_size=None)
        self.info: dict[str, Any] = {}
        self.channels: dict[str, dict[str, Any]] = {}
        self.services: dict[str, dict[str, Any]] = {}
        self.subscriptions: dict[int, str] = {}
        self.messages: list[Message] = []
        self.json: list[dict[str, Any]] = []
        self.binary: list[bytes] = []
        self.closed = False
        while not (self.info and self.channels and (self.services or "services" not in self.info["capabilities"])):
            self._take(self.ws.recv(timeout=20))

    def close(self) -> None:
        self.ws.close()

    def subscribe(self, *topics: str) -> None:
        subs = []
        for topic in topics:
            sub_id = len(self.subscriptions) + 1
            self.subscriptions[sub_id] = topic
            subs.append({"id": sub_id, "channelId": self.channels[topic]["id"]})
        self.send({"op": "subscribe", "subscriptions": subs})

    def send(self, message: dict[str, Any]) -> None:
        self.ws.send(json.dumps(message))

    def call_service(self, name: str, call_id: int, payload: bytes = b"\x00\x01\x00\x00\x00\x00\x00\x00") -> None:
        service = self.services[name]
        encoding = b"cdr"
        self.ws.send(struct.pack("<BIII", 2, service["id"], call_id, len(encoding)) + encoding + payload)

    def _take(self, frame: str | bytes) -> None:
        if isinstance(frame, str):
            message = json.loads(frame)
            self.json.append(message)
            if message["op"] == "serverInfo":
                self.info = message
            elif message["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in message["channels"]})
            elif message["op"] == "advertiseServices":
                self.services.update({s["name"]: s for s in message["services"]})
            return
        if frame[0] == 1:  # message data: u32 subscription, u64 log time, payload
            sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
            self.messages.append(Message(self.subscriptions[sub_id], log_time, bytes(frame[13:])))
        else:
            self.binary.append(bytes(frame))

    def read(self, *, until: Any = None, timeout: float = 20.0, limit: int = 100_000) -> None:
        """Read frames until ``until(self)`` is true, the server closes, or ``limit`` frames."""
        from websockets.exceptions import ConnectionClosed

        for _ in range(limit):
            if until is not None and until(self):
                return
            try:
                self._take(self.ws.recv(timeout=timeout))
            except ConnectionClosed:
                self.closed = True
                return

    def on(self, topic: str) -> list[Message]:
        return [m for m in self.messages if m.topic == topic]

    def ops(self, op: str) -> list[dict[str, Any]]:
        return [m for m in self.json if m.get("op") == op]

    def asset(self, request_id: int) -> tuple[int, bytes] | None:
        """(status, data or error text) of a fetchAsset answer (opcode 4)."""
        for frame in self.binary:
            if frame[0] == 4 and struct.unpack_from("<I", frame, 1)[0] == request_id:
                status = frame[5]
                (length,) = struct.unpack_from("<I", frame, 6)
                return status, frame[10 + length:] if status == 0 else frame[10:10 + length]
        return None

    def service_response(self, call_id: int) -> bytes | None:
        """The payload of a service call response (opcode 3) to ``call_id``."""
        for frame in self.binary:
            if frame[0] == 3:
                _, got, length = struct.unpack_from("<III", frame, 1)
                if got == call_id:
                    return frame[13 + length:]
        return None
