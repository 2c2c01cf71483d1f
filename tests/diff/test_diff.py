"""``tfrec diff``: comparing recordings by meaning — transforms, joints, topics, the URDF."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.recording_helpers import write_mcap, write_rosbag1, write_rosbag2
from tfrec import cli
from tfrec.diff.asserts import assert_recordings_match
from tfrec.diff.compare import FLOAT32_TOL, compare, rotation_error
from tfrec.diff.urdf import diff_urdf_texts
from tfrec.errors import DiffError, RecordingError
from tfrec.formats.mcap.writer import DEFAULT_START_TIME_NS
from tfrec.formats.reader import read_recording
from tfrec.kinematics.fk import Transforms
from tfrec.kinematics.rotations import quaternion_from_axis_angle, quaternion_multiply
from tfrec.model import Robot
from tfrec.recording import FrameSeries, JointStates, Recording, TopicInfo
from tfrec.trajectory.types import JointTrajectory


def _copy(rec: Recording) -> Recording:
    return copy.deepcopy(rec)


# -- equal ---------------------------------------------------------------------------------------


def test_self_diff_is_identical(marm_mcap: Path) -> None:
    report = compare(marm_mcap, marm_mcap)
    assert report.equal and report.differences == []
    text = report.to_text()
    assert text.splitlines()[0] == "identical within tolerance"
    assert f"A: {marm_mcap} (mcap, 2.000 s, 4 topics)" in text
    data = json.loads(report.to_json())
    assert data["equal"] is True and data["verdict"] == "identical within tolerance"
    assert data["differences"] == [] and data["largest"]["translation"]["value"] == 0.0
    assert data["a"]["topics"]["/tf"]["count"] == 101


def test_different_wall_clock_times_compare(tmp_path: Path, marm: Robot, traj: JointTrajectory,
                                            marm_mcap: Path) -> None:
    later = write_mcap(tmp_path / "later.mcap", marm, traj, start_time_ns=DEFAULT_START_TIME_NS + 3_600 * 10**9)
    assert compare(marm_mcap, later).equal
    absolute = compare(marm_mcap, later, absolute=True)
    assert not absolute.equal
    assert any("have no data in B" in d.detail for d in absolute.differences)
    assert "times are stamps" in absolute.to_text()


def test_other_formats_are_identical(tmp_path: Path, marm_rec: Recording, marm_mcap: Path) -> None:
    assert_recordings_match(marm_mcap, write_rosbag2(marm_rec, tmp_path / "bag"))
    assert_recordings_match(marm_mcap, write_rosbag1(marm_rec, tmp_path / "marm.bag"))


def test_mcap_against_its_own_rrd(tmp_path: Path, marm: Robot, traj: JointTrajectory) -> None:
    from tfrec.recorder import plan_outputs, record

    plan = plan_outputs(stem="marm", out=tmp_path / "marm.mcap")
    record(marm, traj, plan)
    assert plan.mcap is not None and plan.rrd is not None
    report = assert_recordings_match(plan.mcap, plan.rrd, pos_tol=FLOAT32_TOL, rot_tol=FLOAT32_TOL)
    assert 0 < report.largest["rotation"].value < 1e-6
    # at the default float64 tolerances the .rrd's float32 transforms compare at float32's precision
    report = compare(plan.mcap, plan.rrd)
    assert report.equal, report.to_text()
    (note,) = [note for note in report.notes if "float32" in note]
    assert note.startswith(f"{plan.rrd} stores transforms as float32: they were compared at the precision")
    assert "max(`pos_tol`, 4·eps32·|t|)" in note and "rotations within up to 4.77e-07 rad" in note
    # ...and a difference float32 can hold still shows: 1e-6 m in one transform of the .rrd's data
    rrd = read_recording(plan.rrd)
    series = rrd.tf[("link2", "link3")]
    series.translation[7, 0] += 1e-6
    moved = compare(plan.mcap, rrd)
    assert [d.what for d in moved.differences] == ["link2 → link3"]
    assert "first above 1e-09 m" not in moved.differences[0].detail  # the float32 tolerance, not the user's


def test_float32_tolerance_is_what_float32_tells_apart() -> None:
    from tfrec.diff.compare import float32_tolerance

    eps32 = float(np.finfo(np.float32).eps)
    np.testing.assert_array_equal(float32_tolerance(1e-9, np.array([0.0, 1.0, 100.0])),
                                  [1e-9, 4 * eps32, 400 * eps32])
    assert float32_tolerance(1e-3, np.array([1.0]))[0] == 1e-3  # a user's larger tolerance stays
    # float32 rounding of a value is within the tolerance at its magnitude, for any magnitude
    values = np.array([1e-6, 0.3, 1.7, 123.456, 9e4])
    rounded = values.astype(np.float32).astype(np.float64)
    assert np.all(np.abs(rounded - values) <= float32_tolerance(0.0, values))


_NO_FIXED_JOINTS = """<?xml version="1.0"?>
<robot name="nofixed">
  <link name="base"/><link name="arm"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def test_mcap_against_its_own_rrd_without_fixed_joints(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The MCAP's /tf_static holds one message without transforms, the .rrd has none: the same."""
    urdf = tmp_path / "nofixed.urdf"
    urdf.write_text(_NO_FIXED_JOINTS)
    mcap, rrd, saved = tmp_path / "nf.mcap", tmp_path / "nf.rrd", tmp_path / "nf-replayed.rrd"
    assert cli.main(["record", str(urdf), "--duration", "0.5", "-o", str(mcap)]) == 0
    assert cli.main(["replay", str(mcap), "--save", str(saved)]) == 0
    capsys.readouterr()
    note = "/tf_static only in A, whose 1 message holds no transforms: the same as no /tf_static"
    for other in (rrd, saved):
        report = compare(mcap, other, pos_tol=FLOAT32_TOL, rot_tol=FLOAT32_TOL)
        assert report.a.topics["/tf_static"].count == 1 and "/tf_static" not in report.b.topics
        assert report.equal and note in report.notes
        assert note.replace("only in A", "only in B") in compare(other, mcap, pos_tol=FLOAT32_TOL,
                                                                 rot_tol=FLOAT32_TOL).notes
        assert cli.main(["diff", str(mcap), str(other), "--pos-tol", "1e-5", "--rot-tol", "1e-5"]) == 0
        assert capsys.readouterr().out.startswith("identical within tolerance\n")
    # a /tf_static that holds transforms is still a difference when the other recording has none
    rec = read_recording(mcap)
    rec.tf_static[("base", "extra")] = (np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))
    report = compare(rec, rrd, pos_tol=FLOAT32_TOL, rot_tol=FLOAT32_TOL)
    assert "/tf_static only in A (1 messages of tf2_msgs/msg/TFMessage)" in [d.detail for d in report.differences]


# -- transforms -----------------------------------------------------------------------------------


def test_moved_transform_is_named_with_its_time(tmp_path: Path, marm: Robot, traj: JointTrajectory,
                                                 marm_mcap: Path) -> None:
    moved_at = DEFAULT_START_TIME_NS + 740_000_000

    def perturb(stamps: np.ndarray, tfs: Transforms) -> Transforms:
        translation = tfs.translation.copy()
        k = tfs.children.index("link3")
        translation[stamps == moved_at, k, 2] += 1e-3
        return Transforms(tfs.parents, tfs.children, translation, tfs.rotation)

    moved = write_mcap(tmp_path / "moved.mcap", marm, traj, perturb=perturb)
    report = compare(marm_mcap, moved)
    assert not report.equal
    assert [(d.kind, d.what) for d in report.differences] == [("tf", "link2 → link3")]
    (diff,) = report.differences
    assert diff.time_s == pytest.approx(0.74) and diff.value == pytest.approx(1e-3)
    text = report.to_text()
    assert text.splitlines()[0] == "1 difference"
    assert ("link2 → link3: translation differs by up to 0.001 m at t=0.740 s; "
            "first above 1e-09 m at t=0.740 s (1 of 101 samples)") in text
    # just within a looser tolerance
    assert compare(marm_mcap, moved, pos_tol=1.001e-3).equal


def test_rotation_error_is_the_relative_angle() -> None:
    axis = np.array([[0.0, 0.6, 0.8]])
    qa = quaternion_from_axis_angle(np.array([[1.0, 0.0, 0.0]]), np.array([0.4]))
    for angle in (1e-12, 1e-6, 0.3, math.pi - 1e-3):
        qb = quaternion_multiply(qa, quaternion_from_axis_angle(axis, np.array([angle])))
        assert rotation_error(qa, qb)[0] == pytest.approx(angle, rel=1e-6, abs=1e-15)
        assert rotation_error(qa, -qb)[0] == pytest.approx(angle, rel=1e-6, abs=1e-15)  # q and -q: same rotation
        assert rotation_error(qa, 3.0 * qb)[0] == pytest.approx(angle, rel=1e-6, abs=1e-15)  # scale-free


def test_rotation_change_is_reported(marm_rec: Recording) -> None:
    other = _copy(marm_rec)
    series = other.tf[("link0", "link1")]
    twist = quaternion_from_axis_angle(np.array([0.0, 0.0, 1.0]), np.array(2e-3))
    series.rotation[50:] = quaternion_multiply(series.rotation[50:], twist)
    report = compare(marm_rec, other)
    (diff,) = report.differences
    assert diff.what == "link0 → link1" and "rotation differs by up to 0.002 rad" in diff.detail
    assert diff.time_s == pytest.approx(1.0)


def test_frames_in_one_recording_only(marm_rec: Recording) -> None:
    other = _copy(marm_rec)
    del other.tf[("link5", "link6")]
    other.tf[("base", "link6")] = marm_rec.tf[("link5", "link6")]  # same child, another parent
    del other.tf[("gripper_link", "gripper_finger_link2")]
    other.tf[("gripper_link", "camera")] = marm_rec.tf[("gripper_link", "gripper_finger_link2")]
    static = other.tf_static.pop(("link6", "gripper_link"))
    other.tf[("link6", "gripper_link")] = FrameSeries(
        marm_rec.tf[("link0", "link1")].time_ns, np.tile(static[0], (101, 1)), np.tile(static[1], (101, 1)))
    details = [d.detail for d in compare(marm_rec, other).differences]
    assert "frame 'link6': parent 'link5' in A, 'base' in B" in details
    assert "gripper_link → gripper_finger_link2 only in A (/tf)" in details
    assert "gripper_link → camera only in B (/tf)" in details
    assert "link6 → gripper_link: on /tf_static in A, on /tf in B" in details


def test_static_transform_change(marm_rec: Recording) -> None:
    other = _copy(marm_rec)
    translation, rotation = other.tf_static[("link6", "gripper_link")]
    other.tf_static[("link6", "gripper_link")] = (translation + [0.0, 0.0, 0.01], rotation)
    (diff,) = compare(marm_rec, other).differences
    assert diff.kind == "tf_static" and diff.detail == "link6 → gripper_link: translation differs by 0.01 m"


# -- time: coverage and interpolation ---------------------------------------------------------


def _synthetic(times_ms: list[int] | np.ndarray, *, start_ns: int = 0) -> Recording:
    """One joint moving at 1 rad/s; one frame translating at 1 m/s and turning at 1 rad/s."""
    time_ns = np.asarray(times_ms, dtype=np.int64) * 1_000_000 + start_ns
    t = (time_ns - start_ns) / 1e9
    rotation = quaternion_from_axis_angle(np.array([0.0, 0.0, 1.0]), t)
    translation = np.stack([t, 2 * t, np.zeros_like(t)], axis=1)
    return Recording(
        path=f"synthetic-{len(time_ns)}", format="mcap",
        topics={"/tf": TopicInfo("tf2_msgs/msg/TFMessage", len(time_ns), int(time_ns[0]), int(time_ns[-1])),
                "/joint_states": TopicInfo("sensor_msgs/msg/JointState", len(time_ns), int(time_ns[0]),
                                           int(time_ns[-1]))},
        joint_states=JointStates(time_ns, ("j",), t[:, None].copy()),
        tf={("a", "b"): FrameSeries(time_ns, translation, rotation)},
        start_ns=int(time_ns[0]), end_ns=int(time_ns[-1]),
    )


def test_other_rate_is_interpolated() -> None:
    a = _synthetic(np.arange(0, 1001, 10))  # 100 Hz
    b = _synthetic(np.arange(0, 1001, 20))  # 50 Hz: same motion, linear in time, slerp-exact
    report = compare(a, b, pos_tol=1e-12, rot_tol=1e-12, joint_tol=1e-12, topics=["/tf", "/joint_states"])
    assert {d.what for d in report.differences} == {"/tf", "/joint_states"}  # the message counts only
    assert all("messages in A" in d.detail for d in report.differences)
    interpolated = ("some of A's times fall between B's samples, so B was interpolated at A's times (linear for "
                    "joint positions and translations, slerp for rotations): /joint_states and /tf a → b "
                    "(A 100 Hz, B 50 Hz)")
    assert [note for note in report.notes if "interpolated" in note] == [interpolated]
    assert report.largest["translation"].value < 1e-12 and report.largest["rotation"].value < 1e-12
    # the other way round, every one of A's times is one of B's: nothing is interpolated
    reverse = compare(b, a, pos_tol=1e-12, rot_tol=1e-12, joint_tol=1e-12)
    assert not any("interpolated" in note for note in reverse.notes)
    assert reverse.largest["translation"].value == 0.0 and reverse.largest["joint position"].value == 0.0
    # B at odd times: still interpolated exactly
    c = _synthetic(np.arange(3, 1000, 7))  # on A's time base: A's samples at 0 and 1000 ms are outside C's span
    report = compare(a, c, pos_tol=1e-9, rot_tol=1e-9, joint_tol=1e-9, absolute=True)
    kinds = {(d.kind, d.what) for d in report.differences}
    assert ("tf", "a → b") in kinds and ("joint_states", "/joint_states") in kinds
    coverage = [d.detail for d in report.differences if "no data in B" in d.detail]
    assert "a → b: 2 sample(s) of A from t=0.000 to 1.000 s have no data in B" in coverage
    assert report.largest["translation"].value < 1e-9


def test_an_early_latched_description_does_not_shift_the_alignment(tmp_path: Path, marm_rec: Recording,
                                                                   marm_mcap: Path) -> None:
    early = _copy(marm_rec)
    assert early.start_ns is not None
    early.start_ns -= 5 * 10**9  # rosbags writes /robot_description and /tf_static 5 s before the data
    bag = write_rosbag2(early, tmp_path / "early")
    report = compare(bag, marm_mcap)
    assert [d.detail for d in report.differences] == [
        "/robot_description: messages from t=-5.000 to -5.000 s in A, from t=0.000 to 0.000 s in B",
        "/tf_static: messages from t=-5.000 to -5.000 s in A, from t=0.000 to 0.000 s in B",
    ]  # the samples line up: no /joint_states or /tf differences
    assert report.origins == (marm_rec.start_ns, marm_rec.start_ns)
    assert "times are s since each recording's start (its first /joint_states or /tf stamp)" in report.to_text()
    assert json.loads(report.to_json())["a"]["origin_ns"] == marm_rec.start_ns
    # the same with --topics: the start does not depend on which topics are compared
    assert compare(bag, marm_mcap, topics=["/robot_description"]).differences == report.differences[:1]


def test_longer_recording_at_the_same_rate_is_not_interpolated() -> None:
    """B goes on after A at the same rate: the samples coincide where both have data."""
    a = _synthetic(np.arange(0, 1001, 20))
    b = _synthetic(np.arange(0, 2001, 20))
    for rec in (a, b):  # a joint missing from one message in both: NaN, the same in both
        assert rec.joint_states is not None
        rec.joint_states.positions[10] = np.nan
    report = compare(a, b)
    assert not any("interpolated" in note for note in report.notes)
    assert {d.kind for d in report.differences} == {"topic", "joint_states", "tf"}
    assert "/joint_states: 50 sample(s) of B lie outside A's time span (no data in A)" in [
        d.detail for d in report.differences]
    assert not any("NaN" in d.detail or "differs" in d.detail for d in report.differences)
    assert report.largest["joint position"].value == 0.0 and report.largest["translation"].value == 0.0


def test_shorter_recording(marm_rec: Recording) -> None:
    b = _synthetic(np.arange(0, 501, 20))
    a = _synthetic(np.arange(0, 1001, 20))
    report = compare(a, b)
    details = [d.detail for d in report.differences]
    assert "a → b: 25 sample(s) of A from t=0.520 to 1.000 s have no data in B" in details
    assert "/tf: messages from t=0.000 to 1.000 s in A, from t=0.000 to 0.500 s in B" in details
    reverse = compare(b, a)
    assert "a → b: 25 sample(s) of B lie outside A's time span (no data in A)" in [
        d.detail for d in reverse.differences]


# -- joint states ---------------------------------------------------------------------------------


def test_joint_differences(marm_rec: Recording) -> None:
    other = _copy(marm_rec)
    js = other.joint_states
    assert js is not None
    positions = js.positions.copy()
    positions[10:, js.names.index("joint4")] += 0.01
    positions[30, js.names.index("joint1")] = np.nan
    other.joint_states = JointStates(js.time_ns, js.names[:-1] + ("gripper",), positions)
    report = compare(marm_rec, other, joint_tol=1e-3)
    details = [d.detail for d in report.differences]
    assert any(d.startswith("joint 'joint4': joint position differs by up to 0.01 at t=") for d in details)
    assert any(d.endswith("first above 0.001 at t=0.200 s (91 of 101 samples)") for d in details)
    assert ("joint 'joint1': joint position in one recording only (NaN in the other) in 1 of 101 samples, "
            "first at t=0.600 s") in details
    assert "joint 'finger_joint2' only in A's /joint_states" in details
    assert "joint 'gripper' only in B's /joint_states" in details


# -- topics ---------------------------------------------------------------------------------------


def test_topic_differences(marm_rec: Recording) -> None:
    other = _copy(marm_rec)
    other.topics["/diagnostics"] = TopicInfo("diagnostic_msgs/msg/DiagnosticArray", 3, other.start_ns, other.end_ns)
    info = other.topics["/tf_static"]
    other.topics["/tf_static"] = TopicInfo("tf2_msgs/msg/TFMessage", 2, info.first_ns, info.last_ns)
    report = compare(marm_rec, other)
    assert [d.detail for d in report.differences] == [
        "/diagnostics only in B (3 messages of diagnostic_msgs/msg/DiagnosticArray)",
        "/tf_static: 1 messages in A, 2 in B",
    ]
    assert compare(marm_rec, other, topics=["/tf", "/joint_states"]).equal


# -- the robot description ----------------------------------------------------------------------


def test_changed_joint_origin_is_a_change_of_that_joint(tmp_path: Path, marm: Robot, traj: JointTrajectory,
                                                         marm_mcap: Path) -> None:
    import re

    joint2 = marm.joint_by_name["joint2"]
    old = " ".join(f"{v:g}" for v in joint2.origin.xyz)
    text = marm.urdf
    match = re.search(r'<joint name="joint2".*?</joint>', text, re.DOTALL)
    assert match is not None
    element = re.sub(r'xyz="[^"]*"', 'xyz="-0.1 0 0.01"', match.group(0), count=1)
    changed = text[: match.start()] + element + text[match.end():]
    from tfrec.description import parse_urdf

    robot = parse_urdf(changed, user_lines=False)
    other = write_mcap(tmp_path / "changed.mcap", robot, traj, description=changed)
    report = compare(marm_mcap, other)
    description = [d for d in report.differences if d.kind == "description"]
    assert [d.detail for d in description] == [
        f"joint 'joint2' changed: origin xyz ({old}) → (-0.1 0 0.01)"]
    assert [d.what for d in report.differences if d.kind == "tf"] == ["link1 → link2"]
    assert report.to_text().splitlines()[0] == "2 differences"


URDF = """<robot name="r">
  <link name="base"/><link name="arm"><visual><geometry><box size="1 1 1"/></geometry></visual></link>
  <link name="hand"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.1" rpy="3.14159265358979 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="fixed"><parent link="arm"/><child link="hand"/></joint>
</robot>"""


def test_urdf_diff_by_meaning() -> None:
    same = URDF.replace('rpy="3.14159265358979 0 0"', 'rpy="-3.14159265358979 0 0"').replace("\n  ", "\n    ")
    assert diff_urdf_texts(URDF, same) == []
    changed = (URDF.replace('name="r"', 'name="r2"')
               .replace('<axis xyz="0 0 1"/>', '<axis xyz="0 1 0"/>')
               .replace('upper="1"', 'upper="1.5"')
               .replace('<box size="1 1 1"/>', '<box size="1 1 2"/>')
               .replace('type="fixed"', 'type="prismatic"><limit lower="0" upper="1" effort="1" velocity="1"/'
                        '><axis xyz="1 0 0"/><mimic joint="shoulder" multiplier="2"/><dummy')
               .replace("<dummy>", ""))
    details = [c.detail for c in diff_urdf_texts(URDF, changed)]
    assert details == [
        "robot name 'r' → 'r2'",
        "link 'arm' changed: visual 0 box size (1 1 1) → (1 1 2)",
        "joint 'shoulder' changed: axis (0 0 1) → (0 1 0); limit upper 1 → 1.5",
        "joint 'wrist' changed: type fixed → prismatic; limit none → [0, 1]; mimic none → 'shoulder' ×2 +0",
    ]
    fewer = URDF.replace('<link name="hand"/>', "").replace(
        '<joint name="wrist" type="fixed"><parent link="arm"/><child link="hand"/></joint>',
        '<link name="tool"/><joint name="tip" type="fixed"><parent link="arm"/><child link="tool"/></joint>')
    assert [c.detail for c in diff_urdf_texts(URDF, fewer)] == [
        "link 'hand' removed (only in A)",
        "link 'tool' added (only in B)",
        "joint 'wrist' removed (only in A)",
        "joint 'tip' added (only in B) (fixed, arm → tool)",
    ]
    (bad,) = diff_urdf_texts(URDF, "<robot name='x'><link/></robot>")
    assert bad.detail.startswith("not a valid URDF: B's robot description:")


def test_description_differs_only_as_text(marm_rec: Recording) -> None:
    other = _copy(marm_rec)
    assert other.robot_description is not None
    other.robot_description = other.robot_description.replace("<robot ", "<!-- a comment --><robot ", 1)
    report = compare(marm_rec, other)
    assert report.equal and any("differ as text" in note for note in report.notes)


# -- errors and the pytest helper -------------------------------------------------------------------


def test_unreadable_file_is_one_line(tmp_path: Path, marm_mcap: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"\x89MCAP0\r\n\x01")
    with pytest.raises(RecordingError) as info:
        compare(marm_mcap, bad)
    assert str(info.value).startswith(f"{bad}: unreadable MCAP") and "\n" not in str(info.value)
    with pytest.raises(ValueError, match="pos_tol must be a finite number >= 0"):
        compare(marm_mcap, marm_mcap, pos_tol=-1.0)


def test_topics_in_neither_recording_are_an_error(marm_mcap: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rest = (f" /nothing: in neither {marm_mcap} nor {marm_mcap} "
            "(their topics: /joint_states, /robot_description, /tf, /tf_static)")
    with pytest.raises(DiffError) as info:
        compare(marm_mcap, marm_mcap, topics=["/tf", "/nothing"])
    assert str(info.value) == "`topics`" + rest  # the library names its parameter ...
    assert cli.main(["diff", str(marm_mcap), str(marm_mcap), "--topics", "/nothing"]) == 2
    assert capsys.readouterr().err == f"tfrec: error: --topics{rest}\n"  # ... the CLI its flag


def test_damaged_file_warns_and_compares(tmp_path: Path, marm_mcap: Path) -> None:
    data = marm_mcap.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: data.rfind(b"\x0f" + (4).to_bytes(8, "little"))])
    with pytest.warns(UserWarning, match="the file ends without a footer"):
        report = compare(marm_mcap, cut)
    assert report.equal and any(note.startswith("damaged file") for note in report.notes)


def test_assert_recordings_match(marm_rec: Recording) -> None:
    other = _copy(marm_rec)
    other.tf[("link1", "link2")].translation[7] += [0.0, 2e-3, 0.0]
    with pytest.raises(AssertionError) as info:
        assert_recordings_match(marm_rec, other)
    message = str(info.value)
    assert message.splitlines()[0] == "recordings differ: 1 difference"
    assert "link1 → link2: translation differs by up to 0.002 m at t=0.140 s" in message
    assert assert_recordings_match(marm_rec, other, pos_tol=1e-2).equal


# -- the command line -----------------------------------------------------------------------------


def test_cli_exit_codes(tmp_path: Path, marm_mcap: Path, marm_rec: Recording,
                        capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["diff", str(marm_mcap), str(marm_mcap)]) == 0
    assert capsys.readouterr().out.splitlines()[0] == "identical within tolerance"

    moved = _copy(marm_rec)
    moved.tf[("link1", "link2")].translation[7] += [0.0, 1e-3, 0.0]
    bag = write_rosbag2(moved, tmp_path / "moved")
    assert cli.main(["diff", str(marm_mcap), str(bag)]) == 1
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "1 difference" and "link1 → link2" in out and "t=0.140 s" in out
    assert cli.main(["diff", str(marm_mcap), str(bag), "--pos-tol", "0.01"]) == 0
    capsys.readouterr()

    assert cli.main(["diff", str(marm_mcap), str(bag), "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    assert data["equal"] is False and data["differences"][0]["what"] == "link1 → link2"

    garbage = tmp_path / "garbage.mcap"
    garbage.write_text("nope")
    assert cli.main(["diff", str(marm_mcap), str(garbage)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("tfrec: error: ") and "garbage.mcap" in err


# -- tiny description changes ----------------------------------------------------------------------


def test_tiny_origin_and_axis_changes_are_seen_at_a_tiny_tolerance() -> None:
    turned = URDF.replace('rpy="3.14159265358979 0 0"', 'rpy="3.14159265358979 0 1e-8"')
    tilted = URDF.replace('<axis xyz="0 0 1"/>', '<axis xyz="0 1e-8 1"/>')  # 1e-8 rad away, still unit
    for changed, what in ((turned, "origin rpy"), (tilted, "axis")):
        (change,) = diff_urdf_texts(URDF, changed, rot_tol=1e-9)
        assert change.what == "joint 'shoulder'" and change.detail.startswith(f"joint 'shoulder' changed: {what} (")
        assert diff_urdf_texts(URDF, changed, rot_tol=1e-7) == []
