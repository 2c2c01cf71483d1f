"""``tfrec diff`` of two recordings read piece by piece: the report is the one of the whole recordings."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

from tests.recording_helpers import marm_trajectory, write_mcap, write_rosbag1, write_rosbag2
from tfrec.diff.compare import compare
from tfrec.formats.mcap.writer import DEFAULT_START_TIME_NS
from tfrec.formats.reader import read_recording
from tfrec.model import Robot
from tfrec.recording import FrameSeries, JointStates, Recording


def _changed(rec: Recording) -> Recording:
    """B: one joint fewer in /joint_states, one /tf frame pair fewer, one pair moved by 1 mm for a while."""
    js = rec.joint_states
    assert js is not None and len(js.names) > 2
    rec.joint_states = JointStates(js.time_ns, js.names[:-1], js.positions[:, :-1].copy(), js.repeated)
    pairs = list(rec.tf)
    del rec.tf[pairs[-1]]
    series = rec.tf[pairs[1]]
    translation = series.translation.copy()
    translation[len(translation) // 3: len(translation) // 2, 0] += 1e-3
    rec.tf[pairs[1]] = FrameSeries(series.time_ns, translation, series.rotation)
    return rec


@pytest.fixture(scope="module")
def pairs(tmp_path_factory: pytest.TempPathFactory, marm: Robot) -> list[tuple[Path, Path]]:
    """(A, B) pairs of every format (MCAP chunks of about 2 kB, so that pieces are small): B at another rate, shorter, starting 7 s later on the clock, with a joint and
    a frame missing and a pair moved; and B the same as A but for its start."""
    folder = tmp_path_factory.mktemp("pieces")
    a = write_mcap(folder / "a.mcap", marm, marm_trajectory(marm), chunk_samples=5, chunk_bytes=2000)
    slower = write_mcap(folder / "slower.mcap", marm, marm_trajectory(marm, duration_s=1.5, rate_hz=30.0),
                        start_time_ns=DEFAULT_START_TIME_NS + 7 * 10**9, chunk_samples=5, chunk_bytes=2000)
    later = write_mcap(folder / "later.mcap", marm, marm_trajectory(marm),
                       start_time_ns=DEFAULT_START_TIME_NS + 3 * 10**9, chunk_samples=5, chunk_bytes=2000)
    changed = _changed(read_recording(slower))
    a_rec = read_recording(a)
    return [
        (a, later),
        (a, slower),
        (slower, a),
        (a, write_rosbag1(changed, folder / "changed.bag")),
        (write_rosbag2(changed, folder / "changed_sqlite"), a),
        (write_rosbag1(a_rec, folder / "a.bag"), write_rosbag2(changed, folder / "changed_sqlite2")),
    ]


@pytest.mark.parametrize("options", [{}, {"absolute": True}, {"topics": ["/tf"]}, {"pos_tol": 1e-2}])
def test_pieces_give_the_whole_report(pairs: list[tuple[Path, Path]], options: dict[str, Any],
                                      monkeypatch: pytest.MonkeyPatch) -> None:
    wholes = [compare(a, b, whole=True, **options) for a, b in pairs]
    assert any(not report.equal for report in wholes)
    if not options.get("absolute"):  # with it, B's samples 7 s later meet none of A's
        assert any("interpolated" in note for report in wholes for note in report.notes)

    def refused(*args: object, **kwargs: object) -> Recording:
        raise AssertionError("a recording read whole")

    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    monkeypatch.setattr(sys.modules["tfrec.diff.compare"], "read_recording", refused)
    for (a, b), whole in zip(pairs, wholes):
        pieces = compare(a, b, **options)
        assert pieces.to_json() == whole.to_json(), (a, b)
        assert pieces.to_text() == whole.to_text()


def test_pieces_hold_a_piece_of_each_series(pairs: list[tuple[Path, Path]], monkeypatch: pytest.MonkeyPatch) -> None:
    """No fold holds more than about a piece of samples of A or B while the pieces are walked."""
    from tfrec.diff.fold import SeriesFold

    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    held: list[int] = []
    run = SeriesFold.run

    def spy(self: SeriesFold, *, final: bool = False) -> None:
        run(self, final=final)
        held.append(max(len(self._a_time), len(self._b_time)))

    monkeypatch.setattr(SeriesFold, "run", spy)
    a, b = pairs[1]
    compare(a, b)
    assert held and max(held) <= 3 * 7


def test_stamps_that_go_back_read_the_whole_recordings(tmp_path: Path, pairs: list[tuple[Path, Path]],
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """A /tf series whose stamps go back is compared as the whole recording compares it."""
    rec = read_recording(pairs[0][0])
    pair = next(iter(rec.tf))
    series = rec.tf[pair]
    time_ns = series.time_ns.copy()
    time_ns[40] = time_ns[5]  # a stamp from the past, logged in order
    rec.tf[pair] = FrameSeries(time_ns, series.translation, series.rotation)
    back = write_rosbag1(rec, tmp_path / "back.bag")
    whole = compare(pairs[0][0], back, whole=True)
    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    module = sys.modules["tfrec.diff.compare"]
    read: list[object] = []

    def reading(path: object, **options: Any) -> Recording:
        read.append(path)
        return read_recording(path, **options)  # type: ignore[arg-type]

    monkeypatch.setattr(module, "read_recording", reading)
    assert compare(pairs[0][0], back).to_json() == whole.to_json()
    assert read == [pairs[0][0], back]
