"""The per-file functions (check_recording, diff_pair), the health checks and fingerprints."""

from __future__ import annotations

import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import ROBOTS
from tests.fleet.helpers import EXPECTED, _mismatched
from tests.recording_helpers import load_robot, write_rosbag1, write_rosbag2
from tfrec.conventions import DEFAULT_START_TIME_NS
from tfrec.fleet import ERROR, FAIL, PASS, SUMMARY, FleetError, Row, check_recording, diff_pair, fingerprint
from tfrec.fleet.health import rate_findings, series_findings, stamp_findings
from tfrec.fleet.report import REPORT_COLUMNS
from tfrec.formats import read_recording


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_each_recording_gets_its_verdict(fleet_dir: Path, name: str) -> None:
    rows = check_recording(fleet_dir / name, config="c0")
    verdict, checks = EXPECTED[name]
    assert rows[0].check == SUMMARY
    assert rows[0].verdict == verdict, rows[0].detail
    assert {row.check for row in rows[1:]} == checks
    assert all(row.verdict == FAIL for row in rows[1:])
    assert all(row.file == os.fspath(fleet_dir / name) and row.config == "c0" for row in rows)
    assert pickle.loads(pickle.dumps(rows)) == rows  # rows travel back from workers


def test_a_passing_recording_says_what_was_checked(fleet_dir: Path) -> None:
    (head,) = check_recording(fleet_dir / "marm" / "sine.mcap")
    assert (head.robot, head.verdict, head.unit, head.max_error) == ("marm", PASS, "m", 0.0)
    assert head.detail.startswith("9 of 9 frames re-simulated (largest errors 0 m at ")
    assert "101 joint states over 2.000 s (50 Hz)" in head.detail
    assert head.fingerprint == fingerprint(fleet_dir / "marm" / "sine.mcap").key
    assert head.size == (fleet_dir / "marm" / "sine.mcap").stat().st_size
    assert head.read_s is not None and head.read_s > 0


def test_a_description_mismatch_names_the_frame_and_when(fleet_dir: Path) -> None:
    head, *findings = check_recording(fleet_dir / "bad" / "mismatch.mcap")
    assert head.verdict == FAIL and head.first_exceed_s == 0.0
    (row,) = findings
    assert (row.check, row.topic, row.frame, row.unit, row.first_exceed_s) == ("resim", "/tf", "link2", "m", 0.0)
    assert row.max_error == pytest.approx(0.01)
    assert row.detail.startswith("link2: translation off by up to 0.01 m")


def test_first_exceed_is_when_the_error_starts(tmp_path: Path) -> None:
    """link3 shifted by 2 mm from t = 1 s, growing to 3 mm: first exceeded at 1 s, largest at the end."""
    from tests.recording_helpers import marm_trajectory, write_mcap
    from tfrec.kinematics import Transforms

    def shift(stamps: np.ndarray, transforms: Transforms) -> Transforms:
        k = transforms.children.index("link3")
        later = stamps >= DEFAULT_START_TIME_NS + 1_000_000_000  # one chunk holds every sample
        transforms.translation[later, k, 2] += np.linspace(0.002, 0.003, int(later.sum()))
        return transforms

    marm = load_robot("marm")
    path = write_mcap(tmp_path / "shifted.mcap", marm, marm_trajectory(marm), perturb=shift, chunk_samples=1000)
    head, row = check_recording(path)
    assert (row.check, row.frame, row.unit) == ("resim", "link3", "m")
    assert row.first_exceed_s == pytest.approx(1.0) and head.first_exceed_s == row.first_exceed_s
    assert row.max_error == pytest.approx(0.003)
    assert row.detail == ("link3: translation off by up to 0.003 m at t=2.000 s; first above 1e-06 m at "
                          "t=1.000 s")


def test_robot_path_replaces_the_description(tmp_path: Path, fleet_dir: Path) -> None:
    variant = tmp_path / "variant.urdf"
    variant.write_text(_mismatched(load_robot("marm").urdf))
    rows = check_recording(fleet_dir / "marm" / "sine.mcap", robot_path=variant)
    assert rows[0].verdict == FAIL and [(r.check, r.frame) for r in rows[1:]] == [("resim", "link2")]
    fixed = check_recording(fleet_dir / "bad" / "mismatch.mcap", robot_path=ROBOTS / "marm.xacro")
    assert [(r.check, r.verdict) for r in fixed] == [(SUMMARY, PASS)]


def test_the_wrong_robot_misses_frames(fleet_dir: Path) -> None:
    rows = check_recording(fleet_dir / "marm" / "sine.mcap", robot_path=ROBOTS / "mbot.xacro")
    assert rows[0].robot == "mbot" and rows[0].verdict == FAIL
    assert {r.check for r in rows[1:]} == {"frames"}
    assert "base_link" in {r.frame for r in rows[1:]}


@pytest.mark.parametrize("kind", ["rosbag2", "ros1"])
def test_no_description_is_a_finding_unless_a_robot_is_given(tmp_path: Path, fleet_dir: Path, kind: str) -> None:
    """ROS 1 keeps the description as a parameter: a bag `rosbag record` wrote has /tf, /tf_static and /joint_states
    only. Without --robot that is a finding (nothing to re-simulate with); with --robot it is none."""
    rec = read_recording(fleet_dir / "marm" / "sine.mcap")
    rec.robot_description = None
    bag = (write_rosbag2(rec, tmp_path / "no_description", storage="mcap") if kind == "rosbag2"
           else write_rosbag1(rec, tmp_path / "no_description.bag"))
    head, row = check_recording(bag)
    assert (head.verdict, row.check, row.detail) == (FAIL, "description", "no /robot_description in the recording")
    assert "nothing re-simulated" in head.detail
    rows = check_recording(bag, robot_path=ROBOTS / "marm.xacro")
    assert [(r.check, r.verdict) for r in rows] == [(SUMMARY, PASS)]
    assert rows[0].detail.startswith("9 of 9 frames re-simulated") and rows[0].robot == "marm"
    rec.tf[next(iter(rec.tf))].translation[5:, 2] += 0.01  # still checked: a wrong transform is found
    head, row = check_recording(write_rosbag1(rec, tmp_path / "moved.bag"), robot_path=ROBOTS / "marm.xacro")
    assert (head.verdict, row.check) == (FAIL, "resim")


def test_an_unusable_description_is_a_finding(tmp_path: Path, fleet_dir: Path) -> None:
    rec = read_recording(fleet_dir / "marm" / "sine.mcap")
    rec.robot_description = "<robot name='x'><link name='a'/><joint name='j' type='fixed'></joint></robot>"
    head, *rows = check_recording(write_rosbag2(rec, tmp_path / "bad_description", storage="mcap"))
    assert head.verdict == FAIL
    assert rows[0].check == "description"
    assert rows[0].detail.startswith("/robot_description is not a usable robot description: ")


def test_what_cannot_be_read_is_an_error_row(tmp_path: Path, fleet_dir: Path) -> None:
    (row,) = check_recording(tmp_path / "missing.mcap")
    assert row.verdict == ERROR and row.detail.endswith("missing.mcap: cannot read: No such file or directory")
    (row,) = check_recording(fleet_dir / "marm" / "sine.mcap", robot_path=tmp_path / "nope.urdf")
    assert row.verdict == ERROR and row.detail.startswith("robot_path: ") and "nope.urdf: no such file" in row.detail
    (row,) = check_recording(fleet_dir / "bad" / "garbage.mcap")
    assert row.verdict == ERROR and row.fingerprint and "not a recording" in row.detail


def test_a_recording_without_tf_cannot_be_re_simulated(tmp_path: Path, fleet_dir: Path) -> None:
    rec = read_recording(fleet_dir / "marm" / "sine.mcap")
    rec.tf = {}
    head, row = check_recording(write_rosbag2(rec, tmp_path / "no_tf", storage="mcap"))
    assert (head.verdict, row.check) == (FAIL, "resim")
    assert row.detail.startswith("cannot re-simulate: ") and "no /tf to compare" in row.detail


def test_the_row_has_the_report_columns() -> None:
    assert list(Row(file="x").to_dict()) == [column.name for column in REPORT_COLUMNS]


# -- health ---------------------------------------------------------------------------------------


def test_zero_and_repeated_stamps() -> None:
    t = np.array([0, 0, 10, 20, 20, 30], dtype=np.int64) * 10_000_000
    (finding,) = stamp_findings("/joint_states", "", t, origin_ns=0)
    assert (finding.check, finding.max_error, finding.unit) == ("stamps", 3.0, "stamps")
    assert finding.first_exceed_s == pytest.approx(0.2)
    assert finding.detail == ("/joint_states: 2 of 6 header stamps are zero; 1 stamp repeat the previous one "
                              "(first at t=0.200 s)")
    assert stamp_findings("/tf", "a", np.arange(5, dtype=np.int64) + 1, 0) == []


def test_gaps_against_the_median_period() -> None:
    t = np.concatenate([np.arange(0, 100), np.arange(110, 200), np.arange(203, 210)]).astype(np.int64) * 10_000_000
    (finding,) = rate_findings("/tf", "link1", t, origin_ns=0, gap_periods=5)
    assert (finding.check, finding.unit) == ("rate", "s")
    assert finding.max_error == pytest.approx(0.11) and finding.first_exceed_s == pytest.approx(0.99)
    assert "1 gap longer than 5 periods (median period 10 ms, 100 Hz)" in finding.detail
    assert rate_findings("/tf", "link1", t, origin_ns=0, gap_periods=20) == []
    assert rate_findings("/tf", "a", np.array([5, 5, 5], dtype=np.int64), 0) == []


def test_tf_pairs_with_one_gap_give_one_finding() -> None:
    t = np.array([1, 2, 3, 4, 20, 21], dtype=np.int64)
    other = np.array([1, 3, 5, 7, 9, 11], dtype=np.int64)
    findings = series_findings(None, {("a", "b"): t, ("b", "c"): t, ("c", "d"): other}, origin_ns=0)
    assert len(findings) == 1 and findings[0].frame == "b"
    assert findings[0].detail.endswith("(also 1 other frame: c)")


# -- diff_pair ------------------------------------------------------------------------------------


def test_a_pair_that_matches_passes(tmp_path: Path, fleet_dir: Path) -> None:
    copy = shutil.copy(fleet_dir / "marm" / "sine.mcap", tmp_path / "copy.mcap")
    (head,) = diff_pair(fleet_dir / "marm" / "sine.mcap", copy, key="sine.mcap", config="d")
    assert (head.file, head.verdict, head.robot, head.config) == ("sine.mcap", PASS, "marm", "d")
    assert head.detail.startswith("identical within tolerance; largest translation 0 m, rotation 0 rad")
    assert head.fingerprint.count("|") == 1 and head.size == 2 * Path(copy).stat().st_size


def test_a_pair_that_differs_has_a_row_per_difference(fleet_dir: Path) -> None:
    head, *rows = diff_pair(fleet_dir / "marm" / "sine.mcap", fleet_dir / "bad" / "mismatch.mcap")
    assert head.verdict == FAIL and head.file == os.fspath(fleet_dir / "marm" / "sine.mcap")
    assert {r.check for r in rows} == {"description"}
    head, *rows = diff_pair(fleet_dir / "marm" / "sine.mcap", fleet_dir / "marm" / "random.mcap", rot_tol=0.1)
    tf = [r for r in rows if r.check == "tf"]
    assert tf and all(r.topic == "/tf" and r.unit in ("m", "rad") and r.first_exceed_s is not None for r in tf)
    assert {r.unit for r in rows if r.check == "joint_states"} == {"joint"}


def test_a_one_sided_pair_is_a_finding(fleet_dir: Path) -> None:
    head, row = diff_pair(None, fleet_dir / "marm" / "sine.mcap", key="sine.mcap")
    assert (head.verdict, row.check, row.verdict) == (FAIL, "missing", FAIL)
    assert row.detail.startswith("only in B (") and row.detail.endswith("no recording at this path in A")
    assert head.fingerprint.startswith("-|")


def test_an_unreadable_side_is_an_error(fleet_dir: Path) -> None:
    (head,) = diff_pair(fleet_dir / "marm" / "sine.mcap", fleet_dir / "bad" / "garbage.mcap", key="k")
    assert head.verdict == ERROR and "not a recording" in head.detail


# -- fingerprints ---------------------------------------------------------------------------------


def test_an_mcap_fingerprint_hashes_the_summary_only(tmp_path: Path, fleet_dir: Path) -> None:
    path = Path(shutil.copy2(fleet_dir / "marm" / "sine.mcap", tmp_path / "a.mcap"))
    before = fingerprint(path)
    assert before == fingerprint(path) and before.size == path.stat().st_size
    stat = path.stat()
    data = bytearray(path.read_bytes())
    data[200] ^= 0xFF  # inside the data section: not hashed
    path.write_bytes(bytes(data))
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert fingerprint(path) == before
    data[-40] ^= 0xFF  # inside the summary section (and its CRC no longer holds: the ends are hashed)
    path.write_bytes(bytes(data))
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert fingerprint(path).digest != before.digest
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1))
    assert fingerprint(path).mtime_ns == stat.st_mtime_ns + 1


def test_bag_fingerprints(tmp_path: Path, fleet_dir: Path) -> None:
    bag = fleet_dir / "bad" / "gap_bag"
    print_ = fingerprint(bag)
    assert print_.size == sum(f.stat().st_size for f in bag.iterdir())
    assert print_.mtime_ns == max(f.stat().st_mtime_ns for f in bag.iterdir())
    ros1 = write_rosbag1(read_recording(fleet_dir / "marm" / "sine.mcap"), tmp_path / "a.bag")
    first = fingerprint(ros1)
    data = bytearray(ros1.read_bytes())
    stat = ros1.stat()
    data[5000] ^= 0xFF  # a message, not the index
    ros1.write_bytes(bytes(data))
    os.utime(ros1, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert fingerprint(ros1) == first
    with pytest.raises(FleetError, match=r"nope\.bag: cannot read: No such file or directory"):
        fingerprint(tmp_path / "nope.bag")
