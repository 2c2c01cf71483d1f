"""The vectorized CDR encoders against rosbags' serializer: byte-identical, message by message."""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tfrec.formats.ros.encode import (
    JointStateEncoder,
    TFMessageEncoder,
    align,
    encode_string,
    ns_from_stamps,
    stamps_from_ns,
)

T0 = 1_700_000_000_123_456_789


@lru_cache(maxsize=1)
def store() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def header(time_ns: int, frame_id: str) -> Any:
    types = store().types
    sec, nanosec = divmod(int(time_ns), 1_000_000_000)
    return types["std_msgs/msg/Header"](
        stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame_id
    )


def reference_joint_state(time_ns: int, names: Sequence[str], position: np.ndarray, velocity: np.ndarray,
                          frame_id: str = "") -> bytes:
    msg = store().types["sensor_msgs/msg/JointState"](
        header=header(time_ns, frame_id), name=list(names), position=position, velocity=velocity, effort=np.zeros(0)
    )
    return bytes(store().serialize_cdr(msg, "sensor_msgs/msg/JointState"))


def reference_tf(time_ns: int, parents: Sequence[str], children: Sequence[str], tr: np.ndarray, rot: np.ndarray) -> bytes:
    types = store().types
    transforms = [
        types["geometry_msgs/msg/TransformStamped"](
            header=header(time_ns, parent),
            child_frame_id=child,
            transform=types["geometry_msgs/msg/Transform"](
                translation=types["geometry_msgs/msg/Vector3"](x=tr[k, 0], y=tr[k, 1], z=tr[k, 2]),
                rotation=types["geometry_msgs/msg/Quaternion"](x=rot[k, 0], y=rot[k, 1], z=rot[k, 2], w=rot[k, 3]),
            ),
        )
        for k, (parent, child) in enumerate(zip(parents, children))
    ]
    msg = types["tf2_msgs/msg/TFMessage"](transforms=transforms)
    return bytes(store().serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))


def stamps(n: int) -> np.ndarray:
    # a whole second, odd nanoseconds, and the last representable second
    base = np.array([0, T0, 2**31 * 1_000_000_000 - 1], dtype=np.int64)
    return np.concatenate([base, T0 + 1 + np.arange(max(0, n - 3), dtype=np.int64) * 10_000_007])[:n]


NAME_LISTS = [
    [],
    ["a"],
    ["ab"],
    ["abc"],
    ["abcd"],  # name lengths 1..4 give every padding before the next count
    ["shoulder_pan_joint", "x", "elbow", "wrist_1_joint"],
    [f"joint_{i}" * (i % 3 + 1) for i in range(25)],
]


@pytest.mark.parametrize("names", NAME_LISTS, ids=lambda names: f"{len(names)}joints")
def test_joint_state_matches_rosbags(names: list[str]) -> None:
    rng = np.random.default_rng(len(names))
    n = 5
    time_ns = stamps(n)
    positions = rng.normal(size=(n, len(names)))
    velocities = rng.normal(size=(n, len(names)))
    if names:
        positions[:, 0] = [np.nan, np.inf, -0.0, 1e-300, 3.0]  # special values keep their bits
    rows = JointStateEncoder(names).encode(time_ns, positions, velocities)
    assert rows.shape == (n, JointStateEncoder(names).size)
    for i in range(n):
        assert rows[i].tobytes() == reference_joint_state(time_ns[i], names, positions[i], velocities[i])


@pytest.mark.parametrize("frame_id", ["a", "base_link", "wörld"])
def test_joint_state_with_a_frame_id_matches_rosbags(frame_id: str) -> None:
    """A frame id (the layout check of tfrec.formats.ros.decode writes a driver's JointState back with its own)."""
    names = ["a", "bb", "ccc"]
    values = np.arange(6, dtype=np.float64).reshape(2, 3)
    rows = JointStateEncoder(names, frame_id=frame_id).encode(stamps(2), values, -values)
    for i in range(2):
        assert rows[i].tobytes() == reference_joint_state(stamps(2)[i], names, values[i], -values[i], frame_id)


FRAME_LISTS = [
    ([], []),
    (["a"], ["bc"]),
    (["base_link", "l1", "l22", "l333"], ["l1", "l22", "l333", "tool0"]),
    (["wörld"], ["bäse"]),  # UTF-8: lengths count bytes, not characters
    ([f"link{i}" for i in range(20)], [f"link{i + 1}_{'x' * (i % 4)}" for i in range(20)]),
]


@pytest.mark.parametrize("frames", FRAME_LISTS, ids=lambda frames: f"{len(frames[0])}frames")
def test_tf_message_matches_rosbags(frames: tuple[list[str], list[str]]) -> None:
    parents, children = frames
    rng = np.random.default_rng(len(parents))
    n = 4
    time_ns = stamps(n)
    tr = rng.normal(size=(n, len(parents), 3))
    rot = rng.normal(size=(n, len(parents), 4))
    rows = TFMessageEncoder(parents, children).encode(time_ns, tr, rot)
    for i in range(n):
        assert rows[i].tobytes() == reference_tf(time_ns[i], parents, children, tr[i], rot[i])


names_strategy = st.lists(st.text(alphabet="abcdefgh_/0123456789", min_size=0, max_size=9), max_size=6)


@settings(max_examples=40, deadline=None)
@given(names=names_strategy, stamp=st.integers(0, 2**31 * 10**9 - 1), seed=st.integers(0, 2**16))
def test_any_names_match_rosbags(names: list[str], stamp: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    time_ns = np.array([stamp], dtype=np.int64)
    values = rng.normal(size=(1, len(names)))
    js = JointStateEncoder(names).encode(time_ns, values, -values)
    assert js[0].tobytes() == reference_joint_state(stamp, names, values[0], -values[0])
    children = [name + "_c" for name in names]
    tr, rot = rng.normal(size=(1, len(names), 3)), rng.normal(size=(1, len(names), 4))
    tf = TFMessageEncoder(names, children).encode(time_ns, tr, rot)
    assert tf[0].tobytes() == reference_tf(stamp, names, children, tr[0], rot[0])


@pytest.mark.parametrize("text", ["", "a", "abcd", '<robot name="r"><link name="ä"/></robot>\n'])
def test_string_matches_rosbags(text: str) -> None:
    msg = store().types["std_msgs/msg/String"](data=text)
    assert encode_string(text) == bytes(store().serialize_cdr(msg, "std_msgs/msg/String"))


def test_encode_into_writes_only_its_columns() -> None:
    encoder = JointStateEncoder(["a", "bb", "ccc"])
    n = 3
    big = np.full((n, 7 + encoder.size + 5), 0xAB, dtype=np.uint8)
    big[:, 7 : 7 + encoder.size] = encoder.template
    time_ns = stamps(n)
    positions = np.arange(9.0).reshape(n, 3)
    encoder.encode_into(big[:, 7 : 7 + encoder.size], time_ns, positions, positions * 2)
    assert (big[:, :7] == 0xAB).all() and (big[:, -5:] == 0xAB).all()
    assert (big[:, 7 : 7 + encoder.size] == encoder.encode(time_ns, positions, positions * 2)).all()


def test_stamps_floor_negative_times() -> None:
    packed = stamps_from_ns(np.array([-1, 1_500_000_000], dtype=np.int64)).view("<i4").reshape(2, 2)
    assert packed.tolist() == [[-1, 999_999_999], [1, 500_000_000]]


def test_stamps_back_to_ns() -> None:
    time_ns = np.array([-1, 0, 1_500_000_000, 2**31 * 10**9 - 1], dtype=np.int64)
    packed = stamps_from_ns(time_ns).view("<i4").reshape(-1, 2).astype(np.int64)
    np.testing.assert_array_equal(ns_from_stamps(packed[:, 0], packed[:, 1] & 0xFFFFFFFF), time_ns)
    assert ns_from_stamps(1_700_000_000, 5) == 1_700_000_000_000_000_005


def test_align() -> None:
    assert [align(offset, 8) for offset in (0, 1, 7, 8, 9)] == [0, 8, 8, 8, 16]
    assert [align(offset, 4) for offset in (0, 2, 4, 5)] == [0, 4, 4, 8]


def test_shape_errors() -> None:
    with pytest.raises(ValueError, match="positions"):
        JointStateEncoder(["a"]).encode(stamps(2), np.zeros((2, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="translation"):
        TFMessageEncoder(["a"], ["b"]).encode(stamps(2), np.zeros((2, 1, 4)), np.zeros((2, 1, 4)))
    with pytest.raises(ValueError, match="parents"):
        TFMessageEncoder(["a"], [])
    with pytest.raises(ValueError, match="rows"):
        JointStateEncoder([]).encode_into(np.zeros((1, 3), dtype=np.uint8), stamps(1), np.zeros((1, 0)), np.zeros((1, 0)))
