"""Every bag of rosbag2's and rosbag.js's own tests (../shared/bags) converts to a ROS 2 MCAP and to a
ROS 1 bag without a traceback: what cannot be carried over is one warning line, what is written
is read back by tfrec and by rosbags."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.conftest import BAGS, BAGS_ABSENT
from tfrec import cli
from tfrec.formats.reader import read_recording


def _shared_bags() -> list[Path]:
    if not BAGS.is_dir():
        return []
    return sorted((BAGS / "rosbag2").iterdir()) + sorted((BAGS / "rosbagjs").glob("*.bag"))


def rosbags_count(path: Path) -> int:
    """Messages rosbags reads from ``path``, each deserialized when rosbags knows its type."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    default = get_typestore(Stores.ROS1_NOETIC if path.suffix == ".bag" else Stores.ROS2_HUMBLE)
    count = 0
    with AnyReader([path], default_typestore=default) as reader:
        known: Any = reader.typestore.fielddefs
        for connection, _, raw in reader.messages():
            if connection.msgtype in known:
                reader.deserialize(raw, connection.msgtype)
            count += 1
    return count


@pytest.mark.skipif(not BAGS.is_dir(), reason=BAGS_ABSENT)
@pytest.mark.parametrize("suffix", [".mcap", ".bag"])
@pytest.mark.parametrize("bag", _shared_bags(), ids=lambda path: path.name)
def test_every_shared_bag_converts(bag: Path, suffix: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_path = tmp_path / f"out{suffix}"
    code = cli.main(["convert", str(bag), str(out_path)])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    if bag.name == "empty-file.bag":
        assert code == 2 and err == f"tfrec: error: {bag}: an empty file (0 bytes), not a recording\n"
        assert not out_path.exists()
        return
    assert code == 0, err
    lines = err.splitlines()
    assert all(line.startswith(f"tfrec: warning: {bag}: /") and (" messages not written: " in line or (
        ": the message definition in the file does not decode its messages" in line)) for line in lines), err
    written = int(out.split(": ")[1].split()[0].replace(",", ""))
    source, result = read_recording(bag), read_recording(out_path)
    assert result.read_error is None
    assert sum(info.count for info in result.topics.values()) == written
    dropped = {line.split(": ")[3] for line in lines if " messages not written: " in line}
    counts = {name: info.count for name, info in result.topics.items()}
    expected = {name: info.count for name, info in source.topics.items() if name not in dropped}
    if suffix == ".mcap":  # an MCAP holds every topic, messages or not
        assert counts == expected and not dropped
    else:
        assert {n: c for n, c in counts.items() if c} == {n: c for n, c in expected.items() if c}
    if readable_by_rosbags(bag):
        assert rosbags_count(out_path) == written


def readable_by_rosbags(path: Path) -> bool:
    """Whether rosbags reads the input itself, every message (it refuses a service event's definition,
    a folder without metadata.yaml, a definition that does not fit the messages)."""
    from rosbags.highlevel import AnyReaderError

    try:
        rosbags_count(path)
    except (AnyReaderError, OSError):
        return False
    return True
