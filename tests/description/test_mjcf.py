"""MuJoCo models (MJCF): tfrec's FK equals MuJoCo's own ``mj_kinematics`` on every model (hand-written ones for
each feature, gymnasium's assets, every example-robot-data URDF converted by MuJoCo's URDF import), recordings
check clean, the generated URDF is what ``inspect --urdf`` prints, and hostile models end in one line."""

from __future__ import annotations

import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from tests.description.mjcf_models import DM_CONTROL, FEATURES, GYM, write_features, write_included
from tests.formats.test_rrd import Rrd
from tests.test_real_robots import ERD, ERD_URDFS, URDFDOM_REFUSES
from tfrec.cli import main
from tfrec.description import load_description
from tfrec.description._mjcf_confine import MjcfLimits
from tfrec.description.mjcf import ball_joint_names, load_mjcf
from tfrec.errors import DescriptionError, TfrecWarning
from tfrec.kinematics.fk import link_poses
from tfrec.kinematics.joints import apply_mimic
from tfrec.model import JointType, Robot

mujoco = pytest.importorskip("mujoco", reason="the mjcf extra is not installed (pip install 'tfrec-robotics[mjcf]')")

TOL = 1e-9


@pytest.fixture(autouse=True)
def _mujoco_warnings_kept_here() -> Iterator[list[str]]:
    """MuJoCo's own warnings while the tests compile models themselves (the oracle, the URDF import): by default
    MuJoCo appends them to MUJOCO_LOG.TXT in the working folder. tfrec's loader leaves none (checked below)."""
    seen: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(seen.append)
    try:
        yield seen
    finally:
        mujoco.set_mju_user_warning(previous)



# -- the oracle ------------------------------------------------------------------------------------------------


def _joint_name(model: object, joint: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint) or f"joint_{joint}"


def _body_name(model: object, body: int) -> str:
    return "world" if body == 0 else mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body_{body}"


def _samples(robot: Robot, n: int, seed: int) -> tuple[list[str], np.ndarray]:
    """Random in-range positions of every actuated joint, mimic joints derived (as tfrec records them)."""
    rng = np.random.default_rng(seed)
    names = [joint.name for joint in robot.moving_joints]
    positions = np.zeros((n, len(names)))
    for k, joint in enumerate(robot.moving_joints):
        low, high = ((joint.limit.lower, joint.limit.upper) if joint.limit is not None
                     and joint.type is not JointType.CONTINUOUS else (-np.pi, np.pi))
        positions[:, k] = rng.uniform(low, high, n)
    apply_mimic(robot, names, positions)
    return names, positions


def _qpos(model: object, values: dict[str, float]) -> np.ndarray:
    """MuJoCo's qpos for tfrec's joint positions: hinge and slide values as they are, a ball joint's three angles
    as the quaternion of intrinsic x-y-z rotations, free joints at their initial pose."""
    qpos = model.qpos0.copy()  # type: ignore[attr-defined]
    for joint in range(model.njnt):  # type: ignore[attr-defined]
        kind, adr = int(model.jnt_type[joint]), int(model.jnt_qposadr[joint])  # type: ignore[attr-defined]
        name = _joint_name(model, joint)
        if kind in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            qpos[adr] = values[name]
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            quat = np.array([1.0, 0.0, 0.0, 0.0])
            for axis, part in zip(np.eye(3), ball_joint_names(name)):
                step, out = np.zeros(4), np.zeros(4)
                mujoco.mju_axisAngle2Quat(step, axis, values[part])
                mujoco.mju_mulQuat(out, quat, step)
                quat = out
            qpos[adr:adr + 4] = quat
    return qpos


def fk_error(path: Path, robot: Robot, *, n: int = 40, seed: int = 0) -> float:
    """The largest difference between tfrec's world pose of every body and MuJoCo's (xpos; xquat as a matrix)."""
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    names, positions = _samples(robot, n, seed)
    poses = link_poses(robot, names, positions)
    worst = 0.0
    rotation = np.zeros(9)
    for s in range(n):
        data.qpos[:] = _qpos(model, dict(zip(names, positions[s])))
        mujoco.mj_kinematics(model, data)
        for body in range(1, model.nbody):
            pose = poses[_body_name(model, body)][s]
            mujoco.mju_quat2Mat(rotation, data.xquat[body])
            worst = max(worst, float(np.abs(pose[:3, 3] - data.xpos[body]).max()),
                        float(np.abs(pose[:3, :3] - rotation.reshape(3, 3)).max()))
    return worst


# -- models ------------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def features(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("mjcf")
    paths = write_features(folder)
    paths["included"] = write_included(folder)
    return paths


def to_mjcf(urdf_text: str, out: Path) -> None:
    """A URDF as MJCF, by MuJoCo's own URDF import (fixed links kept) and ``mj_saveLastXML`` (6 digits)."""
    root = ET.fromstring(urdf_text)
    for link in root.findall("link"):
        for tag in ("visual", "collision", "inertial"):
            for elem in link.findall(tag):
                link.remove(elem)
    extension = ET.SubElement(root, "mujoco")
    ET.SubElement(extension, "compiler", fusestatic="false", discardvisual="true", boundmass="0.001",
                  boundinertia="1e-6")
    model = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    mujoco.mj_saveLastXML(str(out), model)


# -- FK equals MuJoCo's --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", [*FEATURES, "included"])
def test_feature_models_match_mujoco(features: dict[str, Path], name: str) -> None:
    robot = load_description(features[name])
    assert fk_error(features[name], robot) < TOL


@pytest.mark.skipif(not GYM, reason="gymnasium is not installed")
@pytest.mark.parametrize("asset", GYM, ids=[p.name for p in GYM])
def test_gymnasium_models_match_mujoco(asset: Path) -> None:
    robot = load_description(asset)
    assert robot.moving_joints
    assert fk_error(asset, robot) < TOL


BROKEN_MIMICS = {"alex_description/urdf/alex_psyonic_hands.urdf"}
"""URDFs whose ``<mimic>`` names a joint that does not exist: robot_state_publisher (and tfrec) hold the joint at its
offset, MuJoCo's URDF import drops the mimic (the joint moves freely): the diff must say so."""

@pytest.mark.skipif(not DM_CONTROL, reason="dm_control is not installed (it pins its own mujoco)")
@pytest.mark.parametrize("model", DM_CONTROL, ids=[p.name for p in DM_CONTROL])
def test_dm_control_suite_models_match_mujoco(model: Path) -> None:
    robot = load_description(model)  # includes ./common/*.xml; the dog's meshes
    assert fk_error(model, robot, n=10) < TOL


CONVERTIBLE = [p for p in ERD_URDFS if ERD is not None and str(p.relative_to(ERD)) not in URDFDOM_REFUSES]


@pytest.mark.skipif(ERD is None, reason="example-robot-data is not installed")
@pytest.mark.parametrize("urdf", CONVERTIBLE, ids=[str(p.relative_to(ERD)) for p in CONVERTIBLE] if ERD else [])
def test_example_robot_data_as_mjcf_matches_mujoco_and_its_urdf(urdf: Path, tmp_path: Path,
                                                                  capfd: pytest.CaptureFixture[str]) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # missing meshes, floating joints...
        robot = load_description(urdf, package_paths=[ERD])  # type: ignore[list-item]
    xml = tmp_path / f"{urdf.stem}.xml"
    to_mjcf(robot.urdf, xml)
    capfd.readouterr()  # MuJoCo's own import warnings
    converted = load_description(xml)
    assert fk_error(xml, converted, n=20) < TOL
    if int(mujoco.__version__.split(".")[0]) < 4:
        pytest.skip("MuJoCo 3's URDF import drops <mimic> and keeps a continuous joint's <limit>: the conversion "
                    "differs from the URDF there (FK checked)")
    args = ["diff", str(urdf), str(xml), "--package-path", str(ERD), "--pos-tol", "1e-5", "--rot-tol", "1e-5",
            "--joint-tol", "1e-5", "--duration", "2"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(args)
    out = capfd.readouterr().out
    if str(urdf.relative_to(ERD)) in BROKEN_MIMICS:  # type: ignore[arg-type]
        assert code == 1 and "changed: mimic 'index_q1'" in out, out
        return
    assert code == 0, out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main([args[0], args[2], args[1], *args[3:]]) == 0, capfd.readouterr().out  # B's root is A's world's child


@pytest.mark.skipif(ERD is None, reason="example-robot-data is not installed")
def test_diff_across_formats_names_a_moved_body_and_maps_renamed_joints(tmp_path: Path,
                                                                         capfd: pytest.CaptureFixture[str]) -> None:
    urdf = ERD / "panda_description" / "urdf" / "panda.urdf"  # type: ignore[operator]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_description(urdf, package_paths=[ERD])  # type: ignore[list-item]
    xml = tmp_path / "panda.xml"
    to_mjcf(robot.urdf, xml)
    tree = ET.parse(xml)
    body = next(b for b in tree.iter("body") if b.get("name") == "panda_link4")
    pos = [float(v) for v in (body.get("pos") or "0 0 0").split()]
    body.set("pos", " ".join(repr(v) for v in (pos[0] + 0.001, pos[1], pos[2])))
    joint = next(j for j in tree.iter("joint") if j.get("name") == "panda_joint2")
    joint.set("name", "shoulder_pitch")
    moved = tmp_path / "moved.xml"
    tree.write(moved)
    capfd.readouterr()
    tolerances = ["--pos-tol", "1e-5", "--rot-tol", "1e-5", "--joint-tol", "1e-5", "--duration", "2"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["diff", str(urdf), str(moved), "--package-path", str(ERD), *tolerances]) == 1
        unmapped = capfd.readouterr().out
        assert main(["diff", str(urdf), str(moved), "--package-path", str(ERD), "--map",
                     "panda_joint2:=shoulder_pitch", *tolerances]) == 1
    out = capfd.readouterr().out
    assert "joint 'panda_joint2' removed" in unmapped and "joint 'shoulder_pitch' added" in unmapped
    assert "panda_joint2" not in out.split("world poses")[0]  # matched through --map
    assert "panda_link4: position differs by up to 0.001" in out
    assert "panda_link3:" not in out  # the body above it did not move


@pytest.mark.skipif(not GYM, reason="gymnasium is not installed")
@pytest.mark.parametrize("name", ["ant", "humanoid"])  # a quadruped and a humanoid on free bases
def test_gymnasium_robots_record_along_sine_and_check(name: str, tmp_path: Path) -> None:
    model = next(p for p in GYM if p.stem == name)
    out = tmp_path / f"{name}.mcap"
    assert main(["record", str(model), "--traj", "sine", "--duration", "1", "--no-rrd", "-o", str(out)]) == 0
    assert main(["replay", str(out), "--check"]) == 0


def test_the_mapping_of_joint_types(features: dict[str, Path]) -> None:
    robot = load_description(features["ball_free"])
    kinds = {joint.name: joint.type for joint in robot.joints}
    assert kinds["root"] is JointType.FIXED  # a free joint holds the body at its initial pose
    assert kinds["shoulder_x"] is JointType.REVOLUTE and kinds["wrist_z"] is JointType.CONTINUOUS
    limit = robot.joint_by_name["shoulder_y"].limit
    assert limit is not None and limit.upper == pytest.approx(np.radians(80))
    hand = load_description(features["equality_hand"])
    mimic = hand.joint_by_name["f1b"].mimic
    assert mimic is not None and mimic.joint == "f1a" and mimic.multiplier == 1.3
    # joint1 - ref1 = a0 + a1 (joint2 - ref2)
    assert mimic.offset == pytest.approx(0.1 + np.radians(-10) - 1.3 * np.radians(5))
    assert [j.name for j in hand.actuated_joints] == ["f1a"]
    multi = load_description(features["multi_joint"])
    assert multi.joint_by_name["x"].type is JointType.PRISMATIC
    x_limit = multi.joint_by_name["x"].limit
    assert x_limit is not None and (x_limit.lower, x_limit.upper) == (-1.0, 1.0)  # an unlimited slide: ±1 m
    assert {"body_2", "joint_4"} <= set(multi.link_by_name) | set(multi.joint_by_name)


def test_a_nonlinear_joint_equality_warns_and_leaves_the_joints_free(tmp_path: Path) -> None:
    path = tmp_path / "quadratic.xml"
    path.write_text(FEATURES["equality_hand"].replace('polycoef="0 0.5 0 0 0"', 'polycoef="0 0.5 0.2 0 0"'),
                    encoding="utf-8")
    with pytest.warns(TfrecWarning, match=r"quadratic\.xml: the joint equality of 'f1c' and 'f1b' is not linear"):
        robot = load_description(path)
    assert robot.joint_by_name["f1c"].mimic is None and robot.joint_by_name["f1b"].mimic is not None


def test_geoms_become_visuals(features: dict[str, Path]) -> None:
    robot = load_description(features["ref_degrees"])
    shapes = [type(v.geometry).__name__ for link in robot.links for v in link.visuals]
    assert sorted(shapes) == ["Box", "Cylinder", "Cylinder", "Sphere", "Sphere"]  # a capsule: cylinder + 2 spheres
    capsule = robot.link_by_name["a"].visuals[0]
    assert capsule.material is not None and capsule.material.rgba == (1.0, 0.0, 0.0, 1.0)
    box = robot.link_by_name["b"].visuals[0].geometry
    assert box.size == (0.2, 0.1, 0.04)  # type: ignore[union-attr]
    assert capsule.geometry.length == 0.4  # type: ignore[union-attr]  # twice the half-length


def test_mesh_geoms_keep_the_file_frame_and_scale(tmp_path: Path) -> None:
    trimesh = pytest.importorskip("trimesh")
    (tmp_path / "meshes").mkdir()
    box = trimesh.creation.box(extents=[0.1, 0.2, 0.3])
    box.apply_translation([0.5, 0.0, 0.0])  # off-centre: MuJoCo re-centres it on its inertia
    box.export(tmp_path / "meshes" / "part.stl")
    path = tmp_path / "m.xml"
    path.write_text('<mujoco><compiler meshdir="meshes"/><asset><mesh name="part" file="part.stl" scale="2 1 1"/>'
                    '</asset><worldbody><body name="a"><geom type="mesh" mesh="part" pos="0 0 1" '
                    'euler="0 0 90"/></body></worldbody></mujoco>', encoding="utf-8")
    visual = load_description(path).link_by_name["a"].visuals[0]
    assert visual.geometry.filename == (tmp_path / "meshes" / "part.stl").as_uri()  # type: ignore[union-attr]
    assert main(["record", str(path), "--duration", "0.5", "-o", str(tmp_path / "m.mcap")]) == 0
    rrd = Rrd(tmp_path / "m.rrd")  # read back by rerun: the mesh file's bytes are embedded
    assert rrd.static["/robot/a/visual_0"]["Asset3D:blob"]
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    assert main(["replay", str(tmp_path / "m.mcap"), "--save", str(elsewhere / "replayed.rrd")]) == 0
    assert Rrd(elsewhere / "replayed.rrd").static["/robot/a/visual_0"]["Asset3D:blob"]  # from /robot_description
    assert visual.geometry.scale == (2.0, 1.0, 1.0)  # type: ignore[union-attr]
    np.testing.assert_allclose(visual.origin.xyz, (0.0, 0.0, 1.0), atol=1e-12)
    np.testing.assert_allclose(visual.origin.rpy, (0.0, 0.0, np.pi / 2), atol=1e-12)


# -- the pipeline ------------------------------------------------------------------------------------------------


def test_record_inspect_and_replay_check(features: dict[str, Path], tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    from rosbags.highlevel import AnyReader

    model = features["equality_hand"]
    out = tmp_path / "hand.mcap"
    assert main(["record", str(model), "--traj", "sine", "--duration", "1", "-o", str(out)]) == 0
    assert main(["replay", str(out), "--check"]) == 0
    assert load_description(model).name == "equality_hand"  # an unnamed model: its file's stem
    capsys.readouterr()
    assert main(["inspect", str(model), "--urdf"]) == 0
    urdf = capsys.readouterr().out
    assert ET.fromstring(urdf).tag == "robot"
    topics: dict[str, int] = {}
    frames: set[str] = set()
    with AnyReader([out]) as reader:
        for connection, _, raw in reader.messages():
            topics[connection.topic] = topics.get(connection.topic, 0) + 1
            message = reader.deserialize(raw, connection.msgtype)
            if connection.topic == "/joint_states":
                assert set(message.name) == {"f1a", "f1b", "f1c", "f2a"}
            elif connection.topic in ("/tf", "/tf_static"):
                frames |= {t.child_frame_id for t in message.transforms}
            elif connection.topic == "/robot_description":
                assert message.data.strip() == urdf.strip()
    assert {"palm", "f1", "f1b", "f1c", "f2"} <= frames
    assert {"/joint_states", "/tf", "/tf_static", "/robot_description"} <= set(topics)
    assert (tmp_path / "hand.rrd").is_file() or any(tmp_path.glob("*.rrd"))


@pytest.mark.parametrize("name", ["ball_free", "multi_joint"])
def test_free_and_ball_models_record_and_check(features: dict[str, Path], name: str, tmp_path: Path) -> None:
    out = tmp_path / "r.mcap"
    for target in (out, tmp_path / "again.mcap"):
        assert main(["record", str(features[name]), "--traj", "random", "--duration", "1", "--no-rrd",
                     "-o", str(target)]) == 0
    assert main(["replay", str(out), "--check"]) == 0
    assert out.read_bytes() == (tmp_path / "again.mcap").read_bytes()  # the same command, the same bytes


def test_diff_names_a_body_moved_by_a_millimetre(features: dict[str, Path], tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    moved = tmp_path / "moved.xml"
    moved.write_text(FEATURES["ref_degrees"].replace('<body name="b" pos="0.3 0 0"', '<body name="b" pos="0.301 0 0"'),
                     encoding="utf-8")
    assert main(["diff", str(features["ref_degrees"]), str(features["ref_degrees"])]) == 0
    capsys.readouterr()
    assert main(["diff", str(features["ref_degrees"]), str(moved), "--pos-tol", "1e-5", "--rot-tol", "1e-5"]) == 1
    out = capsys.readouterr().out
    assert "b: position differs by up to 0.001" in out


# -- hostile models ----------------------------------------------------------------------------------------------


def _refused(capsys: pytest.CaptureFixture[str], path: Path, *extra: str) -> str:
    assert main(["inspect", str(path), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tfrec: error: ") and err.count("\n") == 1, err
    assert path.name in err
    return err


def test_an_include_outside_the_model_folder_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    secret = tmp_path / "secret.xml"
    secret.write_text("<mujoco><worldbody><body name='s'/></worldbody></mujoco>", encoding="utf-8")
    folder = tmp_path / "model"
    folder.mkdir()
    for target in (str(secret), "../secret.xml", "/etc/passwd"):
        path = folder / "escape.xml"
        path.write_text(f'<mujoco><include file="{target}"/></mujoco>', encoding="utf-8")
        err = _refused(capsys, path)
        assert "refused" in err and "outside the folders" in err
    # ... unless its folder is given as a package path
    path.write_text(f'<mujoco><include file="{secret}"/></mujoco>', encoding="utf-8")
    assert main(["inspect", str(path), "--package-path", str(tmp_path)]) == 0


@pytest.mark.parametrize("asset", ['<mesh file="/etc/hostname"/>', '<texture type="2d" file="../x.png"/>',
                                   '<hfield file="/etc/passwd"/>', '<texture type="cube" fileup="/etc/passwd"/>'])
def test_asset_files_outside_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str], asset: str) -> None:
    path = tmp_path / "m" / "assets.xml"
    path.parent.mkdir()
    path.write_text(f"<mujoco><asset>{asset}</asset></mujoco>", encoding="utf-8")
    assert "refused" in _refused(capsys, path)


def test_a_meshdir_outside_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "m" / "dir.xml"
    path.parent.mkdir()
    path.write_text('<mujoco><compiler meshdir="/etc"/><asset><mesh file="hostname"/></asset></mujoco>',
                    encoding="utf-8")
    assert "meshdir" in _refused(capsys, path)


def test_an_asset_is_checked_against_every_meshdir_of_the_model(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "m"
    (folder / "a" / "b").mkdir(parents=True)
    (folder / "parts.xml").write_text('<mujoco><compiler meshdir="a/b"/></mujoco>', encoding="utf-8")
    path = folder / "two.xml"  # which meshdir is in force is MuJoCo's business: "../../x" must stay inside for each
    path.write_text('<mujoco><compiler meshdir="."/><include file="parts.xml"/><asset><mesh file="../../x.stl"/>'
                    "</asset></mujoco>", encoding="utf-8")
    assert "refused" in _refused(capsys, path)


def test_a_link_out_of_the_folder_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "m"
    folder.mkdir()
    (folder / "link.stl").symlink_to("/etc/hostname")
    path = folder / "link.xml"
    path.write_text('<mujoco><asset><mesh file="link.stl"/></asset></mujoco>', encoding="utf-8")
    assert "a link to" in _refused(capsys, path)


def test_include_cycles_and_missing_includes_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "cycle.xml"
    path.write_text('<mujoco><include file="cycle.xml"/></mujoco>', encoding="utf-8")
    assert "include cycle" in _refused(capsys, path)
    path.write_text('<mujoco><include file="nope.xml"/></mujoco>', encoding="utf-8")
    assert "nope.xml" in _refused(capsys, path)


def test_deep_trees_many_bodies_and_bombs_are_refused_before_compiling(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    deep = tmp_path / "deep.xml"
    deep.write_text("<mujoco><worldbody>" + "<body>" * 300 + "</body>" * 300 + "</worldbody></mujoco>",
                    encoding="utf-8")
    assert "nested more than" in _refused(capsys, deep)
    for opening, closing in (("<worldbody>", "</worldbody>"), ("<default>", "</default>")):
        # frames and defaults classes: MuJoCo's compiler recurses on these too
        inner = "<frame>" * 300 + "</frame>" * 300 if opening == "<worldbody>" else \
            "".join(f'<default class="c{i}">' for i in range(300)) + "</default>" * 300
        deep.write_text(f"<mujoco>{opening}{inner}{closing}</mujoco>", encoding="utf-8")
        assert "nested more than" in _refused(capsys, deep)
    replicate = tmp_path / "replicate.xml"
    replicate.write_text("<mujoco><worldbody>" + '<replicate count="100">' * 4 + "<body><geom size='1'/></body>"
                         + "</replicate>" * 4 + "</worldbody></mujoco>", encoding="utf-8")
    assert "bodies" in _refused(capsys, replicate)
    composite = tmp_path / "composite.xml"
    composite.write_text('<mujoco><worldbody><flexcomp type="grid" count="1000 1000 1000" spacing="1 1 1"/>'
                         "</worldbody></mujoco>", encoding="utf-8")
    assert "bodies" in _refused(capsys, composite)
    texture = tmp_path / "texture.xml"
    texture.write_text('<mujoco><asset><texture type="cube" builtin="checker" width="100000" height="100000"/>'
                       "</asset></mujoco>", encoding="utf-8")
    assert "cells" in _refused(capsys, texture)
    hfield = tmp_path / "hfield.xml"
    hfield.write_text('<mujoco><asset><hfield name="h" nrow="100000" ncol="100000" size="1 1 1 1"/></asset>'
                      "</mujoco>", encoding="utf-8")
    assert "cells" in _refused(capsys, hfield)
    for builtin, params in (("supersphere", "2000 1 1"), ("plate", "1000 1000")):  # MuJoCo takes minutes on these
        mesh = tmp_path / f"{builtin}.xml"
        mesh.write_text(f'<mujoco><asset><mesh name="m" builtin="{builtin}" params="{params}"/></asset>'
                        '<worldbody><geom type="mesh" mesh="m"/></worldbody></mujoco>', encoding="utf-8")
        assert "vertices" in _refused(capsys, mesh)


def test_a_huge_mesh_is_refused_without_reading_it(tmp_path: Path) -> None:
    mesh = tmp_path / "huge.stl"
    with mesh.open("wb") as stream:
        stream.truncate(2048)  # sparse: the bound is on the size, the file is never read
    path = tmp_path / "huge.xml"
    path.write_text('<mujoco><asset><mesh file="huge.stl"/></asset></mujoco>', encoding="utf-8")
    with pytest.raises(DescriptionError, match=r"huge\.xml:1: <mesh>: <mesh file> .*huge\.stl has 2,048 bytes"):
        load_mjcf(path, limits=MjcfLimits(max_asset_bytes=1024))


def test_mujoco_compile_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "bad.xml"
    path.write_text('<mujoco><worldbody><body><joint type="nonsense"/></body></worldbody></mujoco>',
                    encoding="utf-8")
    assert "MuJoCo cannot compile it" in _refused(capsys, path)
    path.write_text("<mujoco><worldbody><body>", encoding="utf-8")
    assert "malformed XML" in _refused(capsys, path)
    path.write_text('<mujoco><compiler settotalmass="1"/><worldbody><body><joint/><geom size="1"/></body>'
                    "</worldbody></mujoco>", encoding="utf-8")  # MuJoCo warns: deprecated
    mujoco.set_mju_user_warning(None)  # MuJoCo's default: print, and append to MUJOCO_LOG.TXT
    assert main(["inspect", str(path)]) == 0
    assert sorted(os.listdir(tmp_path)) == ["bad.xml"]  # no MUJOCO_LOG.TXT in the working folder


def test_a_plain_xml_file_is_not_taken_for_mjcf(tmp_path: Path) -> None:
    path = tmp_path / "robot.xml"
    path.write_text('<?xml version="1.0"?>\n<!-- a comment --><robot name="r"><link name="a"/></robot>',
                    encoding="utf-8")
    assert [link.name for link in load_description(path).links] == ["a"]  # a URDF
    path.write_text('<?xml version="1.0"?>\n<!-- a comment -->\n<mujoco model="m"/>', encoding="utf-8")
    assert load_description(path).name == "m"
    assert os.fspath(load_description(path).source) == os.fspath(path)


def test_a_map_of_names_b_lacks_is_one_line(features: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    model = str(features["ref_degrees"])
    assert main(["diff", model, model, "--map", "h1:=nope"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tfrec: error: ") and "has no link or joint 'nope'" in err and err.count("\n") == 1
    assert main(["diff", model, model, "--map", "h1:=h2"]) == 2  # two joints 'h1' in B
    assert "two joints named 'h1'" in capsys.readouterr().err
    assert main(["diff", model, model, "--map", "h1"]) == 2
    assert "'h1' is not A_NAME:=B_NAME" in capsys.readouterr().err
