"""``tfrec replay``: recordings of every kind replayed into an .rrd (read back with Rerun's reader),
TF computed from joint logs, ``--check`` re-simulation, pacing on a fake clock, damaged files."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tfrec import cli
from tfrec.description import load_description, parse_urdf
from tfrec.errors import ReadError, ReplayError
from tfrec.formats.mcap.sink import McapSink
from tfrec.formats.rrd.paths import joint_entity, link_entity, pair_entity, tf_entity, tf_static_entity
from tfrec.kinematics.fk import Transforms, dynamic_transforms, iter_dynamic_chunks, static_transforms
from tfrec.kinematics.joints import all_joint_states
from tfrec.model import Robot
from tfrec.recorder import DEFAULT_START_TIME_NS, plan_outputs, record
from tfrec.recording import JointStates
from tfrec.replay.check import check_replay
from tfrec.replay.load import derive_transforms, detect_frame_prefix, load_replay
from tfrec.replay.pacing import Pacer, batches
from tfrec.replay.play import play, replay_to_rerun
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.types import JointTrajectory

REPO = Path(__file__).resolve().parents[2]
START_NS = DEFAULT_START_TIME_NS
ATOL32 = 2e-6  # .rrd transforms are float32


# -- fixtures -----------------------------------------------------------------------------------


@pytest.fixture
def tfrec_main() -> Callable[[list[str]], int]:
    return cli.main


@pytest.fixture(scope="module")
def marm() -> Robot:
    return load_description(REPO / "robots" / "marm.xacro")


@pytest.fixture(scope="module")
def traj(marm: Robot) -> JointTrajectory:
    return make_trajectory(marm, "sine", duration_s=2.0, rate_hz=50.0)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory, marm: Robot, traj: JointTrajectory) -> Path:
    """``tfrec record``'s MCAP (and .rrd beside it) of marm along a 2 s sine."""
    folder = tmp_path_factory.mktemp("recorded")
    record(marm, traj, plan_outputs(stem="marm", out=folder / "marm.mcap"))
    return folder / "marm.mcap"


def fk(robot: Robot, traj: JointTrajectory, *, frame_prefix: str = "") -> Transforms:
    names, positions, _ = all_joint_states(robot, traj)
    return dynamic_transforms(robot, names, positions, frame_prefix=frame_prefix)


class Rrd:
    """An .rrd read back with Rerun's reader: static rows and temporal rows by entity."""

    def __init__(self, path: Path) -> None:
        import pyarrow as pa
        import rerun as rr

        self.static: dict[str, dict[str, Any]] = defaultdict(dict)
        self.temporal: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for chunk in rr.chunk.RrdReader(path).stream():
            batch = chunk.to_record_batch()
            columns = [c.cast(pa.int64()) if pa.types.is_timestamp(c.type) else c for c in batch.columns]
            rows = pa.RecordBatch.from_arrays(columns, names=batch.schema.names).to_pylist()
            if chunk.is_static:
                for row in rows:
                    self.static[chunk.entity_path].update(row)
            else:
                self.temporal[chunk.entity_path].extend(rows)

    def transforms(self, entity: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, set[tuple[str, str]]]:
        """(stamps, translations (n, 3), quaternions (n, 4), {(parent, child)}) in time order."""
        rows = sorted(self.temporal[entity], key=lambda row: row["ros_time"])
        return (np.array([r["ros_time"] for r in rows], dtype=np.int64),
                np.array([r["Transform3D:translation"][0] for r in rows]),
                np.array([r["Transform3D:quaternion"][0] for r in rows]),
                {(r["Transform3D:parent_frame"][0], r["Transform3D:child_frame"][0]) for r in rows})


def assert_same_rotations(got: np.ndarray, want: np.ndarray) -> None:
    """Equal up to the sign of the quaternion (and float32 rounding)."""
    sign = np.sign(np.sum(got * want, axis=-1, keepdims=True))
    np.testing.assert_allclose(got * sign, want, atol=ATOL32)


def assert_rrd_moves_like_fk(rrd: Rrd, robot: Robot, traj: JointTrajectory, *, frame_prefix: str = "") -> None:
    """Every joint of the robot is at its FK transform at every sample, on RerunSink's entities."""
    want = fk(robot, traj, frame_prefix=frame_prefix)
    stamps = traj.time_ns + START_NS
    for k, joint in enumerate(robot.moving_joints):
        times, translation, rotation, pairs = rrd.transforms(tf_entity(joint.name))
        np.testing.assert_array_equal(times, stamps, err_msg=joint.name)
        np.testing.assert_allclose(translation, want.translation[:, k], atol=ATOL32, err_msg=joint.name)
        assert_same_rotations(rotation, want.rotation[:, k])
        assert pairs == {(frame_prefix + joint.parent, frame_prefix + joint.child)}
    fixed = static_transforms(robot, frame_prefix=frame_prefix)
    for k, child in enumerate(fixed.children):
        joint = next(j for j in robot.joints if frame_prefix + j.child == child)
        row = rrd.static[tf_static_entity(joint.name)]
        assert (row["Transform3D:parent_frame"], row["Transform3D:child_frame"]) == ([fixed.parents[k]], [child])
        np.testing.assert_allclose(row["Transform3D:translation"][0], fixed.translation[0, k], atol=ATOL32)
        assert_same_rotations(np.array(row["Transform3D:quaternion"]), fixed.rotation[:, k])
    for link in robot.links:
        assert rrd.static[link_entity(link.name)]["CoordinateFrame:frame"] == [frame_prefix + link.name]


# -- writing recordings with other tools' writers -------------------------------------------------


def write_joint_log(path: Path, robot: Robot, traj: JointTrajectory, *, kind: str,
                    joints: Sequence[str] | None = None, description: bool = True,
                    description_ns: int = START_NS) -> Path:
    """/robot_description + /joint_states only, written with rosbags: a joint log from a real robot.

    ``kind`` is ``mcap`` or ``sqlite3`` (rosbag2 folders) or ``ros1`` (a ROS 1 bag). The joint
    states hold the actuated joints (no mimic joints, as a robot driver publishes them); the
    latched description is logged at ``description_ns``.
    """
    from rosbags.typesys import Stores, get_typestore

    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    t = store.types
    names = list(joints if joints is not None else traj.joint_names)
    columns = [traj.joint_names.index(name) for name in names]
    messages: list[tuple[str, str, int, Any]] = []
    if description:
        messages.append(("/robot_description", "std_msgs/msg/String", description_ns,
                         t["std_msgs/msg/String"](data=robot.urdf)))
    for i, time_ns in enumerate(traj.time_ns + START_NS):
        stamp = t["builtin_interfaces/msg/Time"](sec=int(time_ns // 10**9), nanosec=int(time_ns % 10**9))
        header = (t["std_msgs/msg/Header"](seq=i, stamp=stamp, frame_id="") if ros1
                  else t["std_msgs/msg/Header"](stamp=stamp, frame_id=""))
        empty = np.zeros(0)
        messages.append(("/joint_states", "sensor_msgs/msg/JointState", int(time_ns), t["sensor_msgs/msg/JointState"](
            header=header, name=names, position=traj.positions[i, columns].copy(), velocity=empty, effort=empty)))
    if ros1:
        from rosbags.rosbag1 import Writer as Writer1

        with Writer1(path) as writer1:
            connections = {topic: writer1.add_connection(topic, msgtype, typestore=store)
                           for topic, msgtype in {(m[0], m[1]) for m in messages}}
            for topic, msgtype, time_ns, msg in messages:
                writer1.write(connections[topic], time_ns, bytes(store.serialize_ros1(msg, msgtype)))
        return path
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        connections = {topic: writer.add_connection(topic, msgtype, typestore=store)
                       for topic, msgtype in {(m[0], m[1]) for m in messages}}
        for topic, msgtype, time_ns, msg in messages:
            writer.write(connections[topic], time_ns, bytes(store.serialize_cdr(msg, msgtype)))
    return path


def write_perturbed_mcap(path: Path, robot: Robot, traj: JointTrajectory, *, joint: str, sample: int,
                         offset_m: float) -> Path:
    """tfrec's MCAP with one /tf translation moved by ``offset_m`` along x."""
    with open(path, "wb") as stream:
        sink = McapSink(stream)
        sink.begin(robot_description=robot.urdf, static=static_transforms(robot), start_time_ns=START_NS)
        for chunk in iter_dynamic_chunks(robot, traj, chunk_samples=1000):
            k = chunk.names.index(joint)
            translation = chunk.transforms.translation.copy()
            translation[sample, k, 0] += offset_m
            moved = Transforms(chunk.transforms.parents, chunk.transforms.children, translation,
                               chunk.transforms.rotation)
            sink.write_chunk(stamp_ns=chunk.time_ns + START_NS, joint_names=chunk.names, positions=chunk.positions,
                             velocities=chunk.velocities, transforms=moved)
        sink.finish()
    return path


# -- replaying into an .rrd -------------------------------------------------------------------------


def test_save_of_a_tfrec_recording_has_its_transforms(tfrec_main: Callable[[list[str]], int], recorded: Path,
                                                      marm: Robot, traj: JointTrajectory, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "replay.rrd"
    assert tfrec_main(["replay", str(recorded), "--save", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    rrd = Rrd(out)
    assert_rrd_moves_like_fk(rrd, marm, traj)
    assert rrd.static["/robot_description"]["TextDocument:text"] == [marm.urdf]
    assert rrd.static["/robot"]["CoordinateFrame:frame"] == ["link0"]
    names, positions, _ = all_joint_states(marm, traj)
    for j, name in enumerate(names):
        rows = sorted(rrd.temporal[joint_entity(name)], key=lambda row: row["ros_time"])
        np.testing.assert_array_equal([row["Scalars:scalars"][0] for row in rows], positions[:, j])
    assert not [entity for entity in rrd.temporal if entity.count("/") > 2]  # no pair outside the model
    # the same replay gives the same recording (same id, same data)
    again = tmp_path / "again.rrd"
    assert tfrec_main(["replay", str(recorded), "--save", str(again)]) == 0
    compared = subprocess.run([Path(sys.executable).with_name("rerun"), "rrd", "compare", out, again],
                              check=False, capture_output=True, text=True, timeout=60)
    assert compared.returncode == 0, compared.stdout + compared.stderr


def test_save_of_tfrecs_own_rrd_round_trips(recorded: Path, marm: Robot, traj: JointTrajectory,
                                            tmp_path: Path) -> None:
    out = tmp_path / "from_rrd.rrd"
    replay_to_rerun(load_replay(recorded.with_suffix(".rrd")), save=out)
    assert_rrd_moves_like_fk(Rrd(out), marm, traj)


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1"])
def test_joint_log_replays_with_tf_computed_from_the_joints(
    tfrec_main: Callable[[list[str]], int], kind: str, marm: Robot, traj: JointTrajectory, tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    source = write_joint_log(tmp_path / ("log.bag" if kind == "ros1" else "log"), marm, traj, kind=kind)
    out = tmp_path / "log.rrd"
    assert tfrec_main(["replay", str(source), "--save", str(out)]) == 0
    assert ("TF of 8 frames computed from the joint states and of 1 fixed frame taken from the robot "
            "description") in capsys.readouterr().out
    rrd = Rrd(out)
    # finger_joint2 is not in the log: it mimics finger_joint1, as robot_state_publisher derives it
    assert_rrd_moves_like_fk(rrd, marm, traj)
    assert rrd.static["/robot_description"]["TextDocument:text"] == [marm.urdf]


def test_replay_without_tf_topics_recomputes_them(recorded: Path, marm: Robot) -> None:
    full = load_replay(recorded)
    assert not full.derived
    joints_only = load_replay(recorded, topics=["/joint_states", "/robot_description"])
    assert joints_only.derived == set(full.tf) | set(full.static)
    for pair, series in full.tf.items():
        np.testing.assert_array_equal(joints_only.tf[pair].time_ns, series.time_ns)
        np.testing.assert_allclose(joints_only.tf[pair].translation, series.translation, atol=1e-15)
        np.testing.assert_allclose(joints_only.tf[pair].rotation, series.rotation, atol=1e-15)


def test_frame_prefix_lands_on_the_links_entities(tfrec_main: Callable[[list[str]], int], marm: Robot,
                                                  traj: JointTrajectory, tmp_path: Path) -> None:
    source = tmp_path / "left.mcap"
    record(marm, traj, plan_outputs(stem="left", out=source, no_rrd=True), frame_prefix="left/")
    out = tmp_path / "left.rrd"
    assert tfrec_main(["replay", str(source), "--save", str(out)]) == 0
    assert_rrd_moves_like_fk(Rrd(out), marm, traj, frame_prefix="left/")
    assert tfrec_main(["replay", str(source), "--check"]) == 0


def test_pairs_outside_the_model_keep_their_own_entities(marm: Robot, tmp_path: Path) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    source = tmp_path / "odom"
    with Writer(source, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        connection = writer.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store)
        for i in range(5):
            time_ns = START_NS + i * 100_000_000
            msg = t["tf2_msgs/msg/TFMessage"](transforms=[t["geometry_msgs/msg/TransformStamped"](
                header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=time_ns // 10**9,
                                                                                      nanosec=time_ns % 10**9),
                                                frame_id="odom"),
                child_frame_id="base_link",
                transform=t["geometry_msgs/msg/Transform"](
                    translation=t["geometry_msgs/msg/Vector3"](x=0.1 * i, y=0.0, z=0.0),
                    rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))])
            writer.write(connection, time_ns, bytes(store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage")))
    out = tmp_path / "odom.rrd"
    with pytest.warns(UserWarning, match="odom: no /robot_description in the recording and no `robot`: TF is "
                                         r"replayed without robot geometry \(give `robot` FILE\)"):
        replay = load_replay(source)
    assert replay.robot is None and replay.root_frame() == "odom"
    replay_to_rerun(replay, save=out)
    rrd = Rrd(out)
    times, translation, _, pairs = rrd.transforms(pair_entity("odom", "base_link"))
    assert len(times) == 5 and pairs == {("odom", "base_link")}
    np.testing.assert_allclose(translation[:, 0], [0.0, 0.1, 0.2, 0.3, 0.4], atol=1e-7)
    assert rrd.static["/robot"]["CoordinateFrame:frame"] == ["odom"]
    assert rrd.static[link_entity("base_link")]["CoordinateFrame:frame"] == ["base_link"]


def test_start_keeps_latched_data_and_end_cuts(tfrec_main: Callable[[list[str]], int], recorded: Path,
                                               marm: Robot, tmp_path: Path) -> None:
    out = tmp_path / "cut.rrd"
    assert tfrec_main(["replay", str(recorded), "--start", "1.0", "--end", "1.5", "--save", str(out)]) == 0
    rrd = Rrd(out)
    times, *_ = rrd.transforms(tf_entity("joint3"))
    np.testing.assert_array_equal(times, START_NS + np.arange(1000, 1501, 20) * 1_000_000)
    assert rrd.static["/robot_description"]["TextDocument:text"] == [marm.urdf]
    assert rrd.static[tf_static_entity("gripper_joint")]["Transform3D:child_frame"] == ["gripper_link"]
    assert rrd.static[link_entity("link3")]["CoordinateFrame:frame"] == ["link3"]


# -- --check ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".mcap", ".rrd"])
def test_check_passes_on_tfrecs_own_recordings(tfrec_main: Callable[[list[str]], int], recorded: Path,
                                               suffix: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert tfrec_main(["replay", str(recorded.with_suffix(suffix)), "--check"]) == 0
    out = capsys.readouterr().out
    assert "PASS: all 9 frames match the description" in out
    assert out.count(" ok\n") == 9


def test_check_fails_naming_the_perturbed_frame(tfrec_main: Callable[[list[str]], int], marm: Robot,
                                                traj: JointTrajectory, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    source = write_perturbed_mcap(tmp_path / "moved.mcap", marm, traj, joint="joint3", sample=37, offset_m=1e-3)
    assert tfrec_main(["replay", str(source), "--check"]) == 1
    out = capsys.readouterr().out
    assert "FAIL: 1 of 9 frames differ from the description: link3 (translation off by 0.001 m at t=0.740 s)" in out
    assert tfrec_main(["replay", str(source), "--check", "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["failures"] == ["link3"] and not report["passed"]
    frame = next(f for f in report["frames"] if f["frame"] == "link3")
    assert frame["translation_m"] == pytest.approx(1e-3) and frame["translation_time_s"] == pytest.approx(0.74)
    # within a looser tolerance it passes
    assert tfrec_main(["replay", str(source), "--check", "--pos-tol", "2e-3"]) == 0


def test_check_catches_a_description_that_does_not_match(tfrec_main: Callable[[list[str]], int], recorded: Path,
                                                         marm: Robot, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    other = marm.urdf.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 0 1"/>', 1)
    assert other != marm.urdf
    changed = next(j for j in parse_urdf(other).joints if j.axis != marm.joint_by_name[j.name].axis)
    robot = tmp_path / "other.urdf"
    robot.write_text(other)
    assert tfrec_main(["replay", str(recorded), "--check", "--robot", str(robot)]) == 1
    out = capsys.readouterr().out
    assert "FAIL: 1 of 9 frames differ" in out and f": {changed.child} (rotation off by" in out


def test_check_needs_a_robot_description(tfrec_main: Callable[[list[str]], int], marm: Robot,
                                         traj: JointTrajectory, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    source = write_joint_log(tmp_path / "anonymous", marm, traj, kind="mcap", description=False)
    assert tfrec_main(["replay", str(source), "--check"]) == 2
    assert capsys.readouterr().err == (f"tfrec: error: {source}: no robot description to re-simulate with "
                                       "(no /robot_description in the recording); give --robot FILE\n")


def test_an_unusable_description_warns_and_replays_without_a_model(tfrec_main: Callable[[list[str]], int],
                                                                   marm: Robot, traj: JointTrajectory,
                                                                   tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "broken.mcap"
    with open(source, "wb") as stream:
        sink = McapSink(stream)
        sink.begin(robot_description="<robot name='x'>", static=static_transforms(marm), start_time_ns=START_NS)
        for chunk in iter_dynamic_chunks(marm, traj):
            sink.write_chunk(stamp_ns=chunk.time_ns + START_NS, joint_names=chunk.names, positions=chunk.positions,
                             velocities=chunk.velocities, transforms=chunk.transforms)
        sink.finish()
    with pytest.warns(UserWarning, match=r"/robot_description is not a usable robot description \(.*\); "
                                         r"replaying without the robot model \(give `robot` FILE\)"):
        replay = load_replay(source)
    assert replay.robot is None and replay.root_frame() == "link0"
    replay_to_rerun(replay, save=tmp_path / "broken.rrd")
    rrd = Rrd(tmp_path / "broken.rrd")
    times, *_ = rrd.transforms(pair_entity("link2", "link3"))  # no model: pairs keep their own entities
    assert len(times) == len(traj)
    assert tfrec_main(["replay", str(source), "--check"]) == 2
    assert "/robot_description is not a usable robot description" in capsys.readouterr().err
    # --robot replaces it: its geometry and text are logged
    out = tmp_path / "fixed.rrd"
    assert tfrec_main(["replay", str(source), "--robot", str(REPO / "robots" / "marm.xacro"), "--save", str(out)]) == 0
    rrd = Rrd(out)
    assert rrd.static["/robot_description"]["TextDocument:text"] == [marm.urdf]
    assert_rrd_moves_like_fk(rrd, marm, traj)


def test_no_viewer_executable(tfrec_main: Callable[[list[str]], int], recorded: Path,
                              monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from tfrec.viewer import spawn as rerun_replay

    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(rerun_replay.shutil, "which", lambda name: None)
    monkeypatch.setattr(rerun_replay, "_bundled_viewer", lambda: None)
    assert tfrec_main(["replay", str(recorded)]) == 2
    assert capsys.readouterr().err == ("tfrec: error: cannot spawn the Rerun viewer (no 'rerun' executable on PATH); "
                                       "use --save OUT.rrd or --connect URL\n")


def test_check_needs_joint_states_and_tf(tfrec_main: Callable[[list[str]], int], recorded: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    assert tfrec_main(["replay", str(recorded), "--check", "--topics", "/tf", "/robot_description"]) == 2
    assert capsys.readouterr().err == f"tfrec: error: {recorded}: no /joint_states to re-simulate\n"


# -- damaged files and errors -------------------------------------------------------------------------


def test_truncated_mcap_replays_up_to_the_damage(tfrec_main: Callable[[list[str]], int], marm: Robot,
                                                 tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A recorder killed mid-write: the file ends inside its only chunk, whose complete records replay."""
    long = make_trajectory(marm, "sine", duration_s=5.0, rate_hz=100.0)
    full = tmp_path / "full.mcap"
    with open(full, "wb") as stream:
        sink = McapSink(stream)  # 1 MiB chunks: these 5 s are one chunk
        sink.begin(robot_description=marm.urdf, static=static_transforms(marm), start_time_ns=START_NS)
        for chunk in iter_dynamic_chunks(marm, long):
            sink.write_chunk(stamp_ns=chunk.time_ns + START_NS, joint_names=chunk.names, positions=chunk.positions,
                             velocities=chunk.velocities, transforms=chunk.transforms)
        sink.finish()
    data = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    out = tmp_path / "cut.rrd"
    assert tfrec_main(["replay", str(cut), "--save", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(
        f"tfrec: warning: {cut}: reading stopped at byte {len(data) // 2:,} of {len(data) // 2:,}: "
        "the file ends inside a chunk record (recovered ")
    recovered = int(err[0].split("(recovered ")[1].split(" ")[0].replace(",", ""))
    times, translation, _, _ = Rrd(out).transforms(tf_entity("joint3"))
    n = len(times)
    assert 0 < n < len(long) and n == (recovered - 2) // 2  # the cut may leave a /joint_states without its /tf
    assert err[0].endswith(f"; replayed up to t={((recovered - 1) // 2 - 1) * 0.01:.3f} s")
    np.testing.assert_allclose(translation, fk(marm, long).translation[:n, 2], atol=ATOL32)


def test_not_a_recording_is_a_one_line_error(tfrec_main: Callable[[list[str]], int], tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    junk = tmp_path / "notes.txt"
    junk.write_text("hello\n")
    assert tfrec_main(["replay", str(junk), "--save", str(tmp_path / "x.rrd")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"tfrec: error: {junk}: not a recording")
    assert not (tmp_path / "x.rrd").exists()


def test_headless_machine_suggests_save_or_connect(tfrec_main: Callable[[list[str]], int], recorded: Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    if os.name == "nt" or os.uname().sysname == "Darwin":
        pytest.skip("a display is always there")
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"):
        monkeypatch.delenv(name, raising=False)
    assert tfrec_main(["replay", str(recorded)]) == 2
    assert capsys.readouterr().err.endswith(
        "tfrec: error: cannot spawn the Rerun viewer (headless machine?); use --save OUT.rrd or --connect URL\n")
    # a file that is missing or no recording says so first (it was the viewer's error, naming no file)
    junk = recorded.parent / "notes.txt"
    junk.write_text("hello\n")
    for path, problem in ((recorded.parent / "missing.mcap", "no such file or folder"),
                          (junk, "not a recording (neither MCAP, rosbag2, ROS 1 bag nor Rerun .rrd)")):
        assert tfrec_main(["replay", str(path)]) == 2
        assert capsys.readouterr().err == f"tfrec: error: {path}: {problem}\n"


@pytest.mark.parametrize("args, message", [
    (["--loop", "--save", "x.rrd"], "--loop replays forever; it needs a live viewer, not --save"),
    (["--rate", "0"], "--rate 0 is not a speed > 0"),
    (["--save", "x.mcap"], "x.mcap: the output's name must end in .rrd (a Rerun recording)"),
    (["--topics", "/odom", "--save", "x.rrd"],
     ("topic '/odom' cannot be replayed; tfrec replays /robot_description, /tf_static, /joint_states, /tf "
      "(of any namespace, e.g. /robot1/tf)")),
    (["--start", "2", "--end", "1", "--save", "x.rrd"], "--end 1 is before --start 2"),
    (["--start", "-1", "--save", "x.rrd"], "--start -1.0 is not a time in seconds >= 0"),
])
def test_bad_options_are_one_line_errors(tfrec_main: Callable[[list[str]], int], recorded: Path, args: list[str],
                                         message: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert tfrec_main(["replay", str(recorded), *args]) == 2
    assert capsys.readouterr().err == f"tfrec: error: {message}\n"
    assert not list(tmp_path.iterdir())


def test_existing_output_needs_force(tfrec_main: Callable[[list[str]], int], recorded: Path, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "exists.rrd"
    out.write_bytes(b"RRF2old")
    assert tfrec_main(["replay", str(recorded), "--save", str(out)]) == 2
    assert capsys.readouterr().err == f"tfrec: error: {out}: already exists (use --force to overwrite)\n"
    assert out.read_bytes() == b"RRF2old"
    assert tfrec_main(["replay", str(recorded), "--save", str(out), "--force"]) == 0
    assert out.read_bytes()[:4] == b"RRF2"


# -- pacing -------------------------------------------------------------------------------------------


class FakeClock:
    """A clock that only moves when slept on (or when told to)."""

    def __init__(self) -> None:
        self.time = 1000.0
        self.sleeps: list[float] = []

    def now(self) -> float:
        return self.time

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.time += seconds


class ListSink:
    """A sink that notes what it is sent, and when (on the fake clock)."""

    def __init__(self, clock: FakeClock | None = None, *, send_s: float = 0.0) -> None:
        self.clock = clock
        self.send_s = send_s
        self.began: dict[str, Any] = {}
        self.transforms: list[tuple[float | None, tuple[str, str], np.ndarray]] = []
        self.joints: list[tuple[float | None, np.ndarray]] = []
        self.finished = self.aborted = False

    def _now(self) -> float | None:
        if self.clock is None:
            return None
        self.clock.time += self.send_s
        return self.clock.time

    def begin(self, **kwargs: Any) -> None:
        self.began = kwargs

    def write_transforms(self, parent: str, child: str, time_ns: np.ndarray, translation: np.ndarray,
                         rotation: np.ndarray, *, robot: int = 0) -> None:
        self.transforms.append((self._now(), (parent, child), time_ns.copy()))

    def write_joint_positions(self, time_ns: np.ndarray, names: Sequence[str], positions: np.ndarray, *,
                              robot: int = 0) -> None:
        self.joints.append((self._now(), time_ns.copy()))

    def finish(self) -> None:
        self.finished = True

    def abort(self) -> None:
        self.aborted = True


def test_batches_cover_every_stamp_once() -> None:
    a = np.array([0, 10, 20, 30, 95], dtype=np.int64)
    b = np.array([5, 31], dtype=np.int64)
    assert batches([a, b], start_ns=0, span_ns=30) == [(0, 30, 0), (30, 60, 30), (90, 120, 95)]
    assert batches([a], start_ns=25, span_ns=100) == [(25, 125, 30)]
    assert batches([], start_ns=0, span_ns=1) == []


def test_batches_equal_those_of_the_unique_stamps() -> None:
    """The windows come from a stable sort of the stamps (np.unique's sort was 35x slower on an hour of them):
    duplicates, stamps shared between series, stamps before the start and unsorted input give the windows that
    the sorted unique stamps give."""
    rng = np.random.default_rng(7)
    for trial in range(40):
        sizes = rng.integers(0, 400, size=int(rng.integers(1, 5)))
        series = [np.sort(rng.integers(-50, 5_000, size=int(size))) for size in sizes]
        series.append(series[0][::-1].copy())  # unsorted input, every stamp a duplicate
        start_ns, span_ns = int(rng.integers(-60, 200)), int(rng.integers(1, 300))
        every = np.unique(np.concatenate(series))
        every = every[every >= start_ns]
        window = (every - start_ns) // span_ns
        expected = [(start_ns + int(w) * span_ns, start_ns + (int(w) + 1) * span_ns, int(every[i]))
                    for i, w in enumerate(window) if i == 0 or window[i - 1] != w]
        assert batches(series, start_ns=start_ns, span_ns=span_ns) == expected, trial


def test_live_batches_are_sent_on_their_deadlines(recorded: Path) -> None:
    replay = load_replay(recorded)
    clock = FakeClock()
    sink = ListSink(clock)
    result = play(replay, sink, pacer=Pacer(clock, rate=1.0), span_ns=100_000_000)
    assert sink.finished and result.passes == 1 and result.batches == 21
    # every batch goes out when its first stamp is due: 0.1 s apart at rate 1
    sent = sorted({when for when, _ in sink.joints if when is not None})
    np.testing.assert_allclose(np.diff(sent), 0.1)
    np.testing.assert_allclose(clock.sleeps, [0.1] * 20)
    for when, stamps in sink.joints:
        assert when == pytest.approx(1000.0 + (stamps[0] - START_NS) / 1e9)
        assert stamps[-1] - stamps[0] < 100_000_000
    # static data goes first; every transform is sent once, in order
    assert set(sink.began["static"]) == set(replay.static)
    by_pair: dict[tuple[str, str], list[np.ndarray]] = defaultdict(list)
    for _, pair, stamps in sink.transforms:
        by_pair[pair].append(stamps)
    for pair, series in replay.tf.items():
        np.testing.assert_array_equal(np.concatenate(by_pair[pair]), series.time_ns)


def test_rate_scales_the_waits(recorded: Path) -> None:
    replay = load_replay(recorded)
    slept = {}
    for rate in (0.5, 1.0, 2.0):
        clock = FakeClock()
        play(replay, ListSink(clock), pacer=Pacer(clock, rate=rate), span_ns=100_000_000)
        slept[rate] = clock.sleeps
    np.testing.assert_allclose(slept[2.0], np.array(slept[1.0]) / 2)
    np.testing.assert_allclose(slept[0.5], np.array(slept[1.0]) * 2)
    assert sum(slept[1.0]) == pytest.approx(2.0)
    # by default a batch is a 30th of a wall second, whatever the rate
    clock = FakeClock()
    play(replay, ListSink(clock), pacer=Pacer(clock, rate=2.0))
    assert abs(len(clock.sleeps) - 30) <= 1 and sum(clock.sleeps) == pytest.approx(1.0, abs=1 / 30)
    assert max(clock.sleeps) < 1 / 30 + 0.01  # batches start on samples (every 10 ms of wall time at rate 2)


def test_a_late_replay_catches_up_without_sleeping(recorded: Path) -> None:
    clock = FakeClock()
    sink = ListSink(clock, send_s=0.3)  # every send takes 0.3 s: always behind 0.1 s batches
    play(load_replay(recorded), sink, pacer=Pacer(clock), span_ns=100_000_000)
    assert clock.sleeps == []


def test_loop_repeats_later_on_the_timeline(recorded: Path) -> None:
    replay = load_replay(recorded, end_s=0.5)
    clock = FakeClock()
    sink = ListSink(clock)
    result = play(replay, sink, pacer=Pacer(clock), loop=True, max_loops=3, span_ns=100_000_000)
    assert result.passes == 3
    stamps = np.concatenate([s for _, s in sink.joints])
    period = 20_000_000
    expected = START_NS + np.concatenate([np.arange(0, 500_000_001, period) + p * (500_000_000 + period)
                                          for p in range(3)])
    np.testing.assert_array_equal(stamps, expected)
    assert sum(clock.sleeps) == pytest.approx(3 * 0.52 - 0.02)


def test_loop_needs_a_live_sink(recorded: Path) -> None:
    with pytest.raises(ReplayError, match="needs a live viewer"):
        play(load_replay(recorded), ListSink(), loop=True)


def test_connect_streams_to_a_running_server(recorded: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import socket

    import rerun as rr

    from tfrec.viewer import spawn as rerun_replay

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = rr.RecordingStream("tfrec-test-server")
    url = server.serve_grpc(grpc_port=port)
    probed: list[str] = []
    check_can_connect = rerun_replay.check_can_connect

    def counted(url: str) -> None:
        probed.append(url)
        check_can_connect(url)

    monkeypatch.setattr(rerun_replay, "check_can_connect", counted)
    try:
        clock = FakeClock()
        result = replay_to_rerun(load_replay(recorded), connect=url, rate=4.0, clock=clock)
        assert result.passes == 1 and sum(clock.sleeps) == pytest.approx(0.5)
        assert probed == [url]
        # options checked already (the CLI checks them before reading the recording): no second probe
        replay_to_rerun(load_replay(recorded), connect=url, rate=4.0, clock=FakeClock(), checked=True)
        assert probed == [url]
    finally:
        server.disconnect()


# -- TF from joint states ----------------------------------------------------------------------------


def test_joints_missing_from_a_message_are_not_placed_at_its_stamp(marm: Robot) -> None:
    names = ("joint1", "finger_joint1")
    positions = np.array([[0.1, 0.01], [0.2, np.nan], [0.3, 0.015]])
    states = JointStates(np.array([0, 10, 20], dtype=np.int64), names, positions)
    tf = derive_transforms(marm, states)
    assert set(tf) == {("link0", "link1"), ("gripper_link", "gripper_finger_link1"),
                       ("gripper_link", "gripper_finger_link2")}
    np.testing.assert_array_equal(tf[("link0", "link1")].time_ns, [0, 10, 20])
    finger = tf[("gripper_link", "gripper_finger_link1")]
    mimic = tf[("gripper_link", "gripper_finger_link2")]
    np.testing.assert_array_equal(finger.time_ns, [0, 20])
    np.testing.assert_array_equal(mimic.time_ns, [0, 20])
    # finger_joint2 mimics finger_joint1 with multiplier -1: mirrored along y
    np.testing.assert_allclose(mimic.translation[:, 1] - mimic.translation[0, 1],
                               -(finger.translation[:, 1] - finger.translation[0, 1]))


def test_joints_without_positions_warn(marm: Robot, traj: JointTrajectory, tmp_path: Path) -> None:
    source = write_joint_log(tmp_path / "partial", marm, traj, kind="sqlite3", joints=["joint1", "joint2"])
    with pytest.warns(UserWarning, match=r"no /tf and no /joint_states position for joints joint3, joint4, "
                                         r"joint5, joint6, finger_joint1 and 1 more; their links are not placed"):
        replay = load_replay(source)
    assert {child for _, child in replay.tf} == {"link1", "link2"}


def test_selected_topics_missing_from_the_recording_warn(marm: Robot, traj: JointTrajectory,
                                                         tmp_path: Path) -> None:
    source = write_joint_log(tmp_path / "log", marm, traj, kind="mcap")
    with pytest.warns(UserWarning, match=r"log: no /tf_static, /tf in the recording$"):
        replay = load_replay(source, topics=["/tf", "/tf_static", "/joint_states"])
    assert replay.robot_description is None and len(replay.derived) == 9


def test_frame_prefix_detection(marm: Robot) -> None:
    assert detect_frame_prefix(marm, ["link0", "link1", "odom"]) == ""
    assert detect_frame_prefix(marm, ["left/link0", "left/link1", "left/gripper_link", "odom"]) == "left/"
    assert detect_frame_prefix(marm, ["/link0", "/link1"]) == "/"
    assert detect_frame_prefix(marm, ["odom", "map"]) == ""


def test_check_report_of_the_library(recorded: Path) -> None:
    report = check_replay(load_replay(recorded, start_s=0.5))
    assert report.passed and len(report.frames) == 9
    link3 = next(f for f in report.frames if f.frame == "link3")
    assert link3.samples == 76 and link3.topic == "/tf" and link3.joint == "joint3"


# -- replays that would do nothing, and what the summary says ---------------------------------------


def test_connect_to_no_viewer_is_one_line_error(tfrec_main: Callable[[list[str]], int], recorded: Path,
                                                        capfd: pytest.CaptureFixture[str]) -> None:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]  # closed again: nothing listens there
    url = f"rerun+http://127.0.0.1:{port}/proxy"
    assert tfrec_main(["replay", "--connect", url, str(recorded)]) == 2
    out, err = capfd.readouterr()
    assert err.startswith(f"tfrec: error: cannot connect to the Rerun viewer at {url}: ")
    assert err.count("\n") == 1 and "\x1b[" not in err and not out  # no Rerun log lines


def test_joint_log_without_a_description_warns(marm: Robot, traj: JointTrajectory, tmp_path: Path) -> None:
    source = write_joint_log(tmp_path / "bare", marm, traj, kind="mcap", description=False)
    with pytest.warns(UserWarning, match=r"bare: no /robot_description in the recording and no `robot`: only the "
                                         r"joint positions are replayed, with no robot model to move"):
        replay = load_replay(source)
    assert replay.robot is None and not replay.tf and replay.joint_states is not None


def test_an_rrd_not_written_by_tfrec_is_refused(tfrec_main: Callable[[list[str]], int], tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    import rerun as rr

    other = tmp_path / "other.rrd"
    stream = rr.RecordingStream("someone-else")
    stream.save(other)
    stream.set_time("frame", sequence=0)
    stream.log("points", rr.Points3D([[0.0, 0.0, 0.0]]))
    stream.flush()
    stream.disconnect()
    message = (f"{other}: a Rerun recording of 'someone-else', not written by tfrec: tfrec reads back only its "
               "own .rrd files (their entities stand for ROS topics)")
    with pytest.raises(ReadError) as info:
        load_replay(other)
    assert str(info.value) == message
    assert tfrec_main(["replay", str(other), "--save", str(tmp_path / "out.rrd")]) == 2
    assert capsys.readouterr().err == f"tfrec: error: {message}\n"
    assert not (tmp_path / "out.rrd").exists()


def test_start_beyond_the_end_is_an_error_and_an_empty_window_warns(recorded: Path) -> None:
    with pytest.raises(ReplayError, match=r"marm.mcap: `start_s` 100 s is beyond the recording's end \(2 s\)$"):
        load_replay(recorded, start_s=100.0)
    assert load_replay(recorded, start_s=2.0).start_ns == START_NS + 2 * 10**9  # the last sample
    with pytest.warns(UserWarning, match=r"marm.mcap: no /joint_states or /tf sample from 1.001 s to 1.002 s; "
                                         r"only latched data is replayed"):
        replay = load_replay(recorded, start_s=1.001, end_s=1.002)
    assert replay.start_ns is None and replay.static


def test_summary_tells_fixed_frames_from_computed_ones(recorded: Path) -> None:
    tf_only = load_replay(recorded, topics=["/tf"])  # /tf_static is not replayed: its fixed joint comes from the model
    assert not tf_only.derived_dynamic and tf_only.derived_static == {("link6", "gripper_link")}
    assert tf_only.derived_summary() == "TF of 1 fixed frame taken from the robot description"
    joints = load_replay(recorded, topics=["/joint_states", "/robot_description"])
    assert len(joints.derived_dynamic) == 8 and joints.derived_static == {("link6", "gripper_link")}
    assert joints.derived_summary() == ("TF of 8 frames computed from the joint states and of 1 fixed frame "
                                        "taken from the robot description")
    assert load_replay(recorded).derived_summary() == ""


def test_start_counts_from_the_first_sample_not_an_early_description(marm: Robot, traj: JointTrajectory,
                                                                      tmp_path: Path) -> None:
    source = write_joint_log(tmp_path / "early", marm, traj, kind="sqlite3", description_ns=START_NS - 5 * 10**9)
    replay = load_replay(source, start_s=1.0, end_s=1.5)
    assert replay.origin_ns == START_NS
    assert replay.joint_states is not None
    np.testing.assert_array_equal(replay.joint_states.time_ns, START_NS + np.arange(1000, 1501, 20) * 1_000_000)


def test_check_refuses_a_bad_tolerance(recorded: Path) -> None:
    replay = load_replay(recorded)  # the command line refuses these first (tests/test_cli.py)
    with pytest.raises(ReplayError, match=r"^`pos_tol` -1.0 is not a tolerance >= 0$"):
        check_replay(replay, pos_tol=-1.0)
    with pytest.raises(ReplayError, match=r"^`rot_tol` nan is not a tolerance >= 0$"):
        check_replay(replay, rot_tol=float("nan"))
