"""tfrec under an address-space limit (``ulimit -v``, ``RLIMIT_AS``; issue 20): writing an ``.rrd`` gave a
"can't start new thread" traceback, a SIGABRT from Rerun's Rust (a failed allocation, a thread that could not start)
or a hang, at limits from 500 MiB up to 2 GiB — glibc's arena per thread, OpenBLAS's buffers and Rerun's mimalloc
(which reserves 1 GiB at once) exhaust the address space long before memory. Each run here is a process of its own
under ``ulimit -v`` (``RLIMIT_AS``, with nothing in its environment to make it frugal: tfrec must do that
itself) and ``ulimit -t`` (``RLIMIT_CPU``) = 30 s as the hang guard: it ends with exit 0 and outputs an independent reader
reads, or exit 2 and one ``tfrec: error:`` line — never a signal, a traceback or a hang."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from tests.conftest import ROBOTS
from tfrec._address_space import FRUGAL_ENVIRONMENT, RERUN_MIN_ADDRESS_SPACE

REPO = Path(__file__).resolve().parents[2]
CPU_S = 30
BACKSTOP_S = 600  # only a run that waits without using CPU time meets it: a hang, reported as one


def _tfrec(argv: list[str], cwd: Path, *, limit_mib: int) -> subprocess.CompletedProcess[str]:
    """``python -m tfrec argv`` under ``RLIMIT_AS`` = ``limit_mib`` MiB and ``RLIMIT_CPU``; asserts the contract: no
    signal, no traceback, no hang, stderr only tfrec's own lines, one error line exactly when the exit code is 2."""

    env = {name: value for name, value in os.environ.items() if name not in FRUGAL_ENVIRONMENT}
    env["PYTHONPATH"] = str(REPO)
    # the limits hold from exec on, as a user's ulimit sets them (the shell sets them, then becomes tfrec)
    script = f'ulimit -v {limit_mib << 10} && ulimit -t {CPU_S} && exec "$0" -m tfrec "$@"'
    process = subprocess.Popen(["/bin/sh", "-c", script, sys.executable, *argv], cwd=cwd, env=env, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        out, err = process.communicate(timeout=BACKSTOP_S)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail(f"tfrec {' '.join(argv)} under {limit_mib} MiB: a hang (no result, no CPU time used up)")
    where = f"tfrec {' '.join(argv)} under ulimit -v {limit_mib} MiB"
    assert process.returncode >= 0, f"{where}: killed by {signal.Signals(-process.returncode).name}\n{err[-2000:]}"
    assert process.returncode in (0, 2), f"{where}: exit {process.returncode}\n{err[-2000:]}"
    lines = err.splitlines()
    assert all(line.startswith(("tfrec: error: ", "tfrec: warning: ")) for line in lines), f"{where}:\n{err[-2000:]}"
    errors = [line for line in lines if line.startswith("tfrec: error: ")]
    assert len(errors) == (process.returncode == 2), f"{where}:\n{err[-2000:]}"
    return subprocess.CompletedProcess(argv, process.returncode, out, err)


def _mcap_messages(path: Path) -> int:
    with open(path, "rb") as stream:  # mcap's own reader
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics is not None
    return summary.statistics.message_count


def _rrd_chunks(path: Path) -> int:
    import rerun as rr  # rerun's own reader

    return sum(1 for _ in rr.chunk.RrdReader(path).stream())


@pytest.mark.parametrize("limit_mib", [512, 900, 1024, 1536, 2048])
def test_record_with_an_rrd_under_an_address_space_limit(tmp_path: Path, limit_mib: int) -> None:
    done = _tfrec(["record", str(ROBOTS / "marm.xacro"), "-o", "out.mcap", "--duration", "1"], tmp_path,
                  limit_mib=limit_mib)
    if limit_mib << 20 < RERUN_MIN_ADDRESS_SPACE:  # refused up front, naming the output and both figures
        assert done.returncode == 2
        assert done.stderr == (f"tfrec: error: out.rrd: a Rerun recording needs an address space of at least "
                               f"{RERUN_MIN_ADDRESS_SPACE >> 20:,} MiB; ulimit -v is {limit_mib:,} MiB (raise it, or "
                               "write no .rrd)\n")
        assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing written, nothing left
        return
    assert done.returncode == 0, done.stderr
    assert _mcap_messages(tmp_path / "out.mcap") > 0 and _rrd_chunks(tmp_path / "out.rrd") > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.mcap", "out.rrd"]


def _mesh_robot(folder: Path) -> Path:
    """A URDF whose visuals are an STL (binary, a tetrahedron) and a COLLADA file, both written here."""
    import struct

    corners = [(0.0, 0.0, 0.0), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0), (0.0, 0.0, 0.1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    stl = b"\0" * 80 + struct.pack("<I", len(faces)) + b"".join(
        struct.pack("<12fH", 0, 0, 0, *corners[a], *corners[b], *corners[c], 0) for a, b, c in faces)
    (folder / "tetra.stl").write_bytes(stl)
    positions = " ".join(f"{v:g}" for corner in corners for v in corner)
    indices = " ".join(str(i) for face in faces for i in face)
    (folder / "tetra.dae").write_text(
        '<?xml version="1.0"?><COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">'
        '<asset><unit meter="1"/><up_axis>Z_UP</up_axis></asset><library_geometries><geometry id="g"><mesh>'
        f'<source id="p"><float_array id="pa" count="12">{positions}</float_array><technique_common>'
        '<accessor source="#pa" count="4" stride="3"><param name="X" type="float"/><param name="Y" type="float"/>'
        '<param name="Z" type="float"/></accessor></technique_common></source><vertices id="v"><input '
        'semantic="POSITION" source="#p"/></vertices><triangles count="4"><input semantic="VERTEX" source="#v" '
        f'offset="0"/><p>{indices}</p></triangles></mesh></geometry></library_geometries><library_visual_scenes>'
        '<visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node></visual_scene>'
        '</library_visual_scenes><scene><instance_visual_scene url="#s"/></scene></COLLADA>')
    urdf = folder / "meshy.urdf"
    urdf.write_text('<robot name="meshy"><link name="a"><visual><geometry><mesh filename="tetra.stl"/></geometry>'
                    '</visual></link><link name="b"><visual><geometry><mesh filename="tetra.dae"/></geometry></visual>'
                    '</link><joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
                    '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    return urdf


@pytest.mark.parametrize("limit_mib", [512, 1024, 2048])
def test_record_of_meshes_under_an_address_space_limit(tmp_path: Path, limit_mib: int) -> None:
    """Meshes are read with trimesh (and pycollada) before Rerun starts: more address space again."""
    urdf = _mesh_robot(tmp_path)
    done = _tfrec(["record", str(urdf), "-o", "out.mcap", "--duration", "1"], tmp_path, limit_mib=limit_mib)
    if limit_mib << 20 < RERUN_MIN_ADDRESS_SPACE:
        assert done.returncode == 2 and "out.rrd: a Rerun recording needs an address space" in done.stderr
        return
    assert done.returncode == 0 and "mesh" not in done.stderr, done.stderr  # both meshes shown
    assert _rrd_chunks(tmp_path / "out.rrd") > 0


@pytest.mark.parametrize("limit_mib", [512, 1024])
def test_record_without_an_rrd_works_under_a_small_limit(tmp_path: Path, limit_mib: int) -> None:
    done = _tfrec(["record", str(ROBOTS / "marm.xacro"), "-o", "out.mcap", "--duration", "1", "--no-rrd"], tmp_path,
                  limit_mib=limit_mib)
    assert done.returncode == 0, done.stderr
    assert _mcap_messages(tmp_path / "out.mcap") > 0


@pytest.mark.parametrize("limit_mib", [512, 1536])
def test_convert_to_an_rrd_under_an_address_space_limit(tmp_path: Path, limit_mib: int) -> None:
    from tfrec import cli

    assert cli.main(["record", str(ROBOTS / "marm.xacro"), "-o", str(tmp_path / "in.mcap"), "--duration", "1",
                     "--no-rrd"]) == 0
    done = _tfrec(["convert", "in.mcap", "out.rrd"], tmp_path, limit_mib=limit_mib)
    if limit_mib << 20 < RERUN_MIN_ADDRESS_SPACE:
        assert done.returncode == 2 and "out.rrd: a Rerun recording needs an address space of at least" in done.stderr
        assert not (tmp_path / "out.rrd").exists()
    else:
        assert done.returncode == 0, done.stderr
        assert _rrd_chunks(tmp_path / "out.rrd") > 0
