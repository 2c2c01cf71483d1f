"""The ROS 1 source's walk through a bag's index: one chunk's index data records held at a time, in the file's
order of the chunks whatever order the index lists them in, and the same messages as rosbags' reader.

The bags are written here by rosbags' writer (an independent encoder); the index of some is then rewritten with its
chunk info records in reverse (a valid bag: the format does not order them)."""

from __future__ import annotations

import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.formats.test_readers import _assert_same
from tests.recording_helpers import _Messages, _typestore, recording_messages
from tfrec.formats import open_messages
from tfrec.formats.reader import read_pieces, read_recording
from tfrec.recording import Recording

Written = tuple[str, str, int, bytes]
"""(topic, type, log time, ROS 1 bytes) of a message written."""


def _write(path: Path, messages: list[Written], *, chunk_bytes: int) -> Path:
    """A ROS 1 bag of the messages, in the order given, written by rosbags in chunks of about ``chunk_bytes``."""
    from rosbags.rosbag1 import Writer

    store = _typestore(ros1=True)
    writer = Writer(path)
    writer.chunk_threshold = chunk_bytes
    with writer:
        connections: dict[str, Any] = {}
        for topic, msgtype, time_ns, data in messages:
            if topic not in connections:
                latching = 1 if topic in ("/robot_description", "/tf_static") else None
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store, latching=latching)
            writer.write(connections[topic], time_ns, data)
    return path


def _records(data: bytes, pos: int) -> list[tuple[int, bytes]]:
    """(op, whole record) of the records of a bag from byte ``pos`` to its end."""
    out = []
    while pos < len(data):
        header_len = int.from_bytes(data[pos : pos + 4], "little")
        header = data[pos + 4 : pos + 4 + header_len]
        data_len = int.from_bytes(data[pos + 4 + header_len : pos + 8 + header_len], "little")
        end = pos + 8 + header_len + data_len
        at = header.index(b"op=") + 3
        out.append((header[at], data[pos:end]))
        pos = end
    return out


def _reverse_chunk_infos(path: Path) -> None:
    """Rewrite a bag's index with its chunk info records (op 6) in reverse order."""
    data = path.read_bytes()
    at = data.index(b"index_pos=") + len(b"index_pos=")
    index_pos = int.from_bytes(data[at : at + 8], "little")
    records = _records(data, index_pos)
    infos = [record for op, record in records if op == 6]
    assert len(infos) >= 3 and [op for op, _ in records] == [7] * (len(records) - len(infos)) + [6] * len(infos)
    others = [record for op, record in records if op != 6]
    path.write_bytes(data[:index_pos] + b"".join(others) + b"".join(reversed(infos)))


def _chunk_order(path: Path) -> list[list[tuple[str, int]]]:
    """The messages of each chunk, (topic, log time), the chunks in the file's order: from rosbags' reader of the
    index."""
    from rosbags.rosbag1 import Reader

    with Reader(path) as reader:
        topics = {connection.id: connection.topic for connection in reader.connections}
        by_chunk: dict[int, list[tuple[str, int]]] = {info.pos: [] for info in reader.chunk_infos}
        for conn, entries in reader.indexes.items():
            for entry in entries:
                by_chunk[entry.chunk_pos].append((topics[conn], entry.time))
    return [sorted(by_chunk[pos]) for pos in sorted(by_chunk)]


def _shuffled_marm(tmp_path: Path, rec: Recording, *, reverse_index: bool) -> Path:
    """marm's messages written in a shuffled order (seeded), in chunks of ~2 kB: chunks that overlap in time and are
    not in time order."""
    store = _typestore(ros1=True)
    messages = [(topic, msgtype, time_ns, bytes(store.serialize_ros1(msg, msgtype)))
                for topic, msgtype, time_ns, msg in recording_messages(rec, _Messages(store, ros1=True))]
    order = np.random.default_rng(7).permutation(len(messages))
    path = _write(tmp_path / "shuffled.bag", [messages[k] for k in order.tolist()], chunk_bytes=2048)
    if reverse_index:
        _reverse_chunk_infos(path)
    return path


@pytest.mark.parametrize("reverse_index", [False, True])
def test_chunks_out_of_time_order_give_what_rosbags_reads(tmp_path: Path, marm_rec: Recording,
                                                          reverse_index: bool) -> None:
    """Every chunk, in the file's order, as one batch in time order; together the messages rosbags' AnyReader reads;
    the recording (whole and piece by piece) the one the messages were taken from."""
    from rosbags.highlevel import AnyReader

    path = _shuffled_marm(tmp_path, marm_rec, reverse_index=reverse_index)
    expected = _chunk_order(path)
    spans = [(min(t for _, t in chunk), max(t for _, t in chunk)) for chunk in expected]
    assert len(expected) > 20 and spans != sorted(spans), "chunks out of time order"
    batches: list[list[tuple[str, int, bytes]]] = []
    with open_messages(path) as source:
        for batch in source.batches():
            assert bool(np.all(np.diff(batch.log_time) >= 0))
            batches.append([(source.connections[int(batch.conn[k])].topic, int(batch.log_time[k]),
                             bytes(batch.data[k])) for k in range(len(batch))])
        assert source.read_error is None
    assert [sorted((topic, time_ns) for topic, time_ns, _ in batch) for batch in batches] == expected
    with AnyReader([path]) as reader:
        theirs = sorted((connection.topic, int(time_ns), bytes(raw)) for connection, time_ns, raw in reader.messages())
    assert sorted(message for batch in batches for message in batch) == theirs
    rec = read_recording(path)
    assert rec.read_error is None
    _assert_same(rec, marm_rec)
    pieces = list(read_pieces(path, messages=40))
    assert len(pieces) > 3 and pieces[-1][1]
    assert sum(len(piece.joint_states.time_ns) for piece, _ in pieces if piece.joint_states is not None) == len(
        marm_rec.joint_states.time_ns if marm_rec.joint_states is not None else [])


def _string_bag(path: Path, chunks: int, *, reverse_index: bool) -> Path:
    """A bag of ``chunks`` chunks of 200 small std_msgs/String messages each on two topics (1 ms apart), and one
    /robot_description message first."""
    messages: list[Written] = [("/robot_description", "std_msgs/msg/String", 10**9, b"\4\0\0\0<r/>")]
    for k in range(chunks * 200):
        data = f"{k:08d}".encode()
        messages.append((f"/t{k % 2}", "std_msgs/msg/String", 10**9 + k * 10**6, len(data).to_bytes(4, "little") + data))
    _write(path, messages, chunk_bytes=200 * 40)
    if reverse_index:
        _reverse_chunk_infos(path)
    return path


def _peak_of_walk(path: Path, topic: str) -> tuple[int, int]:
    """The peak of Python's allocations (tracemalloc, numpy's included) while the source walks the bag yielding one
    topic's messages, and the messages counted."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        with open_messages(path) as source:
            for _ in source.batches(lambda connection: connection.topic == topic):
                pass
            counted = sum(stats.count for stats in source.stats.values())
        return tracemalloc.get_traced_memory()[1], counted
    finally:
        tracemalloc.stop()


@pytest.fixture(scope="module")
def string_bags(tmp_path_factory: pytest.TempPathFactory) -> dict[bool, tuple[Path, Path]]:
    """A bag of 100 chunks and one of 400 (:func:`_string_bag`), each with its index as written (False) and with its
    chunk info records reversed (True)."""
    folder = tmp_path_factory.mktemp("string-bags")
    return {reverse: (_string_bag(folder / f"small-{reverse}.bag", 100, reverse_index=reverse),
                      _string_bag(folder / f"large-{reverse}.bag", 400, reverse_index=reverse))
            for reverse in (False, True)}


@pytest.mark.parametrize("reverse_index", [False, True])
@pytest.mark.parametrize("topic", ["/robot_description", "/t1"])
def test_the_walk_holds_one_chunks_index_data_at_a_time(string_bags: dict[bool, tuple[Path, Path]],
                                                        reverse_index: bool, topic: str) -> None:
    """The peak memory of a walk does not grow with the bag: 4 times the chunks (60,000 messages more, whose index
    data entries alone are 720 kB; reading the index whole, the peak grew by 1.2 MB) add less than 24 bytes a chunk
    (the order of the chunks while the index is read, and the order held for an index that lists them out of
    order; measured: 52 bytes in all, and 8 bytes a chunk)."""
    from rosbags.rosbag1 import Reader

    small, large = string_bags[reverse_index]
    with Reader(small) as reader_small, Reader(large) as reader_large:
        chunks = len(reader_small.chunk_infos), len(reader_large.chunk_infos)
    assert chunks[0] >= 90 and chunks[1] >= 4 * chunks[0] - 10
    _peak_of_walk(small, topic)  # what is imported or cached once
    peak_small, counted_small = _peak_of_walk(small, topic)
    peak_large, counted_large = _peak_of_walk(large, topic)
    assert (counted_small, counted_large) == (20_001, 80_001)
    assert peak_large - peak_small < 24 * (chunks[1] - chunks[0]), (peak_small, peak_large)


@pytest.mark.parametrize("damage", ["offset", "chunk_pos"])
def test_an_index_that_stops_describing_a_chunk_midway(tmp_path: Path, marm_rec: Recording, damage: str) -> None:
    """An index data record of a chunk in the middle that points past its chunk: the chunks before it are read
    through the index, it and those after record by record. A chunk info record that points to no chunk is found
    before the walk: the whole bag record by record. The same recording either way, with one warning."""
    from tests.formats.test_readers import _index_data_records
    from tfrec.errors import TfrecWarning

    store = _typestore(ros1=True)
    path = _write(tmp_path / "in.bag", [(topic, msgtype, time_ns, bytes(store.serialize_ros1(msg, msgtype)))
                                        for topic, msgtype, time_ns, msg in recording_messages(
                                            marm_rec, _Messages(store, ros1=True))], chunk_bytes=2048)
    data = bytearray(path.read_bytes())
    if damage == "offset":
        entries = _index_data_records(bytes(data))
        at = entries[len(entries) // 2] + 8  # its first entry's offset
        data[at : at + 4] = (10**6).to_bytes(4, "little")
        reason = "an index data record points past its chunk; the bag was read record by record"
    else:
        at = data.index(b"index_pos=") + len(b"index_pos=")
        infos = [record for op, record in _records(bytes(data), int.from_bytes(data[at : at + 8], "little"))
                 if op == 6]
        middle = data.index(infos[len(infos) // 2]) + infos[len(infos) // 2].index(b"chunk_pos=") + len(b"chunk_pos=")
        chunk_pos = int.from_bytes(data[middle : middle + 8], "little")
        data[middle : middle + 8] = (chunk_pos + 4).to_bytes(8, "little")
        reason = f"a damaged record header at byte {chunk_pos + 4:,} .*; the bag was read record by record"
    path.write_bytes(bytes(data))
    with pytest.warns(TfrecWarning, match=reason) as warned:
        rec = read_recording(path)
    assert len(warned) == 1 and rec.read_error is None
    _assert_same(rec, marm_rec)


def test_a_message_record_without_its_time_in_a_chunk_read_record_by_record(tmp_path: Path,
                                                                            marm_rec: Recording) -> None:
    """A message record whose time field is damaged (renamed), in a chunk the index cannot describe then: the
    chunk's records before it are kept, the rest of it skipped and said (an IndexError traceback before: its
    connection was taken, not its time)."""
    store = _typestore(ros1=True)
    messages = [(topic, msgtype, time_ns, bytes(store.serialize_ros1(msg, msgtype)))
                for topic, msgtype, time_ns, msg in recording_messages(marm_rec, _Messages(store, ros1=True))]
    path = _write(tmp_path / "in.bag", messages, chunk_bytes=4096)
    data = bytearray(path.read_bytes())
    field = (len(b"time=") + 8).to_bytes(4, "little") + b"time="
    found = [k + 4 for k in range(len(data)) if data.startswith(field, k)]
    at = found[len(found) // 2]  # a message record's, in a chunk in the middle
    data[at : at + 5] = b"tima="
    path.write_bytes(bytes(data))
    rec = read_recording(path)
    assert rec.read_error is not None and "no 8-byte 'time' field" in rec.read_error, rec.read_error
    assert rec.joint_states is not None and marm_rec.joint_states is not None
    lost = len(marm_rec.joint_states.time_ns) - len(rec.joint_states.time_ns)
    assert 0 <= lost < 10 and rec.topics["/tf"].count < marm_rec.topics["/tf"].count
