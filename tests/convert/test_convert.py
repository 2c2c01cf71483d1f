"""``tfrec convert``: round trips between the formats, the cut that keeps latched topics, TF from
joint states, topic selection, errors — each output read back by rosbags as well as by tfrec."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.bag_builders import Robot, write_bag
from tests.conftest import ROBOTS
from tests.recording_helpers import load_robot, marm_trajectory, write_mcap
from tfrec import cli
from tfrec.convert import convert
from tfrec.diff.compare import compare
from tfrec.errors import ConvertError, WriteError
from tfrec.formats.reader import read_recording
from tfrec.info import summarize
from tfrec.recording import Recording


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def rosbags_messages(path: Path) -> dict[str, list[Any]]:
    """Every message of a recording, deserialized by rosbags' AnyReader (which checks each type's
    hash or md5sum against its definition), per topic."""
    from rosbags.highlevel import AnyReader

    out: dict[str, list[Any]] = {}
    with AnyReader([path]) as reader:
        for connection, _, raw in reader.messages():
            out.setdefault(connection.topic, []).append(reader.deserialize(raw, connection.msgtype))
    return out


def rosbags_latching(path: Path) -> dict[str, bool]:
    """Whether each topic is latched, as rosbags reads the connection (latching=1, or transient_local)."""
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        return {c.topic: bool(getattr(c.ext, "latching", 0)) or any(
            q.durability.value == 1 for q in getattr(c.ext, "offered_qos_profiles", [])) for c in reader.connections}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``tfrec record robots/marm.xacro -o marm.bag``: 4 s at 50 Hz."""
    folder = tmp_path_factory.mktemp("recorded")
    assert cli.main(["record", str(ROBOTS / "marm.xacro"), "-o", str(folder / "marm.bag"), "--no-rrd",
                     "--duration", "4"]) == 0
    return folder / "marm.bag"


@pytest.fixture(scope="module")
def marm_rec(tmp_path_factory: pytest.TempPathFactory) -> Recording:
    marm = load_robot("marm")
    return read_recording(write_mcap(tmp_path_factory.mktemp("marm") / "marm.mcap", marm, marm_trajectory(marm)))


# -- round trips -------------------------------------------------------------------------------------


def test_record_bag_to_mcap_to_bag_folder_diffs_equal(recorded: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "convert", str(recorded), str(tmp_path / "marm.mcap"))
    assert code == 0 and err == ""
    assert out == f"wrote {tmp_path / 'marm.mcap'} (ROS 2 MCAP): 404 messages on 4 topics\n"
    code, out, err = run(capsys, "convert", str(tmp_path / "marm.mcap"), "--bag", str(tmp_path / "folder"))
    assert code == 0 and err == "" and "(rosbag2 folder): 404 messages" in out
    assert sorted(p.name for p in (tmp_path / "folder").iterdir()) == ["folder_0.mcap", "metadata.yaml"]
    report = compare(recorded, tmp_path / "folder")
    assert report.equal, report.differences
    code, out, _ = run(capsys, "diff", str(recorded), str(tmp_path / "folder"))
    assert code == 0 and out.startswith("identical within tolerance")
    for path in (tmp_path / "marm.mcap", tmp_path / "folder"):  # every message, read back by rosbags
        messages = rosbags_messages(path)
        assert {topic: len(m) for topic, m in messages.items()} == {
            "/robot_description": 1, "/tf_static": 1, "/joint_states": 201, "/tf": 201}
        assert rosbags_latching(path) == {"/robot_description": True, "/tf_static": True, "/joint_states": False,
                                          "/tf": False}


def test_mcap_to_bag_and_back(marm_rec: Recording, tmp_path: Path) -> None:
    for compression in ("none", "lz4", "bz2"):
        result = convert(marm_rec.path, tmp_path / f"{compression}.bag", compression=compression)
        assert result.report is not None and result.report.messages == 204
        assert compare(marm_rec, tmp_path / f"{compression}.bag").equal
        messages = rosbags_messages(tmp_path / f"{compression}.bag")
        assert [m.header.seq for m in messages["/joint_states"]][:3] == [0, 0, 0]  # as rosbags converts
        assert rosbags_latching(tmp_path / f"{compression}.bag")["/tf_static"]
    convert(tmp_path / "lz4.bag", tmp_path / "back.mcap", compression="lz4")
    assert compare(marm_rec, tmp_path / "back.mcap").equal
    assert summarize(tmp_path / "back.mcap")["compression"] == "lz4"


def test_the_fast_path_gives_rosbags_bytes(marm_rec: Recording, tmp_path: Path) -> None:
    """TF and joint states translated in bulk are byte for byte what rosbags' conversion gives."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag1 import Reader

    convert(marm_rec.path, tmp_path / "out.bag")
    convert(tmp_path / "out.bag", tmp_path / "back.mcap")
    with AnyReader([Path(marm_rec.path)]) as source, Reader(tmp_path / "out.bag") as bag:
        expected = [bytes(source.typestore.cdr_to_ros1(raw, c.msgtype)) for c, _, raw in source.messages()]
        assert [bytes(raw) for _, _, raw in bag.messages()] == expected
    with AnyReader([tmp_path / "back.mcap"]) as back, AnyReader([Path(marm_rec.path)]) as source:
        assert [bytes(raw) for _, _, raw in back.messages()] == [bytes(raw) for _, _, raw in source.messages()]


# -- the cut ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".bag", ".mcap"])
def test_a_cut_keeps_the_latched_topics(recorded: Path, tmp_path: Path, suffix: str,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    out_path = tmp_path / f"cut{suffix}"
    code, out, err = run(capsys, "convert", str(recorded), str(out_path), "--start", "2", "--end", "3")
    assert code == 0 and err == ""
    assert out.splitlines()[1] == "cut from 2 s to 3 s; latched at the cut: /robot_description, /tf_static"
    summary = summarize(out_path)
    topics = {t["name"]: t for t in summary["topics"]}
    durability = "latched" if suffix == ".bag" else "transient_local"
    for topic in ("/robot_description", "/tf_static"):
        assert topics[topic]["count"] == 1 and topics[topic]["durability"] == durability
    assert topics["/joint_states"]["count"] == 51
    assert summary["start_time_ns"] == 1_700_000_002_000_000_000  # the latched messages are logged at the cut
    code, out, err = run(capsys, "info", str(out_path))
    assert code == 0 and "/tf_static          tf2_msgs/msg/TFMessage        1 msg" in out
    assert rosbags_latching(out_path)["/tf_static"] and rosbags_latching(out_path)["/robot_description"]
    code, out, _ = run(capsys, "replay", "--check", str(out_path))
    assert code == 0 and out.rstrip().endswith("PASS: all 9 frames match the description")


def test_a_cut_counts_from_the_first_joint_state(marm_rec: Recording, tmp_path: Path) -> None:
    """`start_s` counts from when the first /joint_states or /tf message was logged, as replay counts:
    a description published a second before does not move it."""
    early = Robot(marm_rec, topics=("/joint_states", "/tf"))
    bag = write_bag(tmp_path / "early.bag", [early], kind="ros1", extra=[
        ("/robot_description", "std_msgs/msg/String", (marm_rec.start_ns or 0) - 1_000_000_000,
         _string(marm_rec.robot_description or ""))])
    convert(bag, tmp_path / "cut.mcap", start_s=1.0)
    rec = read_recording(tmp_path / "cut.mcap")
    assert rec.start_ns == (marm_rec.start_ns or 0) + 1_000_000_000
    assert rec.robot_description == marm_rec.robot_description
    assert rec.topics["/robot_description"].first_ns == rec.start_ns


def _string(text: str) -> Any:
    from tests.recording_helpers import _typestore

    return _typestore(True).types["std_msgs/msg/String"](data=text)


# -- TF from joint states ---------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["ros1", "mcap", "sqlite3"])
def test_a_joint_only_bag_gains_tf(marm_rec: Recording, tmp_path: Path, kind: str,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    """A real robot's log — /joint_states and /robot_description, no /tf — gains the TF
    robot_state_publisher would have published, equal to the recorded one, and replay --check accepts it."""
    bag = write_bag(tmp_path / ("in.bag" if kind == "ros1" else f"in-{kind}"),
                    [Robot(marm_rec, topics=("/robot_description", "/joint_states"))], kind=kind)
    for suffix in (".mcap", ".bag"):
        out_path = tmp_path / f"out{suffix}"
        code, out, err = run(capsys, "convert", str(bag), str(out_path))
        assert code == 0 and err == ""
        assert "TF computed: 8 joints from /joint_states and 1 fixed frame from the description" in out
        report = compare(marm_rec, out_path)
        assert report.equal, report.differences
        assert {t for t, info in read_recording(out_path).topics.items() if info.count} == {
            "/robot_description", "/joint_states", "/tf", "/tf_static"}
        code, out, _ = run(capsys, "replay", "--check", str(out_path))
        assert code == 0 and "PASS" in out
        assert len(rosbags_messages(out_path)["/tf"]) == 101


def test_tf_from_joints_can_be_refused_and_demanded(marm_rec: Recording, tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "in.bag", [Robot(marm_rec, topics=("/robot_description", "/joint_states"))],
                    kind="ros1")
    convert(bag, tmp_path / "plain.mcap", tf_from_joints=False)
    assert set(read_recording(tmp_path / "plain.mcap").topics) == {"/robot_description", "/joint_states"}
    full = write_bag(tmp_path / "full.bag", [Robot(marm_rec)], kind="ros1")
    result = convert(full, tmp_path / "same.mcap")  # its /tf has every joint: nothing computed
    assert result.report is not None and result.report.derived == {}
    no_description = write_bag(tmp_path / "nodesc.bag", [Robot(marm_rec, topics=("/joint_states",))], kind="ros1")
    with pytest.raises(ConvertError, match=r"`tf_from_joints`: the robot has no usable /robot_description "
                                           r"\(give `robot` FILE\)"):
        convert(no_description, tmp_path / "x.mcap", tf_from_joints=True)
    assert not (tmp_path / "x.mcap").exists()


def test_robot_supplies_the_description(marm_rec: Recording, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = write_bag(tmp_path / "in.bag", [Robot(marm_rec, topics=("/joint_states",))], kind="ros1")
    code, out, err = run(capsys, "convert", str(bag), str(tmp_path / "out.bag"), "--robot", str(ROBOTS / "marm.xacro"))
    assert code == 0 and err == "" and "TF computed: 8 joints from /joint_states" in out
    rec = read_recording(tmp_path / "out.bag")
    assert rec.robot_description == load_robot("marm").urdf
    assert compare(marm_rec, rec).equal
    assert rosbags_latching(tmp_path / "out.bag")["/robot_description"]


# -- what is written --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def two_robots(marm_rec: Recording, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.recording_helpers import _Messages, _typestore

    t = _Messages(_typestore(True), True).t
    extra = [("/diagnostics_note", "std_msgs/msg/String", marm_rec.start_ns or 0, t["std_msgs/msg/String"](data="x"))]
    return write_bag(tmp_path_factory.mktemp("two") / "two.bag",
                     [Robot(marm_rec, namespace="/robot1"), Robot(marm_rec, namespace="/robot2")], kind="ros1",
                     extra=extra)


def test_topics_exclude_namespace_remap(two_robots: Path, marm_rec: Recording, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    def topics(path: Path) -> set[str]:
        return set(read_recording(path).topics)

    convert(two_robots, tmp_path / "ns.mcap", namespace="robot1")
    assert topics(tmp_path / "ns.mcap") == {"/robot1/robot_description", "/robot1/tf_static", "/robot1/joint_states",
                                            "/robot1/tf"}
    convert(two_robots, tmp_path / "some.mcap", topics=["/robot2/tf", "/diagnostics_note"])
    assert topics(tmp_path / "some.mcap") == {"/robot2/tf", "/diagnostics_note"}
    code, out, err = run(capsys, "convert", str(two_robots), str(tmp_path / "ex.bag"), "--exclude", "/robot2/tf",
                         "/robot2/joint_states", "/nope")
    assert code == 0 and err == f"tfrec: warning: {two_robots}: no /nope in the recording\n"
    assert out.splitlines()[-1] == "left out: 2 topics (202 messages) by --topics/--exclude/--namespace"
    assert "/robot2/tf" not in topics(tmp_path / "ex.bag") and "/robot2/tf_static" in topics(tmp_path / "ex.bag")
    convert(two_robots, tmp_path / "remapped.mcap", namespace="/",
            remap=[f"/robot1{topic}:={topic}" for topic in ("/tf", "/tf_static", "/joint_states", "/robot_description")])
    rec = read_recording(tmp_path / "remapped.mcap")
    assert set(rec.topics) == {"/robot_description", "/tf_static", "/joint_states", "/tf", "/diagnostics_note"}
    assert compare(rec, marm_rec, topics=["/tf", "/tf_static", "/joint_states", "/robot_description"]).equal
    code, _, err = run(capsys, "convert", str(two_robots), str(tmp_path / "none.mcap"), "--namespace", "/robot9")
    assert code == 2 and err == (f"tfrec: error: {two_robots}: no topic in --namespace /robot9 (the recording's "
                                 "namespaces: /, /robot1, /robot2)\n")


def test_rerun_output(recorded: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "convert", str(recorded), str(tmp_path / "marm.rrd"), "--start", "1")
    assert code == 0 and out == f"wrote {tmp_path / 'marm.rrd'} (Rerun recording)\n"
    rec = read_recording(tmp_path / "marm.rrd")
    assert rec.robot_description is not None and rec.tf_static
    code, _, err = run(capsys, "convert", str(recorded), str(tmp_path / "x.rrd"), "--compression", "lz4")
    assert code == 2 and err == "tfrec: error: --compression does not apply to a Rerun recording\n"


# -- errors and atomic outputs ----------------------------------------------------------------------


@pytest.mark.parametrize("argv, message", [
    (["{tmp}/OUT.txt"], ("{tmp}/OUT.txt: the output's name must end in .mcap (ROS 2), .bag (ROS 1) or .rrd (Rerun), "
                         "or give --bag DIR for a rosbag2 folder")),
    (["{tmp}/EXISTS.mcap"], "{tmp}/EXISTS.mcap: already exists (use --force to overwrite)"),
    (["{tmp}/OUT.mcap", "--start", "99"], "{in}: --start 99 s is beyond the recording's end (4 s)"),
    (["{tmp}/OUT.mcap", "--start", "3", "--end", "1"], "--end 1 is before --start 3"),
    (["{tmp}/OUT.mcap", "--start", "nan"], "--start nan is not a time in seconds >= 0"),
    (["{tmp}/OUT.mcap", "--bag", "{tmp}/DIR"], "OUT and --bag DIR exclude each other: one output at a time"),
    ([], "give an output: OUT.mcap, OUT.bag or OUT.rrd, or --bag DIR for a rosbag2 folder"),
    (["{tmp}/OUT.mcap", "--compression", "bz2"], "--compression 'bz2' is not one of none, lz4, zstd for a ROS 2 MCAP"),
    (["{tmp}/OUT.bag", "--compression", "zstd"], "--compression 'zstd' is not one of none, bz2, lz4 for a ROS 1 bag"),
    (["{tmp}/OUT.mcap", "--remap", "tf"], "--remap 'tf' is not a remapping rule FROM:=TO (e.g. /robot1/tf:=/tf)"),
    (["{tmp}/OUT.mcap", "--tf-from-joints", "--topics", "/tf"], None),
])
def test_errors_are_one_line(recorded: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                             argv: list[str], message: str | None) -> None:
    (tmp_path / "EXISTS.mcap").write_bytes(b"\x89MCAP0\r\nold")
    code, out, err = run(capsys, "convert", str(recorded), *(a.format(tmp=tmp_path) for a in argv))
    if message is None:  # nothing to compute: every joint is on the recorded /tf
        assert code == 0 and err == ""
        return
    assert code == 2 and out == ""
    assert err == f"tfrec: error: {message.format(tmp=tmp_path, **{'in': recorded})}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["EXISTS.mcap"]
    assert (tmp_path / "EXISTS.mcap").read_bytes() == b"\x89MCAP0\r\nold"


def test_missing_and_rerun_inputs(recorded: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "convert", str(tmp_path / "nope.bag"), str(tmp_path / "x.mcap"))
    assert code == 2 and err == f"tfrec: error: {tmp_path / 'nope.bag'}: no such file or folder\n"
    assert cli.main(["convert", str(recorded), str(tmp_path / "marm.rrd")]) == 0
    capsys.readouterr()
    code, _, err = run(capsys, "convert", str(tmp_path / "marm.rrd"), str(tmp_path / "x.mcap"))
    assert code == 2 and err == (f"tfrec: error: {tmp_path / 'marm.rrd'}: a Rerun recording converts only to an "
                                 ".rrd (it holds no ROS messages)\n")


def test_an_error_midway_leaves_nothing(recorded: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from tfrec.formats import translate

    (tmp_path / "out.mcap").write_bytes(b"\x89MCAP0\r\nold")
    calls = []

    def failing(self: Any, data: Any) -> Any:
        calls.append(1)
        if len(calls) > 2:
            raise OSError(28, "No space left on device")
        return original(self, data)

    original = translate.Translation.apply
    monkeypatch.setattr(translate.Translation, "apply", failing)
    with pytest.raises(WriteError, match="out.mcap: cannot write: No space left on device"):
        convert(recorded, tmp_path / "out.mcap", force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.mcap"]
    assert (tmp_path / "out.mcap").read_bytes() == b"\x89MCAP0\r\nold"


def test_a_damaged_input_converts_up_to_the_damage(recorded: Path, marm_rec: Recording, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    for source, cut in ((recorded, tmp_path / "cut.bag"), (Path(marm_rec.path), tmp_path / "cut.mcap")):
        data = source.read_bytes()
        cut.write_bytes(data[: len(data) * 2 // 3])
        code, out, err = run(capsys, "convert", str(cut), str(tmp_path / f"from-{cut.suffix[1:]}.mcap"))
        assert code == 0 and len(err.splitlines()) == 1, err
        assert err.startswith(f"tfrec: warning: {cut}: reading stopped at byte ") and "converted up to there" in err
        written = int(out.split(": ")[1].split()[0].replace(",", ""))
        assert 100 < written < 404 if source == recorded else 50 < written < 204
        rec = read_recording(tmp_path / f"from-{cut.suffix[1:]}.mcap")
        assert rec.read_error is None and rec.robot_description is not None


def test_a_cut_mcap_without_messages_before_the_cut(marm_rec: Recording, tmp_path: Path) -> None:
    """Latched messages that exist only after the cut stay where they are; an empty window keeps the latched ones."""
    result = convert(marm_rec.path, tmp_path / "late.mcap", start_s=0.5, end_s=0.5)
    assert result.report is not None
    rec = read_recording(tmp_path / "late.mcap")
    assert rec.topics["/tf_static"].count == 1 and rec.topics["/joint_states"].count == 1
    assert result.report.latched == ["/robot_description", "/tf_static"]


def test_writing_is_streamed(marm_rec: Recording, tmp_path: Path) -> None:
    """Many chunks in, many chunks out: the output is written while the input is read."""
    marm = load_robot("marm")
    long = write_mcap(tmp_path / "long.mcap", marm, marm_trajectory(marm, duration_s=60.0, rate_hz=100.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        convert(long, tmp_path / "long.bag")
    shutil.copy(tmp_path / "long.bag", tmp_path / "copy.bag")
    assert compare(long, tmp_path / "copy.bag").equal
    from rosbags.rosbag1 import Reader

    with Reader(tmp_path / "long.bag") as reader:
        assert len(reader.chunk_infos) > 5
        assert reader.message_count == 2 * 6001 + 2
    assert np.isclose(read_recording(tmp_path / "long.bag").duration_ns / 1e9, 60.0)
    for source in (long, tmp_path / "long.bag"):  # chunks after the cut are not read
        result = convert(source, tmp_path / "first.mcap", start_s=2.0, end_s=5.0, force=True)
        assert result.report is not None and result.report.written["/joint_states"] == 301
        assert read_recording(tmp_path / "first.mcap").topics["/tf"].count == 301


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("mode", ["FILE", "MESSAGE"])
def test_compressed_rosbag2_inputs(tmp_path: Path, marm_rec: Recording, storage: str, mode: str) -> None:
    """rosbag2 folders compressed file by file or message by message convert like any other."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    from tests.recording_helpers import _Messages, _typestore, recording_messages

    store = _typestore(False)
    bag = tmp_path / "zipped"
    writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3)
    writer.set_compression(CompressionMode[mode], CompressionFormat.ZSTD)
    with writer:
        connections: dict[str, Any] = {}
        for topic, msgtype, time_ns, msg in recording_messages(marm_rec, _Messages(store, False)):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], time_ns, bytes(store.serialize_cdr(msg, msgtype)))
    convert(bag, tmp_path / "plain.bag", start_s=1.0)
    rec = read_recording(tmp_path / "plain.bag")
    assert rec.topics["/joint_states"].count == 51 and rec.topics["/tf_static"].count == 1  # latched by convention
    assert rec.joint_states is not None and marm_rec.joint_states is not None
    np.testing.assert_array_equal(rec.joint_states.positions, marm_rec.joint_states.positions[-51:])
    assert rosbags_latching(tmp_path / "plain.bag")["/tf_static"]


def test_a_topic_of_several_connections_is_written_in_time_order(marm_rec: Recording, tmp_path: Path) -> None:
    """Two publishers of /tf in one ROS 1 chunk (as in rosbag.js's example.bag): convert wrote one connection's
    messages, then the other's, and a reader taking a chunk's records as they lie saw /tf go back in time —
    ``tfrec info``, which decodes the first thousand /tf messages, missed the second publisher's frames."""
    from mcap.reader import make_reader
    from rosbags.rosbag1 import Writer as Writer1

    from tests.recording_helpers import _typestore

    store = _typestore(True)
    t = store.types
    bag = tmp_path / "two_publishers.bag"
    with Writer1(bag) as writer:
        left = writer.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store, callerid="/left")
        right = writer.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store, callerid="/right")
        for i in range(1500):
            for conn, child in ((left, "left"), (right, "right")):
                stamp_ns = 1_700_000_000_000_000_000 + i * 10_000_000
                transform = t["geometry_msgs/msg/TransformStamped"](
                    header=t["std_msgs/msg/Header"](seq=i, stamp=t["builtin_interfaces/msg/Time"](
                        sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9), frame_id="world"),
                    child_frame_id=child,
                    transform=t["geometry_msgs/msg/Transform"](
                        translation=t["geometry_msgs/msg/Vector3"](x=float(i), y=0.0, z=0.0),
                        rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
                message = t["tf2_msgs/msg/TFMessage"](transforms=[transform])
                writer.write(conn, stamp_ns, store.serialize_ros1(message, "tf2_msgs/msg/TFMessage"))
    out = tmp_path / "two_publishers.mcap"
    convert(bag, out)
    with open(out, "rb") as stream:
        times = [message.log_time for _, _, message in make_reader(stream).iter_messages(log_time_order=False)]
    assert len(times) == 3000 and times == sorted(times)
    frames = {(f["parent"], f["child"]) for f in summarize(out)["tf_frames"]}
    assert frames == {("world", "left"), ("world", "right")}
