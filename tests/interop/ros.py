"""Running Debian's ROS 1 from the tests: its tools found, its processes started in their own process groups on
the loopback interface and stopped, its Python (which has rospy and rosbag; the project's venv does not) run for
what only it reads.

Every wait has a wall-clock backstop (a subprocess timeout, a deadline polled); none is asserted as a speed.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import textwrap
import time
import xmlrpc.client
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

DEBIAN_PYTHON = "/usr/bin/python3"
RSP = "/usr/lib/robot_state_publisher/robot_state_publisher"
JSP = "/usr/lib/joint_state_publisher/joint_state_publisher"
VIEW_FRAMES = "/usr/lib/tf2_tools/view_frames.py"
PACKAGES = ("ros-core", "ros-robot-state-publisher", "joint-state-publisher", "python3-rosbag", "liburdfdom-tools",
            "tf2-tools", "python3-rospy", "python3-roslaunch")
"""What `make interop` installs (.ci/install-ros1)."""

TOOLS = {"check_urdf": "liburdfdom-tools", "roscore": "ros-core", "rosbag": "python3-rosbag",
         "roslaunch": "python3-roslaunch", RSP: "ros-robot-state-publisher", JSP: "joint-state-publisher",
         VIEW_FRAMES: "tf2-tools", DEBIAN_PYTHON: "python3-rospy"}
"""Each tool the interop tier runs, and the Debian package that has it."""

BACKSTOP_S = 180.0
"""The wall-clock backstop of any one wait for a ROS process (it is never reached when things work)."""


def missing(*tools: str) -> list[str]:
    """The tools (of :data:`TOOLS`) that are not here; rospy and rosbag for Debian's python3."""
    gone = [tool for tool in tools if not (shutil.which(tool) if "/" not in tool else os.access(tool, os.X_OK))]
    if DEBIAN_PYTHON in tools and DEBIAN_PYTHON not in gone:
        probe = subprocess.run([DEBIAN_PYTHON, "-c", "import rospy, rosbag, genpy"], capture_output=True,
                               timeout=60, check=False, env=_clean_env())
        if probe.returncode != 0:
            gone.append(DEBIAN_PYTHON)
    return gone


def skip_reason(gone: Sequence[str]) -> str:
    packages = sorted({TOOLS[tool] for tool in gone})
    return (f"Debian's ROS 1 is not here ({', '.join(gone)}; packages {' '.join(packages)}): `make interop` "
            "installs it with apt-get as root; the interop tier compares tfrec with the real tools where they run")


def _clean_env() -> dict[str, str]:
    """The environment without this venv (ROS nodes start with `#!/usr/bin/env python3`: Debian's must come first)."""
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH", "PYTHONHOME")
           and not k.startswith("ROS")}
    env["PATH"] = "/usr/bin:/bin:" + env.get("PATH", "")
    return env


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except (ProcessLookupError, PermissionError):
        return False
    return True


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@dataclass
class Ros:
    """Debian's ROS 1 for one test session: a master on a free loopback port, logs in ``home``.

    Attributes:
        home: ROS_HOME (logs) and the folder of what the processes write.
        port: the master's port.
        package_path: folders of ROS_PACKAGE_PATH before Debian's (/usr/share).
    """

    home: Path
    port: int
    package_path: list[Path] = field(default_factory=list)
    _started: list[subprocess.Popen[bytes]] = field(default_factory=list)

    @property
    def master_uri(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def env(self) -> dict[str, str]:
        env = _clean_env()
        env.update(ROS_MASTER_URI=self.master_uri, ROS_IP="127.0.0.1", ROS_HOME=str(self.home), ROS_LOG_DIR=str(self.home / "log"),
                   ROS_PACKAGE_PATH=":".join([*map(str, self.package_path), "/usr/share"]))
        return env

    # -- processes ------------------------------------------------------------------------------------

    def start(self, *cmd: str | os.PathLike[str], name: str, cwd: Path | None = None) -> subprocess.Popen[bytes]:
        """A process in a session (process group) of its own, its output in ``home/<name>.log``."""
        log = open(self.home / f"{name}.log", "ab")  # noqa: SIM115 - the child holds it
        with log:
            proc = subprocess.Popen([os.fspath(c) for c in cmd], env=self.env, cwd=cwd or self.home, stdout=log,
                                    stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)
        self._started.append(proc)
        return proc

    def stop(self, proc: subprocess.Popen[bytes], *, grace_s: float = 20.0) -> int:
        """SIGINT to the process (as Ctrl-C: it passes it on to what it started — rosbag record's recorder writes its
        index, roslaunch stops its nodes), the rest of its group given the grace to end, then SIGKILL to the group."""
        if proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=grace_s)
            except subprocess.TimeoutExpired:
                pass
        deadline = time.monotonic() + grace_s
        while _group_alive(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)  # whatever of its group is left
        proc.wait(timeout=grace_s)
        if proc in self._started:
            self._started.remove(proc)
        return int(proc.returncode)

    def stop_all(self) -> None:
        for proc in reversed(list(self._started)):
            self.stop(proc, grace_s=10.0)

    @contextlib.contextmanager
    def running(self, *cmd: str | os.PathLike[str], name: str, cwd: Path | None = None
                ) -> Iterator[subprocess.Popen[bytes]]:
        proc = self.start(*cmd, name=name, cwd=cwd)
        try:
            yield proc
        finally:
            self.stop(proc)

    def run(self, *cmd: str | os.PathLike[str], timeout: float = BACKSTOP_S, cwd: Path | None = None,
            check: bool = True) -> subprocess.CompletedProcess[str]:
        """A command to its end (output captured); ``check``: a failure shows its output."""
        done = subprocess.run([os.fspath(c) for c in cmd], env=self.env, cwd=cwd or self.home, capture_output=True,
                              text=True, timeout=timeout, check=False, stdin=subprocess.DEVNULL,
                              start_new_session=True)
        if check and done.returncode != 0:
            raise AssertionError(f"{' '.join(map(str, cmd))} exited {done.returncode}:\n{done.stdout}\n{done.stderr}")
        return done

    def python(self, code: str, *args: str | os.PathLike[str], timeout: float = BACKSTOP_S) -> Any:
        """Debian's python3 running ``code`` (which prints one JSON value last); that value."""
        script = self.home / "snippet.py"
        script.write_text(textwrap.dedent(code))
        done = self.run(DEBIAN_PYTHON, script, *args, timeout=timeout)
        return json.loads(done.stdout.strip().splitlines()[-1])

    # -- the master -----------------------------------------------------------------------------------

    def call(self, method: str, *args: Any) -> Any:
        """One call of the master's XML-RPC API as caller ``/tfrec_tests`` (its connection closed after)."""
        with xmlrpc.client.ServerProxy(self.master_uri) as master:
            return getattr(master, method)("/tfrec_tests", *args)

    def wait_master(self) -> None:
        deadline = time.monotonic() + BACKSTOP_S
        while True:
            with contextlib.suppress(OSError, xmlrpc.client.Error):
                code, _, _ = self.call("getSystemState")
                if code == 1:
                    return
            if time.monotonic() > deadline:
                raise AssertionError(f"no ROS master at {self.master_uri} after {BACKSTOP_S:.0f} s")
            time.sleep(0.2)

    def set_param(self, name: str, value: Any) -> None:
        code, message, _ = self.call("setParam", name, value)
        assert code == 1, message

    def get_param(self, name: str) -> Any:
        code, message, value = self.call("getParam", name)
        assert code == 1, message
        return value

    def delete_param(self, name: str) -> None:
        with contextlib.suppress(xmlrpc.client.Error):
            self.call("deleteParam", name)

    def publishers(self, topic: str) -> list[str]:
        _, _, (publishers, _, _) = self.call("getSystemState")
        return next((nodes for name, nodes in publishers if name == topic), [])

    def wait_publishers(self, topic: str, count: int = 1) -> None:
        deadline = time.monotonic() + BACKSTOP_S
        while len(self.publishers(topic)) < count:
            if time.monotonic() > deadline:
                raise AssertionError(f"no publisher of {topic} after {BACKSTOP_S:.0f} s")
            time.sleep(0.1)

    def wait_connected(self, node: str, topic: str, peer: str) -> None:
        """Until ``node`` publishes ``topic`` over a live connection to a node whose name starts with ``peer``
        (the node's own XML-RPC ``getBusInfo``): a subscriber the master lists may not be connected yet."""
        deadline = time.monotonic() + BACKSTOP_S
        while time.monotonic() < deadline:
            code, _, uri = self.call("lookupNode", node)
            if code == 1:
                with contextlib.suppress(OSError, xmlrpc.client.Error), xmlrpc.client.ServerProxy(uri) as api:
                    _, _, connections = api.getBusInfo("/tfrec_tests")
                    if any(c[2] == "o" and c[4] == topic and str(c[1]).startswith(peer) and (len(c) < 6 or c[5])
                           for c in connections):
                        return
            time.sleep(0.1)
        raise AssertionError(f"{node} never connected to a {peer}… subscriber of {topic}")

    def wait_gone(self, node: str) -> None:
        """Until the master no longer lists ``node`` (a stopped node unregisters itself)."""
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            _, _, state = self.call("getSystemState")
            if not any(node in nodes for group in state for _, nodes in group):
                return
            time.sleep(0.1)

    # -- recording ------------------------------------------------------------------------------------

    def record(self, out: Path, topics: Sequence[str], *, duration_s: float) -> Path:
        """``rosbag record -O out --duration=D topics``, to its end."""
        self.run("rosbag", "record", "-O", out, f"--duration={duration_s}", *topics, timeout=duration_s + BACKSTOP_S)
        assert out.is_file(), f"rosbag record wrote no {out}"
        return out


@dataclass(frozen=True)
class CheckUrdf:
    """What real ``check_urdf`` said of a file.

    Attributes:
        accepted: it parsed the model ("Successfully Parsed XML").
        name, root: the robot's name and root link.
        tree: link → its children, as check_urdf prints the tree.
        endless: the tree it printed never ended (a cycle urdfdom let through); stopped at 1 MiB of output.
        output: what it printed (the start of it).
    """

    accepted: bool
    name: str = ""
    root: str = ""
    tree: dict[str, list[str]] = field(default_factory=dict)
    endless: bool = False
    output: str = ""


_OUTPUT_LIMIT = 1 << 20


def _limit_output() -> None:
    import resource

    resource.setrlimit(resource.RLIMIT_FSIZE, (_OUTPUT_LIMIT, _OUTPUT_LIMIT))  # SIGXFSZ past it


def check_urdf(path: Path, scratch: Path) -> CheckUrdf:
    """Real ``check_urdf`` (urdfdom 3.0.1) on a file; its output goes to a file under ``scratch``, at most 1 MiB."""
    out_file = scratch / "check_urdf.out"
    with open(out_file, "wb") as out:
        done = subprocess.run(["check_urdf", os.fspath(path)], stdout=out, stderr=subprocess.STDOUT, timeout=120,
                              check=False, env=_clean_env(), preexec_fn=_limit_output)
    text = out_file.read_bytes().decode("utf-8", "replace")
    endless = done.returncode == -signal.SIGXFSZ
    if (done.returncode != 0 and not endless) or "Successfully Parsed XML" not in text:
        return CheckUrdf(False, output=text[:4000])
    name = re.search(r"^robot name is: (.*)$", text, re.MULTILINE)
    root = re.search(r"^root Link: (.*) has \d+ child\(ren\)$", text, re.MULTILINE)
    return CheckUrdf(True, name.group(1) if name else "", root.group(1) if root else "",
                     {} if endless else _tree(text, root.group(1) if root else None), endless, text[:4000])


def _tree(text: str, root: str | None) -> dict[str, list[str]]:
    """check_urdf's printed tree: each ``child(k):  name`` four spaces deeper than its parent."""
    tree: dict[str, list[str]] = {}
    stack: list[tuple[int, str]] = []
    for line in text.splitlines():
        if root is not None and line.startswith("root Link: "):
            stack = [(0, root)]
            tree[root] = []
            continue
        child = re.match(r"^( +)child\(\d+\):  (.*)$", line)
        if child is None or not stack:
            continue
        depth = len(child.group(1)) // 4
        while stack and stack[-1][0] >= depth:
            stack.pop()
        tree.setdefault(stack[-1][1], []).append(child.group(2))
        tree.setdefault(child.group(2), [])
        stack.append((depth, child.group(2)))
    return tree


def dot_edges(text: str) -> set[tuple[str, str]]:
    """The ``"parent" -> "child"`` edges of a Graphviz file (view_frames' frames.gv, ``tfrec info --graph x.dot``)."""
    return {(a, b) for a, b in re.findall(r'^\s*"([^"]+)"\s*->\s*"([^"]+)"', text, re.MULTILINE)
            if not b.startswith("Recorded at time")}
