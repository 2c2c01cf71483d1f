"""Reading tfrec's Rerun recording (``.rrd``) into a :class:`~tfrec.recording.Recording`.

Through Rerun's own reader (``rerun.chunk.RrdReader``, run in a child process: it aborts the process on
some damaged files), with the entity paths and the timeline
of :mod:`tfrec.formats.rrd.paths`: ``/tf/<joint>`` and ``/tf_static/<joint>`` (Transform3D with
parent and child frames), ``/joints/<joint>`` (Scalars) and ``/robot_description``
(TextDocument); a replay of several robots has each robot's under its root (``/robot1/tf/…``),
read as that namespace's. Rerun stores transforms as float32, joint positions as float64. An
``.rrd`` has no topics: its entities are listed under the topics they stand for. An ``.rrd`` of
another application (not ``tfrec``) is refused: its entities mean nothing tfrec knows.
"""

from __future__ import annotations

import json
import os
import signal
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import JOINT_STATES, ROBOT_DESCRIPTION, TF, TF_STATIC, robot_topic_kind
from tfrec.errors import ReadError
from tfrec.formats._collect import DECODED_TOPICS, ReadOptions
from tfrec.recording import FrameSeries, JointStates, RecordedRobot, Recording, TopicInfo

__all__ = ["RRD_MAGIC", "read_rrd"]

Array = NDArray[np.float64]

RRD_MAGIC = b"RRF2"


def read_rrd(path: Path, options: ReadOptions) -> Recording:
    """Read an ``.rrd`` written by :class:`tfrec.viewer.sink.RerunSink`, decoding the kinds of
    topics ``options`` select (an ``.rrd`` has no topic names: remapping and namespaces do not apply).

    Raises:
        ReadError: Rerun cannot read the file (damaged or not an RRD), or it was not written by
            tfrec (another application id): what it holds has no ROS meaning tfrec knows.
    """
    from tfrec.formats.rrd import paths as rerun_paths

    where = os.fspath(path)
    wanted = DECODED_TOPICS if options.topics is None else frozenset(
        kind[1] for topic in options.topics if (kind := robot_topic_kind(topic)) is not None)
    recording = Recording(path=where, format="rrd", float32=True)
    applications, chunks = _read_chunks(path)
    if applications and rerun_paths.APPLICATION_ID not in applications:
        raise ReadError(f"{where}: a Rerun recording of {', '.join(repr(a) for a in applications)}, not "
                        f"written by tfrec: tfrec reads back only its own .rrd files (their entities "
                        "stand for ROS topics)")
    parts: dict[str, _Entities] = {}
    for entity_path, batch in chunks:
        found = _rooted(entity_path)
        if found is not None:
            namespace, top, names = found
            columns = {name: batch.column(i) for i, name in enumerate(batch.schema.names)}
            parts.setdefault(namespace, _Entities()).take(top, names, columns)
    times: list[NDArray[np.int64]] = []
    for namespace, entities in sorted(parts.items()):
        topics, data = entities.robot_topics(namespace, wanted, times)
        recording.topics.update(topics)
        if namespace:
            recording.namespaces[namespace] = data
        else:
            recording.robot_description = data.robot_description
            recording.joint_states, recording.tf, recording.tf_static = data.joint_states, data.tf, data.tf_static
    recording.topics = dict(sorted(recording.topics.items()))
    if times:
        recording.start_ns = int(min(t[0] for t in times))
        recording.end_ns = int(max(t[-1] for t in times))
    return recording


def _rooted(path: str) -> tuple[str, str, tuple[str, ...]] | None:
    """(namespace, top, names) of an entity that stands for a topic: ``/tf/joint1`` → ``("", "tf",
    ("joint1",))``; one robot of a multi-robot replay, ``/robot1/tf/joint1`` → ``("/robot1", "tf", …)``;
    None for anything else (geometry, properties)."""
    from tfrec.formats.rrd import paths as rerun_paths

    top, names = rerun_paths.parse_entity(path)
    parts = (top, *names)
    roots = (rerun_paths.TF_ROOT, rerun_paths.TF_STATIC_ROOT, rerun_paths.JOINTS_ROOT, rerun_paths.DESCRIPTION_ROOT,
             rerun_paths.DISPLAY_PREFIX_ROOT)
    leaves = (rerun_paths.DESCRIPTION_ROOT, rerun_paths.DISPLAY_PREFIX_ROOT, rerun_paths.JOINTS_ROOT)
    for i, part in enumerate(parts):
        if part in roots and (part in leaves or i + 1 < len(parts)):
            return ("/" + "/".join(parts[:i]) if i else ""), part, tuple(parts[i + 1 :])
        if part == rerun_paths.ROBOT_ROOT:
            return None
    return None


class _Entities:
    """What one robot's entities hold (the top's, or one robot's of a multi-robot replay)."""

    def __init__(self) -> None:
        self.tf: dict[tuple[str, ...], list[tuple[NDArray[np.int64], Array, Array, tuple[str, str]]]] = {}
        self.joints: dict[str, list[tuple[NDArray[np.int64], Array]]] = {}
        self.no_joints: list[NDArray[np.int64]] = []  # stamps of joint states that name no joint
        self.static: dict[tuple[str, str], tuple[Array, Array]] = {}
        self.description: str | None = None
        self.display_prefix = ""  # what the replay put in front of the recorded frame ids (undone here)

    def take(self, top: str, names: tuple[str, ...], columns: dict[str, Any]) -> None:
        """One chunk of the entity ``top``/``names``: its columns (pyarrow arrays) by name."""
        from tfrec.formats.rrd import paths as rerun_paths

        if top in (rerun_paths.DESCRIPTION_ROOT, rerun_paths.DISPLAY_PREFIX_ROOT):
            self._text(top, columns.get("TextDocument:text"))
            return
        time = None
        if rerun_paths.TIMELINE in columns:
            import pyarrow as pa

            time = np.asarray(columns[rerun_paths.TIMELINE].cast(pa.int64()).to_numpy(zero_copy_only=False),
                              dtype=np.int64)
        if top == rerun_paths.JOINTS_ROOT:
            self._joints(names, columns, time)
        else:
            self._transforms(top, names, columns, time)

    def _text(self, top: str, text: Any) -> None:
        """The robot description, or the display prefix a replay put in front of the frame ids: the last text."""
        from tfrec.formats.rrd import paths as rerun_paths

        if text is None or not len(text):
            return
        values = text.flatten()
        if len(values):
            value = str(values[len(values) - 1].as_py())
            if top == rerun_paths.DESCRIPTION_ROOT:
                self.description = value
            else:
                self.display_prefix = value

    def _joints(self, names: tuple[str, ...], columns: dict[str, Any], time: NDArray[np.int64] | None) -> None:
        """A joint's positions; without a joint, the stamps of /joint_states messages that name no joint."""
        from tfrec.formats.rrd import paths as rerun_paths

        if time is None:
            return
        if not names:
            if rerun_paths.JOINT_COUNT in columns:
                self.no_joints.append(time)
            return
        scalars = columns.get("Scalars:scalars")
        if scalars is not None:
            values, keep = _one_per_row(scalars, 1)
            self.joints.setdefault("/".join(names), []).append((time[keep], values[keep, 0]))

    def _transforms(self, top: str, names: tuple[str, ...], columns: dict[str, Any],
                    time: NDArray[np.int64] | None) -> None:
        """A frame pair's transforms: latched (``/tf_static``, or without a time) or a time series."""
        from tfrec.formats.rrd import paths as rerun_paths

        translation = columns.get("Transform3D:translation")
        quaternion = columns.get("Transform3D:quaternion")
        parent = columns.get("Transform3D:parent_frame")
        child = columns.get("Transform3D:child_frame")
        if translation is None or quaternion is None or parent is None or child is None:
            return
        t_values, t_valid = _one_per_row(translation, 3)
        q_values, q_valid = _one_per_row(quaternion, 4)
        keep = t_valid & q_valid
        if not keep.any():
            return
        pair = (str(parent.flatten()[0].as_py()), str(child.flatten()[0].as_py()))
        if top == rerun_paths.TF_STATIC_ROOT or time is None:
            self.static[pair] = (t_values[keep][-1], q_values[keep][-1])
        else:
            self.tf.setdefault(names, []).append((time[keep], t_values[keep], q_values[keep], pair))

    def robot_topics(self, namespace: str, wanted: frozenset[str],
                     times: list[NDArray[np.int64]]) -> tuple[dict[str, TopicInfo], RecordedRobot]:
        """The topics these entities stand for, and their data (of the kinds ``wanted``); appends the
        stamps of their time series to ``times``."""
        topics: dict[str, TopicInfo] = {}
        if self.description is not None:
            topics[namespace + ROBOT_DESCRIPTION] = TopicInfo("TextDocument", 1, None, None)
        if self.static:
            topics[namespace + TF_STATIC] = TopicInfo("Transform3D", 1, None, None)
        joint_states = None
        if self.joints or self.no_joints:
            names = tuple(self.joints)
            series = {name: _concat_series(parts) for name, parts in self.joints.items()}
            all_times = np.unique(np.concatenate([time for time, _ in series.values()] + self.no_joints))
            positions = np.full((len(all_times), len(names)), np.nan)
            for j, name in enumerate(names):
                time, value = series[name]
                positions[np.searchsorted(all_times, time), j] = value
            topics[namespace + JOINT_STATES] = TopicInfo("Scalars", len(all_times), int(all_times[0]),
                                                         int(all_times[-1]))
            times.append(all_times)
            joint_states = JointStates(all_times, names, positions)
        tf: dict[tuple[str, str], FrameSeries] = {}
        if self.tf:
            tf_times = []
            for parts in self.tf.values():
                time = np.concatenate([p[0] for p in parts])
                order = np.argsort(time, kind="stable")
                tf_times.append(time)
                tf[parts[0][3]] = FrameSeries(time[order], np.concatenate([p[1] for p in parts])[order],
                                              np.concatenate([p[2] for p in parts])[order])
            all_times = np.unique(np.concatenate(tf_times))
            topics[namespace + TF] = TopicInfo("Transform3D", len(all_times), int(all_times[0]), int(all_times[-1]))
            times.append(all_times)
        description = self.description if ROBOT_DESCRIPTION in wanted else None
        static = self.static
        if self.display_prefix:  # the frame ids as recorded, not as the viewer showed them
            tf = {self._recorded(pair): series for pair, series in tf.items()}
            static = {self._recorded(pair): value for pair, value in static.items()}
        return topics, RecordedRobot(namespace, (description,) if description is not None else (),
                                     joint_states if JOINT_STATES in wanted else None,
                                     tf if TF in wanted else {}, static if TF_STATIC in wanted else {})

    def _recorded(self, pair: tuple[str, str]) -> tuple[str, str]:
        prefix = self.display_prefix
        return (pair[0].removeprefix(prefix), pair[1].removeprefix(prefix))


def _read_chunks(path: Path) -> tuple[list[str], list[tuple[str, Any]]]:
    """The application ids of an ``.rrd``'s recordings, and (entity path, pyarrow RecordBatch) of each of
    its chunks, decoded by Rerun in a child process (:mod:`tfrec.formats.rrd._read_child`): Rerun's
    reader aborts the process on some damaged files.

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
    data = memoryview(child.stdout)
    chunks: list[tuple[str, Any]] = []
    try:
        (size,) = struct.unpack_from("<Q", data, 0)
        applications = [str(a) for a in json.loads(bytes(data[8:8 + size]))]
        pos = 8 + size
        while pos < len(data):
            (size,) = struct.unpack_from("<Q", data, pos)
            batch = pa.ipc.open_stream(pa.py_buffer(data[pos + 8:pos + 8 + size])).read_next_batch()
            pos += 8 + size
            entity = (batch.schema.metadata or {}).get(_read_child.ENTITY_PATH, b"").decode(errors="replace")
            chunks.append((entity, batch))
    except (pa.ArrowInvalid, struct.error, ValueError, TypeError) as err:
        raise ReadError(f"{where}: unreadable Rerun recording: {err}") from err
    return applications, chunks


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
