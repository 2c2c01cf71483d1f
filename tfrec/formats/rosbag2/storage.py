"""A rosbag2 bag's files as the sources take them: decompressed.

A bag compressed file by file (``compression_mode: file``, ``bag_0.mcap.zstd``) has each file
decompressed to a temporary copy first, streamed and bounded (:func:`plain_files`, :data:`MAX_FILE_RATIO`); one
compressed message by message has each message decompressed (:func:`message_decompressor`). (The messages counted
are checked against ``metadata.yaml``'s ``topics_with_message_count`` by the source:
:attr:`tfrec.formats.ros.connection.MessageSource.expected_counts`.)
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from tfrec.errors import ReadError
from tfrec.formats._compression import MAX_CHUNK_BYTES
from tfrec.formats.rosbag2.metadata import BagMetadata

__all__ = ["MAX_FILE_RATIO", "message_decompressor", "plain_files"]

MAX_FILE_RATIO = 1000
"""A file of a bag compressed file by file inflates to at most this many times its size (or
:data:`MIN_FILE_LIMIT`): zstd makes 4 GiB of zeros out of 131 kB, a ratio of 32,000, while recorded
messages compress less than 100-fold. This bounds the temporary disk a hostile bag can fill."""

MIN_FILE_LIMIT = 64 << 20


@contextlib.contextmanager
def plain_files(meta: BagMetadata, where: str) -> Iterator[list[Path]]:
    """The bag's files, decompressed to a temporary folder when the bag is compressed file by file.

    Raises:
        ReadError: an unknown compression, or a file that does not decompress.
    """
    if meta.compression_mode != "file":
        yield list(meta.files)
        return
    if meta.compression != "zstd":
        raise ReadError(f"{where}: files compressed with '{meta.compression}' (tfrec reads zstd)")
    import tempfile

    import zstandard

    with tempfile.TemporaryDirectory(prefix="tfrec-") as scratch:
        plain = []
        for file in meta.files:
            target = Path(scratch) / file.name.removesuffix(".zstd")
            try:
                with open(file, "rb") as source, open(target, "wb") as out:
                    limit = max(MIN_FILE_LIMIT, MAX_FILE_RATIO * os.fstat(source.fileno()).st_size)
                    reader, written = zstandard.ZstdDecompressor().stream_reader(source), 0
                    while block := reader.read(1 << 20):
                        written += len(block)
                        if written > limit:
                            raise ReadError(f"{where}: {file.name} inflates to more than {limit:,} bytes (at most "
                                            f"{MAX_FILE_RATIO} times its size): a damaged or hostile file")
                        out.write(block)
            except zstandard.ZstdError as err:
                raise ReadError(f"{where}: {file.name} does not decompress (zstd: {err})") from err
            except OSError as err:
                raise ReadError(f"{where}: cannot read {file.name}: {err.strerror or err}") from err
            plain.append(target)
        yield plain


def message_decompressor(meta: BagMetadata, where: str) -> Callable[[bytes], bytes] | None:
    """What decompresses one message of a bag compressed message by message; None otherwise.

    Raises:
        ReadError: an unknown compression.
    """
    if meta.compression_mode != "message":
        return None
    if meta.compression != "zstd":
        raise ReadError(f"{where}: messages compressed with '{meta.compression}' (tfrec reads zstd)")
    import zstandard

    decompressor = zstandard.ZstdDecompressor()

    def decompress(data: bytes) -> bytes:
        try:  # bounded: zstd ignores max_output_size when the frame states its size, so that is checked first
            if (declared := zstandard.frame_content_size(data)) > MAX_CHUNK_BYTES:
                raise ReadError(f"{where}: a compressed message inflates to {declared:,} bytes (its zstd frame "
                                f"says), more than the {MAX_CHUNK_BYTES:,} a message may have")
            return bytes(decompressor.decompress(data, max_output_size=MAX_CHUNK_BYTES))
        except zstandard.ZstdError as err:
            raise ReadError(f"{where}: a message does not decompress (zstd: {err})") from err

    return decompress
