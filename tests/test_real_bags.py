"""Real bags: what other recorders write and how real systems name things — read, replayed, checked and diffed.

Two sources: the bags of rosbag2's and rosbag.js's own tests in ../shared/bags (every one of them
goes through ``info``, ``replay --save`` and ``diff`` with itself, its counts checked against the
file's own index with an independent reader), and bags built here with rosbags' writers from tfrec
recordings the way multi-robot systems, ROS 1 drivers and simulators record them
(:mod:`tests.bag_builders`): namespaced robots, two robots on one /tf, relative topic names,
frame ids with a leading slash, sim time, stamps of 0, a QoS edited in metadata.yaml.
"""

from __future__ import annotations

import dataclasses
import json
import re
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.bag_builders import Robot, sim_time, write_bag, zeros
from tests.conftest import BAGS, BAGS_ABSENT
from tests.recording_helpers import load_robot, marm_trajectory, write_mcap
from tfrec import cli
from tfrec.diff.compare import compare
from tfrec.errors import ReadError, ReplayError
from tfrec.formats.reader import read_recording
from tfrec.info import summarize
from tfrec.recording import Recording
from tfrec.replay import check_replay, load_replay
from tfrec.robots import find_robots
from tfrec.trajectory.generators import make_trajectory

KINDS = ["sqlite3", "mcap", "ros1"]


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def bag_path(folder: Path, name: str, kind: str) -> Path:
    return folder / (f"{name}.bag" if kind == "ros1" else f"{name}-{kind}")


@pytest.fixture(scope="module")
def marm_rec(tmp_path_factory: pytest.TempPathFactory) -> Recording:
    marm = load_robot("marm")
    return read_recording(write_mcap(tmp_path_factory.mktemp("marm") / "marm.mcap", marm, marm_trajectory(marm)))


@pytest.fixture(scope="module")
def mbot_rec(tmp_path_factory: pytest.TempPathFactory) -> Recording:
    mbot = load_robot("mbot")
    trajectory = make_trajectory(mbot, "sine", duration_s=2.0, rate_hz=50.0)
    return read_recording(write_mcap(tmp_path_factory.mktemp("mbot") / "mbot.mcap", mbot, trajectory))


# -- ../shared/bags ---------------------------------------------------------------------------------


def _shared_bags() -> list[Path]:
    if not BAGS.is_dir():
        return []
    rosbag2 = [path for path in sorted((BAGS / "rosbag2").iterdir())]
    return rosbag2 + sorted((BAGS / "rosbagjs").glob("*.bag"))


def _index_counts(path: Path) -> dict[str, int] | None:
    """Messages per topic as the file's own index says, read by an independent reader: metadata.yaml
    (yaml), an MCAP's summary statistics (mcap), a ROS 1 bag's index (rosbags); None without one."""
    import yaml

    if path.is_dir() and (path / "metadata.yaml").is_file():
        info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        counts: dict[str, int] = {}
        for entry in info["topics_with_message_count"]:
            name = "/" + entry["topic_metadata"]["name"].lstrip("/")
            counts[name] = counts.get(name, 0) + entry["message_count"]
        return counts
    if path.suffix == ".mcap":
        from mcap.reader import make_reader

        with open(path, "rb") as stream:
            summary = make_reader(stream).get_summary()
        assert summary is not None and summary.statistics is not None
        counts = {}
        for channel_id, channel in summary.channels.items():
            counts[channel.topic] = counts.get(channel.topic, 0) + summary.statistics.channel_message_counts.get(
                channel_id, 0)
        return counts
    if path.suffix == ".bag" and path.stat().st_size:
        from rosbags.rosbag1 import Reader

        with Reader(path) as reader:
            return {"/" + topic.lstrip("/"): info.msgcount for topic, info in reader.topics.items()}
    return None


@pytest.mark.skipif(not BAGS.is_dir(), reason=BAGS_ABSENT)
@pytest.mark.parametrize("bag", _shared_bags(), ids=lambda path: path.name)
def test_every_shared_bag_summarizes_replays_and_diffs_with_itself(bag: Path, tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    if bag.name == "empty-file.bag":
        for argv in (["info", str(bag)], ["replay", str(bag), "--save", str(tmp_path / "x.rrd")],
                     ["diff", str(bag), str(bag)]):
            code, _, err = run(capsys, *argv)
            assert code == 2 and err == f"tfrec: error: {bag}: an empty file (0 bytes), not a recording\n"
        return
    start = time.process_time()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        summary = summarize(bag)
    assert time.process_time() - start < 30  # a hang guard in CPU seconds; summaries come from the index
    expected = _index_counts(bag)
    read = {topic["name"]: topic["count"] for topic in summary["topics"] if topic["count"]}
    if expected is not None and {k: v for k, v in expected.items() if v} != read:
        assert any("message counts differ from" in str(w.message) for w in caught), (read, expected)
    code, out, _ = run(capsys, "info", str(bag))
    assert code == 0 and "TF frames (0" not in out
    code, _, err = run(capsys, "replay", str(bag), "--save", str(tmp_path / "out.rrd"))
    if summary["robots"]:
        assert code == 0 and (tmp_path / "out.rrd").is_file()
    else:  # no TF, joint states or description: one line, and no file
        assert code == 2 and err.endswith("in the recording; nothing to replay\n") and err.count("\n") == 1
        assert not (tmp_path / "out.rrd").exists()
    code, out, _ = run(capsys, "diff", str(bag), str(bag))
    assert code == 0 and out.startswith("identical within tolerance")


@pytest.mark.skipif(not BAGS.is_dir(), reason=BAGS_ABSENT)
def test_the_talker_bags_messages_are_read_whatever_their_qos(capsys: pytest.CaptureFixture[str]) -> None:
    """rosbag2's own talker bag: metadata.yaml's QoS text differs from the database's, so rosbags
    yields nothing; every message the database holds is read."""
    from rosbags.highlevel import AnyReader

    bag = BAGS / "rosbag2" / "rosbag2_py__sqlite3_talker"
    with AnyReader([bag]) as reader:
        assert sum(1 for _ in reader.messages()) == 0
    rec = read_recording(bag)
    assert {name: info.count for name, info in rec.topics.items()} == {
        "/rosout": 10, "/parameter_events": 0, "/topic": 10}
    code, out, _ = run(capsys, "info", str(bag), "--json")
    summary = json.loads(out)
    assert code == 0 and summary["message_count"] == 20 and summary["profile"] is None and summary["library"] is None


@pytest.mark.skipif(not BAGS.is_dir(), reason=BAGS_ABSENT)
def test_a_folder_of_mcap_files_without_metadata(capsys: pytest.CaptureFixture[str]) -> None:
    bag = BAGS / "rosbag2" / "rosbag2_py__mcap_reindex_test_bags_multiple_files"
    assert not (bag / "metadata.yaml").exists()
    code, out, _ = run(capsys, "info", str(bag))
    assert code == 0 and "(MCAP storage, no metadata.yaml)" in out
    assert "Files:       multiple_files_0.mcap, multiple_files_1.mcap, multiple_files_2.mcap" in out


def test_ros1_summary_comes_from_the_index(tmp_path: Path, marm_rec: Recording, monkeypatch: pytest.MonkeyPatch) -> None:
    """Only the chunks that hold a message to decode are decompressed; the counts come from the bag's index."""
    from rosbags.rosbag1 import Reader

    from tests.formats.test_readers import _ros1_bag
    from tfrec.formats._compression import decompress as real
    from tfrec.formats.rosbag1 import index

    bag = _ros1_bag(tmp_path / "chunked.bag", marm_rec, compression="lz4", chunk_bytes=4096)
    with Reader(bag) as reader:
        chunks = len(reader.chunk_infos)
    calls: list[int] = []

    def counted(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(index, "decompress", counted)
    rec = read_recording(bag, topics=["/robot_description"])
    assert chunks > 20 and len(calls) == 1  # the one chunk that holds it
    assert rec.robot_description == marm_rec.robot_description
    assert {name: info.count for name, info in rec.topics.items()} == {name: info.count
                                                                      for name, info in marm_rec.topics.items()}


# -- rosbag2 quirks ---------------------------------------------------------------------------------


def _set_qos(bag: Path, topic: str, qos: dict[str, Any]) -> None:
    """Set a topic's offered QoS in a bag's metadata.yaml, as a user overriding it for playback does."""
    import yaml

    from tfrec._yaml import yaml_dump

    meta = bag / "metadata.yaml"
    document = yaml.safe_load(meta.read_text())
    for entry in document["rosbag2_bagfile_information"]["topics_with_message_count"]:
        if entry["topic_metadata"]["name"] == topic:
            entry["topic_metadata"]["offered_qos_profiles"] = [qos]
    meta.write_text(yaml_dump(document))


def test_qos_edited_in_metadata_yaml(tmp_path: Path, marm_rec: Recording, capsys: pytest.CaptureFixture[str]) -> None:
    """A user makes /tf_static volatile in metadata.yaml (a common playback workaround): the topic
    is still read and --check still passes."""
    from rosbags.highlevel import AnyReader

    bag = write_bag(tmp_path / "edited", [Robot(marm_rec)], kind="sqlite3")
    from tfrec.formats.rosbag2.metadata import QOS_LATCHED

    _set_qos(bag, "/tf_static", dict(QOS_LATCHED))
    with AnyReader([bag]) as reader:  # rosbags matches metadata.yaml's QoS text to the database's: no match
        assert not any(connection.topic == "/tf_static" for connection, _, _ in reader.messages())
    rec = read_recording(bag)
    assert list(rec.tf_static) == list(marm_rec.tf_static)
    code, out, _ = run(capsys, "replay", str(bag), "--check")
    assert code == 0 and out.endswith("PASS: all 9 frames match the description\n")


def test_counts_that_differ_from_metadata_yaml_warn_with_both(tmp_path: Path, marm_rec: Recording) -> None:
    bag = write_bag(tmp_path / "counts", [Robot(marm_rec)], kind="mcap")
    meta = bag / "metadata.yaml"
    meta.write_text(meta.read_text().replace("message_count: 101", "message_count: 150", 1))
    with pytest.warns(UserWarning, match=r"counts: message counts differ from metadata\.yaml: /joint_states: 101 "
                                         r"read, 150 in metadata\.yaml$"):
        rec = read_recording(bag)
    assert rec.topics["/joint_states"].count == 101


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("mode", ["FILE", "MESSAGE"])
def test_compressed_rosbag2(tmp_path: Path, marm_rec: Recording, storage: str, mode: str,
                            capsys: pytest.CaptureFixture[str]) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    from tests.recording_helpers import _Messages, _typestore, recording_messages

    store = _typestore(False)
    bag = tmp_path / "zipped"
    writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3)
    writer.set_compression(CompressionMode[mode], CompressionFormat.ZSTD)
    with writer:
        connections: dict[str, Any] = {}
        for topic, msgtype, time_ns, msg in recording_messages(marm_rec, _Messages(store, False)):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], time_ns, bytes(store.serialize_cdr(msg, msgtype)))
    rec = read_recording(bag)
    assert rec.details["bag_compression"] == f"zstd {mode.lower()}"
    assert rec.joint_states is not None and marm_rec.joint_states is not None
    np.testing.assert_array_equal(rec.joint_states.positions, marm_rec.joint_states.positions)
    code, out, _ = run(capsys, "info", str(bag), "--json")
    summary = json.loads(out)
    assert summary["bag_compression"] == f"zstd {mode.lower()}" and summary["robot_name"] == "marm"
    if storage == "mcap":
        assert summary["profile"] == "ros2" and summary["library"].startswith("rosbags")
    else:
        assert summary["profile"] is None and summary["compression"] == "no"
    code, out, _ = run(capsys, "info", str(bag))
    assert code == 0
    kind = "MCAP" if storage == "mcap" else "sqlite3"
    assert f"Format:      rosbag2 folder ({kind} storage, zstd {mode.lower()} compression)" in out
    assert "written by (unknown)" not in out and "profile (none)" not in out


# -- namespaces and several robots ------------------------------------------------------------------


@pytest.fixture(scope="module")
def namespaced(tmp_path_factory: pytest.TempPathFactory, marm_rec: Recording) -> Callable[[str], Path]:
    """/robot1/* and /robot2/* of one model, each with its own /tf (frame ids the same in both)."""
    folder = tmp_path_factory.mktemp("namespaced")

    def make(kind: str) -> Path:
        path = bag_path(folder, "fleet", kind)
        if not path.exists():
            write_bag(path, [Robot(marm_rec, namespace="/robot1"), Robot(marm_rec, namespace="/robot2")], kind=kind)
        return path

    return make


@pytest.mark.parametrize("kind", KINDS)
def test_namespaced_robots_are_read_listed_and_checked(namespaced: Callable[[str], Path], kind: str,
                                                       marm_rec: Recording, capsys: pytest.CaptureFixture[str]) -> None:
    bag = namespaced(kind)
    rec = read_recording(bag)
    assert rec.namespace_names() == ["/robot1", "/robot2"] and not rec.tf and rec.robot_description is None
    for name in ("/robot1", "/robot2"):
        topics = rec.robot_topics(name)
        assert topics.robot_description == marm_rec.robot_description and list(topics.tf) == list(marm_rec.tf)
    code, out, _ = run(capsys, "info", str(bag))
    assert code == 0 and "Robots (2):\n  /robot1: marm\n    Joints (8)" in out and "\n  /robot2: marm\n" in out
    code, out, _ = run(capsys, "replay", str(bag), "--check")
    rows = [line for line in out.splitlines()[2:] if not line.startswith("robot ")]
    assert code == 0 and len(rows) == 18 and all(line.startswith(("/robot1 ", "/robot2 ")) for line in rows)
    assert out.splitlines()[-2:] == ["robot /robot1: PASS: all 9 frames match its description",
                                     "robot /robot2: PASS: all 9 frames match its description"]
    code, out, _ = run(capsys, "replay", str(bag), "--check", "--namespace", "robot2")
    assert code == 0 and out.endswith("PASS: all 9 frames match the description\n")


def test_namespaced_robots_replay_under_their_namespace(namespaced: Callable[[str], Path], tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    from tests.replay.test_replay import Rrd

    out = tmp_path / "fleet.rrd"
    code, text, _ = run(capsys, "replay", str(namespaced("sqlite3")), "--save", str(out))
    assert code == 0 and "2 robots (/robot1, /robot2)" in text
    rrd = Rrd(out)
    for name in ("robot1", "robot2"):  # the same frame ids in both namespaces: shown apart
        times, _, _, pairs = rrd.transforms(f"/{name}/tf/joint1")
        assert len(times) == 101 and pairs == {(f"{name}/link0", f"{name}/link1")}
        assert rrd.static[f"/{name}/robot"]["CoordinateFrame:frame"] == [f"{name}/link0"]
        assert f"/{name}/robot_description" in rrd.static and f"/{name}/joints/joint1" in rrd.temporal


def test_namespace_and_remap_select_and_rename(namespaced: Callable[[str], Path], marm_rec: Recording,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    bag = namespaced("mcap")
    remap = [f"/robot1{topic}:={topic}" for topic in ("/robot_description", "/joint_states", "/tf", "/tf_static")]
    rec = read_recording(bag, remap=remap)
    assert rec.namespace_names() == ["", "/robot2"] and list(rec.tf) == list(marm_rec.tf)
    assert "/tf" in rec.topics and "/robot1/tf" not in rec.topics
    report = compare(bag, marm_rec.path, remap=remap, namespace="/")
    assert report.equal, report.to_text()
    replay = load_replay(bag, topics=["/robot1/tf", "/robot1/robot_description"])  # /robot2: nothing selected
    assert [robot.key for robot in replay.robots] == ["/robot1"] and replay.robot_description is not None
    assert set(replay.tf) == set(marm_rec.tf) and not replay.derived_dynamic
    with pytest.raises(ReplayError, match=r"fleet-mcap: no robot in `namespace` /robot3 \(the recording's namespaces: "
                                          r"/robot1, /robot2\)$"):
        load_replay(bag, namespace="/robot3")
    with pytest.raises(ReadError, match=r"^`remap` '/robot1/tf' is not a remapping rule FROM:=TO"):
        read_recording(bag, remap=["/robot1/tf"])
    code, _, err = run(capsys, "replay", str(bag), "--check", "--remap", "tf")
    assert code == 2 and err == "tfrec: error: --remap 'tf' is not a remapping rule FROM:=TO (e.g. /robot1/tf:=/tf)\n"
    code, _, err = run(capsys, "replay", str(bag), "--check", "--robot", "robots/marm.xacro")
    assert code == 2 and err.startswith("tfrec: error: ") and "--robot is one model, and the recording holds 2 robots " \
        "(/robot1, /robot2): pick one with --namespace" in err


def test_diff_compares_robot_by_robot(tmp_path: Path, marm_rec: Recording, namespaced: Callable[[str], Path]) -> None:
    moved = marm_rec.tf[("link2", "link3")]
    shifted = Recording(marm_rec.path, marm_rec.format, robot_description=marm_rec.robot_description,
                        joint_states=marm_rec.joint_states, tf_static=marm_rec.tf_static,
                        tf={**marm_rec.tf, ("link2", "link3"): type(moved)(moved.time_ns, moved.translation + [0.01, 0, 0],
                                                                           moved.rotation)},
                        start_ns=marm_rec.start_ns, end_ns=marm_rec.end_ns)
    other = write_bag(tmp_path / "other", [Robot(marm_rec, namespace="/robot1"),
                                           Robot(shifted, namespace="/robot2")], kind="ros1")
    report = compare(namespaced("sqlite3"), other)
    details = [d.detail for d in report.differences]
    assert details and all(detail.startswith("robot /robot2: link2 → link3: translation differs by up to 0.01 m")
                           for detail in details), details
    assert compare(namespaced("sqlite3"), namespaced("ros1")).equal


def test_one_robot_each_in_different_namespaces_diffs_equal(tmp_path: Path, marm_rec: Recording) -> None:
    """/robot1/… in A, the root's in B: the robots were compared, but every topic was 'only in A' or 'only in B'."""
    a = write_bag(tmp_path / "a.bag", [Robot(marm_rec, namespace="/robot1")], kind="ros1")
    b = write_bag(tmp_path / "b.bag", [Robot(marm_rec)], kind="ros1")
    report = compare(a, b)
    assert report.equal, [d.detail for d in report.differences]
    assert any(note.startswith("one robot each, in different namespaces: B's /joint_states as /robot1/joint_states")
               for note in report.notes), report.notes
    fewer = write_bag(tmp_path / "c.bag", [Robot(dataclasses.replace(marm_rec, tf_static={}))], kind="ros1")
    details = [d.detail for d in compare(a, fewer).differences]
    assert "/robot1/tf_static only in A (1 messages of tf2_msgs/msg/TFMessage)" in details, details


def test_a_bag_named_by_its_metadata_yaml_is_the_bag(tmp_path: Path, marm_rec: Recording) -> None:
    """diff took metadata.yaml for a robot description ('malformed XML'), info for no recording."""
    bag = write_bag(tmp_path / "b", [Robot(marm_rec)], kind="sqlite3")
    assert read_recording(bag / "metadata.yaml").topics == read_recording(bag).topics
    assert compare(bag / "metadata.yaml", bag).equal


def test_diff_of_a_namespace_neither_recording_has_is_an_error(tmp_path: Path, marm_rec: Recording) -> None:
    from tfrec.errors import DiffError

    a = write_bag(tmp_path / "a.bag", [Robot(marm_rec, namespace="/robot1")], kind="ros1")
    with pytest.raises(DiffError, match=r"a\.bag and .*a\.bag: no robot in `namespace` /nope in either \(their "
                                        r"namespaces: /robot1\)"):
        compare(a, a, namespace="nope")
    assert compare(a, a, namespace="robot1").equal


def test_the_old_tf_message_type_is_the_same_as_tf2s(tmp_path: Path) -> None:
    """rosbag.js's example.bag has /tf as tf/tfMessage; converted, it is tf2_msgs/msg/TFMessage — the same messages."""
    source = BAGS / "rosbagjs" / "example.bag"
    if not source.exists():
        pytest.skip(BAGS_ABSENT)
    from tfrec.convert import convert

    convert(source, tmp_path / "e.mcap")
    convert(tmp_path / "e.mcap", tmp_path / "e.bag")
    report = compare(source, tmp_path / "e.bag")
    assert report.equal, [d.detail for d in report.differences]


def test_two_robots_on_one_tf(tmp_path: Path, marm_rec: Recording, mbot_rec: Recording,
                              capsys: pytest.CaptureFixture[str]) -> None:
    """An arm and a mobile base on one /tf (frame prefixes), /joint_states and /robot_description:
    each description is a robot, each checked, named in every line."""
    bag = write_bag(tmp_path / "pair", [Robot(marm_rec, frame_prefix="arm/"), Robot(mbot_rec, frame_prefix="base/")],
                    kind="mcap")
    rec = read_recording(bag)
    assert len(rec.robot_descriptions) == 2 and rec.robot_description == mbot_rec.robot_description
    robots = find_robots(rec)
    assert [(r.key, r.name, r.frame_prefix, len(r.tf) + len(r.tf_static)) for r in robots] == [
        ("marm", "marm", "arm/", 9), ("mbot", "mbot", "base/", len(mbot_rec.tf) + len(mbot_rec.tf_static))]
    code, out, _ = run(capsys, "info", str(bag))
    assert code == 0 and "Robots (2):\n  marm: marm\n" in out and "\n  mbot: mbot\n" in out
    code, out, _ = run(capsys, "replay", str(bag), "--check")
    lines = out.splitlines()
    assert code == 0 and all(line.startswith(("marm ", "mbot ")) for line in lines[2:-2])
    assert lines[-2] == "robot marm: PASS: all 9 frames match its description"
    assert lines[-1].startswith("robot mbot: PASS: all ")
    info = summarize(bag)
    assert {robot["key"]: robot["joints"] is not None for robot in info["robots"]} == {"marm": True, "mbot": True}


def test_a_check_never_passes_frames_it_did_not_check(tmp_path: Path, marm_rec: Recording, mbot_rec: Recording,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    bag = write_bag(tmp_path / "half", [
        Robot(marm_rec, namespace="/arm"),
        Robot(mbot_rec, namespace="/base", topics=("/joint_states", "/tf", "/tf_static"))], kind="sqlite3")
    code, out, _ = run(capsys, "replay", str(bag), "--check")
    assert code == 0
    assert out.splitlines()[-2:] == [
        "robot /arm: PASS: all 9 frames match its description",
        ("robot /base: NOT CHECKED: no robot description to re-simulate with (no /base/robot_description in the "
         "recording); give --robot FILE")]
    report = check_replay(load_replay(bag, need_robot=True))
    assert report.robots == ["/arm"] and list(report.unchecked) == ["/base"]
    assert {frame.robot for frame in report.frames} == {"/arm"}


def test_two_arms_of_one_model(tmp_path: Path, marm_rec: Recording, capsys: pytest.CaptureFixture[str]) -> None:
    """One description (two robot_state_publishers of one URDF) under two frame prefixes: two robots."""
    bag = write_bag(tmp_path / "twins", [Robot(marm_rec, frame_prefix="left/"),
                                         Robot(marm_rec, frame_prefix="right/", topics=("/tf", "/tf_static"))],
                    kind="ros1")
    robots = find_robots(read_recording(bag))
    assert [(r.key, r.frame_prefix) for r in robots] == [("left", "left/"), ("right", "right/")]
    code, out, _ = run(capsys, "replay", str(bag), "--check")
    assert code == 0 and out.splitlines()[-2:] == ["robot left: PASS: all 9 frames match its description",
                                                   "robot right: PASS: all 9 frames match its description"]


# -- ROS 1 names, sim time, stamps of 0 -------------------------------------------------------------


def test_relative_topics_and_slashed_frames_are_global(tmp_path: Path, marm_rec: Recording,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """robot_state_publisher's own ROS 1 test bag records ``joint_states``; ROS 1 frame ids start
    with a slash: played as /joint_states, seen by tf2 without the slash — diff equal to tfrec's MCAP."""
    bag = write_bag(tmp_path / "ros1.bag", [Robot(marm_rec, relative=True, frame_prefix="/")], kind="ros1")
    from rosbags.rosbag1 import Reader

    with Reader(bag) as reader:
        assert sorted(reader.topics) == ["joint_states", "robot_description", "tf", "tf_static"]
    rec = read_recording(bag)
    assert list(rec.topics) == ["/robot_description", "/tf_static", "/joint_states", "/tf"]
    assert list(rec.tf) == list(marm_rec.tf) and list(rec.tf_static) == list(marm_rec.tf_static)
    assert compare(marm_rec.path, bag).equal
    code, out, _ = run(capsys, "replay", str(bag), "--check")
    assert code == 0 and out.endswith("PASS: all 9 frames match the description\n")


def test_sim_time_is_reported_on_one_clock(tmp_path: Path, marm_rec: Recording,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    """Header stamps count from the simulator's start, log times are the wall clock: times are
    reported on each one's own base, named, never mixed."""
    sim = write_bag(tmp_path / "sim", [Robot(marm_rec, header=sim_time(marm_rec.start_ns or 0))], kind="mcap")
    code, out, _ = run(capsys, "info", str(sim))
    assert code == 0 and "Stamps:      header stamps of /joint_states and /tf from 12.000 s: another clock" in out
    late = write_bag(tmp_path / "late", [Robot(marm_rec, header=sim_time(marm_rec.start_ns or 0),
                                               topics=("/joint_states", "/tf", "/tf_static"))], kind="mcap")
    report = compare(sim, late)
    text = report.to_text()
    assert "/robot_description only in A" in text
    assert all(float(t) < 100 for t in re.findall(r"t=(-?\d+\.\d+)", text)), text
    assert "topic spans are log times" in text
    assert compare(marm_rec.path, sim).equal


def test_zero_stamps_warn_and_replay_by_log_time(tmp_path: Path, marm_rec: Recording) -> None:
    bag = write_bag(tmp_path / "zero.bag", [Robot(marm_rec, header=zeros, topics=("/robot_description",
                                                                                   "/joint_states"))], kind="ros1")
    with pytest.warns(UserWarning, match=r"zero\.bag: 101 of 101 /joint_states messages are stamped 0 \(a driver "
                                         r"that does not stamp them: robot_state_publisher publishes nothing for "
                                         r"them\); their times are meaningless: `use_log_time` replays by log time"):
        replay = load_replay(bag)
    assert replay.start_ns == replay.end_ns == 0
    by_log = load_replay(bag, use_log_time=True)
    assert by_log.time_base == "log" and by_log.joint_states is not None and marm_rec.joint_states is not None
    np.testing.assert_array_equal(by_log.joint_states.time_ns, marm_rec.joint_states.time_ns)
    assert (by_log.end_ns or 0) - (by_log.start_ns or 0) == 2_000_000_000
    assert compare(marm_rec.path, bag, use_log_time=True, topics=["/joint_states"]).equal


# -- foreign .rrd -----------------------------------------------------------------------------------


def test_an_rrd_of_another_application_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import rerun as rr

    other = tmp_path / "points.rrd"
    stream = rr.RecordingStream("my_viewer_app")
    stream.save(other)
    stream.log("tf/x", rr.Transform3D(translation=[1.0, 2.0, 3.0]))
    stream.flush()
    stream.disconnect()
    for argv in (["info", str(other)], ["diff", str(other), str(other)]):
        code, _, err = run(capsys, *argv)
        assert code == 2 and err == (f"tfrec: error: {other}: a Rerun recording of 'my_viewer_app', not written by "
                                     "tfrec: tfrec reads back only its own .rrd files (their entities stand for ROS "
                                     "topics)\n")


def test_an_rrd_of_a_multi_robot_replay_is_read_back_robot_by_robot(namespaced: Callable[[str], Path], tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "fleet.rrd"
    assert cli.main(["replay", str(namespaced("ros1")), "--save", str(out)]) == 0
    rec = read_recording(out)
    assert rec.namespace_names() == ["/robot1", "/robot2"]
    # the viewer showed robot2's frames as robot2/link0… (both robots use the same frame ids); read back, they
    # are the frame ids the bag had, and the .rrd equals the bag
    assert set(rec.robot_topics("/robot2").tf) == set(read_recording(namespaced("ros1")).robot_topics("/robot2").tf)
    assert compare(namespaced("ros1"), out).equal
    code, text, _ = run(capsys, "info", str(out))
    assert code == 0 and "Robots (2):\n  /robot1: marm\n" in text
    from tfrec.formats.rrd.reader import _read_chunks

    shown = {str(batch.column(batch.schema.names.index("Transform3D:child_frame")).flatten()[0])
             for entity, batch in _read_chunks(out)[1]
             if entity.startswith("/robot2/tf/") and "Transform3D:child_frame" in batch.schema.names}
    assert shown and all(frame.startswith("robot2/") for frame in shown)  # as the viewer shows them


def test_info_and_replay_agree_on_an_unusable_description(tmp_path: Path, marm_rec: Recording,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    broken = (marm_rec.robot_description or "").replace('<joint name="joint2"', '<joint name="joint1"', 1)
    bag = write_bag(tmp_path / "broken", [Robot(marm_rec, description=broken)], kind="mcap")
    problem = read_recording(bag)
    (robot,) = find_robots(problem)
    assert robot.model is None and robot.problem is not None and robot.name == "marm"
    code, out, _ = run(capsys, "info", str(bag))
    assert code == 0 and f"Robot:       marm (its description is not usable: {robot.problem})" in out
    code, _, err = run(capsys, "replay", str(bag), "--check")
    assert code == 2 and err == (f"tfrec: error: {bag}: /robot_description is not a usable robot description: "
                                 f"{robot.problem}\n")
    code, _, err = run(capsys, "replay", str(bag), "--save", str(tmp_path / "x.rrd"))
    assert code == 0 and f"/robot_description is not a usable robot description ({robot.problem})" in err


# -- names ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name, namespace, base", [
    ("/tf", "", "/tf"), ("joint_states", "", "/joint_states"), ("/robot1/tf", "/robot1", "/tf"),
    ("robot1//joint_states/", "/robot1", "/joint_states"), ("/fleet/arm/tf_static", "/fleet/arm", "/tf_static"),
])
def test_topic_names_split_into_namespace_and_base(name: str, namespace: str, base: str) -> None:
    from tfrec.conventions import robot_topic_kind, split_topic

    assert split_topic(name) == (namespace, base) and robot_topic_kind(name) == (namespace, base)


def test_remapping_rules_apply_as_ros_applies_them() -> None:
    from tfrec.formats._collect import ReadOptions

    options = ReadOptions.of(remap=["joint_states:=/robot1/joint_states", "/tf:=/robot1/tf", "/tf:=/never"])
    assert options.resolve("joint_states") == "/robot1/joint_states"  # relative names are global first
    assert options.resolve("/tf") == "/robot1/tf" and options.resolve("/tf_static") == "/tf_static"
    assert ReadOptions.of(namespace="robot1/").namespace == "/robot1" and ReadOptions.of(namespace="/").namespace == ""
    for rule in ("/tf", ":=/tf", "/tf:=", "/tf=/x"):
        with pytest.raises(ReadError, match=rf"^`remap` '{re.escape(rule)}' is not a remapping rule FROM:=TO"):
            ReadOptions.of(remap=[rule])
