"""The one walk over MCAP records (``iter_records``) against mcap's own reader and tfrec's inlined reader loop."""

from __future__ import annotations

import struct
from collections import Counter
from pathlib import Path

import pytest
from mcap.reader import make_reader

from tfrec.formats import read_recording
from tfrec.formats._compression import decompress
from tfrec.formats.mcap.records import COMPRESSIONS, MESSAGE, MESSAGE_HEAD_SIZE, OP_MESSAGE, RECORD, iter_records
from tfrec.formats.mcap.summary import chunk_fields, read_summary

GOLDEN = Path(__file__).parents[1] / "golden"


def _walk(path: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time, data) of every message, chunk by chunk through the chunk indexes."""
    out = []
    with open(path, "rb") as stream:
        size = path.stat().st_size
        summary = read_summary(stream, size)
        assert summary is not None
        for index in summary.chunk_indexes:
            stream.seek(index.offset)
            _, length = RECORD.unpack(stream.read(RECORD.size))
            head = chunk_fields(stream.read(length))
            records = memoryview(decompress(head.compression, head.records, head.size, supported=COMPRESSIONS))
            for opcode, pos, body in iter_records(records):
                if opcode == OP_MESSAGE:
                    channel_id, _, log_time = MESSAGE.unpack_from(records, pos)
                    data = bytes(records[pos + MESSAGE_HEAD_SIZE : pos + body])
                    out.append((summary.channels[channel_id].topic, log_time, data))
    return out


@pytest.mark.parametrize("name", ["mbot-sine-2s.mcap", "marm-random-2s.mcap"])
def test_iter_records_takes_what_mcap_reads(name: str) -> None:
    path = GOLDEN / name
    walked = _walk(path)
    with open(path, "rb") as stream:
        theirs = [(channel.topic, message.log_time, bytes(message.data))
                  for _, channel, message in make_reader(stream).iter_messages(log_time_order=False)]
    assert walked == theirs


@pytest.mark.parametrize("name", ["mbot-sine-2s.mcap", "marm-random-2s.mcap"])
def test_the_inlined_reader_loop_counts_what_iter_records_walks(name: str) -> None:
    walked = _walk(GOLDEN / name)
    recording = read_recording(GOLDEN / name)
    counts = Counter(topic for topic, _, _ in walked)
    assert {topic: info.count for topic, info in recording.topics.items()} == dict(counts)
    for topic, info in recording.topics.items():
        times = [t for name_, t, _ in walked if name_ == topic]
        assert (info.first_ns, info.last_ns) == (min(times), max(times))


def test_iter_records_strict_and_lenient_on_a_cut_view() -> None:
    records = RECORD.pack(OP_MESSAGE, 3) + b"abc" + RECORD.pack(OP_MESSAGE, 10) + b"short"
    assert list(iter_records(memoryview(records), strict=False)) == [(OP_MESSAGE, 9, 3)]
    with pytest.raises(ValueError, match="runs past the end"):
        list(iter_records(memoryview(records)))
    with pytest.raises(ValueError, match="header runs past the end"):
        list(iter_records(memoryview(records[:12] + b"\x05\x00")))
    assert struct.calcsize("<BQ") == RECORD.size
