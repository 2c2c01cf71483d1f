"""The MCAP writer puts a chunk's records in log-time order record by record (one slice per record); before, it
gathered the chunk byte by byte through an 8-byte index per byte (47 % of a ROS 1 → MCAP convert). The output is
byte-identical: checked against that byte gather, kept here as the oracle, on random chunks and on converted bags."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from tests.conftest import BAGS, BAGS_ABSENT
from tfrec.convert import convert
from tfrec.formats.mcap import writer

Columns = dict[int, tuple[NDArray[np.int64], NDArray[np.int64]]]


def byte_gather(body: bytes, columns: Columns) -> tuple[bytes, Columns]:
    """The reorder as it was: every byte's source index (its record's start plus its place in the record), one
    numpy gather."""
    channels = np.concatenate([np.full(len(t), c, np.int64) for c, (t, _) in columns.items()])
    times = np.concatenate([t for t, _ in columns.values()])
    offsets = np.concatenate([o for _, o in columns.values()])
    by_offset = np.argsort(offsets, kind="stable")
    times_written = times[by_offset]
    if len(times_written) < 2 or bool((np.diff(times_written) >= 0).all()):
        return body, columns
    starts = offsets[by_offset]
    lengths = np.diff(np.append(starts, len(body)))
    order = np.argsort(times_written, kind="stable")
    moved_lengths = lengths[order]
    destinations = np.concatenate([[0], np.cumsum(moved_lengths)[:-1]])
    source = np.arange(len(body), dtype=np.int64) + np.repeat(starts[order] - destinations, moved_lengths)
    moved = np.frombuffer(body, dtype=np.uint8)[source].tobytes()
    new_offsets = np.empty_like(starts)
    new_offsets[order] = destinations
    placed = np.empty_like(offsets)
    placed[by_offset] = new_offsets
    return moved, {c: (times[channels == c], placed[channels == c]) for c in columns}


def random_chunk(rng: np.random.Generator, records: int) -> tuple[bytes, Columns]:
    """Records of random lengths (1 to 300 bytes, random content) of up to 4 channels, written channel after
    channel as convert writes a topic's connections, with times that repeat and go back."""
    lengths = rng.integers(1, 300, size=records)
    body = rng.integers(0, 256, size=int(lengths.sum()), dtype=np.uint8).tobytes()
    offsets = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    channel_of = np.sort(rng.integers(0, 4, size=records))
    times = rng.integers(0, records // 2 + 1, size=records).astype(np.int64)
    return body, {int(c): (times[channel_of == c], offsets[channel_of == c]) for c in np.unique(channel_of)}


def test_the_record_reorder_equals_the_byte_gather() -> None:
    rng = np.random.default_rng(3)
    reordered = 0
    for records in (1, 2, 3, 10, 100, 2_000):
        for _ in range(5):
            body, columns = random_chunk(rng, records)
            got_body, got_columns = writer._in_time_order(body, columns)
            want_body, want_columns = byte_gather(body, columns)
            assert got_body == want_body
            assert got_columns.keys() == want_columns.keys()
            for channel, (times, offsets) in want_columns.items():
                np.testing.assert_array_equal(got_columns[channel][0], times)
                np.testing.assert_array_equal(got_columns[channel][1], offsets)
            reordered += got_body != body
    assert reordered >= 15  # most chunks of several records were out of order: the reorder ran


def two_publisher_bag(path: Path, messages: int) -> Path:
    """A ROS 1 bag whose /tf has two publishers of different message sizes in the same chunks (convert writes one
    connection's messages, then the other's: the chunk must be reordered) and a /joint_states topic."""
    from rosbags.rosbag1 import Writer as Writer1

    from tests.recording_helpers import _typestore

    store = _typestore(True)
    t = store.types
    with Writer1(path) as bag:
        left = bag.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store, callerid="/left")
        right = bag.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store, callerid="/right")
        joints = bag.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        for i in range(messages):
            stamp_ns = 1_700_000_000_000_000_000 + i * 10_000_000
            header = t["std_msgs/msg/Header"](seq=i, stamp=t["builtin_interfaces/msg/Time"](
                sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9), frame_id="world")
            for conn, children in ((left, ["a"]), (right, ["b", "c", "d"][: 1 + i % 3])):
                transforms = [t["geometry_msgs/msg/TransformStamped"](
                    header=header, child_frame_id=child, transform=t["geometry_msgs/msg/Transform"](
                        translation=t["geometry_msgs/msg/Vector3"](x=float(i), y=0.0, z=0.0),
                        rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
                    for child in children]
                message = t["tf2_msgs/msg/TFMessage"](transforms=transforms)
                bag.write(conn, stamp_ns, store.serialize_ros1(message, "tf2_msgs/msg/TFMessage"))
            state = t["sensor_msgs/msg/JointState"](header=header, name=["j"], position=np.array([float(i)]),
                                                    velocity=np.array([], dtype=np.float64),
                                                    effort=np.array([], dtype=np.float64))
            bag.write(joints, stamp_ns + 1, store.serialize_ros1(state, "sensor_msgs/msg/JointState"))
    return path


@pytest.mark.parametrize("name", ["built", "example.bag", "example-lz4.bag", "example-unsorted-chunks.bag"])
def test_converted_bags_are_byte_identical_to_the_byte_gather(name: str, tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    if name != "built" and not BAGS.is_dir():
        pytest.skip(BAGS_ABSENT)
    bag = two_publisher_bag(tmp_path / "built.bag", 3_000) if name == "built" else BAGS / "rosbagjs" / name
    calls: list[bool] = []
    record_reorder = writer._in_time_order

    def counted(body: bytes, columns: Columns) -> tuple[bytes, Columns]:
        moved, placed = record_reorder(body, columns)
        calls.append(moved != body)
        return moved, placed

    monkeypatch.setattr(writer, "_in_time_order", counted)
    convert(bag, tmp_path / "records.mcap")
    monkeypatch.setattr(writer, "_in_time_order", byte_gather)
    convert(bag, tmp_path / "bytes.mcap")
    assert any(calls)  # chunks were reordered
    assert (tmp_path / "records.mcap").read_bytes() == (tmp_path / "bytes.mcap").read_bytes()
