"""A chunk's messages found through its message index records, with numpy, not record by record.

Every MCAP writer of the ROS world (rosbag2's, mcap's, rosbags', tfrec's) follows each chunk with
one Message Index record per channel: the (log time, offset) of each of the channel's messages in
the chunk's decompressed records. :func:`read_message_indexes` reads them, so a chunk that holds no
message to decode is counted from them without being read; :func:`index_chunk` takes the messages
of a chunk that is read with a handful of numpy operations instead of a Python step per record.

The indexes are not trusted blindly: every indexed offset must hold a Message record of that
channel, the records may not overlap, and the bytes between them (schema and channel records,
messages a writer did not index) are handed back to be walked record by record.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass
from typing import IO

import numpy as np
from numpy.typing import NDArray

from tfrec.formats.mcap.records import MESSAGE_HEAD_SIZE, OP_MESSAGE, OP_MESSAGE_INDEX, RECORD

__all__ = ["ChunkMessages", "index_chunk", "read_message_indexes"]

_INDEX_HEAD = struct.Struct("<HI")
"""A Message Index record's channel id and the byte length of its (log time, offset) array."""


def read_message_indexes(stream: IO[bytes], size: int) -> dict[int, NDArray[np.uint64]]:
    """The Message Index records at the stream's position (those that follow a chunk), up to the
    first other record; the stream is left before that record.

    Returns:
        channel id → uint64 (n, 2) array of (log time, offset); empty when the chunk has none.
        A damaged index record ends the indexes (the chunk is then walked record by record).
    """
    indexes: dict[int, NDArray[np.uint64]] = {}
    while True:
        at = stream.tell()
        head = stream.read(RECORD.size)
        if len(head) < RECORD.size:
            stream.seek(at)
            return indexes
        opcode, length = RECORD.unpack(head)
        if opcode != OP_MESSAGE_INDEX or at + RECORD.size + length > size:
            stream.seek(at)
            return indexes
        body = stream.read(length)
        try:
            channel_id, entries = _INDEX_HEAD.unpack_from(body)
        except struct.error:
            return {}
        if entries % 16 or _INDEX_HEAD.size + entries > len(body):
            return {}
        pairs = np.frombuffer(body, dtype="<u8", count=entries // 8, offset=_INDEX_HEAD.size).reshape(-1, 2)
        indexes[channel_id] = np.concatenate([indexes[channel_id], pairs]) if channel_id in indexes else pairs


def skip_chunk(stream: IO[bytes], length: int) -> None:
    """Move past a chunk record's body (of ``length`` bytes) without reading it."""
    stream.seek(length, os.SEEK_CUR)


@dataclass(frozen=True, slots=True)
class ChunkMessages:
    """The indexed messages of one chunk, in the order of the records.

    Attributes:
        channel: uint16 (n,) channel ids, as each record gives it.
        log_time: int64 (n,) log times, as each record gives them.
        start, stop: int64 (n,) where each message's data begins and ends in the records.
        gaps: (start, stop) byte ranges that no indexed message covers, in order: the records
            there are walked one by one.
    """

    channel: NDArray[np.uint16]
    log_time: NDArray[np.int64]
    start: NDArray[np.int64]
    stop: NDArray[np.int64]
    gaps: list[tuple[int, int]]


def _gather(buffer: NDArray[np.uint8], offsets: NDArray[np.int64], width: int, dtype: str) -> NDArray[np.generic]:
    """The little-endian value of ``width`` bytes at each offset."""
    windows = np.lib.stride_tricks.as_strided(buffer, shape=(len(buffer) - width + 1, width), strides=(1, 1),
                                              writeable=False)
    return windows[offsets].view(dtype).ravel()  # a row per offset: no index per byte


def index_chunk(records: bytes | memoryview, indexes: dict[int, NDArray[np.uint64]]) -> ChunkMessages | None:
    """The messages of a chunk's decompressed ``records`` that its message indexes point to.

    Returns:
        The messages, or None when the indexes do not describe the records (an offset that
        holds no Message record of its channel, records that overlap or run past the end).
    """
    size = len(records)
    if not indexes:
        return None
    offsets = np.concatenate([pairs[:, 1] for pairs in indexes.values()]).astype(np.int64)
    channels = np.concatenate([np.full(len(pairs), channel_id, dtype=np.uint16)
                               for channel_id, pairs in indexes.items()])
    if not len(offsets):
        return ChunkMessages(channels, np.zeros(0, np.int64), offsets, offsets, [(0, size)] if size else [])
    order = np.argsort(offsets, kind="stable")
    offsets, channels = offsets[order], channels[order]
    head = RECORD.size + MESSAGE_HEAD_SIZE
    if offsets[0] < 0 or offsets[-1] + head > size:
        return None
    buffer = np.frombuffer(records, dtype=np.uint8)
    if not (buffer[offsets] == OP_MESSAGE).all():
        return None
    lengths = _gather(buffer, offsets + 1, 8, "<u8").astype(np.int64)
    stops = offsets + RECORD.size + lengths
    if (lengths < MESSAGE_HEAD_SIZE).any() or stops[-1] > size or (stops[:-1] > offsets[1:]).any():
        return None
    if not (_gather(buffer, offsets + RECORD.size, 2, "<u2") == channels).all():
        return None
    log_time = _gather(buffer, offsets + RECORD.size + 6, 8, "<u8").astype(np.int64)
    ends = np.concatenate([[0], stops])
    begins = np.concatenate([offsets, [size]])
    open_ = np.flatnonzero(ends < begins)
    gaps = [(int(ends[k]), int(begins[k])) for k in open_.tolist()]
    return ChunkMessages(channels, log_time, offsets + head, stops, gaps)
