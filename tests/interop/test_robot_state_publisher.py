"""Real robot_state_publisher as the oracle: roscore + robot_state_publisher + a joint source (joint_state_publisher
with `zeros`, or a rospy sine publisher) + `rosbag record`, for robots with mimic, continuous, prismatic, floating
and planar joints; `tfrec replay --check` and `tfrec check --robot` pass on those bags. And tfrec's own bag played
through real robot_state_publisher (`rosbag play` → `rosbag record`) equals tfrec's /tf: frame ids, the
static/dynamic split, stamps, values."""

from __future__ import annotations

import json
import math
import time
import warnings
from importlib.util import find_spec
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.conftest import ROBOTS
from tests.description.mjcf_models import FEATURES, GYM
from tests.interop.conftest import add_to_figure, max_figure, needs
from tests.interop.ros import DEBIAN_PYTHON, JSP, RSP, Ros
from tests.test_real_robots import ERD
from tfrec import cli
from tfrec.description import load_description
from tfrec.model import JointType, Robot
from tfrec.replay import check_replay, load_replay

ZOO = """<robot name="zoo">
  <link name="world"/><link name="body"/><link name="plate"/><link name="slider"/><link name="wheel"/><link name="arm"/>
  <link name="finger"/><link name="twin"/><link name="camera"/>
  <joint name="float" type="floating"><parent link="world"/><child link="body"/><origin xyz="0 0 1" rpy="0 0 0.3"/></joint>
  <joint name="plane" type="planar"><parent link="body"/><child link="plate"/><origin xyz="0.1 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="slide" type="prismatic"><parent link="body"/><child link="slider"/><origin xyz="0 0.2 0"/>
    <axis xyz="1 1 0"/><limit lower="-0.3" upper="0.5" effort="10" velocity="1"/></joint>
  <joint name="spin" type="continuous"><parent link="body"/><child link="wheel"/><origin xyz="0 -0.2 0" rpy="1.5707963 0 0"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="elbow" type="revolute"><parent link="slider"/><child link="arm"/><origin xyz="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1.2" upper="2.0" effort="10" velocity="1"/></joint>
  <joint name="grip" type="revolute"><parent link="arm"/><child link="finger"/><origin xyz="0.2 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/><mimic joint="elbow" multiplier="-0.5" offset="0.1"/></joint>
  <joint name="twin_slide" type="prismatic"><parent link="arm"/><child link="twin"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="slide" multiplier="2"/></joint>
  <joint name="mount" type="fixed"><parent link="arm"/><child link="camera"/><origin xyz="0.05 0 0.1" rpy="0 0.5 0"/>
  </joint>
</robot>
"""
"""Every joint type: floating and planar (fixed for robot_state_publisher), prismatic on a skew axis, continuous,
revolute, mimic joints with multiplier and offset (of a revolute and of a prismatic joint), fixed."""

SINE = """\
import json, math, sys
import rospy
from sensor_msgs.msg import JointState

joints = json.loads(sys.argv[1])  # [name, lower, upper, velocity limit or 0] of each joint to move
rospy.init_node("sine_joints")
publisher = rospy.Publisher("/joint_states", JointState, queue_size=100)
rate = rospy.Rate(50)
start = rospy.Time.now()
while not rospy.is_shutdown():
    now = rospy.Time.now()
    t = (now - start).to_sec()
    message = JointState()
    message.header.stamp = now
    for k, (name, lower, upper, velocity) in enumerate(joints):
        amplitude = 0.8 * (upper - lower) / 2
        period = 1.5 + 0.2 * k  # slower where the joint's velocity limit asks (a controller would)
        # without a velocity limit, at most 1 rad/s or m/s: steps far below what `check` calls a jump
        period = max(period, 2 * math.pi * amplitude / (0.9 * (velocity if velocity > 0 else 1.0)))
        message.name.append(name)
        message.position.append((lower + upper) / 2 + amplitude * math.sin(2 * math.pi * t / period))
    publisher.publish(message)
    rate.sleep()
"""

ROBOT_FILES = {"marm": ROBOTS / "marm.xacro", "mbot": ROBOTS / "mbot.xacro"}
if ERD is not None:
    ROBOT_FILES["talos"] = ERD / "talos_data" / "robots" / "talos_full_v2.urdf"
    ROBOT_FILES["tiago"] = ERD / "tiago_description" / "robots" / "tiago.urdf"
MJCF_MODELS = {"mjcf-hand": "equality_hand", "mjcf-multi": "multi_joint", "mjcf-ref": "ref_degrees"}
"""MuJoCo models (hinge and slide joints, joint equalities, ref, anchors) whose generated URDF robot_state_publisher
reads: the /robot_description of their recordings (tests/description/test_mjcf.py)."""
if find_spec("mujoco") is not None:
    ROBOT_FILES.update({f"gym-{p.stem}": p for p in GYM if p.stem in ("half_cheetah", "walker2d", "reacher")})
ROBOT_NAMES = ["zoo", *ROBOT_FILES, *(MJCF_MODELS if find_spec("mujoco") is not None else ())]


@pytest.fixture(scope="module")
def urdfs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, Robot]]:
    """Each robot as an expanded URDF file (what robot_state_publisher reads from the parameter) and as tfrec's model."""
    folder = tmp_path_factory.mktemp("urdfs")
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # planar and floating joints, missing meshes
        for name in ROBOT_NAMES:
            if name == "zoo":
                text = ZOO
            elif name in MJCF_MODELS:
                model = folder / f"{name}.xml"
                model.write_text(FEATURES[MJCF_MODELS[name]], encoding="utf-8")
                text = load_description(model).urdf
            else:
                robot = load_description(ROBOT_FILES[name], package_paths=[p for p in (ERD, ROBOTS) if p is not None])
                text = robot.urdf
            path = folder / f"{name}.urdf"
            path.write_text(text, encoding="utf-8")
            out[name] = (path, load_description(path))
    return out


def _moving(robot: Robot) -> list[tuple[str, float, float, float]]:
    """The joints a joint source publishes: (name, lower, upper, velocity limit or 0), continuous ones over ±π;
    mimic joints left out. The sine source keeps each joint within its velocity limit, so that `tfrec check`'s
    motion findings have nothing to say and the test is about TF."""
    out = []
    for joint in robot.actuated_joints:
        if joint.mimic is not None:
            continue
        velocity = joint.limit.velocity if joint.limit is not None and math.isfinite(joint.limit.velocity) else 0.0
        if joint.type is JointType.CONTINUOUS or joint.limit is None:
            out.append((joint.name, -math.pi, math.pi, velocity))
        else:
            out.append((joint.name, joint.limit.lower, joint.limit.upper, velocity))
    return out


def _zeros(robot: Robot) -> dict[str, float]:
    """joint_state_publisher's `zeros`: each moving joint held at a third of its range (not 0: something to see)."""
    return {name: lower + (upper - lower) / 3 for name, lower, upper, _ in _moving(robot)}


def _record_live(ros: Ros, urdf: Path, robot: Robot, source: str, out: Path) -> Path:
    ros.set_param("/robot_description", urdf.read_text(encoding="utf-8"))
    ros.delete_param("/joint_state_publisher")
    if source == "joint_state_publisher":
        ros.set_param("/joint_state_publisher/zeros", _zeros(robot))
        ros.set_param("/joint_state_publisher/rate", 50)
        joints = ros.start(JSP, name=f"jsp-{out.stem}")
    else:
        script = ros.home / "sine_joints.py"
        script.write_text(SINE)
        joints = ros.start(DEBIAN_PYTHON, script, json.dumps(_moving(robot)), name=f"sine-{out.stem}")
    rsp = ros.start(RSP, name=f"rsp-{out.stem}")
    try:
        ros.wait_publishers("/joint_states")
        ros.wait_publishers("/tf_static")
        if _moving(robot):
            ros.wait_publishers("/tf")
        return ros.record(out, ["/tf", "/tf_static", "/joint_states"], duration_s=2.0)
    finally:
        ros.stop(joints)
        ros.stop(rsp)
        ros.wait_gone("/robot_state_publisher")


@pytest.mark.parametrize("source", ["joint_state_publisher", "sine"])
@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_bags_real_ros_records_pass_replay_check_and_check(ros: Ros, urdfs: dict[str, tuple[Path, Robot]],
                                                           name: str, source: str, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    needs(RSP, JSP)
    urdf, robot = urdfs[name]
    bag = _record_live(ros, urdf, robot, source, tmp_path / f"{name}-{source}.bag")
    assert cli.main(["replay", str(bag), "--check", "--robot", str(urdf)]) == 0, capsys.readouterr()
    assert cli.main(["check", str(bag), "--robot", str(urdf)]) == 0, capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = check_replay(load_replay(bag, robot=robot))
    compared = [f for f in report.frames if f.problem is None and f.samples]
    assert report.passed and compared
    tf = sum(f.samples for f in compared if f.topic.endswith("/tf"))
    assert tf > 0 or not _moving(robot)
    add_to_figure("robot_state_publisher: bags rosbag record wrote, checked", 1)
    add_to_figure("robot_state_publisher: transforms compared", sum(f.samples for f in compared))
    max_figure("robot_state_publisher: most frames in one bag", len(compared))
    max_figure("robot_state_publisher: max translation error (m)", max(f.translation_m for f in compared))
    max_figure("robot_state_publisher: max rotation error (rad)", max(f.rotation_rad for f in compared))


def _tf_messages(bag: Path) -> tuple[dict[tuple[str, str], list[tuple[int, Any, Any]]], dict[tuple[str, str], Any]]:
    """rosbags' reading of a bag's /tf: (parent, child) → [(header stamp ns, translation, rotation)], and of its
    /tf_static: (parent, child) → (translation, rotation) (the last message's)."""
    from rosbags.highlevel import AnyReader

    dynamic: dict[tuple[str, str], list[tuple[int, Any, Any]]] = {}
    static: dict[tuple[str, str], Any] = {}
    with AnyReader([bag]) as reader:
        for connection, _, raw in reader.messages():
            if connection.topic not in ("/tf", "/tf_static"):
                continue
            for t in reader.deserialize(raw, connection.msgtype).transforms:
                pair = (t.header.frame_id, t.child_frame_id)
                tr, q = t.transform.translation, t.transform.rotation
                values = (np.array([tr.x, tr.y, tr.z]), np.array([q.x, q.y, q.z, q.w]))
                if connection.topic == "/tf":
                    stamp = t.header.stamp.sec * 1_000_000_000 + t.header.stamp.nanosec
                    dynamic.setdefault(pair, []).append((stamp, *values))
                else:
                    static[pair] = values
    return dynamic, static


def _rotation_error(a: Any, b: Any) -> float:
    """The angle (rad) of the rotation between two unit quaternions (x, y, z, w), without acos's loss near 0."""
    ax, ay, az, aw = a / np.linalg.norm(a)
    bx, by, bz, bw = np.array([-b[0], -b[1], -b[2], b[3]]) / np.linalg.norm(b)  # b's inverse
    w = aw * bw - ax * bx - ay * by - az * bz
    v = np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                  aw * bz + ax * by - ay * bx + az * bw])
    return float(2 * math.atan2(float(np.linalg.norm(v)), abs(float(w))))


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_tfrecs_bag_played_through_real_robot_state_publisher_gives_tfrecs_tf(
        ros: Ros, urdfs: dict[str, tuple[Path, Robot]], name: str, tmp_path: Path) -> None:
    """`rosbag play own.bag --topics /joint_states` into real robot_state_publisher, its /tf and /tf_static recorded:
    the same frame pairs on the same topics, the same stamps, the same values (to float64 rounding)."""
    needs(RSP)
    urdf, _ = urdfs[name]
    own = tmp_path / "own.bag"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert cli.main(["record", str(urdf), "-o", str(own), "--no-rrd", "--duration", "1", "--traj", "sine"]) == 0
    ros.set_param("/robot_description", urdf.read_text(encoding="utf-8"))
    ros.delete_param("/robot_state_publisher")
    replayed = tmp_path / "replayed.bag"
    with ros.running(RSP, name=f"rsp-own-{name}"):
        ros.wait_publishers("/tf_static")
        recorder = ros.start("rosbag", "record", "-O", replayed, "/tf", "/tf_static", name=f"record-own-{name}")
        try:
            ros.wait_connected("/robot_state_publisher", "/tf", "/record")
            ros.wait_connected("/robot_state_publisher", "/tf_static", "/record")
            # at a quarter of the recorded rate: robot_state_publisher's subscription keeps one message (queue size
            # 1), so a busy machine must not make it drop one between two of its callbacks; the first message
            # waits for robot_state_publisher's connection
            ros.run("rosbag", "play", "--quiet", "--wait-for-subscribers", "--rate", "0.25", own,
                    "--topics", "/joint_states")
            time.sleep(1.0)  # the last /tf messages on their way to the recorder (not a measurement)
        finally:
            ros.stop(recorder)
    ros.wait_gone("/robot_state_publisher")
    theirs_tf, theirs_static = _tf_messages(replayed)
    ours_tf, ours_static = _tf_messages(own)
    assert set(theirs_tf) == set(ours_tf)  # the same dynamic frame pairs
    assert set(theirs_static) == set(ours_static)  # the same static ones: the static/dynamic split agrees
    worst_t = worst_r = 0.0
    for pair, ours in ours_tf.items():
        theirs = {stamp: (tr, q) for stamp, tr, q in theirs_tf[pair]}
        assert set(theirs) == {stamp for stamp, _, _ in ours}, pair  # every stamp, no other
        for stamp, tr, q in ours:
            worst_t = max(worst_t, float(np.abs(theirs[stamp][0] - tr).max()))
            worst_r = max(worst_r, _rotation_error(theirs[stamp][1], q))
    for pair, (tr, q) in ours_static.items():
        worst_t = max(worst_t, float(np.abs(theirs_static[pair][0] - tr).max()))
        worst_r = max(worst_r, _rotation_error(theirs_static[pair][1], q))
    assert worst_t < 1e-9 and worst_r < 1e-9
    add_to_figure("own bag through robot_state_publisher: robots", 1)
    add_to_figure("own bag through robot_state_publisher: /tf transforms compared (each frame at each stamp)",
                  sum(len(v) for v in ours_tf.values()))
    max_figure("own bag through robot_state_publisher: max translation difference (m)", worst_t)
    max_figure("own bag through robot_state_publisher: max rotation difference (rad)", worst_r)
