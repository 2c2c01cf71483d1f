"""The Rerun sink, read back with Rerun's own reader and checked against yourdfpy's FK."""

from __future__ import annotations

import functools
import io
import subprocess
import sys
import warnings
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rerun as rr

from tests.conftest import CORPUS as SHARED_CORPUS
from tests.conftest import CORPUS_ABSENT
from tfrec.description import load_description, parse_urdf
from tfrec.errors import RecordingError
from tfrec.formats.rrd.paths import (
    APPLICATION_ID,
    TIMELINE,
    joint_entity,
    link_entity,
    pair_entity,
    static_pair_entity,
    tf_entity,
    tf_static_entity,
    velocity_entity,
    visual_entity,
)
from tfrec.kinematics.fk import Transforms, iter_dynamic_chunks, static_transforms
from tfrec.kinematics.rotations import matrix_from_quaternion
from tfrec.model import Box, Cylinder, Mesh, Robot, Sphere
from tfrec.trajectory.generators import make_trajectory
from tfrec.viewer import sink as rerun_io
from tfrec.viewer.sink import RerunSink

REPO = Path(__file__).resolve().parents[2]
CORPUS = SHARED_CORPUS
RERUN = Path(sys.executable).with_name("rerun")
START_NS = 1_700_000_000_000_000_000


@functools.cache
def load_robot(name: str, **args: str) -> Robot:
    """A robot of robots/ or the corpus, once per session; mbot's legacy-macro warning is expected."""
    path = REPO / "robots" / f"{name}.xacro" if "/" not in name else CORPUS / name
    if "/" in name and not CORPUS.is_dir():
        pytest.skip(CORPUS_ABSENT)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*legacy macro calls")
        return load_description(path, args=args, package_paths=[CORPUS] if CORPUS.is_dir() else [])


def write_rrd(
    path: Path,
    robot: Robot,
    *,
    duration_s: float = 2.0,
    rate_hz: float = 50.0,
    chunk_samples: int = 40,
    frame_prefix: str = "",
    recording_id: str = "test-recording",
) -> Path:
    """Record ``robot`` along a sine trajectory with the sink, in several chunks."""
    trajectory = make_trajectory(robot, "sine", duration_s=duration_s, rate_hz=rate_hz)
    sink = RerunSink(path, robot=robot, recording_id=recording_id, frame_prefix=frame_prefix,
                     package_paths=[CORPUS] if CORPUS.is_dir() else [])
    sink.begin(static=static_transforms(robot, frame_prefix=frame_prefix), start_time_ns=START_NS,
               robot_description=robot.urdf)
    for chunk in iter_dynamic_chunks(robot, trajectory, chunk_samples=chunk_samples, frame_prefix=frame_prefix):
        sink.write_chunk(stamp_ns=chunk.time_ns + START_NS, joint_names=chunk.names, positions=chunk.positions,
                         velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()
    return path


class Rrd:
    """A recording read back with ``rerun.chunk.RrdReader``: rows by entity, static and temporal."""

    def __init__(self, path: Path) -> None:
        reader = rr.chunk.RrdReader(path)
        (self.store,) = reader.recordings()
        self.static: dict[str, dict[str, Any]] = defaultdict(dict)
        self.temporal: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for chunk in reader.stream():
            rows = _rows(chunk)
            if chunk.is_static:
                for row in rows:
                    self.static[chunk.entity_path].update(row)
            else:
                self.temporal[chunk.entity_path].extend(rows)
        self.blueprint_chunks = [_rows(chunk) for store in reader.blueprints() for chunk in reader.stream(store=store)]

    def series(self, entity: str, column: str) -> tuple[np.ndarray, list[Any]]:
        """(int64 stamps in ns, values) of one temporal column, in time order."""
        rows = sorted((row for row in self.temporal[entity] if row.get(column) is not None),
                      key=lambda row: row[TIMELINE])
        stamps = np.array([row[TIMELINE] for row in rows], dtype=np.int64)
        return stamps, [row[column] for row in rows]


def _rows(chunk: Any) -> list[dict[str, Any]]:
    """A chunk's rows as dicts; timestamps as int64 nanoseconds (datetime has only microseconds)."""
    import pyarrow as pa

    batch = chunk.to_record_batch()
    columns = [column.cast(pa.int64()) if pa.types.is_timestamp(column.type) else column for column in batch.columns]
    rows: list[dict[str, Any]] = pa.RecordBatch.from_arrays(columns, names=batch.schema.names).to_pylist()
    return rows


@functools.cache
def recorded(name: str, tmp_root: str) -> Rrd:
    return Rrd(write_rrd(Path(tmp_root) / f"{name.replace('/', '_')}.rrd", load_robot(name)))


@pytest.fixture(scope="module")
def tmp_root(tmp_path_factory: pytest.TempPathFactory) -> str:
    return str(tmp_path_factory.mktemp("rrd"))


def fk_reference(robot: Robot, configs: dict[str, float]) -> Any:
    """yourdfpy's model of the same URDF at one configuration of the actuated joints."""
    model = _yourdfpy_model(robot.urdf)
    model.update_cfg({name: configs[name] for name in model.actuated_joint_names})
    return model


@functools.cache
def _yourdfpy_model(urdf: str) -> Any:
    import yourdfpy

    return yourdfpy.URDF.load(io.BytesIO(urdf.encode()), load_meshes=False, build_collision_scene_graph=False)


def homogeneous(translation: list[float], quaternion: list[float]) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = matrix_from_quaternion(np.array(quaternion, dtype=np.float64))
    out[:3, 3] = translation
    return out


# -- geometry ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["mbot", "marm"])
def test_every_visual_has_a_geometry_entity_in_its_link_frame(name: str, tmp_root: str) -> None:
    robot = load_robot(name)
    rrd = recorded(name, tmp_root)
    reference = _yourdfpy_model(robot.urdf)
    for link in robot.links:
        entity = rrd.static[link_entity(link.name)]
        assert entity["CoordinateFrame:frame"] == [link.name]
        assert entity["TransformAxes3D:axis_length"][0] > 0
        reference_visuals = reference.link_map[link.name].visuals
        assert len(reference_visuals) == len(link.visuals)
        for index, (visual, expected) in enumerate(zip(link.visuals, reference_visuals)):
            row = rrd.static[visual_entity(link.name, index)]
            assert row["CoordinateFrame:frame"] == [link.name]
            origin = homogeneous(row["InstancePoses3D:translations"][0], row["InstancePoses3D:quaternions"][0])
            expected_origin = expected.origin if expected.origin is not None else np.eye(4)
            np.testing.assert_allclose(origin, expected_origin, atol=2e-7)
            geometry = visual.geometry
            if isinstance(geometry, Box):
                np.testing.assert_allclose(row["Boxes3D:half_sizes"][0], np.array(expected.geometry.box.size) / 2,
                                           rtol=1e-6)
                colours = row["Boxes3D:colors"]
            elif isinstance(geometry, Cylinder):
                assert row["Cylinders3D:radii"][0] == pytest.approx(expected.geometry.cylinder.radius, rel=1e-6)
                assert row["Cylinders3D:lengths"][0] == pytest.approx(expected.geometry.cylinder.length, rel=1e-6)
                colours = row["Cylinders3D:colors"]
            else:
                assert isinstance(geometry, Sphere)
                np.testing.assert_allclose(row["Ellipsoids3D:half_sizes"][0],
                                           [expected.geometry.sphere.radius] * 3, rtol=1e-6)
                colours = row["Ellipsoids3D:colors"]
            assert visual.material is not None and visual.material.rgba is not None
            assert colours == [_packed(visual.material.rgba)]


def _packed(rgba: tuple[float, float, float, float]) -> int:
    r, g, b, a = (round(c * 255) for c in rgba)
    return (r << 24) | (g << 16) | (b << 8) | a


def test_colours_of_materials_defined_at_robot_level(tmp_root: str) -> None:
    rrd = recorded("mbot", tmp_root)
    # <material name="yellow"> (1 0.4 0 1) is defined once at robot level and referenced by name
    assert rrd.static[visual_entity("base_link", 0)]["Cylinders3D:colors"] == [0xFF6600FF]
    # "black" (0 0 0 0.95) keeps its alpha
    assert rrd.static[visual_entity("front_caster_link", 0)]["Ellipsoids3D:colors"] == [0x000000F2]


# -- transforms and joint states --------------------------------------------------------------

@pytest.mark.parametrize("name", ["mbot", "marm"])
def test_joint_transforms_equal_fk_at_sampled_times(name: str, tmp_root: str) -> None:
    robot = load_robot(name)
    rrd = recorded(name, tmp_root)
    trajectory = make_trajectory(robot, "sine", duration_s=2.0, rate_hz=50.0)
    stamps = trajectory.time_ns + START_NS
    for sample in (0, 1, 37, 60, len(trajectory) - 1):
        configs = dict(zip(trajectory.joint_names, trajectory.positions[sample]))
        reference = fk_reference(robot, configs)
        for joint in robot.moving_joints:
            times, translations = rrd.series(tf_entity(joint.name), "Transform3D:translation")
            _, quaternions = rrd.series(tf_entity(joint.name), "Transform3D:quaternion")
            np.testing.assert_array_equal(times, stamps)
            got = homogeneous(translations[sample][0], quaternions[sample][0])
            expected = reference.get_transform(frame_to=joint.child, frame_from=joint.parent)
            np.testing.assert_allclose(got, expected, atol=2e-6, err_msg=f"{joint.name} at sample {sample}")
    for joint in robot.joints:
        if joint.type.moves:
            _, parents = rrd.series(tf_entity(joint.name), "Transform3D:parent_frame")
            _, children = rrd.series(tf_entity(joint.name), "Transform3D:child_frame")
            assert {p[0] for p in parents} == {joint.parent} and {c[0] for c in children} == {joint.child}
            assert tf_static_entity(joint.name) not in rrd.static
        else:
            row = rrd.static[tf_static_entity(joint.name)]
            assert (row["Transform3D:parent_frame"], row["Transform3D:child_frame"]) == ([joint.parent], [joint.child])
            got = homogeneous(row["Transform3D:translation"][0], row["Transform3D:quaternion"][0])
            expected = _yourdfpy_model(robot.urdf).get_transform(frame_to=joint.child, frame_from=joint.parent)
            np.testing.assert_allclose(got, expected, atol=2e-7)
            assert tf_entity(joint.name) not in rrd.temporal


@pytest.mark.parametrize("name", ["mbot", "marm"])
def test_one_scalar_series_per_joint_on_integer_nanosecond_stamps(name: str, tmp_root: str) -> None:
    robot = load_robot(name)
    rrd = recorded(name, tmp_root)
    trajectory = make_trajectory(robot, "sine", duration_s=2.0, rate_hz=50.0)
    series = {entity.removeprefix("/joints/") for entity in rrd.temporal if entity.startswith("/joints/")}
    assert series == {joint.name for joint in robot.moving_joints}
    for j, name_ in enumerate(trajectory.joint_names):
        times, values = rrd.series(joint_entity(name_), "Scalars:scalars")
        np.testing.assert_array_equal(times, trajectory.time_ns + START_NS)
        np.testing.assert_array_equal(np.array(values)[:, 0], trajectory.positions[:, j])
        _, velocities = rrd.series(velocity_entity(name_), "Scalars:scalars")
        np.testing.assert_array_equal(np.array(velocities)[:, 0], trajectory.velocities[:, j])


def test_recording_identity_properties_and_blueprint(tmp_root: str) -> None:
    rrd = recorded("marm", tmp_root)
    assert (rrd.store.application_id, rrd.store.recording_id) == (APPLICATION_ID, "test-recording")
    assert rrd.static["/robot"]["CoordinateFrame:frame"] == ["link0"]
    assert "ViewCoordinates:xyz" in rrd.static["/"]
    assert rrd.static["/robot_description"]["TextDocument:text"][0].startswith("<")
    rows = [row for chunk in rrd.blueprint_chunks for row in chunk]
    views = {(row["ViewBlueprint:class_identifier"][0], row["ViewBlueprint:space_origin"][0],
              row["ViewBlueprint:display_name"][0]) for row in rows if row.get("ViewBlueprint:class_identifier")}
    assert views == {("3D", "/robot", "robot"), ("TimeSeries", "/joints", "joint positions (rad)"),
                     ("TimeSeries", "/joint_velocities", "joint velocities (rad/s)"),
                     ("TimeSeries", "/joints", "joint positions (m)"),
                     ("TimeSeries", "/joint_velocities", "joint velocities (m/s)"), ("Graph", "/tf_tree", "TF tree")}
    assert any(row.get("EyeControls3D:position") for row in rows)
    # each plot holds the joints of its unit: marm's fingers are prismatic
    contents = {tuple(sorted(row["ViewContents:query"])) for row in rows if row.get("ViewContents:query")}
    assert (joint_entity("finger_joint1"), joint_entity("finger_joint2")) in contents
    assert tuple(sorted(joint_entity(f"joint{i}") for i in range(1, 7))) in contents


def test_joint_plots_have_stable_colours_and_names_and_frame_labels_are_off(tmp_root: str) -> None:
    from tfrec.viewer.blueprint import joint_colour

    rrd, robot = recorded("marm", tmp_root), load_robot("marm")
    for index, joint in enumerate(robot.joints):
        if joint.type.moves:
            for entity in (joint_entity(joint.name), velocity_entity(joint.name)):
                assert rrd.static[entity]["SeriesLines:colors"] == [joint_colour(index)]
                assert rrd.static[entity]["SeriesLines:names"] == [joint.name]
    colours = [joint_colour(i) for i, joint in enumerate(robot.joints) if joint.type.moves]
    assert len(set(colours)) == len(colours)
    assert {rrd.static[link_entity(link.name)]["TransformAxes3D:show_frame"][0] for link in robot.links} == {False}


def test_the_tf_tree_is_a_graph_of_frames(tmp_root: str) -> None:
    rrd, robot = recorded("marm", tmp_root), load_robot("marm")
    tree = rrd.static["/tf_tree"]
    assert sorted(tree["GraphNodes:node_ids"]) == sorted(link.name for link in robot.links)
    edges = [(edge["first"], edge["second"]) for edge in tree["GraphEdges:edges"]]
    assert sorted(edges) == sorted((j.parent, j.child) for j in robot.joints)
    assert tree["GraphEdges:graph_type"] == [2]  # directed
    position = dict(zip(tree["GraphNodes:node_ids"], tree["GraphNodes:positions"]))
    for joint in robot.joints:  # a parent above its child
        assert position[joint.parent][1] < position[joint.child][1]


@pytest.mark.parametrize("name", ["marm", "mbot", "simple_cube"])
def test_the_camera_frames_the_robots_whole_reach(name: str, tmp_path: Path) -> None:
    """Every link origin at every sample, not only the first chunk's, is inside the 3D view's field of view,
    looked at from front-left and above, Z up; and the robot is not lost in the distance."""
    from tfrec.kinematics.fk import link_poses
    from tfrec.kinematics.joints import all_joint_states
    from tfrec.viewer.blueprint import FIELD_OF_VIEW_DEG

    robot = load_robot(name)
    path = tmp_path / f"{name}.rrd"
    trajectory = make_trajectory(robot, "random", duration_s=4.0, rate_hz=50.0, period_s=0.5)
    sink = RerunSink(path, robot=robot, recording_id="reach")
    sink.begin(static=static_transforms(robot), start_time_ns=START_NS)
    for chunk in iter_dynamic_chunks(robot, trajectory, chunk_samples=16):
        sink.write_chunk(stamp_ns=chunk.time_ns + START_NS, joint_names=chunk.names, positions=chunk.positions,
                         velocities=chunk.velocities, transforms=chunk.transforms)
    sink.finish()
    (eye,) = [row for chunk in Rrd(path).blueprint_chunks for row in chunk if row.get("EyeControls3D:position")]
    position, target = np.array(eye["EyeControls3D:position"][0]), np.array(eye["EyeControls3D:look_target"][0])
    assert eye["EyeControls3D:eye_up"][0] == [0.0, 0.0, 1.0]
    view = target - position
    assert view[0] < 0 and view[1] < 0 and view[2] < 0 and abs(view[0] - view[1]) < 1e-6  # ¾ from front-left, above
    names, positions, _ = all_joint_states(robot, trajectory)
    origins = np.concatenate([pose[:, :3, 3] for pose in link_poses(robot, names, positions).values()])
    rays = origins - position
    angles = np.degrees(np.arccos(np.clip(rays @ view / np.linalg.norm(rays, axis=1) / np.linalg.norm(view), -1, 1)))
    assert angles.max() < FIELD_OF_VIEW_DEG / 2  # all of the reach is in view...
    assert angles.max() > FIELD_OF_VIEW_DEG / 10 or len(robot.joints) == 0  # ...and fills a good part of it


def test_frame_prefix_goes_on_frames_not_on_entity_paths(tmp_path: Path) -> None:
    robot = load_robot("marm")
    rrd = Rrd(write_rrd(tmp_path / "prefixed.rrd", robot, duration_s=0.2, frame_prefix="left/"))
    assert rrd.static[link_entity("link3")]["CoordinateFrame:frame"] == ["left/link3"]
    assert rrd.static["/robot"]["CoordinateFrame:frame"] == ["left/link0"]
    _, parents = rrd.series(tf_entity("joint3"), "Transform3D:parent_frame")
    assert parents[0] == ["left/link2"]
    assert rrd.static[tf_static_entity("gripper_joint")]["Transform3D:child_frame"] == ["left/gripper_link"]


# -- the replay side: pairs with their own stamps, joint logs with gaps ------------------------

def _views(rrd: Rrd) -> set[tuple[str, str]]:
    rows = [row for chunk in rrd.blueprint_chunks for row in chunk]
    return {(row["ViewBlueprint:class_identifier"][0], row["ViewBlueprint:space_origin"][0])
            for row in rows if row.get("ViewBlueprint:class_identifier")}


def _eyes(rrd: Rrd) -> list[Any]:
    return [row["EyeControls3D:position"] for chunk in rrd.blueprint_chunks for row in chunk
            if row.get("EyeControls3D:position")]


def _data(static: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Static rows without their row ids (wall-clock TUIDs)."""
    return {entity: {k: v for k, v in row.items() if k != "rerun.controls.RowId"} for entity, row in static.items()}


def test_pairs_and_positions_logged_separately_land_where_chunks_do(tmp_path: Path) -> None:
    robot = load_robot("marm")
    trajectory = make_trajectory(robot, "sine", duration_s=0.5, rate_hz=50.0)
    chunked = Rrd(write_rrd(tmp_path / "chunked.rrd", robot, duration_s=0.5, chunk_samples=1000))
    sink = RerunSink(tmp_path / "pairs.rrd", robot=robot, recording_id="test-recording")
    sink.begin(static=static_transforms(robot), start_time_ns=START_NS, robot_description=robot.urdf)
    (chunk,) = iter_dynamic_chunks(robot, trajectory)
    stamps = chunk.time_ns + START_NS
    sink.fit_camera(chunk.transforms)
    for k, (parent, child) in enumerate(zip(chunk.transforms.parents, chunk.transforms.children)):
        for part in (slice(0, 7), slice(7, None)):  # every pair on its own, in two pieces
            sink.write_transforms(parent, child, stamps[part], chunk.transforms.translation[part, k],
                                  chunk.transforms.rotation[part, k])
    sink.write_joint_positions(stamps, chunk.names, chunk.positions)
    sink.finish()
    pairs = Rrd(tmp_path / "pairs.rrd")
    # the same geometry, frames, axes, fixed joints and URDF (pairs log no velocities, so no velocity styles)
    assert _data(pairs.static) == {e: row for e, row in _data(chunked.static).items() if "/joint_velocities/" not in e}
    assert set(pairs.temporal) == {e for e in chunked.temporal if not e.startswith("/joint_velocities/")}
    for joint in robot.moving_joints:
        for column in ("Transform3D:translation", "Transform3D:quaternion", "Transform3D:child_frame"):
            times, values = pairs.series(tf_entity(joint.name), column)
            np.testing.assert_array_equal(times, stamps)
            assert values == chunked.series(tf_entity(joint.name), column)[1]
        times, values = pairs.series(joint_entity(joint.name), "Scalars:scalars")
        np.testing.assert_array_equal(times, stamps)
        assert values == chunked.series(joint_entity(joint.name), "Scalars:scalars")[1]
    # no velocities, no velocity tab; the same camera
    assert _views(pairs) == {("3D", "/robot"), ("TimeSeries", "/joints"), ("Graph", "/tf_tree")}
    assert _eyes(pairs) == _eyes(chunked)


def test_joint_positions_skip_nan_and_pairs_outside_the_model_keep_their_own_entities(tmp_path: Path) -> None:
    robot = load_robot("marm")
    stamps = START_NS + np.arange(3, dtype=np.int64) * 10_000_000
    sink = RerunSink(tmp_path / "x.rrd", robot=robot, recording_id="x")
    latched = Transforms(("map",), ("odom",), np.zeros((1, 1, 3)), np.array([[[0.0, 0.0, 0.0, 1.0]]]))
    sink.begin(static=latched, start_time_ns=START_NS)
    sink.log_frames(["map", "odom", "link0", "odom"])
    sink.write_joint_positions(stamps, ["joint1", "joint2"], np.array([[0.1, np.nan], [np.nan, np.nan], [0.3, 0.4]]))
    sink.write_transforms("odom", "link0", stamps, np.zeros((3, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (3, 1)))
    sink.finish()
    rrd = Rrd(tmp_path / "x.rrd")
    times, values = rrd.series(joint_entity("joint1"), "Scalars:scalars")
    assert list(times - START_NS) == [0, 20_000_000] and values == [[0.1], [0.3]]
    times, values = rrd.series(joint_entity("joint2"), "Scalars:scalars")
    assert list(times - START_NS) == [20_000_000] and values == [[0.4]]
    _, parents = rrd.series(pair_entity("odom", "link0"), "Transform3D:parent_frame")
    assert parents == [["odom"]] * 3
    assert rrd.static[static_pair_entity("map", "odom")]["Transform3D:child_frame"] == ["odom"]
    for frame in ("map", "odom"):  # frames that are no link get axes of their own
        assert rrd.static[link_entity(frame)]["CoordinateFrame:frame"] == [frame]
        assert rrd.static[link_entity(frame)]["TransformAxes3D:axis_length"] == [pytest.approx(0.1)]
    assert rrd.static[link_entity("link0")]["TransformAxes3D:axis_length"] != [pytest.approx(0.1)]


def test_each_pair_keeps_its_own_time(tmp_path: Path) -> None:
    sink = RerunSink(tmp_path / "x.rrd", robot=load_robot("marm"), recording_id="x")
    sink.begin(static=static_transforms(load_robot("marm")), start_time_ns=START_NS)
    identity = np.zeros((2, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
    later, earlier = np.array([20, 30], dtype=np.int64), np.array([0, 10], dtype=np.int64)
    sink.write_transforms("link0", "link1", later, *identity)
    sink.write_transforms("link1", "link2", earlier, *identity)  # another pair may be behind
    with pytest.raises(RecordingError, match="transforms 'link0' -> 'link1': stamps go back in time"):
        sink.write_transforms("link0", "link1", earlier, *identity)
    with pytest.raises(RecordingError, match=r"transforms 'link1' -> 'link2': 2 stamps with translation \(3, 3\)"):
        sink.write_transforms("link1", "link2", later, np.zeros((3, 3)), identity[1])
    with pytest.raises(RecordingError, match=r"2 stamps of 1 joints have positions \(2, 2\)"):
        sink.write_joint_positions(later, ["joint1"], np.zeros((2, 2)))
    sink.abort()
    assert not (tmp_path / "x.rrd").exists()


def test_a_stream_made_elsewhere(tmp_path: Path) -> None:
    robot = load_robot("marm")
    stream = rr.RecordingStream(APPLICATION_ID, recording_id="streamed", send_properties=False)
    stream.save(tmp_path / "s.rrd")
    sink = RerunSink.from_stream(stream, target="test stream", robot=robot)
    assert sink.path is None
    sink.begin(static=static_transforms(robot), start_time_ns=START_NS, name="replayed")
    sink.send_blueprint()
    sink.finish()  # no second blueprint
    rrd = Rrd(tmp_path / "s.rrd")
    assert rrd.store.recording_id == "streamed"
    assert rrd.static["/__properties"]["RecordingInfo:name"] == ["replayed"]
    assert rrd.static[link_entity("link3")]["CoordinateFrame:frame"] == ["link3"]
    assert sum(1 for chunk in rrd.blueprint_chunks for row in chunk if row.get("ViewportBlueprint:root_container")) == 1
    kept = tmp_path / "kept.rrd"
    other = rr.RecordingStream(APPLICATION_ID, send_properties=False)
    other.save(kept)
    RerunSink.from_stream(other, target="test stream", robot=None).abort()
    assert kept.exists()  # the stream's file is its owner's to delete


def test_a_replay_has_the_recordings_layout_and_a_fitted_camera(tmp_path: Path) -> None:
    from tfrec.recorder import plan_outputs, record
    from tfrec.replay.load import load_replay
    from tfrec.replay.play import replay_to_rerun

    robot = load_robot("marm")
    source = tmp_path / "marm.mcap"
    record(robot, make_trajectory(robot, "sine", duration_s=0.5, rate_hz=50.0), plan_outputs(stem="m", out=source))
    replay_to_rerun(load_replay(source), save=tmp_path / "replay.rrd")
    recorded_, replayed = Rrd(source.with_suffix(".rrd")), Rrd(tmp_path / "replay.rrd")
    assert _views(recorded_) == _views(replayed) | {("TimeSeries", "/joint_velocities")}
    assert ("Graph", "/tf_tree") in _views(replayed)
    assert len(_eyes(replayed)) == 1
    assert set(replayed.static) == {e for e in recorded_.static if not e.startswith("/joint_velocities/")}


# -- the file as rerun's tools see it ---------------------------------------------------------

def test_rerun_rrd_verify_passes(tmp_path: Path) -> None:
    path = write_rrd(tmp_path / "marm.rrd", load_robot("marm"))
    result = subprocess.run([RERUN, "rrd", "verify", path], check=False, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr


def test_same_inputs_give_recordings_rerun_finds_identical(tmp_path: Path) -> None:
    robot = load_robot("marm")
    first = write_rrd(tmp_path / "a.rrd", robot, recording_id="same")
    second = write_rrd(tmp_path / "b.rrd", robot, recording_id="same")
    result = subprocess.run([RERUN, "rrd", "compare", first, second], check=False, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert not any("log_time" in column for rows in Rrd(first).temporal.values() for column in rows[0])


def test_the_same_command_gives_the_same_data_and_blueprint(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """What is equal between two runs of one command (docs/recording-format.md, Determinism): every
    chunk of the recording, in order, but for the ids Rerun mints when it writes (chunk and row ids);
    the blueprint but for those ids and its rows' log_time; the identity and properties. Not the bytes."""
    import pyarrow as pa

    from tfrec import cli

    files = []
    for run in ("one", "two"):
        folder = tmp_path / run
        folder.mkdir()
        monkeypatch.chdir(folder)
        assert cli.main(["record", str(REPO / "robots" / "marm.xacro"), "--duration", "1", "-o", "marm.mcap"]) == 0
        files.append(folder / "marm.rrd")
    assert files[0].read_bytes() != files[1].read_bytes()  # the ids Rerun mints differ...

    def chunks(path: Path, store: Any = None) -> list[tuple[str, pa.RecordBatch]]:
        out = []
        for chunk in rr.chunk.RrdReader(path).stream(store=store):
            batch = chunk.to_record_batch()
            keep = [i for i, name in enumerate(batch.schema.names) if name not in ("rerun.controls.RowId", "log_time")]
            metadata = {k: v for k, v in (batch.schema.metadata or {}).items() if k != b"rerun:id"}
            out.append((chunk.entity_path, pa.RecordBatch.from_arrays(
                [batch.column(i) for i in keep], schema=pa.schema([batch.schema.field(i) for i in keep], metadata))))
        return out

    first, second = chunks(files[0]), chunks(files[1])
    assert [e for e, _ in first] == [e for e, _ in second]  # ...and nothing else: same chunks, same order
    assert all(a.equals(b, check_metadata=True) for (_, a), (_, b) in zip(first, second))
    blueprints = [chunks(path, rr.chunk.RrdReader(path).blueprints()[0]) for path in files]
    assert sorted(e for e, _ in blueprints[0]) == sorted(e for e, _ in blueprints[1])  # stable view ids
    assert sorted(str(b.to_pylist()) for _, b in blueprints[0]) == sorted(str(b.to_pylist()) for _, b in blueprints[1])
    stores = [rr.chunk.RrdReader(path).recordings()[0] for path in files]
    assert stores[0].recording_id == stores[1].recording_id and stores[0].application_id == "tfrec"
    info = Rrd(files[0]).static["/__properties"]
    assert info["RecordingInfo:start_time"] == [START_NS]  # the first stamp, not the wall clock
    result = subprocess.run([RERUN, "rrd", "compare", *files], check=False, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr


def test_waiting_for_the_writer_every_few_bytes_changes_nothing_in_the_recording(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    robot = load_robot("marm")
    whole = write_rrd(tmp_path / "whole.rrd", robot, recording_id="same")
    flushes = 0
    flush = RerunSink.flush

    def counted(sink: RerunSink) -> None:
        nonlocal flushes
        flushes += 1
        flush(sink)

    monkeypatch.setattr(RerunSink, "flush", counted)
    monkeypatch.setattr(rerun_io, "_FLUSH_BYTES", 4096)
    flushed = write_rrd(tmp_path / "flushed.rrd", robot, recording_id="same")
    assert flushes > 10  # not only finish's: Rerun's queue stays short, whatever the recording's length
    for command in (["compare", whole, flushed], ["verify", flushed]):
        result = subprocess.run([RERUN, "rrd", *command], check=False, capture_output=True, text=True, timeout=120)
        assert result.returncode == 0, result.stderr


# -- meshes -----------------------------------------------------------------------------------

def test_corpus_meshes_embedded_and_a_missing_one_warned_once(tmp_path: Path) -> None:
    import trimesh

    robot = load_robot("turtlebot3_description/urdf/turtlebot3_waffle.urdf.xacro")
    with pytest.warns(UserWarning) as caught:
        path = write_rrd(tmp_path / "waffle.rrd", robot, duration_s=0.2)
    messages = [str(w.message) for w in caught]
    assert messages == [
        (
            "package://turtlebot3_description/meshes/bases/waffle_base.stl: mesh for link 'base_link' not found "
            f"({CORPUS.resolve() / 'turtlebot3_description/meshes/bases/waffle_base.stl'}); link logged without it"
        )
    ]
    rrd = Rrd(path)
    for link in robot.links:  # every visual has its entity, meshes found or not
        for index in range(len(link.visuals)):
            assert rrd.static[visual_entity(link.name, index)]["CoordinateFrame:frame"] == [link.name]
    base = rrd.static[visual_entity("base_link", 0)]
    assert "Asset3D:blob" not in base and base["CoordinateFrame:frame"] == ["base_link"]
    tire = rrd.static[visual_entity("wheel_left_link", 0)]
    assert tire["Asset3D:media_type"] == ["model/stl"]
    stl = (CORPUS / "turtlebot3_description/meshes/wheels/left_tire.stl").read_bytes()
    assert bytes(tire["Asset3D:blob"][0]) == stl
    assert tire["InstancePoses3D:scales"] == [[pytest.approx(0.001)] * 3]
    assert tire["Asset3D:albedo_factor"] == [_packed((0.3, 0.3, 0.3, 1.0))]  # URDF material "dark"
    camera = rrd.static[visual_entity("camera_link", 0)]  # r200.dae, in inches: converted to metres
    assert camera["Asset3D:media_type"] == ["model/gltf-binary"]
    glb = trimesh.load(io.BytesIO(bytes(camera["Asset3D:blob"][0])), file_type="glb", force="scene")
    assert 0.1 < max(glb.extents) < 0.2  # the RealSense R200 is 13 cm wide
    assert any(entity.startswith("/tf/") for entity in rrd.temporal)


def test_dae_meshes_of_a_mimic_gripper_keep_their_own_colours(tmp_path: Path) -> None:
    robot = load_robot("franka_description/robots/panda/panda.urdf.xacro", hand="true")
    with pytest.warns(UserWarning) as caught:
        rrd = Rrd(write_rrd(tmp_path / "panda.rrd", robot, duration_s=0.2))
    (message,) = [str(w.message) for w in caught]  # the corpus leaves the arm's 8 visual meshes out: one warning
    assert message.startswith("8 meshes cannot be shown (their links are logged without them): package://"
                              "franka_description/meshes/visual/link0.dae: mesh for link 'panda_link0' not found (")
    assert "link2.dae: mesh for link 'panda_link2' not found" in message and message.endswith("; and 5 more")
    for link in ("panda_hand", "panda_leftfinger", "panda_rightfinger"):
        row = rrd.static[visual_entity(link, 0)]
        assert row["Asset3D:media_type"] == ["model/gltf-binary"]
        assert row.get("Asset3D:albedo_factor") is None
    assert tf_entity("panda_finger_joint2") in rrd.temporal  # the mimic finger moves too


MESH_URDF = """<robot name="meshy">
  <material name="green"><color rgba="0 1 0 1"/></material>
  <link name="base">
    <visual><geometry><mesh filename="meshes/cube.stl"/></geometry><material name="green"/></visual>
    <visual><geometry><mesh filename="file://{folder}/meshes/cube.obj" scale="2 2 2"/></geometry></visual>
    <visual><geometry><mesh filename="package://meshy_description/meshes/cube.stl"/></geometry></visual>
    <visual><geometry><mesh filename="meshes/nowhere.stl"/></geometry></visual>
    <visual><geometry><mesh filename="meshes/nowhere.stl"/></geometry></visual>
  </link>
  <link name="tip">
    <visual><geometry><mesh filename="package://no_such_package/meshes/cube.stl"/></geometry></visual>
  </link>
  <joint name="slide" type="prismatic">
    <parent link="base"/><child link="tip"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_relative_file_and_package_meshes_and_one_warning_for_the_missing_ones(tmp_path: Path) -> None:
    import trimesh

    folder = tmp_path / "meshy_description"
    (folder / "meshes").mkdir(parents=True)
    (folder / "package.xml").write_text("<package><name>meshy_description</name></package>")
    cube = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    cube.export(folder / "meshes" / "cube.stl")
    cube.export(folder / "meshes" / "cube.obj")
    source = folder / "robot.urdf"
    text = MESH_URDF.format(folder=folder)
    source.write_text(text)
    robot = parse_urdf(text, source=str(source))
    with pytest.warns(UserWarning) as caught:
        rrd = Rrd(write_rrd(tmp_path / "meshy.rrd", robot, duration_s=0.1))
    (message,) = [str(w.message) for w in caught]  # one warning for every mesh that cannot be shown
    assert message.startswith("2 meshes cannot be shown (their links are logged without them): "
                              "meshes/nowhere.stl: mesh for link 'base' not found (")
    assert "; package://no_such_package/meshes/cube.stl: mesh for link 'tip' not found (package 'no_such_package' " \
           "not found" in message
    stl = (folder / "meshes" / "cube.stl").read_bytes()
    relative, absolute, packaged = (rrd.static[visual_entity("base", i)] for i in range(3))
    assert bytes(relative["Asset3D:blob"][0]) == stl and relative["Asset3D:albedo_factor"] == [0x00FF00FF]
    assert absolute["Asset3D:media_type"] == ["model/obj"]
    assert absolute["InstancePoses3D:scales"] == [[2.0, 2.0, 2.0]]
    assert bytes(packaged["Asset3D:blob"][0]) == stl
    assert all("Asset3D:blob" not in rrd.static[visual_entity("base", i)] for i in (3, 4))
    assert isinstance(robot.link_by_name["tip"].visuals[0].geometry, Mesh)


# -- errors -----------------------------------------------------------------------------------

def test_unwritable_path_is_a_recording_error(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="no_such_folder/x.rrd: cannot write"):
        RerunSink(tmp_path / "no_such_folder" / "x.rrd", robot=load_robot("marm"), recording_id="x")


def test_chunk_whose_arrays_do_not_match_is_refused(tmp_path: Path) -> None:
    robot = load_robot("marm")
    chunk = next(iter_dynamic_chunks(robot, make_trajectory(robot, "center", duration_s=0.1, rate_hz=50.0)))
    sink = RerunSink(tmp_path / "x.rrd", robot=robot, recording_id="x")
    sink.begin(static=static_transforms(robot), start_time_ns=START_NS)
    with pytest.raises(RecordingError, match=r"chunk of 6 stamps has positions \(5, 8\)"):
        sink.write_chunk(stamp_ns=chunk.time_ns, joint_names=chunk.names, positions=chunk.positions[:5],
                         velocities=chunk.velocities, transforms=chunk.transforms)
    sink.abort()
    assert not (tmp_path / "x.rrd").exists()


def test_stamps_going_back_in_time_are_refused(tmp_path: Path) -> None:
    robot = load_robot("marm")
    chunk = next(iter_dynamic_chunks(robot, make_trajectory(robot, "center", duration_s=0.1, rate_hz=50.0)))
    sink = RerunSink(tmp_path / "x.rrd", robot=robot, recording_id="x")
    sink.begin(static=static_transforms(robot), start_time_ns=START_NS)

    def write_again() -> None:
        sink.write_chunk(stamp_ns=chunk.time_ns + START_NS, joint_names=chunk.names, positions=chunk.positions,
                         velocities=chunk.velocities, transforms=chunk.transforms)

    write_again()
    with pytest.raises(RecordingError, match="chunk stamps go back in time"):
        write_again()
    sink.abort()


FULL_DISK = """
import resource, signal, sys
from tfrec.errors import RecordingError
from tests.formats.test_rrd import load_robot, write_rrd
robot = load_robot("marm")
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, resource.RLIM_INFINITY))
try:
    write_rrd(__import__("pathlib").Path(sys.argv[1]), robot, duration_s=5.0)
except RecordingError as err:
    print(err)
"""


def test_a_write_that_fails_midway_is_a_recording_error(tmp_path: Path) -> None:
    # a file size limit stands in for a full disk: Rerun's writer thread fails after the header
    target = tmp_path / "big.rrd"
    result = subprocess.run([sys.executable, "-c", FULL_DISK, target], check=False, capture_output=True, text=True,
                            cwd=REPO, timeout=120)
    assert result.stdout.startswith(f"{target}: cannot write: "), result.stdout + result.stderr


def test_stamps_that_are_not_int64_nanoseconds_are_refused(tmp_path: Path) -> None:
    robot = load_robot("marm")
    chunk = next(iter_dynamic_chunks(robot, make_trajectory(robot, "center", duration_s=0.1, rate_hz=50.0)))
    sink = RerunSink(tmp_path / "x.rrd", robot=robot, recording_id="x")
    sink.begin(static=static_transforms(robot), start_time_ns=START_NS)
    with pytest.raises(RecordingError, match=r"time_ns must be int64 of shape \(n,\), got float64 \(6,\)"):
        sink.write_chunk(stamp_ns=chunk.time_ns * 1e-9, joint_names=chunk.names,  # type: ignore[arg-type]
                         positions=chunk.positions, velocities=chunk.velocities, transforms=chunk.transforms)
    sink.abort()


def test_a_robot_without_moving_joints_is_framed_too(tmp_path: Path) -> None:
    from tfrec import cli

    out = tmp_path / "cube.mcap"
    assert cli.main(["record", str(REPO / "robots" / "simple_cube.xacro"), "--duration", "1", "-o", str(out)]) == 0
    rrd = Rrd(out.with_suffix(".rrd"))
    (eye,) = [row for chunk in rrd.blueprint_chunks for row in chunk if row.get("EyeControls3D:look_target")]
    target = np.array(eye["EyeControls3D:look_target"][0])
    assert target[0] > 0.3 and target[1] > 0.1  # towards the cube, 1 m and 0.5 m from the root
    assert _views(rrd) == {("3D", "/robot")}  # no joints, no frames: the 3D view alone
