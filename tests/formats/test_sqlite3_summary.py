"""``tfrec info`` of a sqlite3 bag: the first messages a summary decodes are read, the rest counted with SQL
(COUNT, MIN and MAX of the timestamps per topic) — and a topic read whole (/tf_static) is read on only when the
counts say it has rows left (published again late in the bag); the count reads the pages rather than mapping the whole file.
The summary equals what reading every row gives, and rosbags' reader's counts."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pytest

from tests.recording_helpers import _Messages, _typestore, write_rosbag2
from tfrec._yaml import load_yaml, yaml_dump
from tfrec.formats.rosbag2 import source as sqlite3_source
from tfrec.info import summarize
from tfrec.recording import Recording


def _rosbags_counts(bag: Path) -> dict[str, tuple[int, int, int]]:
    """Topic → (messages, first and last log time), as rosbags' AnyReader reads the bag."""
    from rosbags.highlevel import AnyReader

    times: dict[str, list[int]] = {}
    with AnyReader([bag]) as reader:
        for connection, time_ns, _ in reader.messages():
            times.setdefault(connection.topic, []).append(int(time_ns))
    return {topic: (len(t), min(t), max(t)) for topic, t in times.items()}


def _late_tf_static(bag: Path, time_ns: int) -> None:
    """Append a /tf_static message at ``time_ns`` naming a frame pair of its own (world → late_frame)."""
    store = _typestore(ros1=False)
    message = _Messages(store, ros1=False).tf([(("world", "late_frame"), time_ns, np.zeros(3), np.array([0, 0, 0, 1.0]))])
    (db3,) = bag.glob("*.db3")
    with sqlite3.connect(db3) as db:
        (topic_id,) = db.execute("SELECT id FROM topics WHERE name = '/tf_static'").fetchone()
        db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                   (topic_id, time_ns, bytes(store.serialize_cdr(message, "tf2_msgs/msg/TFMessage"))))
    db.close()


@pytest.mark.parametrize("late", [False, True])
def test_the_summary_counts_with_sql_and_reads_only_what_is_left(late: bool, tmp_path: Path, marm_rec: Recording,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    bag = write_rosbag2(marm_rec, tmp_path / "bag", storage="sqlite3")
    assert marm_rec.end_ns is not None
    if late:
        _late_tf_static(bag, marm_rec.end_ns)
        meta = load_yaml((bag / "metadata.yaml").read_text(), where="metadata.yaml")
        info = meta["rosbag2_bagfile_information"]
        for counted in (info, *info["files"], *(t for t in info["topics_with_message_count"]
                                               if t["topic_metadata"]["name"] == "/tf_static")):
            counted["message_count"] += 1
        (bag / "metadata.yaml").write_text(yaml_dump(meta))
    monkeypatch.setattr(sqlite3_source, "BATCH_MESSAGES", 16)  # the summary's first messages end in the first rows
    statements: list[str] = []
    connect = sqlite3_source.connect_read_only

    def traced(file: Path) -> sqlite3.Connection:
        db = connect(file)
        db.set_trace_callback(statements.append)
        return db

    monkeypatch.setattr(sqlite3_source, "connect_read_only", traced)
    summary = summarize(bag)
    counted = [s for s in statements if "COUNT(*)" in s]
    assert len(counted) == 1 and "mmap_size = 0" in " ".join(statements)
    (rest,) = [s for s in statements if s.startswith("SELECT topic_id, timestamp, data FROM")]  # /tf's next rows
    read_after = {int(i) for i in rest.rsplit("topic_id IN (", 1)[1].split(")")[0].split(", ")}
    with sqlite3.connect(next(bag.glob("*.db3"))) as db:
        ids = dict(db.execute("SELECT name, id FROM topics").fetchall())
    db.close()
    assert read_after == {ids["/tf"], *([ids["/tf_static"]] if late else [])}  # /tf_static only when rows are left
    expected = _rosbags_counts(bag)
    assert {t["name"]: t["count"] for t in summary["topics"]} == {topic: c for topic, (c, _, _) in expected.items()}
    assert summary["start_time_ns"] == min(first for _, first, _ in expected.values())
    assert summary["end_time_ns"] == max(last for _, _, last in expected.values())
    frames = {(f["parent"], f["child"]) for f in summary["tf_frames"] if f["static"]}
    assert (("world", "late_frame") in frames) == late
    monkeypatch.setattr(sqlite3_source, "BATCH_MESSAGES", 1 << 20)  # every row counted as it is read
    assert summarize(bag) == summary
