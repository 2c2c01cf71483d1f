"""Hostile and damaged recordings through the command line (issue 11), end to end: chunk bombs in an MCAP, a
rosbag2 folder and a ROS 1 bag, YAML bombs in a rosbag2 metadata.yaml, and the defects the fuzz suite
(tests/fuzz) found — each built here, each one line or a result, in bounded time and memory.

The bombs run in a process of their own under ``RLIMIT_AS`` = 1 GiB (:func:`tests.fuzz.harness.run_tfrec`), so that
a reader that inflates them fails the test with a MemoryError instead of taking the machine down.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shutil
import struct
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.conftest import ROBOTS
from tests.formats.test_decompress_limits import GiB, bz2_bomb, zstd_bomb
from tests.fuzz.harness import Outcome, contract_violations, run_tfrec
from tfrec.cli import main

MARM = str(ROBOTS / "marm.xacro")


def tfrec(*argv: str) -> tuple[int, str, str]:
    """``tfrec argv`` in-process: (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


def bounded(argv: list[str], cwd: Path, *, codes: tuple[int, ...] = (0,)) -> Outcome:
    """``tfrec argv`` in its own process under RLIMIT_AS = 1 GiB and RLIMIT_CPU: it keeps the contract (exit code in
    ``codes`` or 2 with one error line, no traceback, no MemoryError, at most 30 s of CPU time)."""
    outcome = run_tfrec(argv, cwd=cwd, isolated=True)
    problems = contract_violations(outcome, codes=codes)
    assert not problems, f"{problems[0]}\n{outcome.stderr[-3000:]}"
    return outcome


@contextlib.contextmanager
def first_chunk_replaced(module: object, name: str, bomb: bytes) -> Iterator[None]:
    """While recording, ``module.name(compression)`` (tfrec's chunk compressor factory) gives the bomb instead of
    the first chunk's compressed records; the chunk still declares the size of its real records."""
    original: Callable[[str], object] = getattr(module, name)

    def factory(compression: str) -> object:
        made = original(compression)
        real = made[1] if isinstance(made, tuple) else made
        calls = [0]

        def compress(data: bytes) -> bytes:
            calls[0] += 1
            return bomb if calls[0] == 1 else real(data)  # type: ignore[operator]

        return (made[0], compress) if isinstance(made, tuple) else compress

    setattr(module, name, factory)
    try:
        yield
    finally:
        setattr(module, name, original)


def mcap_records(data: bytes) -> Iterator[tuple[int, int, int]]:
    """(opcode, offset of the record, offset of its body) of an MCAP's top-level records."""
    pos = 8
    while pos + 9 <= len(data):
        opcode = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        yield opcode, pos, pos + 9
        pos += 9 + length


@pytest.fixture(scope="module")
def zstd_4gib() -> bytes:
    """4 GiB of zeros as one zstd frame that does not state its size (131 kB)."""
    return zstd_bomb(4 * GiB, declare_size=False)


@pytest.fixture(scope="module")
def bomb_mcap(tmp_path_factory: pytest.TempPathFactory, zstd_4gib: bytes) -> Path:
    """marm's recording whose first chunk (everything latched, and the first samples) inflates to 4 GiB."""
    from tfrec.formats.mcap import writer

    folder = tmp_path_factory.mktemp("bomb")
    with first_chunk_replaced(writer, "chunk_compressor", zstd_4gib):  # 30 s: the samples after fill two more chunks
        code, _, err = tfrec("record", MARM, "-o", str(folder / "bomb.mcap"), "--no-rrd", "--duration", "30")
    assert code == 0, err
    return folder / "bomb.mcap"


# ---- chunk bombs -----------------------------------------------------------------------------------------------


def test_the_mcap_bomb_is_small(bomb_mcap: Path) -> None:
    assert bomb_mcap.stat().st_size < 400_000  # the bomb (131 kB) and 30 s of samples


@pytest.mark.parametrize("command", [["info"], ["replay", "--check"], ["diff"]])
def test_an_mcap_chunk_inflating_to_4_gib_is_skipped(bomb_mcap: Path, tmp_path: Path, command: list[str]) -> None:
    argv = [*command, str(bomb_mcap)] + ([str(bomb_mcap)] if command == ["diff"] else [])
    outcome = bounded(argv, tmp_path, codes=(0, 1))
    if command != ["info"]:  # info summarizes an intact file from its summary section, without inflating anything
        assert "inflate to more than" in outcome.stderr, outcome.stderr


def test_an_mcap_chunk_declaring_4_gib_is_refused_without_work(bomb_mcap: Path, tmp_path: Path) -> None:
    data = bytearray(bomb_mcap.read_bytes())
    for opcode, _, body in mcap_records(bytes(data)):
        if opcode == 0x06:  # Chunk: start time, end time, uncompressed size, ...
            struct.pack_into("<Q", data, body + 16, 4 * GiB)
            break
    declared = tmp_path / "declared.mcap"
    declared.write_bytes(data)
    outcome = bounded(["replay", "--check", str(declared)], tmp_path, codes=(0, 1))
    assert "4,294,967,296 bytes of records, more than the" in outcome.stderr, outcome.stderr


def _two_file_bag(folder: Path, first: Path, second: Path) -> Path:
    """A rosbag2 folder of two MCAP files."""
    bag = folder / "two"
    bag.mkdir()
    shutil.copy(first / f"{first.name}_0.mcap", bag / "two_0.mcap")
    shutil.copy(second, bag / "two_1.mcap")
    text = (first / "metadata.yaml").read_text()
    text = text.replace(f"    - {first.name}_0.mcap\n", "    - two_0.mcap\n    - two_1.mcap\n", 1)
    text = text.replace(f"path: {first.name}_0.mcap", "path: two_0.mcap")
    (bag / "metadata.yaml").write_text(text)
    return bag


def test_a_rosbag2_chunk_inflating_to_4_gib_is_one_line(tmp_path: Path, zstd_4gib: bytes) -> None:
    """rosbags inflated every chunk whatever its size: a 4 GiB MemoryError under 1 GiB, before tfrec bounded it."""
    from tfrec.formats.mcap import writer

    assert tfrec("record", MARM, "--bag", str(tmp_path / "ok"), "--no-rrd", "--duration", "1")[0] == 0
    with first_chunk_replaced(writer, "chunk_compressor", zstd_4gib):
        assert tfrec("record", MARM, "--bag", str(tmp_path / "bomb"), "--no-rrd", "--duration", "1")[0] == 0
    bag = _two_file_bag(tmp_path, tmp_path / "ok", tmp_path / "bomb" / "bomb_0.mcap")
    outcome = bounded(["replay", "--check", str(bag)], tmp_path, codes=(0, 1))
    # the bomb is the second file's only chunk: skipped with a warning, the first file is read and checked
    [warning] = [line for line in outcome.stderr.splitlines() if line.startswith("tfrec: warning:")]
    assert warning.startswith(f"tfrec: warning: {bag / 'two_1.mcap'}: a damaged chunk record at byte ")
    assert "inflate to more than the" in warning and "recovered 0 of its 104 messages" in warning
    assert outcome.code == 0 and "PASS: all 9 frames match the description" in outcome.stdout


def test_a_damaged_zstd_frame_in_a_rosbag2_bag_is_one_line(tmp_path: Path) -> None:
    """Found by tests/fuzz: rosbags let zstd's own ZstdError through (a traceback)."""
    assert tfrec("record", MARM, "--bag", str(tmp_path / "a"), "--no-rrd", "--duration", "1")[0] == 0
    assert tfrec("record", MARM, "--bag", str(tmp_path / "b"), "--no-rrd", "--duration", "1")[0] == 0
    damaged = bytearray((tmp_path / "b" / "b_0.mcap").read_bytes())
    for opcode, _, body in mcap_records(bytes(damaged)):
        if opcode == 0x06:
            (length,) = struct.unpack_from("<I", damaged, body + 28)
            frame = body + 32 + length + 8
            damaged[frame + 4] ^= 0xFF  # the zstd frame header's descriptor
            break
    (tmp_path / "damaged.mcap").write_bytes(damaged)
    bag = _two_file_bag(tmp_path, tmp_path / "a", tmp_path / "damaged.mcap")
    code, out, err = tfrec("replay", "--check", str(bag))
    # the damaged chunk is skipped with one warning; what the bag has besides is read and checked
    assert err.startswith(f"tfrec: warning: {tmp_path / 'two' / 'two_1.mcap'}: a damaged chunk record at byte "), err
    assert "zstd" in err and err.count("\n") == 1
    assert code == 0 and "PASS" in out


def test_a_ros1_bz2_chunk_inflating_to_4_gib_is_skipped(tmp_path: Path) -> None:
    """rosbags inflated ROS 1 chunks whatever their size: a 5 kB bz2 chunk was a MemoryError under 1 GiB."""
    from tfrec.formats.rosbag1 import writer

    bomb = bz2_bomb(4 * GiB)
    assert len(bomb) < 10_000
    with first_chunk_replaced(writer, "compressor", bomb):
        code, _, err = tfrec("record", MARM, "-o", str(tmp_path / "bomb.bag"), "--no-rrd", "--duration", "30",
                             "--compression", "bz2")
    assert code == 0, err
    bag = str(tmp_path / "bomb.bag")
    for argv in (["info", bag], ["diff", bag, bag]):
        outcome = bounded(argv, tmp_path, codes=(0, 1))
        assert "damaged chunk record" in outcome.stderr and "inflate to more than the" in outcome.stderr, outcome.stderr
    # the chunks after the bomb are read, though the connection records they need were in it: the index section
    # repeats them (the bomb held the first 1 s of 30)
    code, out, _ = tfrec("info", bag)
    joint_states = re.search(r"/joint_states +sensor_msgs/msg/JointState +(\d+) msgs", out)
    assert code == 0 and joint_states is not None and 1400 * 0.5 < int(joint_states.group(1)) < 1501, out


# ---- YAML bombs in metadata.yaml -------------------------------------------------------------------------------


@pytest.fixture
def bag(tmp_path: Path) -> Path:
    assert tfrec("record", MARM, "--bag", str(tmp_path / "bag"), "--no-rrd", "--duration", "1")[0] == 0
    return tmp_path / "bag"


def billion_laughs(levels: int = 10) -> str:
    lines = ['lol0: &l0 ["lol"]'] + [f"lol{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * 10) + "]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("metadata, message", [
    (billion_laughs(), r"YAML expands to more than 2,000,000 nodes"),
    # refused by libyaml's own depth limit (PyYAML >= 6.0.3, in its words) or by tfrec's: either way, one line
    ("rosbag2_bagfile_information:\n  version: " + "[" * 20_000 + "]" * 20_000 + "\n", r"\S"),
    ("rosbag2_bagfile_information:\n  version:\n    " + "- " * 20_000 + "x\n", r"YAML nested more than \d+ levels deep"),
], ids=["billion laughs", "20,000 levels of flow", "20,000 levels of compact sequences"])
def test_a_metadata_yaml_bomb_is_one_line(bag: Path, metadata: str, message: str) -> None:
    (bag / "metadata.yaml").write_text(metadata)
    start = time.process_time()
    code, out, err = tfrec("info", str(bag))
    assert time.process_time() - start < 30  # a hang guard in CPU seconds
    assert code == 2 and not out
    assert err.count("\n") == 1
    assert err.startswith(f"tfrec: error: {bag / 'metadata.yaml'}")
    assert re.search(message, err), err


# ---- found by the fuzz suite -----------------------------------------------------------------------------------


def test_a_control_character_in_an_mcap_header_stays_on_one_line(tmp_path: Path) -> None:
    """The profile of an MCAP header was quoted as it was: a vertical tab (or a newline) split the error line."""
    assert tfrec("record", MARM, "-o", str(tmp_path / "a.mcap"), "--no-rrd", "--duration", "1")[0] == 0
    data = (tmp_path / "a.mcap").read_bytes()
    (tmp_path / "b.mcap").write_bytes(data.replace(b"\x04\x00\x00\x00ros2", b"\x04\x00\x00\x00ros\x0b", 1))
    code, _, err = tfrec("replay", "--check", str(tmp_path / "b.mcap"))
    assert code == 2
    assert err == f"tfrec: error: {tmp_path / 'b.mcap'}: MCAP profile 'ros\\x0b', not ros2\n"


def test_a_topic_name_that_is_not_text_in_metadata_yaml_is_one_line(bag: Path) -> None:
    """A topic named by a YAML list went through rosbags into tfrec's tables as a key (TypeError: unhashable)."""
    metadata = bag / "metadata.yaml"
    metadata.write_text(metadata.read_text().replace("name: /joint_states", "name: [[1]]", 1))
    code, _, err = tfrec("info", str(bag))
    assert code == 2
    assert err == (f"tfrec: error: {metadata}: topics_with_message_count[2].topic_metadata.name is not text: "
                   "list\n")


def test_a_length_past_memory_in_a_rosbag2_mcap_is_one_line(tmp_path: Path) -> None:
    """rosbags reads as many bytes as a record's length field says: 2⁴⁰ was a MemoryError."""
    for name in ("a", "b"):
        assert tfrec("record", MARM, "--bag", str(tmp_path / name), "--no-rrd", "--duration", "1")[0] == 0
    damaged = bytearray((tmp_path / "b" / "b_0.mcap").read_bytes())
    struct.pack_into("<Q", damaged, 9, 1 << 40)  # the Header record's length
    (tmp_path / "damaged.mcap").write_bytes(damaged)
    bag = _two_file_bag(tmp_path, tmp_path / "a", tmp_path / "damaged.mcap")
    code, _, err = tfrec("info", str(bag))
    assert code == 2
    assert err == f"tfrec: error: {bag / 'two_1.mcap'}: unreadable MCAP: the file ends inside a header record at byte 17\n"


# ---- a damaged .rrd: Rerun's reader aborts the process -----------------------------------------------------------


def _varint(buf: bytes, pos: int) -> tuple[int, int]:
    shift = value = 0
    while True:
        byte = buf[pos]
        pos += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            return value, pos


def _encode_varint(value: int) -> bytes:
    out = bytearray()
    while True:
        byte, value = value & 0x7F, value >> 7
        out.append(byte | (0x80 if value else 0))
        if not value:
            return bytes(out)


def _protobuf_fields(buf: bytes) -> list[tuple[int, int, int | bytes]]:
    """(field number, wire type, value) of a protobuf message of varints and byte strings."""
    fields: list[tuple[int, int, int | bytes]] = []
    pos = 0
    while pos < len(buf):
        key, pos = _varint(buf, pos)
        value: int | bytes
        if key & 7 == 0:
            value, pos = _varint(buf, pos)
        else:
            size, pos = _varint(buf, pos)
            value, pos = buf[pos:pos + size], pos + size
        fields.append((key >> 3, key & 7, value))
    return fields


def _protobuf(fields: list[tuple[int, int, int | bytes]]) -> bytes:
    out = bytearray()
    for number, wire, value in fields:
        out += _encode_varint(number << 3 | wire)
        out += _encode_varint(value) if isinstance(value, int) else _encode_varint(len(value)) + value
    return bytes(out)


def _buffer_too_long(ipc: bytes) -> bytes:
    """The Arrow IPC stream with the first buffer length of its record batch made 2³² larger than the body."""
    import pyarrow as pa

    for pos in range(8, len(ipc) - 16, 8):
        (value,) = struct.unpack_from("<q", ipc, pos)
        if not 0 < value < 1 << 20:
            continue
        damaged = bytearray(ipc)
        struct.pack_into("<q", damaged, pos, value + (1 << 32))
        try:
            pa.ipc.open_stream(pa.py_buffer(bytes(damaged))).read_all()
        except (OSError, pa.ArrowInvalid):  # pyarrow checks the lengths ("File too short", in its words)
            return bytes(damaged)
    raise AssertionError("no buffer length found")


def damaged_rrd(rrd: bytes) -> bytes:
    """An .rrd whose first Arrow message has a buffer 4 GiB longer than its body (what a flipped bit does): its
    messages (kind u64, length u64, protobuf) up to the end-of-stream one, the first ArrowMsg (field 2: compression,
    3: uncompressed size, 5: payload) stored uncompressed with the damaged payload."""
    import lz4.block

    out, pos, damaged = bytearray(rrd[:12]), 12, False
    while pos + 16 <= len(rrd):
        kind, length = struct.unpack_from("<QQ", rrd, pos)
        body = rrd[pos + 16:pos + 16 + length]
        pos += 16 + length
        if kind == 0:  # the end of the stream, then the footer: left out (a stream cut short)
            break
        if kind == 2 and not damaged:
            fields = _protobuf_fields(body)
            value = {number: v for number, _, v in fields}
            payload, size = value[5], value[3]
            assert isinstance(payload, bytes) and isinstance(size, int) and value[2] == 2  # LZ4
            ipc = _buffer_too_long(lz4.block.decompress(payload, uncompressed_size=size))
            replaced = {2: 1, 3: len(ipc), 5: ipc}  # compression NONE
            body = _protobuf([(number, wire, replaced.get(number, v)) for number, wire, v in fields])
            damaged = True
        out += struct.pack("<QQ", kind, len(body)) + body
    return bytes(out)


def test_an_rrd_that_aborts_reruns_reader_is_one_line(tmp_path: Path) -> None:
    """Found by tests/fuzz: Rerun's reader (Rust, built to abort on a panic) took the whole process down on a buffer
    length past its message — SIGABRT and a Rust backtrace instead of one line. It now reads in a child process."""
    assert tfrec("record", MARM, "-o", str(tmp_path / "a.mcap"), "--rrd", str(tmp_path / "a.rrd"),
                 "--duration", "0.5")[0] == 0
    bad = tmp_path / "bad.rrd"
    bad.write_bytes(damaged_rrd((tmp_path / "a.rrd").read_bytes()))
    for argv in (["info", str(bad)], ["replay", "--check", str(bad)], ["diff", str(tmp_path / "a.mcap"), str(bad)]):
        outcome = bounded(argv, tmp_path, codes=(0, 1))
        assert outcome.code == 2
        assert outcome.stderr == (f"tfrec: error: {bad}: unreadable Rerun recording: Rerun's reader crashed on it "
                                  "(killed by SIGABRT); the file is damaged\n")


# ---- rosbag2 bags compressed per file or per message (rosbags inflates those) ------------------------------------


def _compressed_bag(tmp_path: Path, mode: str) -> Path:
    """marm's recording as a rosbag2 bag written by rosbags, zstd-compressed per ``mode`` (file or message)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    from tests.recording_helpers import _Messages, _typestore, recording_messages
    from tfrec.formats import read_recording

    assert tfrec("record", MARM, "-o", str(tmp_path / "marm.mcap"), "--no-rrd", "--duration", "1")[0] == 0
    store = _typestore(ros1=False)
    bag = tmp_path / mode
    writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode[mode.upper()], CompressionFormat.ZSTD)
    with writer:
        connections: dict[str, object] = {}
        for topic, msgtype, time_ns, msg in recording_messages(read_recording(tmp_path / "marm.mcap"),
                                                               _Messages(store, ros1=False)):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], time_ns, bytes(store.serialize_cdr(msg, msgtype)))  # type: ignore[arg-type]
    return bag


@pytest.mark.parametrize("mode", ["file", "message"])
def test_compressed_rosbag2_bags_read_as_before(tmp_path: Path, mode: str) -> None:
    bag = _compressed_bag(tmp_path, mode)
    code, out, err = tfrec("diff", str(tmp_path / "marm.mcap"), str(bag))
    assert code == 0, out + err


def test_a_zstd_bomb_as_the_file_of_a_compressed_rosbag2_bag_is_one_line(tmp_path: Path, zstd_4gib: bytes) -> None:
    """rosbags inflated a file compressed per file into a temporary folder whatever its size: 4 GiB of disk."""
    bag = _compressed_bag(tmp_path, "file")
    [compressed] = [p for p in bag.iterdir() if p.name.endswith(".zstd")]
    compressed.write_bytes(zstd_4gib)
    outcome = bounded(["info", str(bag)], tmp_path)
    assert outcome.code == 2
    assert f"{compressed.name} inflates to more than 131,090,000 bytes (at most 1000 times its size)" in outcome.stderr


def test_a_zstd_bomb_as_a_message_of_a_compressed_rosbag2_bag_is_one_line(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """A message compressed per message that says it inflates to 4 GiB is refused before any work (rosbags inflated
    it: a MemoryError under 1 GiB)."""
    import rosbags.rosbag2.writer as rosbags_writer

    bomb = zstd_bomb(4 * GiB, declare_size=True)
    real = vars(rosbags_writer)["zstd"]

    class Bomb:
        """rosbags' zstd module, but the first message it compresses becomes the bomb."""

        calls = 0

        @classmethod
        def compress(cls, data: bytes) -> bytes:
            cls.calls += 1
            return bomb if cls.calls == 1 else bytes(real.compress(data))

    monkeypatch.setitem(vars(rosbags_writer), "zstd", Bomb)
    bag = _compressed_bag(tmp_path, "message")
    monkeypatch.setitem(vars(rosbags_writer), "zstd", real)
    outcome = bounded(["replay", "--check", str(bag)], tmp_path, codes=(0, 1))
    assert outcome.code == 2
    assert "a compressed message inflates to 4,294,967,296 bytes (its zstd frame says)" in outcome.stderr, outcome.stderr


# ---- found by trying tfrec as an attacker would (a review after the fuzz suite) -------------------------------


@pytest.fixture
def sqlite_bag(tmp_path: Path) -> Path:
    """marm's recording as a rosbag2 folder with sqlite3 storage, written by rosbags."""
    from tests.bag_builders import Robot, write_bag
    from tfrec.formats import read_recording

    assert tfrec("record", MARM, "-o", str(tmp_path / "marm.mcap"), "--no-rrd", "--duration", "1")[0] == 0
    return write_bag(tmp_path / "sq", [Robot(read_recording(tmp_path / "marm.mcap"))], kind="sqlite3")


def _db3(bag: Path) -> Path:
    [db3] = bag.glob("*.db3")
    return db3


@pytest.mark.parametrize("command", [["info"], ["replay", "--check"], ["convert"]])
def test_a_recursive_view_as_the_messages_table_is_one_line(sqlite_bag: Path, tmp_path: Path,
                                                           command: list[str]) -> None:
    """SELECT … FROM messages ran the view's endless recursion: 100 % CPU, and SIGTERM ignored (SQLite does not
    return to Python while a statement runs) — only SIGKILL ended it."""
    import sqlite3

    db3 = _db3(sqlite_bag)
    with contextlib.closing(sqlite3.connect(db3)) as db:
        db.executescript("DROP TABLE messages; CREATE VIEW messages AS WITH RECURSIVE r(n) AS (SELECT 1 UNION ALL "
                         "SELECT n + 1 FROM r) SELECT n AS id, 1 AS topic_id, n AS timestamp, x'00' AS data FROM r;")
    argv = [*command, str(sqlite_bag)] + ([str(tmp_path / "out.mcap")] if command == ["convert"] else [])
    outcome = bounded(argv, tmp_path)
    assert outcome.code == 2
    assert outcome.stderr == (f"tfrec: error: {db3}: its 'messages' is a view, not a table: not a rosbag2 database "
                              "(tfrec runs no SQL a bag brings)\n")


def test_a_virtual_table_as_the_topics_table_is_one_line(sqlite_bag: Path) -> None:
    import sqlite3

    db3 = _db3(sqlite_bag)
    with contextlib.closing(sqlite3.connect(db3)) as db:
        db.executescript("ALTER TABLE topics RENAME TO old_topics; CREATE VIRTUAL TABLE topics USING rtree(id, a, b);")
    code, _, err = tfrec("info", str(sqlite_bag))
    assert code == 2 and err == (f"tfrec: error: {db3}: its 'topics' is a virtual table, not a table: not a rosbag2 "
                                 "database (tfrec runs no SQL a bag brings)\n")


def test_timestamps_that_are_not_integers_are_skipped(sqlite_bag: Path) -> None:
    """SQLite keeps text in an INTEGER column: MIN(timestamp) was 'x', then a TypeError comparing it (a traceback)."""
    import sqlite3

    with contextlib.closing(sqlite3.connect(_db3(sqlite_bag))) as db:
        db.execute("UPDATE messages SET timestamp = 'x' WHERE id IN (SELECT id FROM messages "
                   "WHERE topic_id = (SELECT id FROM topics WHERE name = '/tf') LIMIT 3)")
        db.commit()
    for command in (["info"], ["replay", "--check"]):
        code, _, err = tfrec(*command, str(sqlite_bag))
        assert code == 0, err
        assert err.startswith(f"tfrec: warning: {sqlite_bag}: message counts differ from metadata.yaml: /tf: 48 read, "
                              "51 in metadata.yaml")
    assert "/tf                 tf2_msgs/msg/TFMessage      48 msgs" in tfrec("info", str(sqlite_bag))[1]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
@pytest.mark.parametrize("name", ["f.mcap", "f.bag", "f.rrd"])
def test_a_fifo_given_as_a_recording_is_one_line(tmp_path: Path, name: str) -> None:
    """Opening a FIFO to read its first bytes waited for a writer forever."""
    os.mkfifo(tmp_path / name)
    outcome = bounded(["info", str(tmp_path / name)], tmp_path)
    assert outcome.code == 2
    assert outcome.stderr == (f"tfrec: error: {tmp_path / name}: not a regular file (a FIFO, device or socket), not a "
                              "recording\n")


@pytest.mark.skipif(not os.path.exists("/dev/zero") or not hasattr(os, "mkfifo"), reason="no /dev/zero or FIFOs")
def test_check_of_a_folder_with_a_fifo_and_a_device_is_error_rows(tmp_path: Path) -> None:
    """check fingerprinted a FIFO by reading it (forever), and /dev/zero behind a link whole (its size is 0)."""
    folder = tmp_path / "bags"
    folder.mkdir()
    os.mkfifo(folder / "fifo.mcap")
    (folder / "zero.mcap").symlink_to("/dev/zero")
    outcome = bounded(["check", str(folder)], tmp_path, codes=(0, 1))
    assert outcome.code == 2
    for name in ("fifo.mcap", "zero.mcap"):
        assert f"ERROR {folder / name}: {folder / name}: not a regular file" in outcome.stdout, outcome.stdout
    assert outcome.stderr.endswith(f"tfrec: error: {folder}: nothing could be read (2 of 2 recordings an error; "
                                   "see above)\n")
    assert tfrec("record", MARM, "-o", str(folder / "marm.mcap"), "--no-rrd", "--duration", "1")[0] == 0
    code, out, err = tfrec("check", str(folder))
    assert code == 1 and "1 pass, 0 fail, 2 error" in out and "tfrec: error" not in err


@pytest.mark.parametrize("argv, code, message", [
    (["replay", "--check", "--start", "1e308"], 2, "{m}: --start 1e+308 s is beyond the recording's end (1 s)"),
    (["replay", "--check", "--end", "1e308"], 0, None),
    (["replay", "--check", "--start", "-inf"], 2, "--start -inf is not a time in seconds >= 0"),
    (["replay", "--check", "--start", "nan"], 2, "--start nan is not a time in seconds >= 0"),
    (["convert", "--start", "1e308"], 2, "{m}: --start 1e+308 s is beyond the recording's end (1 s)"),
    (["convert", "--end", "1e308"], 0, None),
])
def test_huge_start_and_end_are_past_the_end_not_an_overflow(tmp_path: Path, argv: list[str], code: int,
                                                             message: str | None) -> None:
    """round(1e308 * 1e9) is round(inf): OverflowError, a traceback."""
    mcap = tmp_path / "m.mcap"
    assert tfrec("record", MARM, "-o", str(mcap), "--no-rrd", "--duration", "1")[0] == 0
    command, options = argv[:-2], argv[-2:]
    out = [str(tmp_path / "out.mcap")] if command == ["convert"] else []
    got, _, err = tfrec(*command, str(mcap), *out, "=".join(options))
    assert got == code, err
    if message is not None:
        assert err.startswith("tfrec: error: " + message.format(m=mcap)) and err.count("\n") == 1, err
