"""Forward kinematics: per-joint transforms, composed, against yourdfpy and invariants."""

from __future__ import annotations

import dataclasses
import functools
import io
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from tests.conftest import CORPUS as SHARED_CORPUS
from tests.conftest import CORPUS_ABSENT
from tfrec.description import load_description, parse_urdf
from tfrec.errors import KinematicsError
from tfrec.kinematics.fk import (
    Transforms,
    dynamic_transforms,
    iter_dynamic_chunks,
    link_poses,
    root_from_link,
    static_transforms,
    transform_matrices,
)
from tfrec.kinematics.joints import all_joint_states
from tfrec.kinematics.rotations import matrix_from_quaternion, quaternion_from_rpy
from tfrec.model import JointType, Robot
from tfrec.trajectory.generators import make_trajectory
from tfrec.trajectory.joints import joint_bounds
from tfrec.trajectory.types import JointTrajectory

REPO = Path(__file__).resolve().parents[2]
CORPUS = SHARED_CORPUS

# (name, path, xacro args): the repository's robots, then the real packages.
ROBOTS = {
    "marm": (REPO / "robots" / "marm.xacro", {}),
    "mbot": (REPO / "robots" / "mbot.xacro", {}),
    "simple_cube": (REPO / "robots" / "simple_cube.xacro", {}),
}
CORPUS_ROBOTS = {
    "r2d2": (CORPUS / "urdf_tutorial" / "urdf" / "08-macroed.urdf.xacro", {}),
    "turtlebot3": (CORPUS / "turtlebot3_description" / "urdf" / "turtlebot3_burger.urdf.xacro", {}),
    "ur5": (CORPUS / "ur_description" / "urdf" / "ur5.xacro", {}),
    "panda": (CORPUS / "franka_description" / "robots" / "panda" / "panda.urdf.xacro", {"hand": "true"}),
    "robotiq": (CORPUS / "robotiq_description" / "urdf" / "robotiq_2f_85_gripper.urdf.xacro", {}),
}


@functools.cache
def load_robot(name: str) -> Robot:
    """Load a robot once per session; the only warning accepted is mbot's legacy macro calls."""
    path, args = {**ROBOTS, **CORPUS_ROBOTS}[name]
    if name in CORPUS_ROBOTS and not CORPUS.is_dir():
        pytest.skip(CORPUS_ABSENT)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = load_description(path, args=args, package_paths=[CORPUS] if CORPUS.is_dir() else [])
    unexpected = [str(w.message) for w in caught if "legacy macro" not in str(w.message)]
    assert not unexpected
    return robot


def random_configurations(robot: Robot, count: int, seed: int) -> np.ndarray:
    """Actuated positions within limits; continuous joints over ±3π, some beyond ±π."""
    rng = np.random.default_rng(seed)
    columns = []
    for joint in robot.actuated_joints:
        if joint.type is JointType.CONTINUOUS:
            columns.append(rng.uniform(-3 * math.pi, 3 * math.pi, count))
        else:
            columns.append(rng.uniform(*joint_bounds(joint), count))
    return np.array(columns).T.reshape(count, len(robot.actuated_joints))


def trajectory_of(robot: Robot, positions: np.ndarray) -> JointTrajectory:
    return JointTrajectory(
        tuple(j.name for j in robot.actuated_joints),
        np.arange(len(positions), dtype=np.int64),
        np.ascontiguousarray(positions, dtype=np.float64),
        np.zeros_like(positions, dtype=np.float64),
    )


def yourdfpy_poses(robot: Robot, positions: np.ndarray) -> dict[str, np.ndarray]:
    """Root → link poses from yourdfpy, fed the actuated joints only (it applies mimic itself)."""
    import yourdfpy

    model = yourdfpy.URDF.load(io.BytesIO(robot.urdf.encode()), load_meshes=False)
    for joint in model.robot.joints:  # yourdfpy leaves prismatic axes unnormalized; ROS normalizes
        if joint.axis is not None:
            joint.axis = np.asarray(joint.axis, dtype=float) / np.linalg.norm(joint.axis)
    names = [j.name for j in robot.actuated_joints]
    out = {link.name: np.empty((len(positions), 4, 4)) for link in robot.links}
    for i, cfg in enumerate(positions):
        model.update_cfg(dict(zip(names, cfg)))
        for link in robot.links:
            out[link.name][i] = model.get_transform(link.name)
    return out


def tfrec_poses(robot: Robot, positions: np.ndarray) -> dict[str, np.ndarray]:
    names, q, _ = all_joint_states(robot, trajectory_of(robot, positions))
    return link_poses(robot, names, q)


@pytest.mark.parametrize("name", [*ROBOTS, *CORPUS_ROBOTS])
def test_link_poses_match_yourdfpy(name: str) -> None:
    robot = load_robot(name)
    positions = random_configurations(robot, 25, seed=len(name))
    ours = tfrec_poses(robot, positions)
    theirs = yourdfpy_poses(robot, positions)
    assert set(ours) == {link.name for link in robot.links}
    for link, expected in theirs.items():
        np.testing.assert_allclose(ours[link], expected, rtol=0, atol=1e-9, err_msg=link)


def test_continuous_joints_far_beyond_pi_match_yourdfpy() -> None:
    robot = load_robot("mbot")
    positions = np.array([[10 * math.pi + 0.3, -7 * math.pi - 1.0], [4 * math.pi, -math.pi], [1e4, -1e4]])
    ours, theirs = tfrec_poses(robot, positions), yourdfpy_poses(robot, positions)
    for link, expected in theirs.items():
        np.testing.assert_allclose(ours[link], expected, rtol=0, atol=1e-9, err_msg=link)


def test_mimic_joints_move_with_their_master() -> None:
    robot = load_robot("marm")
    positions = np.zeros((1, len(robot.actuated_joints)))
    positions[0, [j.name for j in robot.actuated_joints].index("finger_joint1")] = 0.015
    poses = tfrec_poses(robot, positions)
    gripper = poses["gripper_link"][0]
    finger1 = np.linalg.inv(gripper) @ poses["gripper_finger_link1"][0]
    finger2 = np.linalg.inv(gripper) @ poses["gripper_finger_link2"][0]
    np.testing.assert_allclose(finger1[:3, 3], [0, 0.02 + 0.015, 0.02], atol=1e-12)
    np.testing.assert_allclose(finger2[:3, 3], [0, -0.02 - 0.015, 0.02], atol=1e-12)


def test_transforms_are_float64_unit_quaternions_with_non_negative_w() -> None:
    robot = load_robot("marm")
    names, q, _ = all_joint_states(robot, make_trajectory(robot, "random", duration_s=4, rate_hz=100))
    dynamic = dynamic_transforms(robot, names, q)
    static = static_transforms(robot)
    assert dynamic.translation.shape == (len(q), len(names), 3)
    assert dynamic.rotation.shape == (len(q), len(names), 4)
    assert static.translation.shape == (1, 1, 3) and static.children == ("gripper_link",)
    for tfs in (static, dynamic):
        assert tfs.translation.dtype == tfs.rotation.dtype == np.float64
        assert (tfs.rotation[..., 3] >= 0).all()
        np.testing.assert_allclose(np.linalg.norm(tfs.rotation, axis=-1), 1.0, atol=1e-15)


def test_joints_map_to_static_and_dynamic_transforms() -> None:
    robot = load_robot("mbot")
    static = static_transforms(robot)
    names, q, _ = all_joint_states(robot, make_trajectory(robot, "sine", duration_s=1))
    dynamic = dynamic_transforms(robot, names, q)
    assert set(static.children) == {"base_link", "camera_link", "front_caster_link", "back_caster_link"}
    assert dynamic.parents == ("base_link", "base_link")
    assert dynamic.children == ("left_wheel_link", "right_wheel_link")
    assert len(static) == 1 and len(dynamic) == 51


def test_frame_prefix_goes_in_front_of_every_frame_id_without_a_slash() -> None:
    robot = load_robot("marm")
    names, q, _ = all_joint_states(robot, make_trajectory(robot, "center", duration_s=1))
    static = static_transforms(robot, frame_prefix="left/")
    dynamic = dynamic_transforms(robot, names, q, frame_prefix="arm_")
    assert static.parents == ("left/link6",) and static.children == ("left/gripper_link",)
    assert dynamic.parents[0] == "arm_link0" and dynamic.children[0] == "arm_link1"
    plain = dynamic_transforms(robot, names, q)
    np.testing.assert_array_equal(plain.rotation, dynamic.rotation)


PLANAR_FLOATING = """<robot name="odd">
  <link name="world"/><link name="table"/><link name="puck"/><link name="drone"/><link name="rotor"/>
  <joint name="table_joint" type="fixed"><parent link="world"/><child link="table"/>
    <origin xyz="1 0 0.5"/></joint>
  <joint name="puck_joint" type="planar"><parent link="table"/><child link="puck"/>
    <origin xyz="0 0.2 0.1" rpy="0 0 0.5"/><axis xyz="0 0 1"/></joint>
  <joint name="drone_joint" type="floating"><parent link="world"/><child link="drone"/>
    <origin xyz="0 0 2"/></joint>
  <joint name="rotor_joint" type="continuous"><parent link="drone"/><child link="rotor"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/></joint>
</robot>"""


def test_planar_is_static_origin_and_floating_gets_no_transform() -> None:
    with pytest.warns(UserWarning) as caught:
        robot = parse_urdf(PLANAR_FLOATING)
    assert any("planar" in str(w.message) for w in caught) and any("floating" in str(w.message) for w in caught)
    static = static_transforms(robot)
    assert static.children == ("table", "puck")
    np.testing.assert_allclose(static.translation[0, 1], [0, 0.2, 0.1])
    np.testing.assert_allclose(static.rotation[0, 1], [0, 0, math.sin(0.25), math.cos(0.25)])
    names, q, _ = all_joint_states(robot, trajectory_of(robot, np.array([[1.0]])))
    assert names == ("rotor_joint",)
    poses = link_poses(robot, names, q)
    assert set(poses) == {"world", "table", "puck"}  # drone and rotor hang off a floating joint
    np.testing.assert_allclose(poses["puck"][0][:3, 3], [1, 0.2, 0.6])


def test_prismatic_axis_is_normalized() -> None:
    robot = parse_urdf("""<robot name="slide"><link name="a"/><link name="b"/>
      <joint name="s" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="0 3 4"/>
      <origin rpy="0 0 1.5707963267948966"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
    </robot>""")
    tfs = dynamic_transforms(robot, ["s"], [[0.5]])
    np.testing.assert_allclose(tfs.translation[0, 0], [-0.3, 0, 0.4], atol=1e-15)
    # a hand-built model with an unnormalized axis moves alike
    joint = dataclasses.replace(robot.joints[0], axis=(0.0, 3.0, 4.0))
    hand_built = dataclasses.replace(robot, joints=(joint,))
    np.testing.assert_allclose(dynamic_transforms(hand_built, ["s"], [[0.5]]).translation, tfs.translation)


def test_root_from_link_agrees_with_link_poses_and_chunks_with_whole() -> None:
    robot = load_robot("marm")
    trajectory = make_trajectory(robot, "random", duration_s=3, rate_hz=100, seed=3)
    names, q, _ = all_joint_states(robot, trajectory)
    whole = dynamic_transforms(robot, names, q, frame_prefix="p/")
    chunks = list(iter_dynamic_chunks(robot, trajectory, chunk_samples=64, frame_prefix="p/"))
    assert [len(c.time_ns) for c in chunks] == [64] * 4 + [45]
    np.testing.assert_array_equal(np.concatenate([c.time_ns for c in chunks]), trajectory.time_ns)
    np.testing.assert_array_equal(np.concatenate([c.positions for c in chunks]), q)
    np.testing.assert_array_equal(np.concatenate([c.transforms.rotation for c in chunks]), whole.rotation)
    np.testing.assert_array_equal(np.concatenate([c.transforms.translation for c in chunks]), whole.translation)
    assert all(c.names == names and c.transforms.children == whole.children for c in chunks)
    composed = root_from_link(static_transforms(robot, frame_prefix="p/"), whole, root="p/link0")
    poses = link_poses(robot, names, q)
    assert composed.children == tuple("p/" + link for link in poses)
    np.testing.assert_allclose(transform_matrices(composed), np.stack(list(poses.values()), axis=1), atol=1e-15)


def test_long_trajectories_are_computed_in_blocks_alike() -> None:
    robot = load_robot("marm")
    positions = random_configurations(robot, 9000, seed=5)  # more than one internal block
    names, q, _ = all_joint_states(robot, trajectory_of(robot, positions))
    whole = dynamic_transforms(robot, names, q)
    tail = dynamic_transforms(robot, names, q[8000:])
    np.testing.assert_array_equal(whole.rotation[8000:], tail.rotation)
    poses, tail_poses = link_poses(robot, names, q), link_poses(robot, names, q[8000:])
    for link in poses:
        np.testing.assert_array_equal(poses[link][8000:], tail_poses[link])


def test_root_from_link_accepts_static_transforms_sampled_like_dynamic_ones() -> None:
    robot = load_robot("marm")
    positions = random_configurations(robot, 5000, seed=6)  # more than one internal block
    names, q, _ = all_joint_states(robot, trajectory_of(robot, positions))
    static, dynamic = static_transforms(robot), dynamic_transforms(robot, names, q)
    repeated = Transforms(static.parents, static.children, np.repeat(static.translation, 5000, axis=0),
                          np.repeat(static.rotation, 5000, axis=0))
    once = root_from_link(static, dynamic, root="link0")
    every = root_from_link(repeated, dynamic, root="link0")
    np.testing.assert_array_equal(every.translation, once.translation)
    np.testing.assert_array_equal(every.rotation, once.rotation)


def test_transforms_at_one_instant_as_poses_and_back() -> None:
    static = static_transforms(load_robot("marm"), frame_prefix="p/")
    poses = static.poses()
    assert list(poses) == list(zip(static.parents, static.children))
    again = Transforms.from_poses(poses)
    assert (again.parents, again.children) == (static.parents, static.children)
    np.testing.assert_array_equal(again.translation, static.translation)
    np.testing.assert_array_equal(again.rotation, static.rotation)
    empty = Transforms.from_poses({})
    assert len(empty) == 1 and empty.children == () and empty.poses() == {}


def test_robot_without_moving_joints_has_only_static_transforms() -> None:
    robot = load_robot("simple_cube")
    names, q, _ = all_joint_states(robot, make_trajectory(robot, "center", duration_s=1, rate_hz=2))
    assert names == () and q.shape == (3, 0)
    assert len(dynamic_transforms(robot, names, q).children) == 0
    poses = link_poses(robot, names, q)
    assert list(poses) == ["base_link"] and poses["base_link"].shape == (3, 4, 4)
    np.testing.assert_array_equal(poses["base_link"], np.broadcast_to(np.eye(4), (3, 4, 4)))


def test_unknown_joint_name_is_an_error() -> None:
    robot = load_robot("marm")
    with pytest.raises(KinematicsError, match="'elbow' is not a moving joint of robot 'marm'"):
        dynamic_transforms(robot, ["elbow"], [[0.0]])


def test_fixed_joint_name_is_an_error() -> None:
    robot = load_robot("marm")
    with pytest.raises(KinematicsError, match="'gripper_joint' is not a moving joint of robot 'marm'"):
        dynamic_transforms(robot, ["gripper_joint"], [[0.0]])


def test_positions_of_the_wrong_shape_are_an_error() -> None:
    robot = load_robot("marm")
    with pytest.raises(KinematicsError, match=r"positions of shape \(2, 3\) do not match 2 joint names"):
        dynamic_transforms(robot, ["joint1", "joint2"], np.zeros((2, 3)))


def test_non_finite_position_is_an_error() -> None:
    robot = load_robot("marm")
    with pytest.raises(KinematicsError, match="joint 'joint2' has position nan at sample 1"):
        dynamic_transforms(robot, ["joint1", "joint2"], [[0.0, 0.0], [0.0, math.nan]])


def test_a_frame_with_two_parents_is_placed_below_the_first_that_reaches_it() -> None:
    # b -> c given first, but root a reaches c directly before it reaches b's child c
    one = Transforms(("a", "b", "a"), ("b", "c", "c"), np.array([[[1.0, 0, 0], [0, 5.0, 0], [0, 0, 2.0]]]),
                     np.tile([0.0, 0, 0, 1], (1, 3, 1)))
    empty = Transforms((), (), np.zeros((1, 0, 3)), np.zeros((1, 0, 4)))
    world = root_from_link(one, empty, root="a")
    assert world.children == ("a", "b", "c")
    np.testing.assert_allclose(world.translation[0, 2], [0.0, 0.0, 2.0])


@pytest.mark.parametrize("pairs", [
    [("a", "a"), ("a", "b")],  # a frame that is its own parent
    [("a", "b"), ("b", "a")],  # a cycle through the root
    [("a", "b"), ("b", "c"), ("c", "b")],  # a cycle below it
    [("a", "b"), ("x", "y"), ("y", "x")],  # a cycle apart from the tree
])
def test_a_cycle_is_not_followed(pairs: list[tuple[str, str]]) -> None:
    k = len(pairs)
    tfs = Transforms(tuple(p for p, _ in pairs), tuple(c for _, c in pairs), np.ones((3, k, 3)),
                     np.tile([0.0, 0, 0, 1], (3, k, 1)))
    static = Transforms((), (), np.zeros((1, 0, 3)), np.zeros((1, 0, 4)))
    world = root_from_link(static, tfs, root="a")
    assert world.children[0] == "a" and len(set(world.children)) == len(world.children)
    assert "b" in world.children and "x" not in world.children


def test_a_chain_of_100_000_frames_composes_without_recursion() -> None:
    n = 100_000
    tfs = Transforms(tuple(f"l{i}" for i in range(n)), tuple(f"l{i + 1}" for i in range(n)),
                     np.tile([0.0, 0.0, 0.001], (1, n, 1)), np.tile([0.0, 0, 0, 1], (1, n, 1)))
    world = root_from_link(tfs, Transforms((), (), np.zeros((1, 0, 3)), np.zeros((1, 0, 4))), root="l0")
    assert world.children[-1] == f"l{n}"
    assert world.translation[0, -1, 2] == pytest.approx(100.0)


# Property tests on random trees of joints ------------------------------------------------------

angles = st.floats(-math.pi, math.pi, allow_nan=False)
lengths = st.floats(-1.0, 1.0, allow_nan=False)
axes = st.tuples(lengths, lengths, lengths).filter(lambda v: math.dist(v, (0, 0, 0)) > 0.1)
joint_specs = st.tuples(
    st.sampled_from(["revolute", "continuous", "prismatic", "fixed"]),
    st.tuples(lengths, lengths, lengths),
    st.tuples(angles, angles, angles),
    axes,
    st.floats(0.0, 1.0),  # which earlier link is the parent, as a fraction
)


def tree_robot(specs: list[tuple]) -> Robot:
    parts = ['<robot name="tree"><link name="l0"/>']
    for i, (kind, xyz, rpy, axis, where) in enumerate(specs, start=1):
        parent = min(int(where * i), i - 1)
        parts.append(
            f'<link name="l{i}"/><joint name="j{i}" type="{kind}"><parent link="l{parent}"/>'
            f'<child link="l{i}"/><origin xyz="{" ".join(map(repr, xyz))}" rpy="{" ".join(map(repr, rpy))}"/>'
            f'<axis xyz="{" ".join(map(repr, axis))}"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        )
    parts.append("</robot>")
    return parse_urdf("".join(parts))


def origin_matrix(xyz: tuple, rpy: tuple) -> np.ndarray:
    """URDF origin from elementary rotations, independently of tfrec.kinematics.rotations."""
    r, p, y = rpy
    rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    out = np.eye(4)
    out[:3, :3] = rz @ ry @ rx
    out[:3, 3] = xyz
    return out


def joint_matrices(robot: Robot, q: np.ndarray) -> np.ndarray:
    """parent_from_child of each moving joint, (N, K, 4, 4)."""
    names = [j.name for j in robot.moving_joints]
    return transform_matrices(dynamic_transforms(robot, names, q))


property_settings = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@property_settings
@given(st.lists(joint_specs, min_size=1, max_size=6))
def test_zero_configuration_gives_the_chain_of_joint_origins(specs: list[tuple]) -> None:
    robot = tree_robot(specs)
    names = [j.name for j in robot.moving_joints]
    poses = link_poses(robot, names, np.zeros((1, len(names))))
    expected = {"l0": np.eye(4)}
    for joint in robot.tree_order:
        expected[joint.child] = expected[joint.parent] @ origin_matrix(joint.origin.xyz, joint.origin.rpy)
    for link, matrix in expected.items():
        np.testing.assert_allclose(poses[link][0], matrix, atol=1e-12, err_msg=link)


@property_settings
@given(st.lists(joint_specs, min_size=1, max_size=6), st.integers(0, 2**32 - 1))
def test_rotations_are_orthonormal_with_determinant_one(specs: list[tuple], seed: int) -> None:
    robot = tree_robot(specs)
    names = [j.name for j in robot.moving_joints]
    q = np.random.default_rng(seed).uniform(-3, 3, size=(8, len(names)))
    for matrix in link_poses(robot, names, q).values():
        rotation = matrix[:, :3, :3]
        np.testing.assert_allclose(rotation @ rotation.transpose(0, 2, 1), np.broadcast_to(np.eye(3), (8, 3, 3)),
                                   atol=1e-12)
        np.testing.assert_allclose(np.linalg.det(rotation), 1.0, atol=1e-12)
        np.testing.assert_array_equal(matrix[:, 3], np.broadcast_to([0.0, 0, 0, 1], (8, 4)))


@property_settings
@given(st.lists(joint_specs, min_size=1, max_size=4), st.floats(-20.0, 20.0, allow_nan=False))
def test_q_followed_by_minus_q_returns_the_origin_pose(specs: list[tuple], value: float) -> None:
    robot = tree_robot(specs)
    assume(robot.moving_joints)
    k = len(robot.moving_joints)
    at_q, at_zero, at_minus = joint_matrices(robot, np.array([[value] * k, [0.0] * k, [-value] * k]))
    for joint, forward, origin, backward in zip(robot.moving_joints, at_q, at_zero, at_minus):
        # origin · motion(q) · motion(-q), with motion(-q) = origin⁻¹ · (origin · motion(-q))
        np.testing.assert_allclose(forward @ np.linalg.inv(origin) @ backward, origin, atol=1e-9, err_msg=joint.name)
        np.testing.assert_allclose(origin, origin_matrix(joint.origin.xyz, joint.origin.rpy), atol=1e-12)


@property_settings
@given(axes, angles, angles, angles, st.floats(-10.0, 10.0, allow_nan=False))
def test_continuous_joint_is_periodic_and_quaternion_is_canonical(axis, r, p, y, value) -> None:
    robot = tree_robot([("continuous", (0.1, 0.2, 0.3), (r, p, y), axis, 0.0)])
    tfs = dynamic_transforms(robot, ["j1"], [[value], [value + 2 * math.pi], [value - 4 * math.pi]])
    assert (tfs.rotation[..., 3] >= 0).all()
    matrices = transform_matrices(tfs)
    np.testing.assert_allclose(matrices[1], matrices[0], atol=1e-12)
    np.testing.assert_allclose(matrices[2], matrices[0], atol=1e-12)
    if tfs.rotation[0, 0, 3] > 1e-6:  # away from w = 0 the canonical quaternion is unique
        np.testing.assert_allclose(tfs.rotation[1], tfs.rotation[0], atol=1e-12)


@property_settings
@given(angles, angles, angles)
def test_rpy_quaternion_matches_elementary_rotations(r: float, p: float, y: float) -> None:
    np.testing.assert_allclose(
        matrix_from_quaternion(quaternion_from_rpy([r, p, y])), origin_matrix((0, 0, 0), (r, p, y))[:3, :3], atol=1e-14
    )
