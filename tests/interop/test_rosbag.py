"""Real rosbag on every kind of ROS 1 bag tfrec writes — `record` and `convert` (from MCAP, from a rosbag2 folder,
from a ROS 1 bag), with none, lz4 and bz2 chunks: `rosbag info` reads its index, `rosbag check` finds nothing to
migrate, `rosbag fix` changes nothing, `rosbag reindex` keeps every message, and `rosbag.Bag.read_messages`
deserializes every message as Debian's message classes define them."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path
from typing import Any

import pytest

from tests.conftest import ROBOTS
from tests.interop.conftest import add_to_figure
from tests.interop.ros import Ros
from tfrec import cli
from tfrec.convert import convert
from tfrec.formats.reader import read_recording

COMPRESSIONS = ("none", "lz4", "bz2")
ORIGINS = ("record", "convert-mcap", "convert-rosbag2", "convert-bag")

READ = """\
import json, sys
import rosbag

def messages(path):
    out = []
    with rosbag.Bag(path) as bag:
        for topic, message, time in bag.read_messages():  # deserialized with the bag's own definitions
            buffer = __import__("io").BytesIO()
            message.serialize(buffer)
            out.append([topic, time.to_nsec(), buffer.getvalue().hex()])
        connections = sorted([c.topic, c.datatype, c.md5sum, c.header.get("latching", b"0").decode()]
                             for c in bag._connections.values())
        definitions = {c.datatype: c.msg_def for c in bag._connections.values()}
    return out, connections, definitions

def system_definitions(types):
    import genpy.message
    found = {}
    for name in types:
        cls = genpy.message.get_message_class(name)
        found[name] = cls._full_text if cls is not None else None
    return found

result = {}
for path in sys.argv[1:]:
    msgs, connections, definitions = messages(path)
    result[path] = {"messages": msgs, "connections": connections, "definitions": definitions,
                    "system": system_definitions(sorted(definitions))}
print(json.dumps(result))
"""


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Every kind of ROS 1 bag tfrec writes: origin × chunk compression."""
    folder = tmp_path_factory.mktemp("tfrec_bags")
    mcap = folder / "marm.mcap"
    rosbag2 = folder / "marm_bag"
    ros1 = folder / "marm_source.bag"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert cli.main(["record", str(ROBOTS / "marm.xacro"), "-o", str(mcap), "--no-rrd", "--duration", "2"]) == 0
        assert cli.main(["record", str(ROBOTS / "mbot.xacro"), "--bag", str(rosbag2), "--no-rrd",
                         "--duration", "2"]) == 0
        assert cli.main(["record", str(ROBOTS / "marm.xacro"), "-o", str(ros1), "--no-rrd", "--duration", "2",
                         "--compression", "bz2"]) == 0
        out = {}
        for compression in COMPRESSIONS:
            name = f"record-{compression}"
            out[name] = folder / f"{name}.bag"
            assert cli.main(["record", str(ROBOTS / "marm.xacro"), "-o", str(out[name]), "--no-rrd", "--duration", "2",
                             "--compression", compression]) == 0
            for origin, source in (("convert-mcap", mcap), ("convert-rosbag2", rosbag2), ("convert-bag", ros1)):
                name = f"{origin}-{compression}"
                out[name] = convert(source, folder / f"{name}.bag", compression=compression).target
    return out


@pytest.fixture(scope="module")
def read_by_rosbag(ros: Ros, bags: dict[str, Path]) -> dict[str, Any]:
    """rosbag's Python API on every bag (one run of Debian's python3)."""
    script = ros.home / "read_bags.py"
    script.write_text(READ)
    return dict(ros.python(script.read_text(), *map(str, bags.values())))


NAMES = [f"{origin}-{compression}" for origin in ORIGINS for compression in COMPRESSIONS]


@pytest.mark.parametrize("name", NAMES)
def test_rosbag_info_reads_the_index(ros: Ros, bags: dict[str, Path], name: str) -> None:
    bag = bags[name]
    info = ros.run("rosbag", "info", "--yaml", bag).stdout
    expected = sum(s.count for s in read_recording(bag).topics.values())
    assert f"messages: {expected}\n" in info
    assert ("compression: none" in info) == name.endswith("-none")
    assert "indexed: True" in info


@pytest.mark.parametrize("name", NAMES)
def test_rosbag_check_finds_nothing_to_migrate_and_fix_changes_nothing(ros: Ros, bags: dict[str, Path], name: str,
                                                                       read_by_rosbag: dict[str, Any],
                                                                       tmp_path: Path) -> None:
    bag = bags[name]
    check = ros.run("rosbag", "check", bag)
    assert check.stdout.strip() == "Bag file does not need any migrations."
    fixed = tmp_path / "fixed.bag"
    ros.run("rosbag", "fix", bag, fixed)
    again = ros.python(READ, fixed)[str(fixed)]
    ours = read_by_rosbag[str(bag)]
    assert again["messages"] == ours["messages"] and again["connections"] == ours["connections"]
    assert again["definitions"] == ours["definitions"]
    add_to_figure("rosbag: bags checked (info, check, fix, reindex, read_messages)", 1)


@pytest.mark.parametrize("name", NAMES)
def test_the_definitions_are_the_ones_rosbag_record_writes(bags: dict[str, Path], name: str,
                                                           read_by_rosbag: dict[str, Any]) -> None:
    """Each connection's message definition is Debian's generated class's full text (what rosbag record writes)."""
    found = read_by_rosbag[str(bags[name])]
    for msgtype, definition in found["definitions"].items():
        assert found["system"][msgtype] is not None, msgtype
        assert definition == found["system"][msgtype], msgtype


@pytest.mark.parametrize("name", NAMES)
def test_rosbag_reindex_keeps_every_message(ros: Ros, bags: dict[str, Path], name: str,
                                            read_by_rosbag: dict[str, Any], tmp_path: Path) -> None:
    """It rewrites the bag header in place and the index from the chunks: a shorter header record than rosbag's
    let it overwrite the first chunk (0 messages left)."""
    copy = tmp_path / "copy.bag"
    shutil.copy(bags[name], copy)
    ros.run("rosbag", "reindex", copy)
    reindexed = ros.python(READ, copy)[str(copy)]
    ours = read_by_rosbag[str(bags[name])]
    assert len(reindexed["messages"]) == len(ours["messages"]) > 0
    assert reindexed["messages"] == ours["messages"] and reindexed["connections"] == ours["connections"]
    assert sum(s.count for s in read_recording(copy).topics.values()) == len(ours["messages"])


@pytest.mark.parametrize("name", NAMES)
def test_read_messages_gives_what_tfrec_wrote(bags: dict[str, Path], name: str, read_by_rosbag: dict[str, Any]) -> None:
    found = read_by_rosbag[str(bags[name])]
    counts: dict[str, int] = {}
    for topic, _, _ in found["messages"]:
        counts[topic] = counts.get(topic, 0) + 1
    rec = read_recording(bags[name])
    assert counts == {topic: stats.count for topic, stats in rec.topics.items()}
    latched = {topic for topic, _, _, latching in found["connections"] if latching == "1"}
    assert latched == {topic for topic, stats in rec.topics.items() if stats.durability == "latched"}
    assert {"/tf_static", "/robot_description"} <= latched
    add_to_figure("rosbag: messages read by rosbag.Bag.read_messages", len(found["messages"]))
