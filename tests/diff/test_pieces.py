"""``tfrec diff`` of two recordings read piece by piece: the report is the one of the whole recordings."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

from tests.recording_helpers import marm_trajectory, write_mcap, write_rosbag1, write_rosbag2
from tfrec.diff.compare import compare
from tfrec.errors import TfrecWarning
from tfrec.formats.mcap.writer import DEFAULT_START_TIME_NS
from tfrec.formats.reader import read_recording
from tfrec.model import Robot
from tfrec.recording import FrameSeries, JointStates, Recording


def _small_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    """ROS 1 bags written (by rosbags) in chunks of about 2 kB, sqlite3 bags read 5 rows at a time: small pieces."""
    from rosbags.rosbag1 import Writer

    init = Writer.__init__

    def small(self: Writer, path: Path | str) -> None:
        init(self, path)
        self.chunk_threshold = 2000

    monkeypatch.setattr(Writer, "__init__", small)
    monkeypatch.setattr("tfrec.formats.rosbag2.source.BATCH_MESSAGES", 5)


def _pieces_of(path: Path) -> int:
    from tfrec.formats.reader import read_pieces

    return sum(1 for _ in read_pieces(path))


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
    with pytest.MonkeyPatch.context() as monkeypatch:
        _small_chunks(monkeypatch)
        return _pairs(folder, marm)


def _pairs(folder: Path, marm: Robot) -> list[tuple[Path, Path]]:
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


@pytest.mark.parametrize("options", [{}, {"absolute": True}, {"topics": ["/tf"]}, {"pos_tol": 1e-2}, {"use_log_time": True}])
def test_pieces_give_the_whole_report(pairs: list[tuple[Path, Path]], options: dict[str, Any],
                                      monkeypatch: pytest.MonkeyPatch) -> None:
    wholes = [compare(a, b, whole=True, **options) for a, b in pairs]
    assert any(not report.equal for report in wholes)
    if not options.get("absolute"):  # with it, B's samples 7 s later meet none of A's
        assert any("interpolated" in note for report in wholes for note in report.notes)

    def refused(*args: object, **kwargs: object) -> Recording:
        raise AssertionError("a recording read whole")

    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    _small_chunks(monkeypatch)
    assert all(_pieces_of(path) > 5 for pair in pairs for path in pair)
    monkeypatch.setattr(sys.modules["tfrec.diff.compare"], "read_recording", refused)
    for (a, b), whole in zip(pairs, wholes):
        pieces = compare(a, b, **options)
        assert pieces.to_json() == whole.to_json(), (a, b)
        assert pieces.to_text() == whole.to_text()


def test_pieces_hold_a_piece_of_each_series(pairs: list[tuple[Path, Path]], monkeypatch: pytest.MonkeyPatch) -> None:
    """No fold holds more than about a piece of samples of A or B while the pieces are walked."""
    from tfrec.diff.fold import SeriesFold

    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    _small_chunks(monkeypatch)
    held: list[int] = []
    run = SeriesFold.run

    def spy(self: SeriesFold, *, final: bool = False) -> None:
        run(self, final=final)
        held.append(max(len(self._a_time), len(self._b_time)))

    monkeypatch.setattr(SeriesFold, "run", spy)
    for a, b in pairs:
        compare(a, b)
    assert held and max(held) <= 7


def test_stamps_that_go_back_read_the_whole_recordings(tmp_path: Path, pairs: list[tuple[Path, Path]],
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """A /tf series whose stamps go back is compared as the whole recording compares it."""
    rec = read_recording(pairs[0][0])
    pair = next(iter(rec.tf))
    series = rec.tf[pair]
    time_ns = series.time_ns.copy()
    time_ns[40] = time_ns[5]  # a stamp from the past, logged in order
    rec.tf[pair] = FrameSeries(time_ns, series.translation, series.rotation)
    _small_chunks(monkeypatch)
    back = write_rosbag1(rec, tmp_path / "back.bag")
    whole = compare(pairs[0][0], back, whole=True)
    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    _small_chunks(monkeypatch)
    module = sys.modules["tfrec.diff.compare"]
    read: list[object] = []

    def reading(path: object, **options: Any) -> Recording:
        read.append(path)
        return read_recording(path, **options)  # type: ignore[arg-type]

    monkeypatch.setattr(module, "read_recording", reading)
    with pytest.warns(TfrecWarning) as said:
        assert compare(pairs[0][0], back).to_json() == whole.to_json()
    assert read == [pairs[0][0], back]
    expected = (f"{back}: the stamps of a /joint_states or /tf series go back or repeat (a chunk given twice, "
                "messages out of order): read whole to compare them, in memory that grows with its length")
    assert [str(w.message) for w in said] == [expected]  # the one whose stamps go back, and why memory grows


@pytest.mark.parametrize("kind", ["sqlite3", "ros1"])  # (rosbags writes a rosbag2 MCAP in one chunk)
def test_pieces_of_several_robots_give_the_whole_report(tmp_path: Path, pairs: list[tuple[Path, Path]], kind: str,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Two robots in namespaces, B's /robot2 changed (another rate, shorter, a joint and a frame missing), against
    one robot; ``namespace`` picks one of them."""
    from tests.bag_builders import Robot as Published
    from tests.bag_builders import write_bag

    _small_chunks(monkeypatch)
    same = read_recording(pairs[0][0])
    changed = _changed(read_recording(pairs[1][1]))
    suffix = ".bag" if kind == "ros1" else ""
    a = write_bag(tmp_path / f"a{suffix}", [Published(same, namespace="/robot1"), Published(same, namespace="/robot2")],
                  kind=kind)
    b = write_bag(tmp_path / f"b{suffix}", [Published(same, namespace="/robot1"),
                                            Published(changed, namespace="/robot2")], kind=kind)
    cases = [(a, b, {}), (b, a, {}), (a, b, {"namespace": "/robot2"}), (pairs[0][0], b, {})]
    wholes = [compare(x, y, whole=True, **options) for x, y, options in cases]
    assert not wholes[0].equal and any("robot /robot2" in d.detail for d in wholes[0].differences)
    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    assert _pieces_of(a) > 5 and _pieces_of(b) > 5
    for (x, y, options), whole in zip(cases, wholes):
        assert compare(x, y, **options).to_json() == whole.to_json()


def test_a_recording_of_one_piece_is_read_once(pairs: list[tuple[Path, Path]], monkeypatch: pytest.MonkeyPatch) -> None:
    """A short recording (one piece) is read once and compared as it is, beside a long one read piece by piece (its
    first walk and its second): the report is the whole recordings' and says whether it holds every sample."""
    from tfrec.formats import reader

    a, slower = pairs[1]
    whole = compare(a, slower, whole=True)
    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 100)
    assert _pieces_of(slower) == 1 < _pieces_of(a)
    module = sys.modules["tfrec.diff.compare"]
    walks: list[object] = []

    def counted(path: object, **options: Any) -> Any:
        walks.append(path)
        return reader.read_pieces(path, **options)  # type: ignore[arg-type]

    monkeypatch.setattr(module, "read_pieces", counted)
    for x, y in ((a, slower), (slower, a), (slower, slower)):
        walks.clear()
        report = compare(x, y)
        counted_walks = list(walks)
        assert report.to_json() == compare(x, y, whole=True).to_json()
        assert counted_walks.count(slower) == (1 if x != y else 2)  # one piece each side: read once
        assert counted_walks.count(a) == (2 if a in (x, y) else 0)  # its first walk (from its first piece), its second
        assert report.whole == (a not in (x, y))
    assert compare(a, slower).to_json() == whole.to_json()


def test_a_report_of_pieces_is_not_plotted(pairs: list[tuple[Path, Path]], monkeypatch: pytest.MonkeyPatch) -> None:
    """The errors of a comparison read piece by piece are not in its report (it holds each series' first and last
    stamp): plotting it is one error, not a plot of two points; ``whole=True`` plots every sample."""
    from tfrec.plots import errors_from_diff
    from tfrec.plots._figure import PlotError

    a, b = pairs[0]
    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    pieces = compare(a, b)
    assert not pieces.whole
    with pytest.raises(PlotError, match="piece by piece"):
        errors_from_diff(pieces)
    whole = compare(a, b, whole=True)
    series = errors_from_diff(whole)
    assert whole.whole and series and max(len(s.t_s) for s in series) == len(next(iter(whole.a.tf.values())))


@pytest.mark.parametrize("kind", ["bag", "mcap"])
def test_damaged_recordings_give_the_whole_report(tmp_path: Path, pairs: list[tuple[Path, Path]], kind: str,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Bytes overwritten or cut at places spread over a recording: read piece by piece, it compares as it does read
    whole — its topic table counts what could be read of the time series (their own walk), not the index's counts."""
    import random
    import warnings

    intact = pairs[3][1] if kind == "bag" else pairs[0][0]
    data = intact.read_bytes()
    monkeypatch.setattr("tfrec.formats.reader.PIECE_MESSAGES", 7)
    rng = random.Random(3)
    compared = 0
    for k in range(24):
        damaged = bytearray(data)
        at = len(data) * (k + 1) // 26
        damaged[at: at + 64] = bytes(rng.randrange(256) for _ in range(64))
        if k % 4 == 0:
            damaged = damaged[: at + 200]
        path = tmp_path / f"damaged{k}.{kind}"
        path.write_bytes(bytes(damaged))
        outcomes = []
        for whole in (False, True):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    outcomes.append(compare(path, intact, whole=whole).to_json())
                except Exception as err:  # the same error either way  # noqa: BLE001
                    outcomes.append(f"{type(err).__name__}: {err}")
        assert outcomes[0] == outcomes[1], (k, at)
        compared += outcomes[0].startswith("{")
    assert compared >= 5  # most damage still leaves a report to compare
