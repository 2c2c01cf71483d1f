"""What the Rerun sink logs per sample, read back with Rerun's own reader: the transforms exactly the float32 of
FK's float64 values (the sink converts them once per chunk, as Rerun stored them when it converted each column),
the joint positions and velocities exactly FK's float64, every sample once, each column in time order."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.formats.test_rrd import START_NS, Rrd, load_robot, write_rrd
from tfrec.formats.rrd.paths import joint_entity, tf_entity, velocity_entity
from tfrec.kinematics.fk import iter_dynamic_chunks
from tfrec.trajectory.generators import make_trajectory


def test_logged_columns_are_fk_values_exactly(tmp_path: Path) -> None:
    robot = load_robot("marm")
    path = write_rrd(tmp_path / "marm.rrd", robot, chunk_samples=37)  # chunks of odd length: strided slices
    rrd = Rrd(path)
    chunks = list(iter_dynamic_chunks(robot, make_trajectory(robot, "sine", duration_s=2.0, rate_hz=50.0),
                                      chunk_samples=37))
    stamps = np.concatenate([chunk.time_ns for chunk in chunks]) + START_NS
    names = chunks[0].names
    positions = np.concatenate([chunk.positions for chunk in chunks])
    velocities = np.concatenate([chunk.velocities for chunk in chunks])
    for j, name in enumerate(names):
        for entity, expected in ((joint_entity(name), positions[:, j]), (velocity_entity(name), velocities[:, j])):
            got_stamps, values = rrd.series(entity, "Scalars:scalars")
            np.testing.assert_array_equal(got_stamps, stamps)
            assert np.array_equal(np.array([v[0] for v in values], dtype=np.float64), expected), entity
    transforms = chunks[0].transforms
    joints = {(joint.parent, joint.child): joint.name for joint in robot.joints}
    translation = np.concatenate([chunk.transforms.translation for chunk in chunks])
    rotation = np.concatenate([chunk.transforms.rotation for chunk in chunks])
    for k, pair in enumerate(zip(transforms.parents, transforms.children)):
        entity = tf_entity(joints[pair])
        got_stamps, got_translation = rrd.series(entity, "Transform3D:translation")
        _, got_rotation = rrd.series(entity, "Transform3D:quaternion")
        np.testing.assert_array_equal(got_stamps, stamps)
        t = np.array([np.asarray(v, dtype=np.float64).reshape(3) for v in got_translation])
        q = np.array([np.asarray(v, dtype=np.float64).reshape(4) for v in got_rotation])
        assert np.array_equal(t, translation[:, k].astype(np.float32)), entity  # float32 values, exactly
        assert np.array_equal(q, rotation[:, k].astype(np.float32)), entity
        assert not np.array_equal(t, translation[:, k])  # they are float32 there, not float64
