"""Issue 22, item 4: bags others write — a rosbag2 .db3 given without its metadata.yaml, a ROS 1 bag whose header
record is damaged, an MCAP with attachments and metadata records converted. Each input is built here; rosbags and
the mcap library read the results independently."""

from __future__ import annotations

import shutil
import struct
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.recording_helpers import write_rosbag1, write_rosbag2
from tfrec import cli
from tfrec.convert import convert
from tfrec.formats.reader import read_recording
from tfrec.recording import Recording

CALIBRATION = b"camera_matrix: [600.0, 0.0, 320.0, 0.0, 600.0, 240.0, 0.0, 0.0, 1.0]\n"
BIG = bytes(range(256)) * 12_000  # 3 MB: copied in pieces


def _same_recording(a: Recording, b: Recording) -> None:
    assert a.topics.keys() == b.topics.keys()
    assert {t: s.count for t, s in a.topics.items()} == {t: s.count for t, s in b.topics.items()}
    assert a.tf.keys() == b.tf.keys()
    for pair, series in a.tf.items():
        np.testing.assert_array_equal(series.time_ns, b.tf[pair].time_ns)
        np.testing.assert_array_equal(series.translation, b.tf[pair].translation)
    assert a.joint_states is not None and b.joint_states is not None
    np.testing.assert_array_equal(a.joint_states.positions, b.joint_states.positions)


# -- a .db3 on its own -------------------------------------------------------------------------------------------


def test_a_db3_without_its_metadata_yaml_is_read_with_a_warning(tmp_path: Path, marm_rec: Recording,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """rosbags (`Reader(path.db3)`) and `ros2 bag info path.db3` read a database on its own; tfrec said "not a
    recording"."""
    bag = write_rosbag2(marm_rec, tmp_path / "bag", storage="sqlite3")
    (db3,) = bag.glob("*.db3")
    alone = tmp_path / "elsewhere" / "copied.db3"
    alone.parent.mkdir()
    shutil.copy(db3, alone)
    with pytest.warns(UserWarning, match=r"copied\.db3: no metadata\.yaml beside it: read as a rosbag2 database on its "
                                         r"own \(as rosbags and `ros2 bag` read it\)"):
        lone = read_recording(alone)
    _same_recording(lone, read_recording(bag))
    from rosbags.rosbag2 import Reader

    with Reader(alone) as reader:  # the independent reader agrees on what is in it
        assert reader.message_count == sum(s.count for s in lone.topics.values())
    assert cli.main(["info", str(alone)]) == 0
    out, err = capsys.readouterr()
    assert "/joint_states" in out and "no metadata.yaml beside it" in err
    with pytest.warns(UserWarning, match="no metadata.yaml beside it"):
        result = convert(alone, tmp_path / "out.mcap")
    assert result.report is not None and result.report.messages == lone_messages(lone)


def lone_messages(rec: Recording) -> int:
    return sum(s.count for s in rec.topics.values())


def test_a_sqlite_file_that_is_no_db3_is_still_not_a_recording(tmp_path: Path) -> None:
    import sqlite3

    other = tmp_path / "notes.sqlite"
    with sqlite3.connect(other) as db:
        db.execute("CREATE TABLE notes (text TEXT)")
    db.close()
    assert cli.main(["info", str(other)]) == 2


# -- ROS 1 bags with a damaged header record ----------------------------------------------------------------------


def _header_length_at(data: bytes) -> int:
    """Where the bag header record's data (padding) length lies."""
    return 13 + 4 + struct.unpack_from("<I", data, 13)[0]


@pytest.mark.parametrize("writer", ["tfrec", "rosbags"])
@pytest.mark.parametrize("padding", [0xFFFF_FFFF, 0, 100])
def test_a_ros1_bag_with_a_damaged_header_padding_is_read_through_its_index(
        tmp_path: Path, marm_rec: Recording, marm_mcap: Path, writer: str, padding: int) -> None:
    """rosbags reads such a bag (it never looks at the padding); tfrec refused it ("the file ends inside a bag header
    record")."""
    if writer == "tfrec":
        bag = tmp_path / "marm.bag"
        convert(marm_mcap, bag)
    else:
        bag = write_rosbag1(marm_rec, tmp_path / "marm.bag")
    intact = read_recording(bag)
    data = bytearray(bag.read_bytes())
    struct.pack_into("<I", data, _header_length_at(bytes(data)), padding)
    damaged = tmp_path / "damaged.bag"
    damaged.write_bytes(bytes(data))
    from rosbags.rosbag1 import Reader

    with Reader(damaged) as reader:
        assert sum(1 for _ in reader.messages()) == lone_messages(intact)
    with pytest.warns(UserWarning, match=rf"damaged\.bag: a damaged bag header record \(its padding is {padding:,} "
                                         r"bytes long\); read through its index, as rosbags reads it$"):
        rec = read_recording(damaged)
    _same_recording(rec, intact)
    assert rec.read_error is None
    with pytest.warns(UserWarning, match="a damaged bag header record"):
        result = convert(damaged, tmp_path / "out.mcap")
    assert result.report is not None and result.report.messages == lone_messages(intact)


@pytest.mark.parametrize("damage", ["fields", "length", "op", "zeros"])
def test_a_ros1_bag_whose_header_record_is_destroyed_is_read_record_by_record(
        tmp_path: Path, marm_mcap: Path, damage: str) -> None:
    """No index position without the header's fields: the records after it, where rosbag puts them, are read."""
    bag = tmp_path / "marm.bag"
    convert(marm_mcap, bag)
    intact = read_recording(bag)
    data = bytearray(bag.read_bytes())
    size = struct.unpack_from("<I", data, 13)[0]
    if damage == "fields":
        data[17 : 17 + size] = b"\xff" * size
    elif damage == "length":
        struct.pack_into("<I", data, 13, 0x0FFF_FFFF)
    elif damage == "op":
        at = bytes(data).index(b"op=\x03")
        data[at + 3] = 9
    else:
        data[13 : 13 + 4104] = bytes(4104)
    damaged = tmp_path / "damaged.bag"
    damaged.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match=r"damaged\.bag: a damaged bag header record .*; the bag was read record by "
                                         r"record$"):
        rec = read_recording(damaged)
    _same_recording(rec, intact)
    assert rec.read_error is None


def test_a_bag_header_counting_fewer_chunks_than_its_index_holds_is_read_whole(tmp_path: Path,
                                                                                marm_mcap: Path) -> None:
    """rosbags reads 0 messages of it (the header says 0 chunks); the index's chunk info records say otherwise."""
    bag = tmp_path / "marm.bag"
    convert(marm_mcap, bag)
    data = bytearray(bag.read_bytes())
    at = bytes(data).index(b"chunk_count=") + len(b"chunk_count=")
    data[at : at + 4] = bytes(4)
    damaged = tmp_path / "damaged.bag"
    damaged.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match="the index goes on past the records the bag header counts"):
        rec = read_recording(damaged)
    assert lone_messages(rec) == lone_messages(read_recording(bag))


# -- attachments and metadata records -----------------------------------------------------------------------------


def _with_extras(source: Path, target: Path, *, bad_crc: bool = False) -> Path:
    """``source`` (an MCAP) rewritten by the mcap library with two attachments and a metadata record."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(source, "rb") as stream, open(target, "wb") as out:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None
        writer = Writer(out)
        writer.start(profile="ros2", library="someone else's recorder")
        for schema in summary.schemas.values():
            writer.register_schema(schema.name, schema.encoding, schema.data)
        for channel in summary.channels.values():
            writer.register_channel(channel.topic, channel.message_encoding, channel.schema_id, channel.metadata)
        writer.add_attachment(create_time=5, log_time=7, name="calibration.yaml", media_type="application/yaml",
                              data=CALIBRATION)
        for _, channel, message in reader.iter_messages():
            writer.add_message(channel.id, message.log_time, message.data, message.publish_time, message.sequence)
        writer.add_metadata("robot_info", {"serial": "A123", "site": "lab 4"})
        writer.add_attachment(create_time=6, log_time=8, name="weights.bin", media_type="application/octet-stream",
                              data=BIG)
        writer.finish()
    if bad_crc:
        data = bytearray(target.read_bytes())
        at = bytes(data).index(CALIBRATION)
        data[at] ^= 0xFF  # the calibration's bytes no longer match its CRC
        target.write_bytes(bytes(data))
    return target


def _extras(path: Path) -> tuple[list[tuple[str, str, int, int, bytes]], list[tuple[str, dict[str, str]]], Any]:
    from mcap.reader import make_reader

    with open(path, "rb") as stream:
        reader = make_reader(stream)
        attachments = [(a.name, a.media_type, a.log_time, a.create_time, a.data) for a in reader.iter_attachments()]
        metadata = [(m.name, m.metadata) for m in reader.iter_metadata() if m.name != "rosbag2"]
        return attachments, metadata, reader.get_summary()


@pytest.mark.parametrize("kind", ["mcap", "rosbag2"])
def test_convert_copies_attachments_and_metadata_to_an_mcap(tmp_path: Path, marm_mcap: Path, kind: str) -> None:
    """A calibration attachment in a real bag was lost without a word."""
    source = _with_extras(marm_mcap, tmp_path / "with_extras.mcap")
    target = tmp_path / ("out.mcap" if kind == "mcap" else "out_bag")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = convert(source, target) if kind == "mcap" else convert(source, bag=target)
    assert result.report is not None
    assert result.report.extras == ["attachment 'calibration.yaml'", "metadata record 'robot_info'",
                                    "attachment 'weights.bin'"]
    written = target if kind == "mcap" else next(target.glob("*.mcap"))
    attachments, metadata, summary = _extras(written)
    assert attachments == [("calibration.yaml", "application/yaml", 7, 5, CALIBRATION),
                           ("weights.bin", "application/octet-stream", 8, 6, BIG)]
    assert metadata == [("robot_info", {"serial": "A123", "site": "lab 4"})]
    assert summary.statistics.attachment_count == 2 and summary.statistics.metadata_count == 2  # and rosbag2's
    assert [i.name for i in summary.attachment_indexes] == ["calibration.yaml", "weights.bin"]
    assert sorted(i.name for i in summary.metadata_indexes) == ["robot_info", "rosbag2"]
    from rosbags.highlevel import AnyReader

    with AnyReader([target]) as reader:  # the messages are all there, in a file rosbags reads
        assert reader.message_count == result.report.messages
    again = tmp_path / ("again.mcap" if kind == "mcap" else "again_bag")
    convert(source, again) if kind == "mcap" else convert(source, bag=again)
    assert (again if kind == "mcap" else next(again.glob("*.mcap"))).read_bytes() == written.read_bytes()


def test_a_cut_keeps_the_attachments(tmp_path: Path, marm_mcap: Path) -> None:
    source = _with_extras(marm_mcap, tmp_path / "with_extras.mcap")
    convert(source, tmp_path / "cut.mcap", start_s=1.0)
    attachments, metadata, _ = _extras(tmp_path / "cut.mcap")
    assert [a[0] for a in attachments] == ["calibration.yaml", "weights.bin"] and len(metadata) == 1


@pytest.mark.parametrize("suffix, holder", [(".bag", "a ROS 1 bag"), (".rrd", "a Rerun recording of the replay")])
def test_an_output_that_cannot_hold_them_names_what_was_left_out(tmp_path: Path, marm_mcap: Path, suffix: str,
                                                                 holder: str) -> None:
    source = _with_extras(marm_mcap, tmp_path / "with_extras.mcap")
    with pytest.warns(UserWarning) as record:
        convert(source, tmp_path / f"out{suffix}")
    messages = [str(w.message) for w in record if "not written" in str(w.message)]
    assert len(messages) == 1
    assert messages[0].startswith(f"{source}: ")
    assert all(name in messages[0] for name in ("attachment 'calibration.yaml'", "attachment 'weights.bin'",
                                                "metadata record 'robot_info'"))
    assert messages[0].endswith(f"not written: {holder} holds no attachments or metadata records"
                                if suffix == ".rrd" else f"not written: {holder} cannot hold attachments or metadata "
                                "records")


def test_an_attachment_whose_crc_fails_is_left_out_with_a_warning(tmp_path: Path, marm_mcap: Path) -> None:
    source = _with_extras(marm_mcap, tmp_path / "with_extras.mcap", bad_crc=True)
    with pytest.warns(UserWarning, match=r"with_extras\.mcap: attachment 'calibration\.yaml' not written: its CRC "
                                         r"fails$"):
        convert(source, tmp_path / "out.mcap")
    attachments, metadata, summary = _extras(tmp_path / "out.mcap")
    assert [a[0] for a in attachments] == ["weights.bin"] and len(metadata) == 1
    assert summary.statistics.attachment_count == 1 and len(summary.attachment_indexes) == 1


def test_a_recording_of_tfrec_has_no_extras_to_warn_of(tmp_path: Path, marm_mcap: Path) -> None:
    """Its own rosbag2 metadata record is written anew, not copied nor reported."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = convert(marm_mcap, tmp_path / "out.bag")
    assert result.report is not None and result.report.extras == [] and result.report.extras_left_out == []


def test_a_damaged_attachment_record_is_left_out_and_the_messages_after_it_are_copied(tmp_path: Path,
                                                                                         marm_mcap: Path) -> None:
    """An attachment whose name runs past its record: left out with a warning; the walk goes on after it (the
    record's length frames it)."""
    source = _with_extras(marm_mcap, tmp_path / "with_extras.mcap")
    data = bytearray(source.read_bytes())
    name = data.index(b"calibration.yaml")
    struct.pack_into("<I", data, name - 4, 0x7FFF_FFFF)  # the name's length: past the record
    source.write_bytes(bytes(data))
    expected = lone_messages(read_recording(marm_mcap))
    with pytest.warns(UserWarning, match=r"with_extras\.mcap: a damaged attachment record at byte [\d,]+ \(a name runs "
                                         r"past the record\): left out$"):
        result = convert(source, tmp_path / "out.mcap")
    assert result.report is not None and result.report.messages == expected
    attachments, metadata, _ = _extras(tmp_path / "out.mcap")
    assert [a[0] for a in attachments] == ["weights.bin"] and len(metadata) == 1
