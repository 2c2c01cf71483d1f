"""Recordings of very many channels (issue 20): an MCAP of 60,000 channels took 79 s of CPU to convert, from work
done per channel that grew with the channels (a mask over the whole batch per channel, a type store, a YAML dump
and a YAML parse per channel, rosbag2 metadata through PyYAML's pure-Python emitter). Each file is built here (60,000
channels of one message each: an MCAP channel id is 16 bits; a ROS 1 bag of as many connections; a sqlite3 bag of
100,000 topics) and every command keeps within :mod:`tests.faults.guarded`'s CPU guard."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from tests.faults.guarded import guarded
from tfrec._yaml import yaml_dump
from tfrec.formats.rosbag2.metadata import QOS_LATCHED, QOS_VOLATILE, bag_info, bag_metadata_yaml

CHANNELS = 60_000
START_NS = 1_700_000_000_000_000_000
STRING = b"\x00\x01\x00\x00\x02\x00\x00\x00x\x00"  # CDR of std_msgs/msg/String "x"


@pytest.fixture(scope="module")
def many(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An MCAP of 60,000 channels (one schema), a message each."""
    folder = tmp_path_factory.mktemp("many")
    with open(folder / "many.mcap", "wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data\n")
        for i in range(CHANNELS):
            channel = writer.register_channel(f"/topic_{i}", "cdr", schema)
            writer.add_message(channel, log_time=START_NS + i, data=STRING, publish_time=START_NS + i)
        writer.finish()
    return folder


def _channels(path: Path) -> int:
    with open(path, "rb") as stream:  # mcap's own reader
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return len(summary.channels)


def test_60000_channels_convert_to_every_output(many: Path) -> None:
    for target in ("out.mcap", "out.bag"):
        guarded(["convert", "many.mcap", target], many)
    assert _channels(many / "out.mcap") == CHANNELS
    guarded(["convert", "many.mcap", "--bag", "bag"], many)
    (stored,) = (many / "bag").glob("*.mcap")
    assert _channels(stored) == CHANNELS
    # no robot topics: an .rrd and a re-simulation have nothing to show, one line each
    assert guarded(["convert", "many.mcap", "out.rrd"], many).code == 2
    assert guarded(["replay", "--check", "many.mcap"], many).code == 2


def test_60000_channels_are_read(many: Path) -> None:
    info = guarded(["info", "many.mcap"], many)
    assert f"/topic_{CHANNELS - 1}" in info.stdout
    guarded(["diff", "many.mcap", "many.mcap"], many, codes=(0, 1))
    guarded(["check", "many.mcap"], many, codes=(0, 1))


def test_a_ros1_bag_of_60000_connections(many: Path) -> None:
    guarded(["convert", "many.mcap", "ros1.bag"], many)
    info = guarded(["info", "ros1.bag"], many)
    assert f"/topic_{CHANNELS - 1}" in info.stdout
    guarded(["convert", "ros1.bag", "back.mcap"], many)
    assert _channels(many / "back.mcap") == CHANNELS


def test_a_sqlite3_bag_of_100000_topics(tmp_path: Path) -> None:
    folder = tmp_path / "db"
    folder.mkdir()
    with sqlite3.connect(folder / "db_0.db3") as db:  # rosbag2's schema; no metadata.yaml (it would be 60 MB)
        db.executescript("CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
                         "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
                         "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
                         "timestamp INTEGER NOT NULL, data BLOB NOT NULL);")
        db.executemany("INSERT INTO topics VALUES (?, ?, 'std_msgs/msg/String', 'cdr', '')",
                       [(i + 1, f"/topic_{i}") for i in range(100_000)])
        db.executemany("INSERT INTO messages VALUES (?, ?, ?, ?)",
                       [(i + 1, i + 1, START_NS + i, STRING) for i in range(100_000)])
    info = guarded(["info", "db"], tmp_path)
    assert "/topic_99999" in info.stdout
    # an MCAP numbers its channels with 16 bits: 100,000 topics are one line (they were a struct.error traceback)
    refused = guarded(["convert", "db", "out.mcap"], tmp_path)
    assert refused.code == 2 and "65,535 channels" in refused.stderr and not (tmp_path / "out.mcap").exists()
    guarded(["convert", "db", "out.bag"], tmp_path)  # a ROS 1 bag numbers connections with 32 bits
    from rosbags.rosbag1 import Reader  # an independent reader

    with Reader(tmp_path / "out.bag") as bag:
        assert len(bag.connections) == 100_000 and bag.message_count == 100_000


def test_bag_metadata_of_many_topics_is_written_as_pyyaml_writes_it() -> None:
    odd = [("/a b: c", "x", "cdr", [QOS_VOLATILE], "yes", 3), ("/t", "true", "cdr", [QOS_VOLATILE], "RIHS01_x", 3),
           ("", "", "", [], "", 0), ("/π", "p/msg/T", "cdr", [QOS_LATCHED], "", 1)]
    topics = [(f"/topic_{i}", "std_msgs/msg/String", "cdr" if i % 7 else "ros1",
               [QOS_VOLATILE if i % 3 else QOS_LATCHED], "RIHS01_abc" if i % 5 else "", i) for i in range(300)]
    info = bag_info(topics + odd, message_count=1, start_ns=0, end_ns=1)
    assert bag_metadata_yaml(info) == yaml_dump(info)
