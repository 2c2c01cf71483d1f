"""What the Rerun sink logs per sample, read back with Rerun's own reader: the transforms exactly the float32 of
FK's float64 values (the sink converts them once per chunk, as Rerun stored them when it converted each column),
the joint positions and velocities exactly FK's float64, every sample once, each column in time order; the columns
the sink builds from numpy buffers are the ones Rerun's own converters make, and need no pandas."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rerun as rr

from tests.formats.test_rrd import RERUN, START_NS, Rrd, load_robot, write_rrd
from tfrec.formats.rrd.paths import ELAPSED_TIMELINE, TIMELINE, joint_entity, tf_entity, velocity_entity
from tfrec.kinematics.fk import iter_dynamic_chunks
from tfrec.trajectory.generators import make_trajectory
from tfrec.viewer import columns, sink


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


def _rerun_transform_columns(translation: Any, quaternion: Any, parent: str, child: str) -> Any:
    """The transforms' columns as Rerun's own converters make them (what the sink used to send)."""
    n = len(translation)
    return rr.Transform3D.columns(translation=translation, quaternion=quaternion, parent_frame=[parent] * n,
                                  child_frame=[child] * n)


def _arrays(built: Any) -> list[tuple[str, Any]]:
    return [(str(column.component_descriptor().component), column.as_arrow_array()) for column in built]


def test_sample_columns_are_the_ones_rerun_converters_make() -> None:
    rng = np.random.default_rng(7)
    n = 37
    wide = rng.normal(size=(n, 9)) * 1e3  # float64, strided columns of it: what replay and record hand over
    translation, quaternion, values = wide[:, 0:3], wide[:, 3:7], wide[:, 7]
    ours = _arrays(columns.transform_columns(translation, quaternion, "base_link", "arm/link \u00e9"))
    theirs = _arrays(_rerun_transform_columns(translation, quaternion, "base_link", "arm/link \u00e9"))
    assert [name for name, _ in ours] == [name for name, _ in theirs]
    for (name, mine), (_, reference) in zip(ours, theirs):
        assert mine.type == reference.type and mine.type.value_field == reference.type.value_field, name
        assert mine.equals(reference), name
    assert [a.equals(b) for (_, a), (_, b) in zip(_arrays([columns.scalar_column(values)]),
                                                   _arrays(rr.Scalars.columns(scalars=values)))] == [True]
    stamps = START_NS + np.cumsum(rng.integers(1, 10**7, size=n))
    assert columns.time_column(stamps).as_arrow_array().equals(
        rr.TimeColumn(TIMELINE, timestamp=stamps.astype("datetime64[ns]")).as_arrow_array())
    assert columns.elapsed_column(stamps[::2], START_NS).as_arrow_array().equals(
        rr.TimeColumn(ELAPSED_TIMELINE, duration=(stamps[::2] - START_NS).astype("timedelta64[ns]")).as_arrow_array())


def test_a_recording_equals_one_sent_through_rerun_converters(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The whole file, as ``rerun rrd compare`` sees it, is the one the sink wrote when Rerun converted every
    column (the reference is made here, with Rerun's converters put back in the sink)."""
    robot = load_robot("marm")
    ours = write_rrd(tmp_path / "ours.rrd", robot, chunk_samples=37, recording_id="same")
    monkeypatch.setattr(sink, "transform_columns", _rerun_transform_columns)
    monkeypatch.setattr(sink, "scalar_column", lambda values: next(iter(rr.Scalars.columns(scalars=values))))
    monkeypatch.setattr(sink, "time_column",
                        lambda stamps: rr.TimeColumn(TIMELINE, timestamp=stamps.astype("datetime64[ns]")))
    monkeypatch.setattr(sink, "elapsed_column", lambda stamps, origin: rr.TimeColumn(
        ELAPSED_TIMELINE, duration=(stamps - origin).astype("timedelta64[ns]")))
    reference = write_rrd(tmp_path / "reference.rrd", robot, chunk_samples=37, recording_id="same")
    result = subprocess.run([RERUN, "rrd", "compare", ours, reference], check=False, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    other = write_rrd(tmp_path / "other.rrd", robot, chunk_samples=37, recording_id="same", duration_s=1.0)
    assert subprocess.run([RERUN, "rrd", "compare", ours, other], check=False, capture_output=True,
                          timeout=120).returncode != 0  # the comparison sees a difference where there is one


def test_arrays_reused_after_a_call_do_not_change_what_was_logged(tmp_path: Path) -> None:
    """Rerun keeps the Arrow arrays it is handed and writes them later: a caller (a replay's batches) that reuses
    its arrays once a call returns must not change the file. Contiguous arrays, which need no conversion."""
    from tfrec.recording import Transforms

    writer = sink.RerunSink(tmp_path / "reused.rrd", robot=None, recording_id="reused")
    writer.begin(static=Transforms((), (), np.zeros((1, 0, 3)), np.zeros((1, 0, 4))), start_time_ns=START_NS)
    stamps = START_NS + np.arange(500, dtype=np.int64) * 10**7
    positions = np.linspace(0.0, 1.0, 500).reshape(500, 1)  # one joint: its column is the array itself
    translation = np.ascontiguousarray(np.linspace(0.0, 1.0, 1500, dtype=np.float32).reshape(500, 3))
    rotation = np.tile(np.array([0.0, 0.0, 0.0, 1.0], np.float32), (500, 1))
    expected = (stamps.copy(), positions[:, 0].copy(), translation.astype(np.float64))
    writer.write_joint_positions(stamps, ["j"], positions)
    writer.write_transforms("a", "b", stamps, translation, rotation)
    stamps[:] = START_NS
    positions[:] = -1.0
    translation[:] = -1.0
    writer.finish()
    rrd = Rrd(tmp_path / "reused.rrd")
    times, values = rrd.series(joint_entity("j"), "Scalars:scalars")
    np.testing.assert_array_equal(times, expected[0])
    np.testing.assert_array_equal([v[0] for v in values], expected[1])
    times, vectors = rrd.series("/tf/a/b", "Transform3D:translation")
    np.testing.assert_array_equal(times, expected[0])
    np.testing.assert_array_equal(np.array([np.asarray(v, dtype=np.float64).reshape(3) for v in vectors]), expected[2])


_NO_PANDAS = """
import sys
import numpy as np
import rerun as rr
from tfrec.viewer.columns import elapsed_column, scalar_column, time_column, transform_columns
stream = rr.RecordingStream("tfrec", recording_id="x", send_properties=False)
stream.save(sys.argv[1])
stamps = np.arange(100, dtype=np.int64) * 10**7 + 10**18
index = [time_column(stamps), elapsed_column(stamps, 10**18)]
values = np.random.default_rng(0).normal(size=(100, 8))
rr.send_columns("/tf/j", indexes=index, columns=transform_columns(values[:, :3], values[:, 3:7], "a", "b"),
                recording=stream, strict=True)
rr.send_columns("/joints/j", indexes=index, columns=[scalar_column(values[:, 7])], recording=stream, strict=True)
stream.flush()
assert "pandas" not in sys.modules, "pandas was imported"
"""


def test_the_samples_columns_import_no_pandas(tmp_path: Path) -> None:
    """pyarrow imports pandas whenever it is installed and converts a numpy array or a list (+40 MB, ~0.2 s): the
    samples' columns are built from buffers and do not (a fresh process, pandas installed)."""
    pytest.importorskip("pandas")
    result = subprocess.run([sys.executable, "-c", _NO_PANDAS, str(tmp_path / "x.rrd")], check=False,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "x.rrd").stat().st_size > 0
