"""The unbounded chunk decompression tfrec had before issue 11, kept as the reference the bounded one
(:mod:`tfrec.formats._compression`) is tested equal to on ordinary data: zstd, lz4 (MCAP, ROS 1) and bz2 (ROS 1).

A chunk that decompresses with an error, or to the wrong size, is damaged (:func:`decompress`).
A chunk that the file ends inside still holds the records of every compressed block that is
whole — zstd and lz4 compress in blocks of 128 KiB and 64 KiB of records, bz2 in blocks of up
to 900 kB — so :func:`salvage` feeds its data to a streaming decompressor a piece at a time and
keeps what comes out before the data ends or a block is corrupt.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["decompress", "salvage"]

_UNCOMPRESSED = ("", "none")
"""How MCAP (``""``) and ROS 1 bags (``"none"``) name uncompressed chunks."""
_PIECE = 4096
"""Compressed bytes fed at a time when salvaging a cut chunk, so the blocks before a corrupt tail come out."""


def decompress(compression: str, data: bytes | memoryview, size: int, *, supported: tuple[str, ...]) -> bytes | memoryview:
    """A whole chunk's records, decompressed.

    Args:
        compression: the chunk's compression: ``""`` or ``"none"`` (uncompressed), ``zstd``,
            ``lz4`` or ``bz2``.
        data: the compressed records.
        size: their uncompressed size, as the chunk gives it.
        supported: the compressions the format allows.

    Raises:
        ValueError: the compression is not supported, or the data does not decompress to ``size`` bytes.
    """
    if compression not in supported:
        raise ValueError(f"unsupported chunk compression '{compression}'")
    out: bytes | memoryview
    if compression in _UNCOMPRESSED:
        out = data
    elif compression == "zstd":
        import zstandard

        try:
            out = zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
        except zstandard.ZstdError as err:
            raise ValueError(f"zstd: {err}") from err
    elif compression == "lz4":
        import lz4.frame

        try:
            out = lz4.frame.decompress(data)
        except RuntimeError as err:  # lz4 reports corrupt frames as RuntimeError
            raise ValueError(f"lz4: {err}") from err
    elif compression == "bz2":
        import bz2

        try:
            out = bz2.decompress(data)
        except (OSError, EOFError, ValueError) as err:
            raise ValueError(f"bz2: {err}") from err
    else:
        raise ValueError(f"unsupported chunk compression '{compression}'")
    if len(out) != size:
        raise ValueError(f"its records decompress to {len(out):,} bytes, not {size:,}")
    return out


def salvage(compression: str, data: bytes | memoryview, *, supported: tuple[str, ...]) -> bytes | memoryview:
    """What decompresses of a cut chunk's records: every whole compressed block, up to the end
    of the data or to the first corrupt block; nothing for an unsupported compression.

    Args: as for :func:`decompress`.
    """
    if compression not in supported:
        return b""
    if compression in _UNCOMPRESSED:
        return data
    feed: Callable[[bytes | memoryview], bytes]
    errors: tuple[type[Exception], ...]
    if compression == "zstd":
        import zstandard

        feed, errors = zstandard.ZstdDecompressor().decompressobj().decompress, (zstandard.ZstdError,)
    elif compression == "lz4":
        import lz4.frame

        feed, errors = lz4.frame.LZ4FrameDecompressor().decompress, (RuntimeError, EOFError)
    elif compression == "bz2":
        import bz2

        feed, errors = bz2.BZ2Decompressor().decompress, (OSError, EOFError, ValueError)
    else:
        return b""
    out: list[bytes] = []
    for at in range(0, len(data), _PIECE):
        try:
            out.append(feed(data[at : at + _PIECE]))
        except errors:
            break
    return b"".join(out)
