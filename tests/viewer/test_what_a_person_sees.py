"""What a person sees in the viewer (issue 26): a timeline in seconds from the recording's start, shown first."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.conftest import REPO
from tfrec import cli

MARM = str(REPO / "robots" / "marm.xacro")


def test_every_sample_is_also_on_a_timeline_of_seconds_from_the_start(tmp_path: Path) -> None:
    """record --start-time far from 0: beside ros_time (a date), the `time` timeline counts from 0 to the duration,
    as durations; the blueprint's time panel shows it."""
    from rerun.chunk import RrdReader

    rrd = tmp_path / "r.rrd"
    assert cli.main(["record", MARM, "--duration", "2", "--rate", "10", "--no-mcap", "--rrd", str(rrd),
                     "--start-time", "1800000000"]) == 0
    elapsed: list[int] = []
    stamps: list[int] = []
    types = set()
    for chunk in RrdReader(rrd).stream():
        batch = chunk.to_record_batch()
        if chunk.entity_path == "/joints/joint1" and "time" in batch.schema.names:
            elapsed += batch.column("time").cast("int64").to_pylist()
            stamps += batch.column("ros_time").cast("int64").to_pylist()
            types.add(str(batch.schema.field("time").type))
    assert elapsed == [i * 100_000_000 for i in range(21)]
    assert np.all(np.array(stamps) - np.array(elapsed) == 1_800_000_000 * 10**9)
    assert len(types) == 1 and types.pop().startswith("duration")
