"""`tfrec record` end to end: MCAP read back by independent readers, FK checked against yourdfpy,
byte-identical reruns, atomic outputs, rosbag2 folders, `tfrec info`."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from tests.conftest import ROBOTS
from tfrec.cli import main
from tfrec.errors import RecordingError
from tfrec.model import Robot
from tfrec.recorder import default_stem, plan_outputs, record
from tfrec.trajectory.generators import make_trajectory


def load_robot(name: str) -> Robot:
    from tfrec.description import load_description

    return load_description(ROBOTS / f"{name}.xacro")

MARM = str(ROBOTS / "marm.xacro")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def marm_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("rec") / "marm.mcap"
    assert main(["record", MARM, "--traj", "random", "--duration", "3", "--rate", "40", "--seed", "7",
                 "-o", str(out), "--no-rrd"]) == 0
    return out


def _read_all_rosbags(path: Path) -> dict[str, list[tuple[int, object]]]:
    from rosbags.highlevel import AnyReader

    out: dict[str, list[tuple[int, object]]] = {}
    with AnyReader([path]) as reader:
        for conn, stamp, raw in reader.messages():
            out.setdefault(conn.topic, []).append((stamp, reader.deserialize(raw, conn.msgtype)))
    return out


def test_rosbags_decodes_every_message_and_qos(marm_recording: Path) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import Qos  # noqa: F401  (exists in rosbags >= 0.10)

    msgs = _read_all_rosbags(marm_recording)
    assert {t: len(m) for t, m in msgs.items()} == {
        "/robot_description": 1, "/tf_static": 1, "/joint_states": 121, "/tf": 121}
    with AnyReader([marm_recording]) as reader:
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
    for topic in ("/robot_description", "/tf_static"):
        assert [q.durability.name for q in qos[topic]] == ["TRANSIENT_LOCAL"]
    for topic in ("/joint_states", "/tf"):
        assert [q.durability.name for q in qos[topic]] == ["VOLATILE"]
    # log time = header stamp; names in URDF order incl. the mimic finger
    for stamp, js in msgs["/joint_states"]:
        assert stamp == js.header.stamp.sec * 10**9 + js.header.stamp.nanosec  # type: ignore[attr-defined]
    names = list(msgs["/joint_states"][0][1].name)  # type: ignore[attr-defined]
    assert names == [f"joint{i}" for i in range(1, 7)] + ["finger_joint1", "finger_joint2"]
    first_tf = msgs["/tf"][0][1]
    assert [(t.header.frame_id, t.child_frame_id) for t in first_tf.transforms][:2] == [  # type: ignore[attr-defined]
        ("link0", "link1"), ("link1", "link2")]


def test_mcap_ros2_decodes_every_message(marm_recording: Path) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    counts: dict[str, int] = {}
    with open(marm_recording, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            assert message.log_time == message.publish_time
            assert decoded is not None
    assert counts == {"/robot_description": 1, "/tf_static": 1, "/joint_states": 121, "/tf": 121}


def test_tf_in_file_equals_fk_of_joint_states_in_file(marm_recording: Path) -> None:
    """Compose the file's /tf_static + /tf into link poses and compare with yourdfpy's FK of the file's
    /joint_states, on the URDF from the file's /robot_description."""
    import yourdfpy

    from tfrec.kinematics.rotations import matrix_from_quaternion

    msgs = _read_all_rosbags(marm_recording)
    urdf_text = msgs["/robot_description"][0][1].data  # type: ignore[attr-defined]
    oracle = yourdfpy.URDF.load(io.BytesIO(urdf_text.encode()), load_meshes=False, build_scene_graph=True)

    def matrix(t: object) -> np.ndarray:
        m = np.eye(4)
        r = t.transform.rotation  # type: ignore[attr-defined]
        v = t.transform.translation  # type: ignore[attr-defined]
        m[:3, :3] = matrix_from_quaternion(np.array([r.x, r.y, r.z, r.w]))
        m[:3, 3] = (v.x, v.y, v.z)
        return m

    static = {t.child_frame_id: (t.header.frame_id, matrix(t)) for t in msgs["/tf_static"][0][1].transforms}  # type: ignore[attr-defined]
    for (_, js), (_, tf) in list(zip(msgs["/joint_states"], msgs["/tf"]))[::10]:
        edges = dict(static)
        edges.update({t.child_frame_id: (t.header.frame_id, matrix(t)) for t in tf.transforms})  # type: ignore[attr-defined]
        actuated = {n: p for n, p in zip(js.name, js.position) if oracle.joint_map[n].mimic is None}  # type: ignore[attr-defined]
        oracle.update_cfg(actuated)
        for link in oracle.link_map:
            pose, frame = np.eye(4), link
            while frame in edges:
                parent, m = edges[frame]
                pose = m @ pose
                frame = parent
            assert frame == oracle.base_link
            np.testing.assert_allclose(pose, oracle.get_transform(link), atol=1e-9)


def test_byte_identical_reruns(tmp_path: Path) -> None:
    args = ["record", MARM, "--traj", "sine", "--duration", "1", "--no-rrd"]
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    assert main([*args, "-o", str(tmp_path / "a" / "r.mcap")]) == 0
    assert main([*args, "-o", str(tmp_path / "b" / "r.mcap")]) == 0
    assert (tmp_path / "a" / "r.mcap").read_bytes() == (tmp_path / "b" / "r.mcap").read_bytes()


def test_start_time_and_frame_prefix(tmp_path: Path) -> None:
    out = tmp_path / "p.mcap"
    assert main(["record", MARM, "--traj", "center", "--duration", "0.1", "--rate", "10", "--no-rrd",
                 "--start-time", "12.5", "--frame-prefix", "robot1/", "-o", str(out)]) == 0
    msgs = _read_all_rosbags(out)
    assert [s for s, _ in msgs["/joint_states"]] == [12_500_000_000, 12_600_000_000]
    assert msgs["/tf_static"][0][0] == 12_500_000_000
    frames = {(t.header.frame_id, t.child_frame_id) for t in msgs["/tf"][0][1].transforms}  # type: ignore[attr-defined]
    assert ("robot1/link0", "robot1/link1") in frames


def test_existing_file_needs_force(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x.mcap"
    out.write_bytes(b"\x89MCAP0\r\nolder")  # an MCAP (its magic): what --force may replace
    code, _, err = run(capsys, "record", MARM, "--duration", "0.2", "--no-rrd", "-o", str(out))
    assert code == 2 and err == f"tfrec: error: {out}: already exists (use --force to overwrite)\n"
    assert out.read_bytes() == b"\x89MCAP0\r\nolder"
    code, _, _ = run(capsys, "record", MARM, "--duration", "0.2", "--no-rrd", "-o", str(out), "--force")
    assert code == 0 and out.read_bytes()[:5] == b"\x89MCAP"


@pytest.mark.parametrize("error", [RecordingError, KeyboardInterrupt])
def test_failure_mid_write_leaves_nothing(tmp_path: Path, error: type[BaseException]) -> None:
    robot = load_robot("marm")
    trajectory = make_trajectory(robot, "sine", duration_s=4, rate_hz=100)
    out = tmp_path / "x.mcap"
    out.write_bytes(b"\x89MCAP0\r\nolder")
    plan = plan_outputs(stem="x", out=out, no_rrd=True, force=True)
    calls = []

    def progress(done: int, total: int) -> None:
        calls.append(done)
        if len(calls) == 2:
            raise error("stop")

    with pytest.raises(error):
        record(robot, trajectory, plan, chunk_samples=100, progress=progress)
    assert calls == [100, 200]
    assert out.read_bytes() == b"\x89MCAP0\r\nolder"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.mcap"]


def test_bag_folder_read_by_rosbag2_reader(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from rosbags.rosbag2 import Reader

    bag = tmp_path / "run1"
    code, out, _ = run(capsys, "record", MARM, "--duration", "1", "--bag", str(bag), "--no-rrd")
    assert code == 0 and f"wrote {bag}/" in out
    assert sorted(p.name for p in bag.iterdir()) == ["metadata.yaml", "run1_0.mcap"]
    from mcap.reader import make_reader

    with open(bag / "run1_0.mcap", "rb") as stream:  # metadata.yaml holds what the MCAP embeds, and names the file
        embedded, recipe = make_reader(stream).iter_metadata()  # and how the recording was made
    assert recipe.name == "tfrec.recipe" and recipe.metadata["traj"] == "sine"
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["relative_file_paths"] == ["run1_0.mcap"] and meta["files"][0]["path"] == "run1_0.mcap"
    assert {**meta, "relative_file_paths": [], "files": []} == yaml.safe_load(embedded.metadata["serialized_metadata"])
    with Reader(bag) as reader:
        assert reader.message_count == 2 + 2 * 51
        topics = {c.topic: c.msgtype for c in reader.connections}
        assert topics == {"/robot_description": "std_msgs/msg/String", "/tf_static": "tf2_msgs/msg/TFMessage",
                          "/joint_states": "sensor_msgs/msg/JointState", "/tf": "tf2_msgs/msg/TFMessage"}
        assert sum(1 for _ in reader.messages()) == 104


def test_default_output_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    code, out, _ = run(capsys, "record", MARM, "--traj", "sweep", "--duration", "0.5", "--no-rrd")
    assert code == 0
    (written,) = (tmp_path / "recordings").iterdir()
    import re

    assert re.fullmatch(r"marm-sweep-\d{8}-\d{6}\.mcap", written.name)
    assert f"wrote recordings/{written.name}" in out


def test_default_stem_names_the_trajectory() -> None:
    robot = load_robot("marm")
    assert default_stem(robot, "sweep", now=0).startswith("marm-sweep-")
    assert default_stem(robot, "moves/pick.csv", now=0).startswith("marm-pick-")


def test_bad_compression_leaves_nothing(tmp_path: Path) -> None:
    robot = load_robot("marm")
    plan = plan_outputs(stem="x", out=tmp_path / "x.mcap", no_rrd=True)
    with pytest.raises(RecordingError, match=r"^compression 'gzip' is not one of none, lz4, zstd$"):
        record(robot, make_trajectory(robot, "sine", duration_s=0.1, rate_hz=10), plan, compression="gzip")
    assert not list(tmp_path.iterdir())


def test_bad_trajectory_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "t.csv"
    csv.write_text("time,joint1,elbow\n0,0,0\n")
    code, _, err = run(capsys, "record", MARM, "--traj", str(csv), "--no-rrd", "-o", str(tmp_path / "o.mcap"))
    assert code == 2 and err.count("\n") == 1 and "column 'elbow'" in err
    assert not (tmp_path / "o.mcap").exists()
    code, _, err = run(capsys, "record", MARM, "--set", "joint1", "--no-rrd", "-o", str(tmp_path / "o.mcap"))
    assert code == 2 and err == "tfrec: error: --set 'joint1' is not of the form joint=number\n"


def test_option_conflicts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "record", MARM, "--no-rrd", "--no-mcap")
    assert code == 2 and "leave nothing to write" in err
    code, _, err = run(capsys, "record", MARM, "-o", str(tmp_path / "x.db3"), "--no-rrd")
    assert code == 2 and "must end in .mcap" in err
    folder = tmp_path / "x.rrd"
    folder.mkdir()
    code, _, err = run(capsys, "record", MARM, "--no-mcap", "--rrd", str(folder), "--force")
    assert code == 2 and err == f"tfrec: error: {folder}: exists and is a folder\n"


def test_mbot_record_and_info_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mbot.mcap"
    code, _, err = run(capsys, "record", str(ROBOTS / "mbot.xacro"), "--duration", "2", "--no-rrd", "-o", str(out))
    assert code == 0 and "expanded legacy macro calls" in err
    code, text, _ = run(capsys, "info", str(out), "--json")
    assert code == 0
    summary = json.loads(text)
    assert summary["robot_name"] == "mbot" and summary["joints"] == ["left_wheel_joint", "right_wheel_joint"]
    code, text, _ = run(capsys, "info", str(out))
    assert code == 0 and "/joint_states" in text and "50.000 Hz" in text
    bad = tmp_path / "bad.mcap"
    bad.write_text("not an mcap")
    code, _, err = run(capsys, "info", str(bad))
    assert code == 2 and err.count("\n") == 1 and "bad.mcap" in err


def test_sink_streams_chunk_by_chunk() -> None:
    """Bytes reach the stream as chunks complete, not all at the end (the one-hour peak-memory figure
    is measured by benchmarks/bench_mcap.py)."""
    from tfrec.formats.mcap.sink import McapSink
    from tfrec.kinematics.fk import iter_dynamic_chunks, static_transforms

    robot = load_robot("marm")
    trajectory = make_trajectory(robot, "sine", duration_s=20, rate_hz=100)
    stream = io.BytesIO()
    sink = McapSink(stream, compression="zstd")
    sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=0)
    sizes = []
    for chunk in iter_dynamic_chunks(robot, trajectory, chunk_samples=500):
        sink.write_chunk(stamp_ns=chunk.time_ns, joint_names=chunk.names, positions=chunk.positions,
                         velocities=chunk.velocities, transforms=chunk.transforms)
        sizes.append(stream.tell())
    sink.finish()
    assert 0 < sizes[0] < sizes[len(sizes) // 2] < sizes[-1]


def test_progress_bar_only_on_a_terminal_and_after_a_second() -> None:
    from tfrec.cli._common import Progress

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    now = [0.0]
    term = Terminal()
    bar = Progress(term, clock=lambda: now[0])
    bar(10, 100)
    assert term.getvalue() == ""  # under a second: nothing
    now[0] = 1.5
    bar(50, 100)
    bar(100, 100)
    bar.close()
    assert term.getvalue() == ("\r[###############...............]  50% 50/100 samples"
                               "\r[##############################] 100% 100/100 samples\n")
    piped = io.StringIO()  # not a terminal: never
    bar = Progress(piped, clock=lambda: 10.0)
    bar(100, 100)
    bar.close()
    assert piped.getvalue() == ""


def test_an_output_written_meanwhile_is_not_replaced_without_force(tmp_path: Path) -> None:
    """Two recorders writing one name: the second to finish fails instead of replacing the first."""
    robot = load_robot("marm")
    trajectory = make_trajectory(robot, "sine", duration_s=0.5, rate_hz=20)
    out = tmp_path / "x.mcap"
    plan = plan_outputs(stem="x", out=out, force=False)  # both outputs checked absent here
    rrd = out.with_suffix(".rrd")
    calls = []

    def meanwhile(done: int, total: int) -> None:
        if not calls:
            rrd.write_bytes(b"RRF2 the other recorder's")  # appears after the check, before the rename
        calls.append(done)

    with pytest.raises(RecordingError, match=r"x\.rrd: already exists \(written meanwhile by another process\?\)"):
        record(robot, trajectory, plan, progress=meanwhile)
    assert rrd.read_bytes() == b"RRF2 the other recorder's"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.rrd"]  # no MCAP of ours, no temporaries
    forced = plan_outputs(stem="x", out=out, force=True)
    record(robot, trajectory, forced)
    assert rrd.read_bytes()[:5] != b"RRF2 " and out.exists()


def test_start_time_is_exact_decimal(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    assert main(["record", MARM, "--traj", "center", "--duration", "0.1", "--rate", "10", "--no-rrd",
                 "--start-time", "1700000000.123456789", "-o", str(out)]) == 0
    assert [s for s, _ in _read_all_rosbags(out)["/joint_states"]] == [1700000000123456789, 1700000000223456789]


def test_csv_trajectory_warns_that_duration_does_not_apply(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "t.csv"
    csv.write_text("time,joint1\n0,0\n0.5,0.1\n")
    code, _, err = run(capsys, "record", MARM, "--traj", str(csv), "--duration", "5", "--no-rrd",
                       "-o", str(tmp_path / "o.mcap"))
    assert code == 0
    assert f"tfrec: warning: --duration does not apply to the CSV trajectory {csv}: its own times are used" in err


def test_sigterm_leaves_no_partial_output(tmp_path: Path) -> None:
    """`kill` / `timeout` send SIGTERM: cleaned up like Ctrl-C, exit 143."""
    import subprocess
    import sys
    import time

    out = tmp_path / "long.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "tfrec", "record", MARM, "--duration", "3600", "--rate", "100",
                             "-o", str(out)], stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not any(p.name.startswith(".tfrec-") for p in tmp_path.iterdir()):  # temporaries being written
        assert time.monotonic() < deadline and proc.poll() is None
        time.sleep(0.05)
    proc.terminate()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and err.strip().endswith("tfrec: terminated")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("compression", [None, "bz2", "lz4"])
def test_record_a_ros1_bag(tmp_path: Path, compression: str | None, capsys: pytest.CaptureFixture[str]) -> None:
    """`-o out.bag` writes a ROS 1 bag: read back by rosbags (latched description and static TF),
    byte-identical for the same command, and equal to the MCAP of the same command by meaning."""
    from rosbags.highlevel import AnyReader

    from tfrec.diff import compare

    extra = [] if compression is None else ["--compression", compression]
    paths = []
    for name in ("a.bag", "b.bag", "c.mcap"):
        out = tmp_path / name
        assert main(["record", str(ROBOTS / "marm.xacro"), "--traj", "random", "--duration", "2", "-o", str(out),
                     "--no-rrd", *(extra if name.endswith(".bag") else [])]) == 0
        paths.append(out)
    assert "(ROS 1 bag)" in capsys.readouterr().out
    assert paths[0].read_bytes() == paths[1].read_bytes()
    with AnyReader([paths[0]]) as reader:
        latched = {c.topic: c.ext.latching for c in reader.connections}
        counts = {c.topic: c.msgcount for c in reader.connections}
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
    assert latched == {"/robot_description": 1, "/tf_static": 1, "/joint_states": 0, "/tf": 0}
    assert counts == {"/robot_description": 1, "/tf_static": 1, "/joint_states": 101, "/tf": 101}
    report = compare(paths[2], paths[0])
    assert report.equal, report.to_text()
    assert main(["replay", "--check", str(paths[0])]) == 0


def test_a_ros1_bag_refuses_an_mcap_compression(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["record", str(ROBOTS / "marm.xacro"), "-o", str(tmp_path / "x.bag"), "--compression", "zstd"]) == 2
    assert capsys.readouterr().err == ("tfrec: error: --compression zstd: a ROS 1 bag chunk compression is one of "
                                       "none, bz2, lz4\n")
    assert not list(tmp_path.iterdir())
