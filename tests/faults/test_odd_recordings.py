"""Well-formed but odd recordings (issue 20, "Nothing lost"), end to end through the command line: a JointState
that names a joint twice, a ROS 1 bag or an MCAP that defines a type tfrec reads with another layout, message
definitions whose types contain themselves or nest thousands deep, and mesh URIs with percent-encoded hazards.
Each input is built here (rosbags' and mcap's writers, not tfrec's), and every command that reads it ends in a
result, a warning or one ``tfrec: error:`` line."""

from __future__ import annotations

import hashlib
import resource
import shutil
import sqlite3
import struct
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.bag_builders import Robot as Publisher
from tests.bag_builders import write_bag
from tests.fuzz.harness import Outcome, contract_violations, run_tfrec
from tests.recording_helpers import load_robot, marm_trajectory, write_mcap
from tfrec.formats import read_recording
from tfrec.recording import JointStates, Recording

START_NS = 1_700_000_000_000_000_000
SEPARATOR = "=" * 80 + "\n"


def run(argv: Sequence[str], cwd: Path, *, codes: Sequence[int] = (0,)) -> Outcome:
    """``tfrec argv`` in-process in ``cwd``: it keeps the contract (tests/fuzz/harness.py) within 30 s of CPU."""
    before = resource.getrusage(resource.RUSAGE_SELF)
    outcome = run_tfrec(list(argv), cwd=cwd, isolated=False)
    after = resource.getrusage(resource.RUSAGE_SELF)
    problems = contract_violations(outcome, codes=codes)
    assert not problems, f"tfrec {' '.join(argv)}: {problems[0]}\n{outcome.stderr[-3000:]}"
    assert (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime) < 30, "a hang"
    return outcome


def warnings_of(outcome: Outcome, text: str) -> list[str]:
    return [line for line in outcome.stderr.splitlines() if line.startswith("tfrec: warning: ") and text in line]


@pytest.fixture(scope="module")
def marm_recording(tmp_path_factory: pytest.TempPathFactory) -> Recording:
    """robots/marm.xacro's sine trajectory (2 s at 50 Hz) as tfrec recorded it: TF from the true joint positions."""
    marm = load_robot("marm")
    path = write_mcap(tmp_path_factory.mktemp("marm") / "marm.mcap", marm, marm_trajectory(marm))
    return read_recording(path)


# -- a JointState that names a joint twice ------------------------------------------------------------------------


def _twice(rec: Recording, *, tf: bool) -> Recording:
    """The recording with every /joint_states message naming joint2 a second time with another position (+0.5): the
    first occurrence holds the true position, from which /tf was computed."""
    js = rec.joint_states
    assert js is not None
    k = js.names.index("joint2")
    names = js.names + ("joint2",)
    positions = np.hstack([js.positions, js.positions[:, k : k + 1] + 0.5])
    return replace(rec, joint_states=JointStates(js.time_ns, names, positions), tf=rec.tf if tf else {})


def _moved_second(messages: list[Any], store: Any) -> None:
    """Some messages (a fifth: another layout, decoded one by one) name the repeated joint right after its first
    occurrence instead of at the end."""
    for i, (topic, msgtype, _, msg) in enumerate(messages):
        if topic == "/joint_states" and i % 5 == 0:
            names, positions = list(msg.name), list(msg.position)
            names.insert(2, names.pop())
            positions.insert(2, positions.pop())
            msg.name, msg.position = names, np.asarray(positions)


@pytest.fixture(scope="module", params=["mcap", "ros1"])
def twice(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory, marm_recording: Recording) -> Path:
    """A rosbag2 (MCAP storage) or ROS 1 bag of marm whose /joint_states name joint2 twice, with /tf."""
    from tests import bag_builders

    folder = tmp_path_factory.mktemp("twice")
    original = bag_builders.robot_messages

    def messages(robot: Publisher, *, ros1: bool) -> list[Any]:
        out = original(robot, ros1=ros1)
        _moved_second(out, None)
        return out

    bag_builders.robot_messages = messages
    try:
        target = folder / ("twice.bag" if request.param == "ros1" else "twice")
        return write_bag(target, [Publisher(_twice(marm_recording, tf=True))], kind=request.param)
    finally:
        bag_builders.robot_messages = original


def test_the_first_position_of_a_joint_named_twice_is_taken(twice: Path) -> None:
    """robot_state_publisher fills a std::map with insert (ROS 1) / emplace (ROS 2): a name's first value wins (Debian's
    robot_state_publisher 1.15.2, fed ["j", "j"] with [0.5, 1.5], publishes the TF of 0.5). The recorded /tf was
    computed from the first positions, so the re-simulation agrees with it only if tfrec takes them too."""
    outcome = run(["replay", "--check", twice.name], twice.parent)
    assert outcome.code == 0, outcome.stdout
    assert len(warnings_of(outcome, "joint 'joint2' more than once")) == 1
    assert "/joint_states" in warnings_of(outcome, "joint2")[0]
    with pytest.warns(UserWarning, match=r"/joint_states names joint 'joint2' more than once .*the first position"):
        rec = read_recording(twice)
    assert rec.joint_states is not None and rec.joint_states.names.count("joint2") == 1


@pytest.mark.parametrize("argv, codes", [
    (["info", "IN"], (0,)),
    (["info", "IN", "--json"], (0,)),
    (["replay", "--check", "IN", "--json"], (0,)),
    (["replay", "IN", "--save", "out.rrd"], (0,)),
    (["diff", "IN", "IN"], (0,)),
    (["plot", "IN", "-o", "out.svg"], (0,)),
    (["convert", "IN", "out.mcap"], (0,)),
    (["convert", "IN", "out.bag"], (0,)),
    (["convert", "IN", "out.rrd"], (0,)),
    (["convert", "IN", "out.mcap", "--tf-from-joints"], (0,)),
    (["check", "IN", "--report", "report.jsonl"], (0,)),
])
def test_every_command_reads_a_joint_named_twice(twice: Path, tmp_path: Path, argv: list[str], codes: tuple[int, ...]) -> None:
    shutil.copytree(twice, tmp_path / twice.name) if twice.is_dir() else shutil.copy(twice, tmp_path)
    outcome = run([twice.name if a == "IN" else a for a in argv], tmp_path, codes=codes)
    assert outcome.code in codes
    found = warnings_of(outcome, "joint 'joint2' more than once")
    if argv[0] == "check":  # a fleet run gives warnings as notes of its rows
        rows = (tmp_path / "report.jsonl").read_text()
        assert "joint 'joint2' more than once" in rows and "/joint_states" in rows
    elif argv[0] != "diff":
        assert len(found) == 1, outcome.stderr
    else:
        assert len(found) == 2, outcome.stderr  # once per input


@pytest.mark.parametrize("kind", ["mcap", "ros1"])
def test_tf_from_joints_takes_the_first_position(tmp_path: Path, marm_recording: Recording, kind: str) -> None:
    """Without /tf in the bag, convert computes it from the joint states: joint2's child link (link2) moves as the
    first position says — read back with rosbags and compared with tfrec's own recording of the true motion."""
    from rosbags.highlevel import AnyReader

    source = write_bag(tmp_path / ("in.bag" if kind == "ros1" else "in"), [Publisher(_twice(marm_recording, tf=False))],
                       kind=kind)
    outcome = run(["convert", source.name, "out.mcap", "--tf-from-joints"], tmp_path)
    assert len(warnings_of(outcome, "joint 'joint2' more than once")) == 1
    found: dict[int, np.ndarray] = {}
    with AnyReader([tmp_path / "out.mcap"]) as reader:
        connections = [c for c in reader.connections if c.topic == "/tf"]
        for connection, _, raw in reader.messages(connections=connections):
            for tf in reader.deserialize(raw, connection.msgtype).transforms:
                if tf.child_frame_id == "link2":
                    stamp = tf.header.stamp.sec * 1_000_000_000 + tf.header.stamp.nanosec
                    r = tf.transform.rotation
                    found[stamp] = np.array([r.x, r.y, r.z, r.w])
    pair = next(p for p in marm_recording.tf if p[1] == "link2")
    truth = marm_recording.tf[pair]
    assert len(found) == len(truth.time_ns)
    got = np.array([found[int(t)] for t in truth.time_ns])
    assert np.allclose(np.abs(np.sum(got * truth.rotation, axis=1)), 1.0, atol=1e-9)


# -- a type tfrec reads, defined with another layout --------------------------------------------------------------


def _ros1_bag(path: Path, connections: list[tuple[str, str, str | None, str | None, list[bytes]]],
              robot: Recording | None = None) -> Path:
    """A ROS 1 bag: robot topics of ``robot`` (with their real definitions), then connections (topic, type,
    definition, md5sum, messages) as given. Written by rosbags' writer, or — when a field is to be empty (None),
    which rosbags' writer refuses — by tfrec's."""
    from rosbags.rosbag1 import Writer

    from tests.bag_builders import robot_messages
    from tests.recording_helpers import _typestore
    from tfrec.formats.rosbag1.writer import Ros1BagWriter

    store = _typestore(True)
    messages = sorted(robot_messages(Publisher(robot), ros1=True), key=lambda m: m[2]) if robot is not None else []
    latched = ("/tf_static", "/robot_description")
    if all(md5sum and definition is not None for _, _, definition, md5sum, _ in connections):
        with Writer(path) as writer:
            made: dict[str, Any] = {}
            for topic, msgtype, time_ns, msg in messages:
                if topic not in made:
                    made[topic] = writer.add_connection(topic, msgtype, typestore=store,
                                                        latching=1 if topic in latched else None)
                writer.write(made[topic], time_ns, bytes(store.serialize_ros1(msg, msgtype)))
            for topic, msgtype, definition, md5sum, datas in connections:
                connection = writer.add_connection(topic, msgtype, msgdef=definition, md5sum=md5sum)
                for i, data in enumerate(datas):
                    writer.write(connection, START_NS + i * 20_000_000, data)
        return path
    with Ros1BagWriter(path) as own:
        ids: dict[str, int] = {}
        for topic, msgtype, time_ns, msg in messages:
            if topic not in ids:
                text, md5 = store.generate_msgdef(msgtype, ros_version=1)
                ids[topic] = own.add_connection(topic, msgtype, msgdef=text, md5sum=md5, latching=topic in latched)
            own.write(ids[topic], time_ns, bytes(store.serialize_ros1(msg, msgtype)))
        for topic, msgtype, definition, md5sum, datas in connections:
            conn = own.add_connection(topic, msgtype, msgdef=definition or "", md5sum=md5sum or "")
            for i, data in enumerate(datas):
                own.write(conn, START_NS + i * 20_000_000, data)
    return path


def _mcap(path: Path, channels: list[tuple[str, str, str, list[bytes], dict[str, str]]],
          robot: Recording | None = None, *, encoding: str = "ros2msg") -> Path:
    """An MCAP written by mcap's writer: the robot's topics (rosbags' CDR and Humble's definitions), then channels
    (topic, type, ros2msg definition, messages, channel metadata) as given."""
    from mcap.writer import Writer

    from tests.bag_builders import robot_messages
    from tests.recording_helpers import _typestore

    store = _typestore(False)
    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2")
        if robot is not None:
            made: dict[str, int] = {}
            for topic, msgtype, time_ns, msg in sorted(robot_messages(Publisher(robot), ros1=False), key=lambda m: m[2]):
                if topic not in made:
                    text, _ = store.generate_msgdef(msgtype, ros_version=2)
                    made[topic] = writer.register_channel(topic, "cdr", writer.register_schema(msgtype, "ros2msg", text.encode()))
                data = bytes(store.serialize_cdr(msg, msgtype))
                writer.add_message(made[topic], log_time=time_ns, data=data, publish_time=time_ns)
        for topic, msgtype, definition, datas, metadata in channels:
            channel = writer.register_channel(topic, "cdr", writer.register_schema(msgtype, encoding, definition.encode()),
                                              metadata=metadata)
            for i, data in enumerate(datas):
                writer.add_message(channel, log_time=START_NS + i * 20_000_000, data=data, publish_time=START_NS)
        writer.finish()
    return path


INTS_ROS1 = [struct.pack("<i", i) for i in range(10)]
INTS_CDR = [b"\x00\x01\x00\x00" + struct.pack("<i", i) for i in range(10)]


def _robot_only(rec: Recording) -> Recording:
    """The recording without /tf (its /tf is the odd topic of the test)."""
    return replace(rec, tf={})


def test_a_ros1_tf_message_of_another_layout_is_foreign_data(tmp_path: Path, marm_recording: Recording) -> None:
    """/tf as tf2_msgs/TFMessage, defined ``int32 x`` with that definition's md5sum: not ROS's TFMessage (roscpp
    would refuse to decode it as one). It is listed, not read as TF, and a ROS 1 copy keeps it byte for byte."""
    from rosbags.rosbag1 import Reader

    _ros1_bag(tmp_path / "odd.bag", [("/tf", "tf2_msgs/msg/TFMessage", "int32 x\n",
                                       hashlib.md5(b"int32 x").hexdigest(), INTS_ROS1)], _robot_only(marm_recording))
    info = run(["info", "odd.bag"], tmp_path)
    assert "/tf " in info.stdout and len(warnings_of(info, "/tf (tf2_msgs/msg/TFMessage): its md5sum")) == 1
    check = run(["replay", "--check", "odd.bag"], tmp_path, codes=(0, 1))
    assert check.code == 2 and "no /tf" in check.stderr  # nothing to compare with: one line
    saved = run(["replay", "odd.bag", "--save", "out.rrd"], tmp_path)  # TF computed from the joint states instead
    assert "computed from the joint states" in saved.stdout
    run(["convert", "odd.bag", "out.bag"], tmp_path)
    with Reader(tmp_path / "odd.bag") as before, Reader(tmp_path / "out.bag") as after:
        [old] = [c for c in before.connections if c.topic == "/tf"]
        kept, computed = sorted((c for c in after.connections if c.topic == "/tf"), key=lambda c: c.digest != old.digest)
        assert (kept.msgdef.data, kept.digest) == (old.msgdef.data, old.digest)
        assert [raw for _, _, raw in after.messages(connections=[kept])] == INTS_ROS1
        assert computed.digest == "94810edda583a504dfda3829e70d7eec"  # beside it, the TF computed from joint states


@pytest.mark.parametrize("md5sum, definition, foreign", [
    ("*", "int32 x\n", True),  # a wildcard md5sum: the definition decides
    ("*", None, False),  # neither: the type's name is taken
    (None, "int32 x\n", True),
    ("*", "tf2", False),  # the real definition (from rosbags), md5sum '*'
])
def test_a_ros1_wildcard_md5sum_is_decided_by_the_definition(tmp_path: Path, marm_recording: Recording,
                                                             md5sum: str | None, definition: str | None,
                                                             foreign: bool) -> None:
    from tests.recording_helpers import _Messages, _typestore

    store = _typestore(True)
    if definition == "tf2":
        definition = store.generate_msgdef("tf2_msgs/msg/TFMessage", ros_version=1)[0]
    rec = marm_recording
    pairs = list(rec.tf)
    messages = _Messages(store, True)
    datas = [bytes(store.serialize_ros1(messages.tf([(p, int(t), rec.tf[p].translation[i], rec.tf[p].rotation[i])
                                                     for p in pairs]), "tf2_msgs/msg/TFMessage"))
             for i, t in enumerate(rec.tf[pairs[0]].time_ns)]
    times = rec.tf[pairs[0]].time_ns
    _ros1_bag(tmp_path / "tf.bag", [("/tf", "tf2_msgs/msg/TFMessage", definition, md5sum, datas)], _robot_only(rec))
    outcome = run(["replay", "--check", "tf.bag"], tmp_path, codes=(0, 1))
    if foreign:
        assert outcome.code == 2 and warnings_of(outcome, "/tf (tf2_msgs/msg/TFMessage)")
    else:
        assert outcome.code == 0 and not warnings_of(outcome, "/tf (tf2_msgs"), outcome.stderr
    assert len(times) == len(datas)


def test_an_mcap_schema_of_another_layout_is_foreign_data(tmp_path: Path, marm_recording: Recording) -> None:
    """/tf's schema says ``int32 x``; /joint_states lacks the header; /tf_static's type contains itself. Each is
    listed, warned about once, not read; an MCAP copy keeps schema and bytes."""
    from mcap.reader import make_reader

    recursive = ("geometry_msgs/TransformStamped[] transforms\n" + SEPARATOR +
                 "MSG: geometry_msgs/TransformStamped\ngeometry_msgs/TransformStamped[] next\n")
    empty = [b"\x00\x01\x00\x00" + struct.pack("<I", 0)] * 3
    _mcap(tmp_path / "odd.mcap", [
        ("/tf", "tf2_msgs/msg/TFMessage", "int32 x\n", INTS_CDR, {}),
        ("/tf_static", "tf2_msgs/msg/TFMessage", recursive, empty, {}),
        ("/joint_states", "sensor_msgs/msg/JointState", "string[] name\n", empty, {}),
    ], replace(marm_recording, joint_states=None, tf={}, tf_static={}))
    info = run(["info", "odd.mcap"], tmp_path)
    for topic, why in (("/tf", "field 1 is 'x', not 'transforms'"), ("/tf_static", "contains itself"),
                       ("/joint_states", "field 1 is 'name', not 'header'")):
        assert len(warnings_of(info, f"{topic} (")) == 1 and why in warnings_of(info, f"{topic} (")[0]
        assert f"  {topic} " in info.stdout
    for argv in (["replay", "--check", "odd.mcap"], ["diff", "odd.mcap", "odd.mcap"], ["plot", "odd.mcap", "-o", "o.svg"],
                 ["convert", "odd.mcap", "o.bag"], ["check", "odd.mcap"]):
        run(argv, tmp_path, codes=(0, 1))
    run(["convert", "odd.mcap", "out.mcap"], tmp_path)
    with open(tmp_path / "out.mcap", "rb") as stream:
        reader = make_reader(stream)
        kept = {channel.topic: (reader.get_summary().schemas[channel.schema_id].data, [])  # type: ignore[union-attr]
                for channel in reader.get_summary().channels.values()}  # type: ignore[union-attr]
        for _, channel, message in reader.iter_messages():
            kept[channel.topic][1].append(message.data)
    assert kept["/tf"] == (b"int32 x\n", INTS_CDR)
    assert kept["/tf_static"] == (recursive.encode(), empty)


def test_an_mcap_schema_that_differs_only_in_comments_is_read(tmp_path: Path, marm_recording: Recording) -> None:
    """Comments, constants, blank lines and spacing are not the layout: such a /joint_states is read."""
    from tests.recording_helpers import _typestore

    store = _typestore(False)
    text, _ = store.generate_msgdef("sensor_msgs/msg/JointState", ros_version=2)
    text = "# the joints\n\nint8 UNUSED = 3\n" + text.replace("\n", "   # note\n", 2)
    js = marm_recording.joint_states
    assert js is not None
    from tests.recording_helpers import _Messages

    messages = _Messages(store, False)
    datas = [bytes(store.serialize_cdr(messages.joint_state(int(t), js.names, js.positions[i]), "sensor_msgs/msg/JointState"))
             for i, t in enumerate(js.time_ns)]
    _mcap(tmp_path / "ok.mcap", [("/joint_states", "sensor_msgs/msg/JointState", text, datas, {})])
    outcome = run(["info", "ok.mcap", "--json"], tmp_path)
    assert not warnings_of(outcome, "/joint_states")
    assert '"joint1"' in outcome.stdout


@pytest.mark.parametrize("right", [True, False])
def test_an_mcap_schema_without_text_is_decided_by_its_type_hash(tmp_path: Path, marm_recording: Recording,
                                                                right: bool) -> None:
    from tests.recording_helpers import _Messages, _typestore

    store = _typestore(False)
    digest = store.hash_rihs01("sensor_msgs/msg/JointState") if right else "RIHS01_" + "0" * 64
    js = marm_recording.joint_states
    assert js is not None
    messages = _Messages(store, False)
    datas = [bytes(store.serialize_cdr(messages.joint_state(int(t), js.names, js.positions[i]), "sensor_msgs/msg/JointState"))
             for i, t in enumerate(js.time_ns[:5])]
    _mcap(tmp_path / "h.mcap", [("/joint_states", "sensor_msgs/msg/JointState", "", datas, {"topic_type_hash": digest})])
    outcome = run(["info", "h.mcap"], tmp_path)
    assert bool(warnings_of(outcome, "its type hash is")) is not right


def test_a_sqlite3_bag_whose_message_definitions_differ_is_foreign_data(tmp_path: Path, marm_recording: Recording) -> None:
    """rosbag2 Iron and later keep each type's definition in the database's message_definitions table."""
    bag = write_bag(tmp_path / "bag", [Publisher(marm_recording)], kind="sqlite3")
    [db3] = bag.glob("*.db3")
    with sqlite3.connect(db3) as db:
        db.execute("CREATE TABLE IF NOT EXISTS message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, "
                   "encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL, type_description_hash TEXT NOT NULL)")
        db.execute("DELETE FROM message_definitions")
        db.execute("INSERT INTO message_definitions(topic_type, encoding, encoded_message_definition, type_description_hash) "
                   "VALUES ('sensor_msgs/msg/JointState', 'ros2msg', 'float64[] position\n', '')")
    outcome = run(["replay", "--check", "bag"], tmp_path, codes=(0, 1))
    assert len(warnings_of(outcome, "/joint_states (sensor_msgs/msg/JointState): its definition is not ROS's")) == 1


# -- definitions whose types contain themselves, or nest thousands deep ------------------------------------------

RECURSIVE = {
    "directly": "pkg/Node child\nint32 v\n",
    "through an array": "pkg/Node[] children\nint32 v\n",
    "through another type": "pkg/Edge[] edges\n" + SEPARATOR + "MSG: pkg/Edge\npkg/Node to\n",
}


def _chain(n: int) -> str:
    return SEPARATOR.join(["pkg/T0 f\n"] + [f"MSG: pkg/T{i}\npkg/T{i + 1} f\n" for i in range(n)] + [f"MSG: pkg/T{n}\nint32 v\n"])


def _wide(n: int) -> str:
    return "".join(f"pkg/T{i} f{i}\n" for i in range(n)) + "".join(SEPARATOR + f"MSG: pkg/T{i}\nint32 v\n" for i in range(n))


ODD_DEFINITIONS = {**RECURSIVE, "5,000 types deep": _chain(5000), "65 types deep": _chain(65),
                   "3,000 types wide": _wide(3000)}


@pytest.mark.parametrize("name", list(ODD_DEFINITIONS))
@pytest.mark.parametrize("kind", ["mcap", "ros1"])
def test_a_definition_whose_types_recurse_or_nest_deeply_is_one_warning(tmp_path: Path, marm_recording: Recording,
                                                                         name: str, kind: str) -> None:
    """On a topic of its own (``/graph``, pkg/Node) and as /tf's TFMessage: read, replayed, diffed and converted (the
    same serialization keeps it; the other cannot carry it: a warning naming why)."""
    definition = ODD_DEFINITIONS[name]
    robot = _robot_only(marm_recording)
    if kind == "ros1":
        _ros1_bag(tmp_path / "in.bag", [("/graph", "pkg/msg/Node", definition, "0" * 32, INTS_ROS1[:3]),
                                        ("/tf", "tf2_msgs/msg/TFMessage", definition, "*", INTS_ROS1[:3])], robot)
        target, other = "in.bag", "out.mcap"
    else:
        _mcap(tmp_path / "in.mcap", [("/graph", "pkg/msg/Node", definition, INTS_CDR[:3], {}),
                                     ("/tf", "tf2_msgs/msg/TFMessage", definition, INTS_CDR[:3], {})], robot)
        target, other = "in.mcap", "out.bag"
    info = run(["info", target], tmp_path)
    assert "/graph" in info.stdout and len(warnings_of(info, "/tf (tf2_msgs/msg/TFMessage)")) == 1
    for argv in (["replay", target, "--save", "out.rrd"], ["diff", target, target], ["plot", target, "-o", "o.svg"]):
        run(argv, tmp_path, codes=(0, 1))
    run(["convert", target, "same" + Path(target).suffix], tmp_path)
    crossed = run(["convert", target, other], tmp_path)
    assert warnings_of(crossed, "/graph: 3 messages not written: pkg/msg/Node: its message definition")


IDL_RECURSIVE = ("module pkg { module msg { struct Node { sequence<pkg::msg::Node> children; }; }; };\n"
                 "module tf2_msgs { module msg { struct TFMessage { sequence<pkg::msg::Node> transforms; }; }; };\n")
IDL_NESTED = "module a {" * 3000 + "};" * 3000


@pytest.mark.parametrize("idl", [IDL_RECURSIVE, IDL_NESTED], ids=["recursive", "3,000 modules deep"])
def test_a_ros2idl_schema_that_recurses_is_foreign_data(tmp_path: Path, marm_recording: Recording, idl: str) -> None:
    _mcap(tmp_path / "idl.mcap", [("/tf", "tf2_msgs/msg/TFMessage", idl, INTS_CDR[:3], {})], _robot_only(marm_recording),
          encoding="ros2idl")
    for argv in (["info", "idl.mcap"], ["replay", "idl.mcap", "--save", "out.rrd"], ["convert", "idl.mcap", "out.bag"]):
        outcome = run(argv, tmp_path)
        assert len(warnings_of(outcome, "/tf (tf2_msgs/msg/TFMessage)")) == 1, outcome.stderr


# -- mesh URIs -----------------------------------------------------------------------------------------------------

ASCII_STL = "solid part\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 0.05 0 0\n  vertex 0 0.05 0\n endloop\nendfacet\nendsolid part\n"


@pytest.mark.parametrize("uri, phrase", [
    ("package://arm/meshes/x%00.stl", "a NUL character"),
    ("file://HERE/arm/meshes/part%00.stl", "a NUL character"),
    ("package://arm/%2e%2e/%2e%2e/secret.stl", "leaves package"),
    ("package://arm/meshes%2F..%2F..%2Fsecret.stl", "leaves package"),
    ("package://arm/meshes/%2E%2E/%2e%2E/secret.stl", "leaves package"),
    ("package://../secret.stl", "is not the name of a package"),  # AMENT_PREFIX_PATH's share/.. is the prefix
    ("package:///secret.stl", "is not the name of a package"),
    ("package://arm/meshes/%zz%2.stl", "not found"),
    ("package://arm/meshes/%ff%fe.stl", "not found"),
])
def test_a_hostile_mesh_uri_is_a_warning_and_the_link_is_logged_without_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, uri: str, phrase: str) -> None:
    prefix = tmp_path / "prefix"
    (prefix / "share").mkdir(parents=True)
    (prefix / "secret.stl").write_text(ASCII_STL)  # a real mesh outside every package: never embedded
    (tmp_path / "secret.stl").write_text(ASCII_STL)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(prefix))
    arm = tmp_path / "ws" / "arm"
    (arm / "meshes").mkdir(parents=True)
    (arm / "urdf").mkdir()
    (arm / "package.xml").write_text("<package><name>arm</name></package>\n")
    (arm / "meshes" / "part.stl").write_text(ASCII_STL)
    (arm / "urdf" / "arm.urdf").write_text(f"""<robot name="arm">
  <link name="base"><visual><geometry><mesh filename="{uri.replace('HERE', str(tmp_path / 'ws'))}"/></geometry></visual></link>
  <link name="tip"><visual><geometry><mesh filename="package://arm/meshes/part.stl"/></geometry></visual></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="tip"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
""")
    outcome = run(["record", "ws/arm/urdf/arm.urdf", "-o", "arm.mcap", "--rrd", "arm.rrd", "--duration", "0.2"], tmp_path)
    [warning] = warnings_of(outcome, "mesh for link 'base'")
    assert phrase in warning and "link logged without it" in warning
    assert not warnings_of(outcome, "link 'tip'")
    replayed = run(["replay", "arm.mcap", "--save", "again.rrd", "--package-path", "ws"], tmp_path)
    assert len(warnings_of(replayed, "mesh for link 'base'")) == 1


# -- found by the fuzz suite ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("position", [1 << 63, (1 << 64) - 1, 1 << 40])
def test_a_chunk_info_record_pointing_past_the_file_reads_the_bag_record_by_record(
        tmp_path: Path, marm_recording: Recording, position: int) -> None:
    """A chunk_pos of 2**63 or more is past what seek() takes (a ValueError traceback before)."""
    bag = write_bag(tmp_path / "in.bag", [Publisher(marm_recording)], kind="ros1")
    data = bytearray(bag.read_bytes())
    at = data.rfind(b"chunk_pos=") + len(b"chunk_pos=")
    data[at : at + 8] = struct.pack("<Q", position)
    bag.write_bytes(bytes(data))
    for argv in (["info", "in.bag"], ["replay", "--check", "in.bag"], ["diff", "in.bag", "in.bag"]):
        outcome = run(argv, tmp_path)
        assert warnings_of(outcome, "points past the end of the file"), outcome.stderr
