"""Decoding the messages tfrec reads back — JointState, TFMessage — in bulk, with numpy.

A publisher like joint_state_publisher or robot_state_publisher sends the same joint or frame
names in every message, so every message has the same byte layout: only the stamps and the
float64 values change. :func:`message_layout` walks one message (CDR as ROS 2 writes it, or
ROS 1 serialization) and records where those variable fields sit; a batch of messages of that
length whose other bytes all equal the template is then decoded as one (N, size) uint8 array,
one numpy slice per field. Any other message (different names, a different layout) goes
through a per-message deserializer supplied by the caller (rosbags'), so nothing is lost.

A layout is taken when it reads its message as rosbags does. That is proven without rosbags when tfrec's encoder
(:mod:`tfrec.formats.ros.encode`, whose bytes are rosbags' serialization: tests/formats/test_cdr.py) writes what
the layout read back to the message's own bytes — so ``tfrec info`` of tfrec's recordings loads no rosbags type
store —; a message the encoder does not write (efforts, transforms of several stamps in one message) is compared
with rosbags' deserialization instead. :func:`read_string` and :func:`read_transforms` read single messages
(descriptions, /tf_static) the same way.

Pure numpy, with the CDR rules of :mod:`tfrec.formats.ros.encode`: the readers supply the bytes and the fallback
deserializer.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.errors import WriteError
from tfrec.formats.ros.encode import (
    CDR_HEADER,
    JointStateEncoder,
    TFMessageEncoder,
    align,
    encode_string,
    ns_from_stamps,
)
from tfrec.formats.ros.joint_names import first_positions

__all__ = [
    "JointStateAccumulator",
    "MessageLayout",
    "RawMessages",
    "TFAccumulator",
    "match_layout",
    "message_layout",
    "read_string",
    "read_transforms",
    "stamp_ns",
    "transforms_of",
]

Array = NDArray[np.float64]
Deserialize = Callable[[bytes], Any]


@dataclass(frozen=True, slots=True)
class MessageLayout:
    """Where the variable fields of one fixed-layout message sit.

    Attributes:
        size: bytes per message.
        fixed: byte ranges [start, stop) that every message of this layout repeats exactly.
        stamps: offset of each header stamp (sec, then nanosec, 4 bytes each).
        floats: offset of each block of float64 values (7 per transform; J positions).
        names: frame pairs (parent, child) of a TFMessage, or joint names of a JointState.
        frame_id: a JointState's ``header.frame_id`` (``""`` for a TFMessage).
        ros1: ROS 1 serialization (unsigned seconds) rather than CDR (signed).
        template: the message the layout was learnt from.
        values: the byte ranges [start, stop) that carry values, in message order: each header
            stamp and each block of float64 values (empty blocks included) — what a message of
            this kind keeps between ROS 1 and CDR (ROS 1's header ``seq`` is not one of them).
    """

    size: int
    fixed: tuple[tuple[int, int], ...]
    stamps: tuple[int, ...]
    floats: tuple[int, ...]
    names: tuple[Any, ...]
    ros1: bool
    template: NDArray[np.uint8]
    values: tuple[tuple[int, int], ...] = ()
    frame_id: str = ""


class _Walker:
    """Reads one message, noting the byte ranges whose contents vary between messages."""

    def __init__(self, data: bytes, *, ros1: bool) -> None:
        self.data = data
        self.ros1 = ros1
        if not ros1 and data[: len(CDR_HEADER)] != CDR_HEADER:
            raise ValueError("not little-endian CDR")
        self.base = 0 if ros1 else len(CDR_HEADER)
        self.pos = self.base
        self.variable: list[tuple[int, int]] = []
        self.values: list[tuple[int, int]] = []

    def _take(self, size: int) -> int:
        start = self.pos
        if start + size > len(self.data):
            raise ValueError("message too short")
        self.pos += size
        return start

    def align(self, size: int) -> None:
        if not self.ros1:
            self.pos = self.base + align(self.pos - self.base, size)

    def uint32(self) -> int:
        self.align(4)
        start = self._take(4)
        return int.from_bytes(self.data[start : start + 4], "little")

    def string(self) -> str:
        length = self.uint32()
        start = self._take(length)
        raw = self.data[start : start + length]
        if not self.ros1:
            if not raw.endswith(b"\0"):
                raise ValueError("CDR string without NUL")
            raw = raw[:-1]
        return raw.decode("utf-8")

    def header(self) -> tuple[int, str]:
        """A std_msgs/Header; returns the offset of its stamp and its frame_id."""
        if self.ros1:  # uint32 seq, varies per message
            self.variable.append((self._take(4), self.pos))
        self.align(4)
        stamp = self._take(8)
        self.variable.append((stamp, self.pos))
        self.values.append((stamp, self.pos))
        return stamp, self.string()

    def float64s(self, count: int) -> int:
        if count:
            self.align(8)
        start = self._take(8 * count)
        self.variable.append((start, self.pos))
        self.values.append((start, self.pos))
        return start

    def layout(self, stamps: list[int], floats: list[int], names: list[Any], frame_id: str = "") -> MessageLayout:
        fixed: list[tuple[int, int]] = []
        cursor = 0
        for start, stop in self.variable:
            if start > cursor:
                fixed.append((cursor, start))
            cursor = stop
        if cursor < len(self.data):
            fixed.append((cursor, len(self.data)))
        return MessageLayout(len(self.data), tuple(fixed), tuple(stamps), tuple(floats), tuple(names), self.ros1,
                             np.frombuffer(self.data, dtype=np.uint8), tuple(self.values), frame_id)


def message_layout(kind: str, data: bytes | memoryview, *, ros1: bool) -> MessageLayout:
    """The layout of one ``TFMessage`` (kind ``"tf"``) or ``JointState`` (kind ``"joint_states"``).

    Raises:
        ValueError: the bytes are not such a message (or not little-endian CDR).
    """
    walker = _Walker(bytes(data), ros1=ros1)
    stamps: list[int] = []
    floats: list[int] = []
    names: list[Any] = []
    frame_id = ""
    if kind == "tf":
        for _ in range(walker.uint32()):
            stamp, parent = walker.header()
            stamps.append(stamp)
            child = walker.string()
            names.append((parent, child))
            floats.append(walker.float64s(7))
    elif kind == "joint_states":
        stamp, frame_id = walker.header()
        stamps.append(stamp)
        names.extend(walker.string() for _ in range(walker.uint32()))
        for _ in range(3):  # position, velocity, effort
            count = walker.uint32()
            floats.append(walker.float64s(count) if count == len(names) else -1)
            if count != len(names):
                walker.float64s(count)
    else:
        raise ValueError(f"unknown message kind {kind!r}")
    if len(walker.data) - walker.pos >= 4:  # CDR may pad to 4 bytes; more is not this message
        raise ValueError("trailing bytes")
    return walker.layout(stamps, floats, names, frame_id)


def _written_back(encoded: bytes, data: bytes, *, ros1: bool) -> bool:
    """Whether ``data`` is the message ``encoded`` as rosbags reads it: the same bytes (CDR may end with up to 3
    bytes of padding, which rosbags' deserializer leaves; ROS 1 ends where the message ends)."""
    extra = len(data) - len(encoded)
    return 0 <= extra <= (0 if ros1 else 3) and data[: len(encoded)] == encoded


def read_string(data: bytes | memoryview, *, ros1: bool, deserialize: Deserialize) -> str:
    """The text of one ``std_msgs/String`` message: read directly when tfrec's encoder writes that text back to the
    message's bytes, else with ``deserialize`` (rosbags', which raises on bytes that are no such message)."""
    raw = bytes(data)
    try:
        text = _Walker(raw, ros1=ros1).string()
    except (ValueError, UnicodeDecodeError):
        text = None
    if text is not None and _written_back(encode_string(text, ros1=ros1), raw, ros1=ros1):
        return text
    return str(deserialize(raw).data)


def read_transforms(data: bytes | memoryview, *, ros1: bool,
                    deserialize: Deserialize) -> list[tuple[tuple[str, str], int, tuple[float, ...]]]:
    """What :func:`transforms_of` gives of one ``tf2_msgs/TFMessage``: read with its layout when tfrec's encoder
    writes what it read back to the message's bytes, else with ``deserialize`` (rosbags')."""
    raw = bytes(data)
    try:
        layout: MessageLayout | None = message_layout("tf", raw, ros1=ros1)
    except (ValueError, UnicodeDecodeError):
        layout = None
    rows = np.frombuffer(raw, dtype=np.uint8).reshape(1, -1)
    if layout is not None and TFAccumulator.written_back(layout, rows):
        return [(pair, int(time[0]), tuple(values[0].tolist())) for pair, time, values in TFAccumulator.decode(layout, rows)]
    return transforms_of(deserialize(raw))


def stamp_ns(stamp: Any) -> int:
    """Nanoseconds of a deserialized builtin_interfaces/Time (or ROS 1 time)."""
    return ns_from_stamps(int(stamp.sec), int(stamp.nanosec))


class RawMessages(Sequence[memoryview]):
    """Serialized messages that lie in one buffer (a chunk's records): message ``i`` is
    ``buffer[starts[i]:stops[i]]``. A reader that found them with numpy (through a chunk's index)
    hands them over like this, so that no Python object is made per message: messages of one size
    that lie evenly spaced — a recorder's fixed-layout messages, interleaved — are taken as one
    strided (N, size) view of the buffer, without a copy.
    """

    def __init__(self, buffer: bytes | memoryview | NDArray[np.uint8], starts: NDArray[np.int64],
                 stops: NDArray[np.int64]) -> None:
        self.buffer = buffer if isinstance(buffer, np.ndarray) else np.frombuffer(buffer, dtype=np.uint8)
        self.starts = starts
        self.stops = stops

    def __len__(self) -> int:
        return len(self.starts)

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return RawMessages(self.buffer, self.starts[index], self.stops[index])
        return self.buffer[int(self.starts[index]) : int(self.stops[index])].data

    def sizes(self) -> NDArray[np.int64]:
        return self.stops - self.starts

    def rows(self, index: NDArray[np.intp], size: int) -> NDArray[np.uint8]:
        """The messages ``index`` (each ``size`` bytes long) as an (n, size) array: a view when evenly spaced."""
        starts = self.starts[index]
        if len(starts) == 0:
            return np.zeros((0, size), dtype=np.uint8)
        steps = np.diff(starts)
        if len(starts) == 1 or (steps[0] >= size and bool((steps == steps[0]).all())):
            step = int(steps[0]) if len(steps) else size
            rows: NDArray[np.uint8] = np.lib.stride_tricks.as_strided(
                self.buffer[int(starts[0]):], shape=(len(starts), size), strides=(step, 1), writeable=False)
            return rows
        windows = np.lib.stride_tricks.as_strided(self.buffer, shape=(len(self.buffer) - size + 1, size),
                                                  strides=(1, 1), writeable=False)
        gathered: NDArray[np.uint8] = windows[starts]  # a copy, one row at a time (no index per byte)
        return gathered


def _rows(datas: Sequence[bytes | memoryview], index: NDArray[np.intp], size: int) -> NDArray[np.uint8]:
    if isinstance(datas, RawMessages):
        return datas.rows(index, size)
    chosen = datas if len(index) == len(datas) else [datas[i] for i in index.tolist()]
    return np.frombuffer(b"".join(chosen), dtype=np.uint8).reshape(len(chosen), size)


TILED_BYTES = 1 << 20
"""Bytes of rows whose fixed bytes are compared in one pass (the template repeated along them is kept): more
rows are compared a block of them at a time."""


def _fixed_bytes_match(layout: MessageLayout, rows: NDArray[np.uint8]) -> NDArray[np.bool_]:
    """Which rows repeat the layout's fixed bytes exactly.

    Rows lying evenly spaced in one buffer (a chunk's records, or a gathered copy) are compared in one pass
    over the bytes they span against the template repeated at their spacing, the variable bytes masked out;
    only when something differs are the rows that differ found. A comparison and a row reduction per fixed
    range cost 5× as much on a TFMessage of 8 transforms: numpy reduces short rows slowly.
    """
    ok = np.ones(len(rows), dtype=bool)
    if not layout.fixed or not len(rows):
        return ok
    step = rows.strides[0]
    if len(rows) == 1 or rows.strides[1] != 1 or not layout.size <= step <= TILED_BYTES:
        return _fixed_rows_match(layout, rows)
    block = TILED_BYTES // step + 1
    if len(rows) > block:
        for start in range(0, len(rows), block):
            ok[start : start + block] = _fixed_bytes_match(layout, rows[start : start + block])
        return ok
    span = (len(rows) - 1) * step + layout.size
    fixed_bytes = b"".join(layout.template[start:stop].tobytes() for start, stop in layout.fixed)
    template, fixed = _tiled(layout.size, layout.fixed, fixed_bytes, step, span)
    flat = np.lib.stride_tricks.as_strided(rows, shape=(span,), strides=(1,), writeable=False)
    differs = flat != template[:span]
    differs &= fixed[:span]
    if differs.any():
        ok[np.flatnonzero(differs) // step] = False
    return ok


_TILED: dict[tuple[int, tuple[tuple[int, int], ...], bytes, int], tuple[NDArray[np.uint8], NDArray[np.bool_]]] = {}


def _tiled(size: int, fixed: tuple[tuple[int, int], ...], fixed_bytes: bytes, step: int,
           span: int) -> tuple[NDArray[np.uint8], NDArray[np.bool_]]:
    """A message's fixed bytes (``fixed_bytes``, those of the ranges ``fixed`` one after the other; zeros
    elsewhere) and their mask, repeated ``step`` bytes apart over at least ``span`` bytes: kept per layout and
    spacing (a layout learnt again from another message has other variable bytes, the same fixed ones), made
    again (for a multiple of 256 rows) only when a longer run of rows comes."""
    key = (size, fixed, fixed_bytes, step)
    found = _TILED.get(key)
    if found is not None and len(found[0]) >= span:
        return found
    if len(_TILED) >= 16:
        _TILED.clear()
    count = min((span // step // 256 + 1) * 256, TILED_BYTES // step + 1)  # at most a block: ≤ 2 × TILED_BYTES
    row = np.zeros(step, dtype=np.uint8)
    mask = np.zeros(step, dtype=bool)
    taken = 0
    for start, stop in fixed:
        row[start:stop] = np.frombuffer(fixed_bytes, dtype=np.uint8, count=stop - start, offset=taken)
        mask[start:stop] = True
        taken += stop - start
    _TILED[key] = found = (np.tile(row, count), np.tile(mask, count))
    return found


def _fixed_rows_match(layout: MessageLayout, rows: NDArray[np.uint8]) -> NDArray[np.bool_]:
    """:func:`_fixed_bytes_match` of rows anywhere: each row's span from its first fixed byte to its last."""
    lo, hi = layout.fixed[0][0], layout.fixed[-1][1]
    fixed = np.zeros(hi - lo, dtype=bool)
    for start, stop in layout.fixed:
        fixed[start - lo : stop - lo] = True
    differs = rows[:, lo:hi] != layout.template[lo:hi]
    differs &= fixed
    ok: NDArray[np.bool_] = ~differs.any(axis=1)
    return ok


def _split(
    layout: MessageLayout | None, datas: Sequence[bytes | memoryview]
) -> tuple[NDArray[np.uint8] | None, NDArray[np.intp], list[int]]:
    """Rows of the messages that match ``layout``, their indices, and the indices of the rest."""
    if layout is None or not datas:
        return None, np.zeros(0, dtype=np.intp), list(range(len(datas)))
    if isinstance(datas, RawMessages):
        lengths = datas.sizes()
    else:
        lengths = np.fromiter(map(len, datas), dtype=np.int64, count=len(datas))
    same = np.flatnonzero(lengths == layout.size)
    rows = _rows(datas, same, layout.size)
    ok = _fixed_bytes_match(layout, rows)
    good = same[ok]
    if len(good) == len(datas):
        return rows, good, []
    others = np.ones(len(datas), dtype=bool)
    others[good] = False
    return rows[ok], good, np.flatnonzero(others).tolist()


def match_layout(
    layout: MessageLayout, datas: Sequence[bytes | memoryview]
) -> tuple[NDArray[np.uint8] | None, NDArray[np.intp], list[int]]:
    """The messages of ``datas`` that have ``layout`` (its length, and its fixed bytes exactly).

    Returns:
        (their rows as an (n, size) array — a view of the buffer when they lie evenly spaced in one —,
        their indices, the indices of the others).
    """
    return _split(layout, datas)


def _stamps(rows: NDArray[np.uint8], offset: int, ros1: bool) -> NDArray[np.int64]:
    raw = np.ascontiguousarray(rows[:, offset : offset + 8]).view("<u4")
    sec = raw[:, 0].astype(np.int64) if ros1 else raw[:, 0].view("<i4").astype(np.int64)
    return ns_from_stamps(sec, raw[:, 1].astype(np.int64))


def _float_block(rows: NDArray[np.uint8], offset: int, count: int) -> Array:
    return np.ascontiguousarray(rows[:, offset : offset + 8 * count]).view("<f8").astype(np.float64, copy=False)


class _Accumulator:
    """Shared: learning the layout from the first message and validating it."""

    kind = ""

    def __init__(self, deserialize: Deserialize, *, ros1: bool) -> None:
        self.deserialize = deserialize
        self.ros1 = ros1
        self.layout: MessageLayout | None = None
        self._tried = False
        self.messages = 0

    def _learn(self, data: bytes | memoryview) -> None:
        """Take the layout of ``data`` when it decodes as rosbags decodes it; else keep the old one."""
        self._tried = True
        try:
            layout = message_layout(self.kind, data, ros1=self.ros1)
        except (ValueError, UnicodeDecodeError):
            return
        if self._check(layout, data):
            self.layout = layout

    def _check(self, layout: MessageLayout, data: bytes | memoryview) -> bool:
        """Whether ``layout`` reads ``data`` as rosbags does: proven when the encoder writes what it read back to
        the same bytes; else compared with rosbags' deserialization of it."""
        rows = np.frombuffer(bytes(data), dtype=np.uint8).reshape(1, -1)
        return self.written_back(layout, rows) or self._alike(layout, rows, self.deserialize(bytes(data)))

    @staticmethod
    def written_back(layout: MessageLayout, rows: NDArray[np.uint8]) -> bool:
        """Whether tfrec's encoder writes the message read with ``layout`` from ``rows`` (one row) back to its
        bytes."""
        raise NotImplementedError

    def _alike(self, layout: MessageLayout, rows: NDArray[np.uint8], msg: Any) -> bool:
        """Whether ``layout`` reads ``rows`` (one row) as rosbags read it (``msg``)."""
        raise NotImplementedError

    def add(self, datas: Sequence[bytes | memoryview], log_times: NDArray[np.int64] | None = None) -> None:
        """Decode a batch of raw messages (in order).

        Args:
            datas: the serialized messages.
            log_times: when given, the messages' log times stand for their header stamps
                (a recording whose stamps are unusable, replayed by log time).
        """
        if not datas:
            return
        self.messages += len(datas)
        if not self._tried:
            self._learn(datas[0])
        rows, good, rest = _split(self.layout, datas)
        if rows is not None and len(rows):
            self._add_rows(rows, None if log_times is None else log_times[good])
        if len(rest) * 2 > len(datas):  # most messages have another layout (or the first was odd): learn it
            previous = self.layout
            self._learn(datas[rest[len(rest) // 2]])
            if self.layout is not previous:
                rows, good, still = _split(self.layout, [datas[i] for i in rest])
                if rows is not None and len(rows):
                    self._add_rows(rows, None if log_times is None else log_times[np.asarray(rest)[good]])
                rest = [rest[i] for i in still]
        for i in rest:
            self._add_message(self.deserialize(bytes(datas[i])), None if log_times is None else int(log_times[i]))

    def _add_rows(self, rows: NDArray[np.uint8], times: NDArray[np.int64] | None) -> None:
        raise NotImplementedError

    def _add_message(self, msg: Any, time_ns: int | None) -> None:
        raise NotImplementedError


class JointStateAccumulator(_Accumulator):
    """Collects sensor_msgs/JointState messages into (time, names, positions) segments.

    Attributes:
        repeated: joint name → how many messages name it more than once (its first position is taken,
            :func:`first_positions`).
    """

    kind = "joint_states"

    def __init__(self, deserialize: Deserialize, *, ros1: bool) -> None:
        super().__init__(deserialize, ros1=ros1)
        self._segments: list[tuple[tuple[str, ...], NDArray[np.int64], Array]] = []
        self._pending_names: tuple[str, ...] | None = None
        self._pending: list[tuple[int, Array]] = []
        self.repeated: dict[str, int] = {}

    def _once(self, names: tuple[str, ...], positions: Array, messages: int) -> tuple[tuple[str, ...], Array]:
        """``names`` each once with their first position (``positions`` (N, len(names))), counting the repeats."""
        unique, keep, repeated = first_positions(names)
        if keep is None:
            return names, positions
        for name in repeated:
            self.repeated[name] = self.repeated.get(name, 0) + messages
        return unique, positions[:, keep]

    @staticmethod
    def written_back(layout: MessageLayout, rows: NDArray[np.uint8]) -> bool:
        if layout.floats[0] < 0 or layout.floats[1] < 0:  # position or velocity not one per joint
            return False
        time, names, positions = JointStateAccumulator._decode(layout, rows)
        velocities = _float_block(rows, layout.floats[1], len(names))
        stamp = layout.stamps[0]
        seq = int.from_bytes(rows[0, stamp - 4 : stamp].tobytes(), "little") if layout.ros1 else 0
        try:
            encoded = JointStateEncoder(names, frame_id=layout.frame_id, ros1=layout.ros1).encode(
                time, positions, velocities, first_seq=seq)
        except WriteError:  # a ROS 1 stamp whose nanoseconds carry it past ROS 1's last time
            return False
        return _written_back(encoded.tobytes(), rows.tobytes(), ros1=layout.ros1)

    def _alike(self, layout: MessageLayout, rows: NDArray[np.uint8], msg: Any) -> bool:
        time, names, positions = self._decode(layout, rows)
        return (
            tuple(msg.name) == names
            and stamp_ns(msg.header.stamp) == int(time[0])
            and np.array_equal(np.asarray(msg.position, dtype=np.float64).reshape(1, -1), positions, equal_nan=True)
        )

    @staticmethod
    def _decode(layout: MessageLayout, rows: NDArray[np.uint8]) -> tuple[NDArray[np.int64], tuple[str, ...], Array]:
        names = tuple(layout.names)
        time = _stamps(rows, layout.stamps[0], layout.ros1)
        if layout.floats[0] < 0:
            positions = np.full((len(rows), len(names)), np.nan)
        else:
            positions = _float_block(rows, layout.floats[0], len(names))
        return time, names, positions

    def _flush_pending(self) -> None:
        if self._pending and self._pending_names is not None:
            time = np.array([t for t, _ in self._pending], dtype=np.int64)
            positions = np.stack([p for _, p in self._pending]) if self._pending_names else np.zeros((len(time), 0))
            self._segments.append((self._pending_names, time, positions))
        self._pending = []
        self._pending_names = None

    def _add_rows(self, rows: NDArray[np.uint8], times: NDArray[np.int64] | None) -> None:
        assert self.layout is not None
        self._flush_pending()
        time, names, positions = self._decode(self.layout, rows)
        names, positions = self._once(names, positions, len(rows))
        self._segments.append((names, time if times is None else times, positions))

    def _add_message(self, msg: Any, time_ns: int | None) -> None:
        names = tuple(msg.name)
        position = np.full(len(names), np.nan)
        given = np.asarray(msg.position, dtype=np.float64)[: len(names)]
        position[: len(given)] = given
        names, positions = self._once(names, position.reshape(1, -1), 1)
        position = positions[0]
        if names != self._pending_names:
            self._flush_pending()
            self._pending_names = names
        self._pending.append((stamp_ns(msg.header.stamp) if time_ns is None else time_ns, position))

    def result(self) -> tuple[NDArray[np.int64], tuple[str, ...], Array]:
        """(time_ns (N,), names, positions (N, J)): the union of all names, NaN where a message lacks one."""
        self._flush_pending()
        names: dict[str, int] = {}
        for seg_names, _, _ in self._segments:
            for name in seg_names:
                names.setdefault(name, len(names))
        if len(self._segments) == 1 and tuple(names) == self._segments[0][0]:
            _, time, positions = self._segments[0]
        else:
            total = sum(len(t) for _, t, _ in self._segments)
            time = np.empty(total, dtype=np.int64)
            positions = np.full((total, len(names)), np.nan)
            row = 0
            for seg_names, seg_time, seg_pos in self._segments:
                cols = [names[n] for n in seg_names]
                time[row : row + len(seg_time)] = seg_time
                if cols:
                    positions[row : row + len(seg_time), cols] = seg_pos
                row += len(seg_time)
        order = _time_order(time)
        if order is not None:
            time, positions = time[order], positions[order]
        return time, tuple(names), positions


class TFAccumulator(_Accumulator):
    """Collects tf2_msgs/TFMessage messages into per (parent, child) time series."""

    kind = "tf"

    def __init__(self, deserialize: Deserialize, *, ros1: bool) -> None:
        super().__init__(deserialize, ros1=ros1)
        self._blocks: dict[tuple[str, str], list[tuple[NDArray[np.int64], Array]]] = {}
        self._singles: dict[tuple[str, str], list[tuple[int, tuple[float, ...]]]] = {}

    @staticmethod
    def written_back(layout: MessageLayout, rows: NDArray[np.uint8]) -> bool:
        decoded = list(TFAccumulator.decode(layout, rows))
        stamps = {int(time[0]) for _, time, _ in decoded}
        if len(stamps) > 1:  # the encoder writes one stamp per message, as robot_state_publisher does
            return False
        values = np.stack([block[0] for _, _, block in decoded]) if decoded else np.zeros((0, 7))
        try:
            encoded = TFMessageEncoder([parent for (parent, _), _, _ in decoded], [child for (_, child), _, _ in decoded],
                                       ros1=layout.ros1).encode(np.array([next(iter(stamps), 0)], dtype=np.int64),
                                                                values[np.newaxis, :, :3], values[np.newaxis, :, 3:])
        except WriteError:  # a ROS 1 stamp whose nanoseconds carry it past ROS 1's last time
            return False
        return _written_back(encoded.tobytes(), rows.tobytes(), ros1=layout.ros1)

    def _alike(self, layout: MessageLayout, rows: NDArray[np.uint8], msg: Any) -> bool:
        decoded = list(self.decode(layout, rows))
        expected = transforms_of(msg)
        if len(decoded) != len(expected):
            return False
        for (pair, time, values), (pair2, time2, values2) in zip(decoded, expected):
            if pair != pair2 or int(time[0]) != time2 or not np.array_equal(values[0], np.array(values2)):
                return False
        return True

    @staticmethod
    def decode(
        layout: MessageLayout, rows: NDArray[np.uint8]
    ) -> Iterator[tuple[tuple[str, str], NDArray[np.int64], Array]]:
        """Each transform of the messages ``rows`` of ``layout``, in message order: (pair, stamps (N,), values (N, 7))."""
        for pair, stamp, floats in zip(layout.names, layout.stamps, layout.floats):
            yield pair, _stamps(rows, stamp, layout.ros1), _float_block(rows, floats, 7)

    def _add_rows(self, rows: NDArray[np.uint8], times: NDArray[np.int64] | None) -> None:
        assert self.layout is not None
        for pair, time, values in self.decode(self.layout, rows):
            self._blocks.setdefault(pair, []).append((time if times is None else times, values))

    def _add_message(self, msg: Any, time_ns: int | None) -> None:
        for pair, time, values in transforms_of(msg):
            self._singles.setdefault(pair, []).append((time if time_ns is None else time_ns, values))

    def result(self) -> dict[tuple[str, str], tuple[NDArray[np.int64], Array]]:
        """(parent, child) → (time_ns (M,), values (M, 7): translation xyz, rotation xyzw), in time order."""
        out: dict[tuple[str, str], tuple[NDArray[np.int64], Array]] = {}
        for pair in list(self._blocks) + [p for p in self._singles if p not in self._blocks]:
            times = [t for t, _ in self._blocks.get(pair, [])]
            values = [v for _, v in self._blocks.get(pair, [])]
            singles = self._singles.get(pair, [])
            if singles:
                times.append(np.array([t for t, _ in singles], dtype=np.int64))
                values.append(np.array([v for _, v in singles], dtype=np.float64).reshape(-1, 7))
            time = np.concatenate(times) if len(times) > 1 else times[0]
            value = np.concatenate(values) if len(values) > 1 else values[0]
            order = _time_order(time)
            if order is not None:
                time, value = time[order], value[order]
            out[pair] = (time, value)
        return out


def transforms_of(msg: Any) -> list[tuple[tuple[str, str], int, tuple[float, ...]]]:
    """((parent, child), stamp_ns, (tx, ty, tz, qx, qy, qz, qw)) of each transform of a deserialized TFMessage."""
    out: list[tuple[tuple[str, str], int, tuple[float, ...]]] = []
    for tf in msg.transforms:
        t, r = tf.transform.translation, tf.transform.rotation
        out.append(((tf.header.frame_id, tf.child_frame_id), stamp_ns(tf.header.stamp),
                    (float(t.x), float(t.y), float(t.z), float(r.x), float(r.y), float(r.z), float(r.w))))
    return out


def _time_order(time: NDArray[np.int64]) -> NDArray[np.intp] | None:
    """A stable sorting order when ``time`` is not already non-decreasing."""
    if len(time) < 2 or bool(np.all(time[1:] >= time[:-1])):
        return None
    return np.argsort(time, kind="stable")
