"""``tfrec serve`` with real clients: the server in a child process, Foxglove WebSocket clients written from the
protocol (tests/live/foxglove_client.py), messages decoded with rosbags, compared with tfrec's forward kinematics."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("foxglove")

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from tests.conftest import REPO
from tests.live.foxglove_client import Client, Message, serving
from tfrec.description import load_description
from tfrec.kinematics.fk import iter_dynamic_chunks, static_transforms
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.joints import bounds_arrays

MARM = str(REPO / "robots" / "marm.xacro")
START_S = 1_700_000_000
START_NS = START_S * 1_000_000_000
TOPICS = ("/robot_description", "/tf_static", "/joint_states", "/tf")

TRIGGER = get_typestore(Stores.ROS2_HUMBLE)
TRIGGER.register(get_types_from_msg("bool success\nstring message\n", "std_srvs/msg/Trigger_Response"))


def _stamp(msg: Any) -> int:
    return int(msg.sec) * 1_000_000_000 + int(msg.nanosec)


def _tf(message: Message) -> tuple[int, dict[tuple[str, str], np.ndarray]]:
    """(stamp, (parent, child) → x y z qx qy qz qw) of a /tf message, decoded by rosbags."""
    msg = message.decode("tf2_msgs/msg/TFMessage")
    poses = {}
    for t in msg.transforms:
        tr, rot = t.transform.translation, t.transform.rotation
        poses[(t.header.frame_id, t.child_frame_id)] = np.array([tr.x, tr.y, tr.z, rot.x, rot.y, rot.z, rot.w])
    return _stamp(msg.transforms[0].header.stamp), poses


def _expected_fk(robot: Any, trajectory: Any) -> dict[int, dict[tuple[str, str], np.ndarray]]:
    out = {}
    for chunk in iter_dynamic_chunks(robot, trajectory):
        t = chunk.transforms
        for i, time_ns in enumerate(chunk.time_ns.tolist()):
            out[START_NS + time_ns] = {(p, c): np.r_[t.translation[i, k], t.rotation[i, k]]
                                       for k, (p, c) in enumerate(zip(t.parents, t.children))}
    return out


def _fk_at(robot: Any, names: tuple[str, ...], positions: np.ndarray) -> dict[tuple[str, str], np.ndarray]:
    from tfrec.trajectory.types import JointTrajectory

    one = JointTrajectory(names, np.zeros(1, dtype=np.int64), positions[np.newaxis, :], np.zeros((1, len(names))))
    chunk = next(iter_dynamic_chunks(robot, one))
    t = chunk.transforms
    return {(p, c): np.r_[t.translation[0, k], t.rotation[0, k]] for k, (p, c) in enumerate(zip(t.parents, t.children))}


def test_a_trajectory_is_served_as_tfrec_computes_it() -> None:
    """serverInfo, the four channels with ROS 2 schemas and CDR, and every /tf message equal to tfrec's FK of the
    trajectory at its stamp; /joint_states with the mimic joint; the latched topics sent to a late subscriber."""
    robot = load_description(MARM)
    trajectory = make_trajectory(robot, "sine", duration_s=3.0, rate_hz=50.0)
    expected = _expected_fk(robot, trajectory)
    with serving([MARM, "--traj", "sine", "--duration", "3", "--start-time", str(START_S)]) as served:
        client = Client(served.port)
        assert client.info["op"] == "serverInfo"
        assert {t: client.channels[t]["schemaName"] for t in TOPICS} == {
            "/robot_description": "std_msgs/msg/String", "/tf_static": "tf2_msgs/msg/TFMessage",
            "/joint_states": "sensor_msgs/msg/JointState", "/tf": "tf2_msgs/msg/TFMessage"}
        assert {client.channels[t]["encoding"] for t in TOPICS} == {"cdr"}
        assert {client.channels[t]["schemaEncoding"] for t in TOPICS} == {"ros2msg"}
        client.subscribe(*TOPICS)
        client.read()  # until the server ends
        code, _, err = served.stop(interrupt=False)
    assert code == 0, err
    assert "served 151 samples" in err
    description = client.on("/robot_description")
    assert description and description[0].decode("std_msgs/msg/String").data == robot.urdf
    static = _tf(client.on("/tf_static")[0])[1]
    want_static = static_transforms(robot)
    assert set(static) == set(zip(want_static.parents, want_static.children))
    tf = [_tf(m) for m in client.on("/tf")]
    assert len(tf) > 50
    for stamp, poses in tf:
        assert set(poses) == set(expected[stamp])
        for pair, pose in poses.items():
            np.testing.assert_allclose(pose, expected[stamp][pair], atol=1e-12)
    # every sample from the subscription on, none skipped, in order
    stamps = [stamp for stamp, _ in tf]
    assert np.all(np.diff(stamps) == 20_000_000)
    assert stamps[-1] == START_NS + 3_000_000_000
    joint_states = [m.decode("sensor_msgs/msg/JointState") for m in client.on("/joint_states")]
    names = list(joint_states[-1].name)
    assert "finger_joint2" in names
    last = dict(zip(names, joint_states[-1].position))
    assert last["finger_joint2"] == pytest.approx(-last["finger_joint1"])


def test_a_parameter_moves_its_joint_within_limits_and_tf_follows() -> None:
    robot = load_description(MARM)
    names = tuple(j.name for j in robot.actuated_joints)
    with serving([MARM, "--duration", "60"]) as served:
        client = Client(served.port)
        assert {"parameters", "services", "assets"} <= set(client.info["capabilities"])
        assert set(client.services) == {"Center", "Randomize"}
        client.subscribe("/joint_states", "/tf")
        client.send({"op": "subscribeParameterUpdates", "parameterNames": list(names)})
        client.send({"op": "getParameters", "parameterNames": [], "id": "get"})
        client.read(until=lambda c: any(m.get("id") == "get" for m in c.ops("parameterValues")))
        values = next(m for m in client.ops("parameterValues") if m.get("id") == "get")["parameters"]
        assert [p["name"] for p in values] == list(names)
        # joint2 past its upper limit: clamped; finger_joint1 moves its mimic finger_joint2
        client.send({"op": "setParameters", "id": "set", "parameters": [
            {"name": "joint2", "value": 10.0}, {"name": "finger_joint1", "value": 0.015}]})
        client.read(until=lambda c: any(m.get("id") == "set" for m in c.ops("parameterValues")))
        answer = {p["name"]: p["value"] for p in next(m for m in client.ops("parameterValues")
                                                       if m.get("id") == "set")["parameters"]}
        assert answer["joint2"] == pytest.approx(3.14159) and answer["finger_joint1"] == pytest.approx(0.015)

        def moved(c: Client) -> bool:
            states = [m.decode("sensor_msgs/msg/JointState") for m in c.on("/joint_states")[-3:]]
            return any(dict(zip(s.name, s.position)).get("joint2") == pytest.approx(3.14159) for s in states)

        client.read(until=moved)
        state = client.on("/joint_states")[-1].decode("sensor_msgs/msg/JointState")
        position = dict(zip(state.name, state.position))
        assert position["finger_joint2"] == pytest.approx(-0.015)
        stamp = _stamp(state.header.stamp)
        client.read(until=lambda c: any(_tf(m)[0] == stamp for m in c.on("/tf")[-5:]))
        tf = next(poses for s, poses in map(_tf, client.on("/tf")) if s == stamp)
        want = _fk_at(robot, names, np.array([position[n] for n in names]))
        for pair, pose in want.items():
            np.testing.assert_allclose(tf[pair], pose, atol=1e-12)
        # malformed requests are answered with a warning and change nothing
        client.send({"op": "setParameters", "id": "bad", "parameters": [
            {"name": "joint3", "value": "up"}, {"name": "no_such_joint", "value": 1.0}]})
        client.read(until=lambda c: len(c.ops("status")) >= 2)
        # Randomize: every joint within its bounds; Center: back to 0
        client.call_service("Randomize", 11)
        client.read(until=lambda c: c.service_response(11) is not None)
        response = TRIGGER.deserialize_cdr(client.service_response(11), "std_srvs/msg/Trigger_Response")
        assert response.success
        client.read(until=lambda c: len(c.on("/joint_states")) > 0 and _changed(c, position))
        lower, upper = bounds_arrays(robot)
        state = client.on("/joint_states")[-1].decode("sensor_msgs/msg/JointState")
        now = dict(zip(state.name, state.position))
        assert all(lower[i] <= now[n] <= upper[i] for i, n in enumerate(names))
        client.call_service("Center", 12)
        client.read(until=lambda c: c.service_response(12) is not None and _centered(c, names))
        code, _, err = served.stop()
    assert code == 0, err
    assert "'up' is not a finite number" in err and "no_such_joint" in err
    updates = [m for m in client.ops("parameterValues") if m.get("id") is None]
    assert updates  # the services' changes published to parameter subscribers


def _changed(client: Client, before: dict[str, float]) -> bool:
    state = client.on("/joint_states")[-1].decode("sensor_msgs/msg/JointState")
    return dict(zip(state.name, state.position))["joint1"] != before["joint1"]


def _centered(client: Client, names: tuple[str, ...]) -> bool:
    state = client.on("/joint_states")[-1].decode("sensor_msgs/msg/JointState")
    return all(dict(zip(state.name, state.position))[n] == 0.0 for n in names)


STL = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n"


def test_the_description_and_its_meshes_are_fetchable_and_nothing_else(tmp_path: Path) -> None:
    package = tmp_path / "demo_pkg"
    (package / "meshes").mkdir(parents=True)
    (package / "package.xml").write_text("<package format='3'><name>demo_pkg</name></package>")
    (package / "meshes" / "part.stl").write_bytes(STL)
    (package / "secret.txt").write_text("not a mesh")
    urdf = package / "robot.urdf"
    urdf.write_text(
        "<robot name='meshy'><link name='base'><visual><geometry><mesh filename='package://demo_pkg/meshes/part.stl'/>"
        "</geometry></visual></link><link name='arm'/><joint name='j' type='revolute'><parent link='base'/>"
        "<child link='arm'/><limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>")
    with serving([str(urdf), "--duration", "60"]) as served:
        client = Client(served.port)
        client.subscribe("/robot_description")
        client.send({"op": "fetchAsset", "uri": "package://demo_pkg/meshes/part.stl", "requestId": 1})
        client.send({"op": "fetchAsset", "uri": "package://demo_pkg/secret.txt", "requestId": 2})
        client.send({"op": "fetchAsset", "uri": "file:///etc/passwd", "requestId": 3})
        client.read(until=lambda c: all(c.asset(i) is not None for i in (1, 2, 3)) and c.on("/robot_description"))
        assert client.asset(1) == (0, STL)
        assert client.asset(2)[0] == 1 and client.asset(3)[0] == 1
        description = client.on("/robot_description")[0].decode("std_msgs/msg/String").data
        assert "package://demo_pkg/meshes/part.stl" in description
        # latched: a client that comes long after the start gets the description and /tf_static on subscribing
        late = Client(served.port)
        late.subscribe("/robot_description", "/tf_static")
        late.read(until=lambda c: c.on("/robot_description") and c.on("/tf_static"))
        assert late.on("/robot_description")[0].decode("std_msgs/msg/String").data == description
        served.stop()


def test_two_clients_one_never_reading_and_the_loop_keeps_time() -> None:
    """A client that subscribes to everything and never reads: the other gets every sample, in time (each logged
    within a second of when it was due, by the server's own log times), and the server ends on time."""
    with serving([MARM, "--traj", "sine", "--rate", "200", "--duration", "4"]) as served:
        stuck = Client(served.port)
        stuck.subscribe(*TOPICS)
        reader = Client(served.port)
        reader.subscribe("/tf", "/joint_states")
        reader.read()
        code, _, err = served.stop(interrupt=False)
        stuck.ws.close_timeout = 1
    assert code == 0, err
    assert "served 801 samples" in err
    tf = reader.on("/tf")
    stamps = np.array([_tf(m)[0] for m in tf])
    assert len(stamps) > 400 and np.all(np.diff(stamps) == 5_000_000)
    # log time (the server's clock when sent) - stamp (when due): the loop's lag, stable over the run
    lag = np.array([m.log_time_ns for m in tf]) - stamps
    assert lag.max() - lag.min() < 1_000_000_000


def test_record_keeps_what_was_served_until_ctrl_c(tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader

    out = tmp_path / "live.mcap"
    with serving([MARM, "--traj", "sine", "--loop", "--record", str(out), "--start-time", str(START_S)]) as served:
        client = Client(served.port)
        client.subscribe("/tf")
        client.read(until=lambda c: len(c.on("/tf")) >= 30)
        code, stdout, err = served.stop()  # Ctrl-C
    assert code == 0, err
    samples = int(err.split("served ")[1].split()[0])
    assert out.is_file() and out.with_suffix(".rrd").is_file()
    assert f"wrote {out}" in stdout
    with AnyReader([out]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        stamps = [_stamp(reader.deserialize(raw, c.msgtype).header.stamp)
                  for c, _, raw in reader.messages(connections=[c for c in reader.connections
                                                                 if c.topic == "/joint_states"])]
    assert counts["/tf"] == counts["/joint_states"] == samples >= 30
    assert counts["/robot_description"] == counts["/tf_static"] == 1
    assert stamps[0] == START_NS and np.all(np.diff(stamps) == 20_000_000)


def test_a_recording_is_served_at_its_rate_from_start_to_end(tmp_path: Path) -> None:
    from tfrec import cli

    mcap = tmp_path / "rec.mcap"
    assert cli.main(["record", MARM, "--traj", "sine", "--duration", "4", "-o", str(mcap), "--no-rrd"]) == 0
    robot = load_description(MARM)
    expected = _expected_fk(robot, make_trajectory(robot, "sine", duration_s=4.0, rate_hz=50.0))
    shift = 1_700_000_000_000_000_000 - START_NS  # record's default start time
    with serving([str(mcap), "--rate", "4", "--start", "1", "--end", "3"]) as served:
        client = Client(served.port)
        client.subscribe(*TOPICS)
        client.read()
        code, _, err = served.stop(interrupt=False)
    assert code == 0, err
    tf = [_tf(m) for m in client.on("/tf")]
    assert tf
    for stamp, poses in tf:
        for pair, pose in poses.items():
            np.testing.assert_allclose(pose, expected[stamp - shift][pair], atol=1e-12)
    stamps = sorted({s for s, _ in tf})
    first_ns = 1_700_000_000_000_000_000
    assert first_ns + 1_000_000_000 <= stamps[0] and stamps[-1] <= first_ns + 3_000_000_000


def test_bad_inputs_are_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tfrec import cli

    assert cli.main(["serve", str(tmp_path / "missing.urdf"), "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tfrec: error: ") and "missing.urdf" in err and len(err.strip().splitlines()) == 1
    with serving([MARM, "--duration", "60"]) as served:
        assert cli.main(["serve", MARM, "--port", str(served.port), "--duration", "1"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("tfrec: error: cannot serve on 127.0.0.1:") and len(err.strip().splitlines()) == 1
    assert cli.main(["serve", MARM, "--port", "0", "--start", "1"]) == 2
    assert "--start and --end cut a recording" in capsys.readouterr().err
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):  # headless: no viewer to spawn
        assert cli.main(["serve", MARM, "--port", "0", "--rerun", "--duration", "1"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("tfrec: error: --rerun: cannot spawn") and "--connect URL" in err
        assert len(err.strip().splitlines()) == 1


def _free_port() -> int:
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@contextlib.contextmanager
def _rerun_saving(out: Path) -> Iterator[str]:
    """The real ``rerun`` of the pinned rerun-sdk as a headless gRPC server saving what it gets to ``out``: its URL;
    stopped with Ctrl-C (so that it writes ``out``) when the block ends, killed if it does not stop."""
    import shutil
    import signal
    import socket
    import subprocess
    import sys
    import time

    port = _free_port()
    rerun = shutil.which("rerun", path=str(Path(sys.executable).parent)) or "rerun"
    proc = subprocess.Popen([rerun, "--port", str(port), "--save", str(out)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        for _ in range(200):  # until it listens (a hang guard of its own: at most 200 tries)
            with socket.socket() as sock:
                if sock.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.1)
        else:
            raise AssertionError("rerun did not listen")
        yield f"rerun+http://127.0.0.1:{port}/proxy"
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=30)


def test_connect_streams_the_same_to_a_rerun_viewer(tmp_path: Path) -> None:
    """--connect: the real `rerun` (headless, saving what it receives) gets the served robot: every sample's joint
    states and TF equal to tfrec's FK (Rerun keeps float32)."""
    import subprocess
    import sys

    from tfrec.replay.load import load_replay

    out = tmp_path / "viewer.rrd"
    with _rerun_saving(out) as url:
        run = subprocess.run([sys.executable, "-m", "tfrec", "serve", MARM, "--traj", "sine", "--duration", "2",
                              "--port", "0", "--start-time", str(START_S), "--connect", url],
                             check=False, capture_output=True, text=True, timeout=120, cwd=REPO)
        assert run.returncode == 0, run.stderr
    robot = load_description(MARM)
    expected = _expected_fk(robot, make_trajectory(robot, "sine", duration_s=2.0, rate_hz=50.0))
    replay = load_replay(out)
    assert replay.robot_description == robot.urdf
    tf = replay.tf
    assert tf
    for (parent, child), series in tf.items():
        assert len(series) == 101
        for i, stamp in enumerate(series.time_ns.tolist()):
            want = expected[stamp][(parent, child)]
            np.testing.assert_allclose(series.translation[i], want[:3], atol=1e-6)
            np.testing.assert_allclose(np.abs(series.rotation[i] @ want[3:]), 1.0, atol=1e-6)


def test_a_whole_served_trajectory_leaves_the_files_record_writes(tmp_path: Path) -> None:
    """serve --traj --record, run to its end, writes the same MCAP bytes as `tfrec record` of that trajectory, and an
    .rrd Rerun finds identical to record's (the same sinks, fed in pieces as they were served)."""
    import shutil
    import subprocess
    import sys

    from tfrec import cli

    served, recorded = tmp_path / "served.mcap", tmp_path / "recorded.mcap"
    args = [MARM, "--traj", "random", "--duration", "2", "--start-time", str(START_S)]
    run = subprocess.run([sys.executable, "-m", "tfrec", "serve", *args, "--port", "0", "--record", str(served)],
                         check=False, capture_output=True, text=True, timeout=120, cwd=REPO)
    assert run.returncode == 0, run.stderr
    assert cli.main(["record", *args, "-o", str(recorded)]) == 0
    assert served.read_bytes() == recorded.read_bytes()
    rerun = shutil.which("rerun", path=str(Path(sys.executable).parent))
    if rerun is not None:
        compare = subprocess.run([rerun, "rrd", "compare", str(served.with_suffix(".rrd")),
                                  str(recorded.with_suffix(".rrd"))], check=False, capture_output=True, timeout=120)
        assert compare.returncode == 0, compare.stdout + compare.stderr


def test_malformed_client_messages_are_ignored_and_serving_goes_on() -> None:
    """Garbage from a client — text that is no JSON, unknown operations, a subscription to no channel, binary frames
    of unknown opcodes or cut short, a service call to no service, parameters of the wrong types — leaves the server
    serving: another client still gets every sample, and the run ends as asked."""
    import struct

    from websockets.exceptions import ConnectionClosed

    with serving([MARM, "--duration", "2", "--rate", "50"]) as served:
        bad = Client(served.port)
        good = Client(served.port)
        good.subscribe("/tf")
        for text in ("{not json", '{"op": "launchMissiles"}', "[]", '{"op": "subscribe", "subscriptions": 7}',
                     '{"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 999999}]}',
                     '{"op": "setParameters", "parameters": [{"name": "joint1", "value": {"x": 1}}]}',
                     '{"op": "setParameters", "parameters": [{"name": "joint1", "value": [1, 2]}]}',
                     '{"op": "fetchAsset", "uri": "../../etc/passwd", "requestId": 5}'):
            try:
                bad.ws.send(text)
            except ConnectionClosed:  # the server may drop this client: that is fine
                break
        for frame in (b"\xff\x00", b"\x02\x01", struct.pack("<BIII", 2, 9999, 1, 3) + b"cdr",
                      struct.pack("<BIII", 2, 1, 1, 1000) + b"cdr"):
            try:
                bad.ws.send(frame)
            except ConnectionClosed:
                break
        good.read()
        code, _, err = served.stop(interrupt=False)
    assert code == 0, err
    assert "served 101 samples" in err
    stamps = np.array([_tf(m)[0] for m in good.on("/tf")])
    assert len(stamps) > 50 and np.all(np.diff(stamps) == 20_000_000)


def test_a_recording_served_with_connect_reaches_the_rerun_viewer_too(tmp_path: Path) -> None:
    """serve FILE --connect: the replay goes to Foxglove's clients and to the real `rerun` (saving what it gets) at
    once; the viewer's recording reads back with the recorded transforms."""
    import subprocess
    import sys

    from tfrec import cli
    from tfrec.replay.load import load_replay

    mcap = tmp_path / "rec.mcap"
    assert cli.main(["record", MARM, "--traj", "sine", "--duration", "2", "-o", str(mcap), "--no-rrd"]) == 0
    out = tmp_path / "viewer.rrd"
    with _rerun_saving(out) as url:
        run = subprocess.run([sys.executable, "-m", "tfrec", "serve", str(mcap), "--rate", "4", "--port", "0",
                              "--connect", url], check=False, capture_output=True, text=True, timeout=120, cwd=REPO)
        assert run.returncode == 0, run.stderr
    got, want = load_replay(out), load_replay(mcap)
    assert set(got.tf) == set(want.tf) and got.tf
    for pair, series in want.tf.items():
        np.testing.assert_array_equal(got.tf[pair].time_ns, series.time_ns)
        np.testing.assert_allclose(got.tf[pair].translation, series.translation, atol=1e-6)
