"""Reading an MCAP file (ROS 2 profile, CDR) into a :class:`~tfrec.recording.Recording`.

tfrec's own sequential reader: it walks the records of the file and, for each chunk (zstd, lz4
or uncompressed), first the Message Index records that follow it (:mod:`tfrec.formats.mcap.index`):
a chunk that holds nothing to decode is counted from them and not read; a chunk that is read has
its messages found with numpy through them, each kept as a memoryview of its chunk, so no Python
object is built per record (a chunk without indexes is walked record by record). The messages
are then decoded in bulk. mcap's reader builds a record object per message and reads ~130k
messages/s.

When the file's summary section is intact, the messages read are checked against its Statistics
record: a channel whose count differs warns with both numbers.

A damaged file (a recorder killed mid-write, flipped bytes) is read as far as possible, and
:attr:`Recording.read_error` says what was lost:

- a file that ends inside a chunk keeps the complete records of the part that is there: the
  records of every compressed block that is whole are recovered (:func:`tfrec.formats._compression.salvage`);
- a whole chunk whose data does not decompress, or does not match its CRC, is skipped, and
  reading goes on with the next record: a flipped byte mostly decompresses to wrong data
  without any error, so only the CRC tells which messages can be trusted. The summary's
  schemas and channels then stand in for the ones the skipped chunk held.

When messages were lost, :attr:`Recording.start_ns` (and ``end_ns``) still give the recording's
true span, so times count from its real start: the summary's Statistics record when the
summary is intact (its CRC holds), else the message start times in the headers of the chunk
records read — a chunk's header survives damage to its compressed records. The records other
than messages are parsed by :mod:`tfrec.formats.mcap.summary`.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from tfrec.errors import ReadError, TfrecWarning
from tfrec.formats._collect import (
    Collector,
    ReadOptions,
    ReadStopped,
    count_differences,
    read_error_line,
)
from tfrec.formats.mcap.walker import McapWalker
from tfrec.recording import Recording

__all__ = ["read_mcap", "read_mcap_into"]

def read_mcap(path: Path, options: ReadOptions) -> Recording:
    """Read an MCAP file, decoding what ``options`` select.

    Raises:
        ReadError: the file cannot be opened, or is damaged before its first channel.
    """
    where = os.fspath(path)
    recording = Recording(path=where, format="mcap")
    collector = Collector(recording, options, ros1=False)
    problems = read_mcap_into(path, collector, where=where)
    collector.finish()
    if problems is not None and problems[1] is not None:
        true_start = problems[1]
        if recording.start_ns is None or true_start < recording.start_ns:
            recording.start_ns = true_start  # messages before the first one read were lost
            if recording.end_ns is None:
                recording.end_ns = true_start
    return recording


def read_mcap_into(path: Path, collector: Collector, *, where: str,
                   check: bool = True) -> tuple[list[str], int | None] | None:
    """Read one MCAP file into ``collector`` (one of several files of a rosbag2 bag).

    Sets the recording's ``details`` (profile, library, compressions of this file, merged with
    those of earlier files) and, for a damaged file, its ``read_error``.

    Args:
        path: the file.
        collector: where its messages go.
        where: the recording's name in messages.
        check: warn when the counts read differ from the file's summary statistics.

    Returns:
        None for an intact file; else (what was lost, the true start as far as the file tells).

    Raises:
        ReadError: the file cannot be opened, or is damaged before its first channel.
    """
    recording = collector.recording
    name = os.fspath(path)
    try:
        with open(path, "rb") as stream:
            size = os.fstat(stream.fileno()).st_size
            reader = McapWalker(stream, collector, name, size)
            stop: ReadStopped | None = None
            try:
                reader.run()
            except ReadStopped as err:
                stop = err
            if not reader.channels and reader.damage:
                raise ReadError(f"{name}: unreadable MCAP: {reader.damage_summary()}")
            if not reader.channels and stop is not None:
                raise ReadError(f"{name}: unreadable MCAP: {stop.reason} at byte {stop.offset:,}")
            problems = [reader.damage_summary()] if reader.damage else []
            if stop is not None:
                problems.append(stop.problem(size))
            reader.flush()
            if not problems:
                reader.summary_channels()  # channels without messages may be only there
            reader.finish()
            indexed = reader.indexed_counts() if check and not problems else None
            true_start = reader.true_start() if problems else None
            details = recording.details
            details["profile"] = details.get("profile") or reader.profile
            details["library"] = details.get("library") or reader.library
            compressions = {c for c in details.get("compression", "").split(", ") if c} | reader.compressions
            details["compression"] = ", ".join(sorted(compressions))
    except OSError as err:
        raise ReadError(f"{name}: cannot read: {err.strerror or err}") from err
    if indexed is not None:
        read: dict[str, int] = {}
        for channel in reader.channels.values():
            read[channel.topic] = read.get(channel.topic, 0) + channel.count
        differ = count_differences(read, indexed, index="its summary statistics")
        if differ is not None:
            warnings.warn(f"{name}: {differ}", TfrecWarning, stacklevel=3)
    if not problems:
        return None
    line = read_error_line(name, problems, reader.messages)
    recording.read_error = line if recording.read_error is None else f"{recording.read_error}; {line}"
    return problems, true_start
