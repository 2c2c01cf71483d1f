"""Recordings of very many distinct schemas (issue 20): converting an MCAP of 65,000 schemas cost ~3 ms of CPU per
schema — a rosbags type store built and compiled for each, to check that the file's definition decodes its
messages — and exceeded the 30 s CPU guard; converted to ROS 1, a store per type (~4 ms, 50 kB each). A type the
distro does not know is copied as it is without a check, and the types of one definition share one converter. Each file is
built here; every command keeps within :mod:`tests.faults.guarded`'s CPU guard (``RLIMIT_CPU``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from tests.faults.guarded import guarded

SCHEMAS = 65_000  # an MCAP's schema ids are 16 bits
START_NS = 1_700_000_000_000_000_000
STRING = b"\x00\x01\x00\x00\x02\x00\x00\x00x\x00"  # CDR of std_msgs/msg/String "x"


def _many_schemas(path: Path, *, grown: bool = True) -> None:
    """Types of their own (``pkg_i/msg/T``), and with ``grown`` half of them one type with a field more in each
    definition instead; one channel and one message each."""
    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        for i in range(SCHEMAS):
            if i % 2 or not grown:
                schema = writer.register_schema(f"pkg_{i}/msg/T", "ros2msg", b"string data\n")
            else:
                text = f"string data\n# comment {i}\nint32 extra_{i}\n".encode()
                schema = writer.register_schema("pkg/msg/Grown", "ros2msg", text)
            channel = writer.register_channel(f"/topic_{i}", "cdr", schema)
            writer.add_message(channel, log_time=START_NS + i, data=STRING, publish_time=START_NS + i)
        writer.finish()


def test_65000_distinct_schemas_convert_within_the_cpu_guard(tmp_path: Path) -> None:
    _many_schemas(tmp_path / "many.mcap")
    guarded(["convert", "many.mcap", "out.mcap"], tmp_path)
    with open(tmp_path / "out.mcap", "rb") as stream:  # mcap's own reader
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and len(summary.channels) == SCHEMAS
        schemas = {(s.name, s.data) for s in summary.schemas.values()}
        assert len(schemas) == SCHEMAS  # every definition carried as the file gives it
        assert sum(1 for _ in reader.iter_messages()) == SCHEMAS


def test_65000_types_of_one_definition_convert_to_ros1_within_the_cpu_guard(tmp_path: Path) -> None:
    """To ROS 1 each type is converted by rosbags: the types of one definition share one converter."""
    _many_schemas(tmp_path / "many.mcap", grown=False)
    guarded(["convert", "many.mcap", "out.bag"], tmp_path)
    from rosbags.rosbag1 import Reader  # an independent reader

    with Reader(tmp_path / "out.bag") as bag:
        assert len(bag.connections) == SCHEMAS and bag.message_count == SCHEMAS
        assert len({c.msgtype for c in bag.connections}) == SCHEMAS
        string = ("string data\n", "992ce8a1687cec8c8bd883ec73ca41d1")  # std_msgs/String's md5sum: the same fields
        assert {(c.msgdef.data, c.digest) for c in bag.connections} == {string}


@pytest.mark.parametrize("target", ["out.mcap", "out.bag"])
def test_a_few_schemas_of_other_types_convert(tmp_path: Path, target: str) -> None:
    """The same file in small: what the guard protects is also right (ROS 1 output: converted by rosbags)."""
    with open(tmp_path / "few.mcap", "wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        for i in range(20):
            schema = writer.register_schema(f"pkg_{i}/msg/T", "ros2msg", b"string data\n")
            channel = writer.register_channel(f"/topic_{i}", "cdr", schema)
            writer.add_message(channel, log_time=START_NS + i, data=STRING, publish_time=START_NS + i)
        writer.finish()
    guarded(["convert", "few.mcap", target], tmp_path, isolated=False)
    from rosbags.highlevel import AnyReader  # an independent reader

    with AnyReader([tmp_path / target]) as reader:
        assert len(reader.connections) == 20
        messages = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    assert [m.data for m in messages] == ["x"] * 20
