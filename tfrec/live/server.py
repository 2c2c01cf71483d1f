"""The Foxglove WebSocket server of ``tfrec serve``, through the official SDK (PyPI ``foxglove-sdk``): the only
importer of ``foxglove``.

Channels, ROS 2 schemas (``ros2msg``) and CDR, the bytes ``tfrec record`` writes into an MCAP
(:mod:`tfrec.formats.ros.encode`):

- ``/robot_description`` (``std_msgs/msg/String``) and ``/tf_static`` (``tf2_msgs/msg/TFMessage``), latched: sent
  again whenever a client subscribes to either, so a client that connects later gets them (the SDK keeps no
  messages for new clients);
- ``/joint_states`` (``sensor_msgs/msg/JointState``) and ``/tf`` (``tf2_msgs/msg/TFMessage``), one each per sample.

The joint_state_publisher_gui half (a robot served without a trajectory): each actuated joint is a parameter
(float64, its name the joint's), which Foxglove's Parameters panel edits; a value set is clamped to the joint's range
and published back. ``Center`` and ``Randomize`` are services (``std_srvs/srv/Trigger``, CDR), which the Service Call
panel calls. Meshes are served through the SDK's asset capability: exactly the URIs the description names
(``package://…``, ``file://…``, relative paths), read from where tfrec finds them, nothing else.

A client that reads slowly or not at all never stalls the loop: the SDK queues at most
:data:`MESSAGE_BACKLOG` messages per client and drops its oldest data messages beyond that (a client whose control
queue fills is disconnected). Malformed client requests (a parameter that is no number, an unknown joint) are
answered with a warning status to the client and queued for the caller (:meth:`FoxgloveServer.take_notes`).
"""

from __future__ import annotations

import os
import struct
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import foxglove
import numpy as np
from foxglove.websocket import Capability, ChannelView, Client, ServerListener, StatusLevel
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.errors import TfrecError, WriteError
from tfrec.formats.mcap.sink import TOPICS
from tfrec.formats.mcap.writer import message_definition
from tfrec.formats.ros.encode import CDR_HEADER, JointStateEncoder, TFMessageEncoder, encode_string
from tfrec.live.joints import JointControl
from tfrec.model import Mesh, Robot
from tfrec.recording import Transforms

__all__ = ["MAX_ASSET_BYTES", "MESSAGE_BACKLOG", "SERVICES", "STOP_LINGER_S", "FoxgloveServer", "description_assets", "trigger_response"]

MESSAGE_BACKLOG = 1024
"""Messages the SDK queues per client; beyond them it drops the client's oldest data messages."""

MAX_ASSET_BYTES = 256 << 20
"""The largest mesh file served."""

STOP_LINGER_S = 0.3
"""Seconds between the last message and closing the connections: what the clients' queues hold goes out."""

SERVICES = ("Center", "Randomize")
"""The services of a robot served without a trajectory: joint_state_publisher_gui's two buttons."""

_TRIGGER_RESPONSE = b"bool success\nstring message\n"

Array = NDArray[np.float64]


def trigger_response(message: str) -> bytes:
    """A ``std_srvs/srv/Trigger`` response (success, ``message``) in CDR."""
    data = message.encode("utf-8")
    return CDR_HEADER + b"\x01\0\0\0" + struct.pack("<I", len(data) + 1) + data + b"\0"


class _Listener(ServerListener):
    """The SDK's callbacks (its threads): subscriptions to latched topics, parameters."""

    def __init__(self, server: FoxgloveServer) -> None:
        self._server = server

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        if channel.topic in (ROBOT_DESCRIPTION, TF_STATIC):
            self._server.relatch.set()

    def on_get_parameters(self, client: Client, param_names: list[str],
                          request_id: str | None = None) -> list[foxglove.Parameter]:
        wanted = set(param_names)
        return [p for p in self._server.parameters() if not wanted or p.name in wanted]

    def on_set_parameters(self, client: Client, parameters: list[foxglove.Parameter],
                          request_id: str | None = None) -> list[foxglove.Parameter]:
        control = self._server.control
        for parameter in parameters:
            try:
                if control is None:
                    raise TfrecError("joints follow the trajectory: parameters are read-only")
                control.set(parameter.name, parameter.get_value())
            except TfrecError as err:
                self._server.note(f"client {client.id}: parameter '{parameter.name}' ignored: {err}")
        self._server.parameters_changed.set()
        return self._server.parameters()


class FoxgloveServer:
    """A robot served to Foxglove: start it, :meth:`publish_latched` once, then samples with :meth:`publish`.

    Args:
        host, port: where to listen (port 0: any free port, see :attr:`port`).
        control: the joints clients move (parameters and services), or None (a trajectory or a recording drives
            them: no parameters, no services).
        assets: URI as the description names it → the file it is read from.
        name: the server's name, shown by clients.

    Raises:
        WriteError: the server cannot listen there (the address taken, a host that is no address here).
    """

    def __init__(self, *, host: str, port: int, control: JointControl | None = None,
                 assets: Mapping[str, Path] = {}, name: str = "tfrec") -> None:
        self.control = control
        self.relatch = threading.Event()
        self.parameters_changed = threading.Event()
        self._assets = dict(assets)
        self._notes: list[str] = []
        self._notes_lock = threading.Lock()
        self._latched: tuple[int, bytes, bytes] | None = None
        self._encoders: dict[tuple[Any, ...], JointStateEncoder | TFMessageEncoder] = {}
        self._context = foxglove.Context()
        self._channels = {topic: _channel(self._context, topic, msgtype) for topic, msgtype, _ in TOPICS}
        capabilities = [Capability.Parameters, Capability.Services] if control is not None else []
        services = [_service(name, self._service_handler(name)) for name in SERVICES] if control is not None else []
        try:
            self._server = foxglove.start_server(
                name=name, host=host, port=port, capabilities=capabilities, server_listener=_Listener(self),
                supported_encodings=["cdr"], services=services, asset_handler=self._asset,
                context=self._context, message_backlog_size=MESSAGE_BACKLOG,
            )
        except RuntimeError as err:
            raise WriteError(f"cannot serve on {host}:{port}: {err}") from err

    @property
    def port(self) -> int:
        """The port listened on."""
        return self._server.port

    def stop(self, *, linger_s: float = STOP_LINGER_S) -> None:
        """Close every connection and stop listening, ``linger_s`` after the last message (the SDK sends from its
        own threads, and stopping drops what its queues still hold)."""
        time.sleep(linger_s)
        self._server.stop()

    # -- what the SDK's threads call -----------------------------------------------------------------

    def note(self, text: str) -> None:
        """Queue a warning about a client's request (shown to clients, and by :meth:`take_notes`)."""
        with self._notes_lock:
            self._notes.append(text)

    def take_notes(self) -> list[str]:
        """The warnings since the last call; each is also sent to the clients as a status message."""
        with self._notes_lock:
            notes, self._notes = self._notes, []
        for text in notes:
            self._server.publish_status(text, StatusLevel.Warning)
        return notes

    def parameters(self) -> list[foxglove.Parameter]:
        """Each actuated joint's position as a float64 parameter (none without :attr:`control`)."""
        if self.control is None:
            return []
        return [foxglove.Parameter(name, value=float(value), type=foxglove.ParameterType.Float64)
                for name, value in zip(self.control.names, self.control.positions())]

    def _service_handler(self, name: str) -> Callable[[foxglove.ServiceRequest], bytes]:
        def handle(request: foxglove.ServiceRequest) -> bytes:
            assert self.control is not None
            if name == "Center":
                self.control.center()
            else:
                self.control.randomize()
            self.parameters_changed.set()
            return trigger_response(f"{name}: {len(self.control.names)} joints moved")

        return handle

    def _asset(self, uri: str) -> bytes | None:
        path = self._assets.get(uri)
        if path is None:
            self.note(f"asset '{uri}' refused: the description names no such mesh")
            return None
        try:
            with open(path, "rb") as stream:
                data = stream.read(MAX_ASSET_BYTES + 1)
        except OSError as err:
            self.note(f"asset '{uri}' not readable: {err.strerror or err}")
            return None
        if len(data) > MAX_ASSET_BYTES:
            self.note(f"asset '{uri}' refused: larger than {MAX_ASSET_BYTES >> 20} MiB")
            return None
        return data

    # -- publishing (the caller's loop) --------------------------------------------------------------

    def publish_latched(self, *, robot_description: str, static: Transforms, start_time_ns: int) -> None:
        """Send /robot_description and /tf_static (stamped ``start_time_ns``), and again to each new subscriber."""
        stamp = np.array([start_time_ns], dtype=np.int64)
        tf_static = TFMessageEncoder(static.parents, static.children).encode(stamp, static.translation, static.rotation)
        self._latched = (start_time_ns, encode_string(robot_description), tf_static[0].tobytes())
        self.relatch.clear()
        self._send_latched(start_time_ns)

    def _send_latched(self, log_time_ns: int) -> None:
        if self._latched is None:
            return
        _, description, tf_static = self._latched
        self._channels[ROBOT_DESCRIPTION].log(description, log_time=log_time_ns)
        self._channels[TF_STATIC].log(tf_static, log_time=log_time_ns)

    def service_requests(self, now_ns: int) -> None:
        """Answer what clients asked for since the last call: the latched messages for new subscribers, changed
        parameters for every parameter subscriber."""
        if self.relatch.is_set():
            self.relatch.clear()
            self._send_latched(now_ns)
        if self.parameters_changed.is_set():
            self.parameters_changed.clear()
            self._server.publish_parameter_values(self.parameters())

    def encode(self, *, stamp_ns: NDArray[np.int64], joint_names: Sequence[str], positions: Array,
               velocities: Array, transforms: Transforms) -> tuple[NDArray[np.uint8], NDArray[np.uint8] | None]:
        """The /joint_states and /tf messages of N samples, (N, size) bytes each (no /tf without moving frames)."""
        joint_states = self._encoder(("js", tuple(joint_names)), lambda: JointStateEncoder(joint_names))
        assert isinstance(joint_states, JointStateEncoder)
        rows = joint_states.encode(stamp_ns, positions, velocities)
        if not transforms.children:
            return rows, None
        tf = self._encoder(("tf", transforms.parents, transforms.children),
                           lambda: TFMessageEncoder(transforms.parents, transforms.children))
        assert isinstance(tf, TFMessageEncoder)
        return rows, tf.encode(stamp_ns, transforms.translation, transforms.rotation)

    def _encoder(self, key: tuple[Any, ...], make: Callable[[], JointStateEncoder | TFMessageEncoder]
                 ) -> JointStateEncoder | TFMessageEncoder:
        encoder = self._encoders.get(key)
        if encoder is None:
            if len(self._encoders) > 64:  # a recording's frame pairs: bounded
                self._encoders.clear()
            encoder = self._encoders[key] = make()
        return encoder

    def log(self, topic: str, message: bytes, time_ns: int) -> None:
        """Send one message (``topic`` one of the four) logged at ``time_ns``."""
        self._channels[topic].log(message, log_time=time_ns)

    def log_sample(self, joint_states: bytes, tf: bytes | None, time_ns: int) -> None:
        """Send one sample's /joint_states and /tf messages."""
        self._channels[JOINT_STATES].log(joint_states, log_time=time_ns)
        if tf is not None:
            self._channels[TF].log(tf, log_time=time_ns)


def _channel(context: foxglove.Context, topic: str, msgtype: str) -> foxglove.Channel:
    text, _ = message_definition(msgtype)
    schema = foxglove.Schema(name=msgtype, encoding="ros2msg", data=text.encode())
    return foxglove.Channel(topic, schema=schema, message_encoding="cdr", context=context)


def _service(name: str, handler: Callable[[foxglove.ServiceRequest], bytes]) -> foxglove.Service:
    request = foxglove.MessageSchema(encoding="cdr", schema=foxglove.Schema(
        name="std_srvs/srv/Trigger_Request", encoding="ros2msg", data=b""))
    response = foxglove.MessageSchema(encoding="cdr", schema=foxglove.Schema(
        name="std_srvs/srv/Trigger_Response", encoding="ros2msg", data=_TRIGGER_RESPONSE))
    schema = foxglove.ServiceSchema("std_srvs/srv/Trigger", request=request, response=response)
    return foxglove.Service(name, schema=schema, handler=handler)


def description_assets(robot: Robot, package_paths: Sequence[str | os.PathLike[str]] = ()) -> dict[str, Path]:
    """The meshes a client may fetch: each ``<mesh filename>`` URI of the description → the file it names, found as
    ``record`` finds meshes (``package_paths``, the environment, the description's workspace, confined the same
    way); URIs that resolve to no file are left out (a client asking for them is refused)."""
    from tfrec.description.packages import PackageFinder

    finder = PackageFinder(package_paths, near=robot.source)
    uris = sorted({visual.geometry.filename for link in robot.links for visual in link.visuals
                   if isinstance(visual.geometry, Mesh)})
    out: dict[str, Path] = {}
    for uri in uris:
        try:
            out[uri] = finder.resolve_uri(uri, relative_to=robot.source)
        except TfrecError:
            continue
    return out
