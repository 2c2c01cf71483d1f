"""One source per format (tfrec.formats.open_messages): the connections asked for, in time-ordered batches; the
others counted from the index without being read; what a damaged database holds skipped, never a traceback.

Each recording is written here — by tfrec, or by rosbags' writers (an independent encoder) — and read back by
rosbags' AnyReader, the independent reader the sources are compared with."""

from __future__ import annotations

import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.formats.test_readers import _ros1_bag
from tests.recording_helpers import write_rosbag1, write_rosbag2
from tfrec import cli
from tfrec.formats import open_messages
from tfrec.formats.reader import read_recording
from tfrec.formats.ros.connection import Connection
from tfrec.recording import Recording

KINDS = ["mcap", "ros1", "rosbag2-mcap", "rosbag2-sqlite3"]


def _recording(kind: str, tmp_path: Path, marm_mcap: Path, marm_rec: Recording) -> Path:
    """marm's recording in one of the formats: tfrec's MCAP as it is, the others written by rosbags."""
    if kind == "mcap":
        return marm_mcap
    if kind == "ros1":
        return write_rosbag1(marm_rec, tmp_path / "marm.bag")
    return write_rosbag2(marm_rec, tmp_path / "bag", storage=kind.removeprefix("rosbag2-"))


def _rosbags_messages(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    """Every message by topic, (log time, raw bytes), in time order, as rosbags' AnyReader reads them."""
    from rosbags.highlevel import AnyReader

    out: dict[str, list[tuple[int, bytes]]] = {}
    with AnyReader([path]) as reader:
        for connection, time_ns, raw in reader.messages():
            out.setdefault(connection.topic, []).append((int(time_ns), bytes(raw)))
    return out


def _read(path: Path, wanted: Callable[[Connection], bool]) -> tuple[dict[str, list[tuple[int, bytes]]], Any]:
    """The messages the source yields, by topic, and the source (after its walk)."""
    got: dict[str, list[tuple[int, bytes]]] = {}
    with open_messages(path) as source:
        for batch in source.batches(wanted):
            assert len(batch) and bool(np.all(np.diff(batch.log_time) >= 0)), "a batch is in log-time order"
            for k in range(len(batch)):
                topic = source.connections[int(batch.conn[k])].topic
                got.setdefault(topic, []).append((int(batch.log_time[k]), bytes(batch.data[k])))
    return got, source


@pytest.mark.parametrize("kind", KINDS)
def test_only_the_connections_asked_for_are_yielded_and_every_one_is_counted(
        kind: str, tmp_path: Path, marm_mcap: Path, marm_rec: Recording) -> None:
    path = _recording(kind, tmp_path, marm_mcap, marm_rec)
    expected = _rosbags_messages(path)
    got, source = _read(path, lambda connection: connection.topic in ("/tf", "/tf_static"))
    assert sorted(got) == ["/tf", "/tf_static"]
    for topic in got:  # the same bytes at the same times as the independent reader's
        assert sorted(got[topic]) == sorted(expected[topic]), topic
    counted = {}
    for conn, stats in source.stats.items():
        counted[source.connections[conn].topic] = counted.get(source.connections[conn].topic, 0) + stats.count
    assert counted == {topic: len(messages) for topic, messages in expected.items()}
    assert source.messages == len(got["/tf"]) + len(got["/tf_static"]) and source.read_error is None


@pytest.mark.parametrize("kind", KINDS)
def test_every_connection_is_yielded_without_a_filter(kind: str, tmp_path: Path, marm_mcap: Path,
                                                      marm_rec: Recording) -> None:
    path = _recording(kind, tmp_path, marm_mcap, marm_rec)
    got, _ = _read(path, lambda connection: True)
    assert {topic: sorted(messages) for topic, messages in got.items()} == {
        topic: sorted(messages) for topic, messages in _rosbags_messages(path).items()}


def _chunks(path: Path) -> int:
    """How many chunks a file has, as mcap's reader and rosbags' ROS 1 reader say."""
    if path.suffix == ".mcap":
        from mcap.reader import make_reader

        with open(path, "rb") as stream:
            summary = make_reader(stream).get_summary()
        assert summary is not None
        return len(summary.chunk_indexes)
    from rosbags.rosbag1 import Reader

    with Reader(path) as reader:
        return len(reader.chunk_infos)


@pytest.mark.parametrize("kind", ["mcap", "ros1"])
def test_chunks_of_nothing_asked_for_are_not_decompressed(kind: str, tmp_path: Path, marm_rec: Recording,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """/robot_description lies in the first chunk: the other chunks are counted from their index, not read."""
    from tfrec.formats._compression import decompress
    from tfrec.formats.mcap import source as mcap_source
    from tfrec.formats.rosbag1 import index as ros1_index

    if kind == "mcap":
        path = tmp_path / "small.mcap"
        assert cli.main(["record", "robots/marm.xacro", "-o", str(path), "--no-rrd", "--duration", "60"]) == 0
        module: Any = mcap_source
    else:
        path = _ros1_bag(tmp_path / "small.bag", marm_rec, compression="lz4", chunk_bytes=4096)
        module = ros1_index
    calls: list[int] = []

    def counted(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return decompress(*args, **kwargs)

    assert _chunks(path) >= 3
    monkeypatch.setattr(module, "decompress", counted)
    got, source = _read(path, lambda connection: connection.topic == "/robot_description")
    assert len(got["/robot_description"]) == 1 and len(calls) == 1
    total = sum(stats.count for stats in source.stats.values())
    assert total == sum(len(messages) for messages in _rosbags_messages(path).values()) > 200


@pytest.mark.parametrize("kind", ["mcap", "ros1"])
def test_a_connection_done_leaves_the_chunks_after_unread(kind: str, tmp_path: Path, marm_rec: Recording) -> None:
    """What a summary does: the first batch of /tf is all it wants; the rest is counted from the index."""
    if kind == "mcap":
        path = tmp_path / "long.mcap"
        assert cli.main(["record", "robots/marm.xacro", "-o", str(path), "--no-rrd", "--duration", "120"]) == 0
    else:
        path = _ros1_bag(tmp_path / "long.bag", marm_rec, compression="none", chunk_bytes=4096)
    assert _chunks(path) >= 3
    batches = 0
    with open_messages(path) as source:
        for batch in source.batches(lambda connection: connection.topic == "/tf"):
            batches += 1
            for conn in set(batch.conn.tolist()):
                source.done(conn)
        tf = [stats.count for conn, stats in source.stats.items() if source.connections[conn].topic == "/tf"]
    assert batches == 1 and tf == [len(_rosbags_messages(path)["/tf"])]


def test_latching_is_a_connections_own(tmp_path: Path, marm_mcap: Path) -> None:
    """/robot_description and /tf_static are latched (transient_local, latching=1) in tfrec's MCAP and ROS 1 bag."""
    bag = tmp_path / "marm.bag"
    assert cli.main(["convert", str(marm_mcap), str(bag)]) == 0
    for path in (marm_mcap, bag):
        with open_messages(path) as source:
            for _ in source.batches(lambda connection: False):
                pass
            latched = {c.topic for c in source.connections.values() if c.latched}
        assert latched == {"/robot_description", "/tf_static"}, path


@pytest.mark.parametrize("value", ["NULL", "'text'", "42"])
def test_a_row_whose_data_is_no_blob_is_skipped(value: str, tmp_path: Path, marm_rec: Recording,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """A messages table made without rosbag2's NOT NULL (any value goes in a column then): such a row ended every
    command with a TypeError traceback; it is damaged data, skipped, and metadata.yaml's count differs."""
    bag = write_rosbag2(marm_rec, tmp_path / "bag", storage="sqlite3")
    (db3,) = bag.glob("*.db3")
    with sqlite3.connect(db3) as db:
        db.execute("ALTER TABLE messages RENAME TO rows")
        db.execute("CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
                   "timestamp INTEGER NOT NULL, data BLOB)")
        db.execute("INSERT INTO messages SELECT * FROM rows")
        db.execute("DROP TABLE rows")
        (topic_id,) = db.execute("SELECT id FROM topics WHERE name = '/joint_states'").fetchone()
        db.execute(f"UPDATE messages SET data = {value} WHERE id = (SELECT max(id) FROM messages WHERE topic_id = ?)",
                   (topic_id,))
    db.close()
    with pytest.warns(UserWarning, match=r"message counts differ from metadata\.yaml: /joint_states: 100 read, "
                                         r"101 in metadata\.yaml"):
        rec = read_recording(bag)
    assert rec.joint_states is not None and len(rec.joint_states) == 100 and rec.read_error is None
    for argv in (["info", str(bag)], ["replay", "--check", str(bag)], ["convert", str(bag), str(tmp_path / "o.mcap")]):
        assert cli.main(argv) == 0, argv
        assert "message counts differ from metadata.yaml" in capsys.readouterr().err
