"""Reading tfrec's Rerun recording (``.rrd``) into a :class:`~tfrec.recording.Recording`.

Through Rerun's own reader (``rerun.chunk.RrdReader``, run in a child process: it aborts the process on
some damaged files), with the entity paths and the timeline of :mod:`tfrec.formats.rrd.paths`:
``/tf/<joint>`` and ``/tf_static/<joint>`` (Transform3D with parent and child frames), ``/joints/<joint>``
(Scalars) and ``/robot_description`` (TextDocument). Rerun stores transforms as float32, joint positions as float64. An ``.rrd``
has no topics: its entities are listed under the topics they stand for.
"""

from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC
from tfrec.errors import ReadError
from tfrec.recording import FrameSeries, JointStates, Recording, TopicInfo

__all__ = ["RRD_MAGIC", "read_rrd"]

Array = NDArray[np.float64]

RRD_MAGIC = b"RRF2"


def read_rrd(path: Path, wanted: frozenset[str]) -> Recording:
    """Read an ``.rrd`` written by :class:`tfrec.formats.rrd.sink.RerunSink`, decoding the topics in ``wanted``.

    Raises:
        ReadError: Rerun cannot read the file (damaged or not an RRD).
    """
    import pyarrow as pa

    from tfrec.formats.rrd import paths as rerun_paths

    where = os.fspath(path)
    recording = Recording(path=where, format="rrd", float32=True)
    tf_parts: dict[tuple[str, ...], list[tuple[NDArray[np.int64], Array, Array, tuple[str, str]]]] = {}
    joint_parts: dict[str, list[tuple[NDArray[np.int64], Array]]] = {}
    static: dict[tuple[str, str], tuple[Array, Array]] = {}
    description: str | None = None
    timeline = rerun_paths.TIMELINE
    for entity_path, batch in _read_chunks(path):
        top, names = rerun_paths.parse_entity(entity_path)
        if top not in (rerun_paths.TF_ROOT, rerun_paths.TF_STATIC_ROOT, rerun_paths.JOINTS_ROOT,
                       rerun_paths.DESCRIPTION_ROOT):
            continue
        columns = {name: batch.column(i) for i, name in enumerate(batch.schema.names)}
        if top == rerun_paths.DESCRIPTION_ROOT:
            text = columns.get("TextDocument:text")
            if text is not None and len(text):
                values = text.flatten()
                if len(values):
                    description = str(values[len(values) - 1].as_py())
            continue
        time = None
        if timeline in columns:
            time = np.asarray(columns[timeline].cast(pa.int64()).to_numpy(zero_copy_only=False), dtype=np.int64)
        if top == rerun_paths.JOINTS_ROOT:
            scalars = columns.get("Scalars:scalars")
            if scalars is None or time is None:
                continue
            values, keep = _one_per_row(scalars, 1)
            joint_parts.setdefault("/".join(names), []).append((time[keep], values[keep, 0]))
            continue
        translation = columns.get("Transform3D:translation")
        quaternion = columns.get("Transform3D:quaternion")
        parent = columns.get("Transform3D:parent_frame")
        child = columns.get("Transform3D:child_frame")
        if translation is None or quaternion is None or parent is None or child is None:
            continue
        t_values, t_valid = _one_per_row(translation, 3)
        q_values, q_valid = _one_per_row(quaternion, 4)
        keep = t_valid & q_valid
        if not keep.any():
            continue
        pair = (str(parent.flatten()[0].as_py()), str(child.flatten()[0].as_py()))
        if top == rerun_paths.TF_STATIC_ROOT or time is None:
            static[pair] = (t_values[keep][-1], q_values[keep][-1])
        else:
            tf_parts.setdefault(names, []).append((time[keep], t_values[keep], q_values[keep], pair))
    if ROBOT_DESCRIPTION in wanted:
        recording.robot_description = description
    topics: dict[str, TopicInfo] = {}
    if description is not None:
        topics[ROBOT_DESCRIPTION] = TopicInfo("TextDocument", 1, None, None)
    if static:
        topics[TF_STATIC] = TopicInfo("Transform3D", 1, None, None)
    if TF_STATIC in wanted:
        recording.tf_static = static
    times: list[NDArray[np.int64]] = []
    if joint_parts:
        names = tuple(joint_parts)
        series = {name: _concat_series(parts) for name, parts in joint_parts.items()}
        all_times = np.unique(np.concatenate([time for time, _ in series.values()]))
        positions = np.full((len(all_times), len(names)), np.nan)
        for j, name in enumerate(names):
            time, value = series[name]
            positions[np.searchsorted(all_times, time), j] = value
        topics[JOINT_STATES] = TopicInfo("Scalars", len(all_times), int(all_times[0]), int(all_times[-1]))
        times.append(all_times)
        if JOINT_STATES in wanted:
            recording.joint_states = JointStates(all_times, names, positions)
    if tf_parts:
        tf_times = []
        for parts in tf_parts.values():
            time = np.concatenate([p[0] for p in parts])
            translation = np.concatenate([p[1] for p in parts])
            rotation = np.concatenate([p[2] for p in parts])
            order = np.argsort(time, kind="stable")
            tf_times.append(time)
            if TF in wanted:
                recording.tf[parts[0][3]] = FrameSeries(time[order], translation[order], rotation[order])
        all_times = np.unique(np.concatenate(tf_times))
        topics[TF] = TopicInfo("Transform3D", len(all_times), int(all_times[0]), int(all_times[-1]))
        times.append(all_times)
    recording.topics = dict(sorted(topics.items()))
    if times:
        recording.start_ns = int(min(t[0] for t in times))
        recording.end_ns = int(max(t[-1] for t in times))
    return recording


def _read_chunks(path: Path) -> list[tuple[str, Any]]:
    """(entity path, pyarrow RecordBatch) of every chunk of an ``.rrd``, decoded by Rerun in a child process
    (:mod:`tfrec.formats.rrd._read_child`): Rerun's reader aborts the process on some damaged files.

    Raises:
        ReadError: Rerun refused the file, or its reader crashed on it.
    """
    import pyarrow as pa

    from tfrec.formats.rrd import _read_child

    where = os.fspath(path)
    try:
        child = subprocess.run([sys.executable, _read_child.__file__, os.fspath(path)], capture_output=True,
                               check=False, env={**os.environ, "RUST_LOG": "off", "RUST_BACKTRACE": "0"})
    except OSError as err:
        raise ReadError(f"{where}: cannot start Rerun's reader: {err.strerror or err}") from err
    if child.returncode == _read_child.REFUSED:
        reason = " ".join(child.stderr.decode(errors="replace").split()) or "no reason given"
        raise ReadError(f"{where}: unreadable Rerun recording: {reason}")
    if child.returncode != 0:
        how = (f"killed by {signal.Signals(-child.returncode).name}" if child.returncode < 0
               else f"exit code {child.returncode}")
        raise ReadError(f"{where}: unreadable Rerun recording: Rerun's reader crashed on it ({how}); the file is "
                        "damaged")
    chunks: list[tuple[str, Any]] = []
    data = memoryview(child.stdout)
    pos = 0
    try:
        while pos < len(data):
            (size,) = struct.unpack_from("<Q", data, pos)
            batch = pa.ipc.open_stream(pa.py_buffer(data[pos + 8:pos + 8 + size])).read_next_batch()
            pos += 8 + size
            entity = (batch.schema.metadata or {}).get(_read_child.ENTITY_PATH, b"").decode(errors="replace")
            chunks.append((entity, batch))
    except (pa.ArrowInvalid, struct.error) as err:
        raise ReadError(f"{where}: unreadable Rerun recording: {err}") from err
    return chunks


def _one_per_row(column: Any, width: int) -> tuple[Array, NDArray[np.bool_]]:
    """The last instance of each row of a list<fixed_size_list<float>[width]> (or list<float>) column.

    Returns:
        (values (rows, width), valid (rows,)): rows without an instance (cleared) are NaN and
        not valid.
    """
    import pyarrow as pa

    if isinstance(column, pa.ChunkedArray):
        column = column.combine_chunks()
    offsets = np.asarray(column.offsets.to_numpy(zero_copy_only=False), dtype=np.int64)
    counts = np.diff(offsets)
    valid = counts >= 1
    if column.null_count:
        valid &= ~np.asarray(column.is_null().to_numpy(zero_copy_only=False), dtype=bool)
    inner = column.values
    flat = inner.flatten() if isinstance(inner.type, pa.FixedSizeListType) else inner
    values = np.asarray(flat.to_numpy(zero_copy_only=False), dtype=np.float64).reshape(-1, width)
    out = np.full((len(counts), width), np.nan)
    out[valid] = values[(offsets[:-1] + counts - 1)[valid]]
    return out, valid


def _concat_series(parts: list[tuple[NDArray[np.int64], Array]]) -> tuple[NDArray[np.int64], Array]:
    time = np.concatenate([p[0] for p in parts])
    value = np.concatenate([p[1] for p in parts])
    order = np.argsort(time, kind="stable")
    return time[order], value[order]
