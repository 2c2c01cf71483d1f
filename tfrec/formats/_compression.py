"""Decompressing chunks without trusting their sizes: zstd, lz4 (MCAP, ROS 1), bz2 (ROS 1).

A recording is input from others, and compression makes it cheap to ask for a lot of memory: a
131 kB zstd frame of zeros inflates to 4 GiB, and a zstd frame that records its content size
in its header is inflated to that size by ``zstandard``'s one-shot ``decompress`` whatever
``max_output_size`` says. The functions here never produce more than the bound they are given:

* :func:`decompress` — a whole chunk, refused without any work when it declares more
  than the limit, and refused as soon as it inflates past what it declared;
* :func:`salvage` — what decompresses of a chunk the file ends inside (or that turns
  corrupt), at most ``limit`` bytes: what the whole data would give, cut at ``limit``, without inflating the rest.

Both stream: zstd through ``stream_reader`` (or one shot when the frame header states exactly
the declared size), lz4 and bz2 through their decompressors' ``max_length``.
"""

from __future__ import annotations

from typing import Protocol

__all__ = ["MAX_CHUNK_BYTES", "decompress", "inflate_at_most", "salvage"]

MAX_CHUNK_BYTES = 512 * 1024 * 1024
"""A suggested ``limit`` for one chunk's records. Writers cut chunks at a few MiB (rosbag2's MCAP
default: 768 KiB; ROS 1: 768 KiB) but a single large message (a point cloud, a 4K image) makes
its chunk as large as itself; 512 MiB leaves room for those and still bounds what a hostile
file can make a reader allocate."""

_UNCOMPRESSED = ("", "none")
"""How MCAP (``""``) and ROS 1 bags (``"none"``) name uncompressed chunks."""
_KNOWN = ("", "none", "zstd", "lz4", "bz2")
_STEP = 1 << 20
"""Output produced per call while streaming (bytes)."""
_FEED = 1 << 20
"""Compressed bytes given to a decompressor at a time."""
_PIECE = 4096
"""Compressed bytes fed at a time when salvaging lz4 and bz2."""
_ZSTD_PIECE = 64
"""Compressed bytes fed at a time when salvaging zstd. An RLE block turns 4 bytes into 128 KiB,
so a piece can inflate 32,768-fold: 64 bytes give at most 2 MiB past the bound."""


def decompress(
    compression: str,
    data: bytes | memoryview,
    declared_size: int,
    *,
    limit: int = MAX_CHUNK_BYTES,
    supported: tuple[str, ...] | None = None,
) -> bytes | memoryview:
    """A whole chunk's records, decompressed, never inflating past ``min(limit, declared_size)``.

    Args:
        compression: ``""`` or ``"none"`` (uncompressed), ``zstd``, ``lz4`` or ``bz2``.
        data: the compressed records.
        declared_size: their uncompressed size, as the chunk declares it.
        limit: the most bytes a chunk may declare (:data:`MAX_CHUNK_BYTES`).
        supported: the compressions the format allows (default: all of the above).

    Returns:
        Exactly ``declared_size`` bytes.

    Raises:
        ValueError: an unsupported compression; a chunk that declares more than ``limit``
            bytes (no work is done); data that inflates to more than it declares (refused as
            soon as it does), to less, or that does not decompress.
    """
    _check_supported(compression, supported)
    if declared_size < 0:
        raise ValueError(f"it declares a negative size ({declared_size:,} bytes)")
    if declared_size > limit:
        raise ValueError(f"it declares {declared_size:,} bytes of records, more than the {limit:,} allowed")
    if compression in _UNCOMPRESSED:
        if len(data) != declared_size:
            raise ValueError(f"its records are {len(data):,} bytes, not the {declared_size:,} declared")
        return data
    out = _inflate(compression, data, declared_size)
    if len(out) > declared_size:
        raise ValueError(f"its records inflate to more than the {declared_size:,} bytes declared")
    if len(out) != declared_size:
        raise ValueError(f"its records decompress to {len(out):,} bytes, not {declared_size:,}")
    return out


def inflate_at_most(
    compression: str,
    data: bytes | memoryview,
    limit: int = MAX_CHUNK_BYTES,
) -> bytes | memoryview:
    """All of ``data`` decompressed where nothing declares its size (a ROS 1 chunk as rosbags reads it,
    one message of a rosbag2 bag compressed per message): refused as soon as it inflates past ``limit``.

    Raises:
        ValueError: an unknown compression; data that inflates past ``limit``, or that does not decompress.
    """
    _check_supported(compression, None)
    if compression in _UNCOMPRESSED:
        return data
    if compression == "zstd":
        import zstandard

        try:
            size = zstandard.frame_content_size(data)
        except zstandard.ZstdError as err:
            raise ValueError(f"zstd: {err}") from err
        if size > limit:
            raise ValueError(f"it inflates to {size:,} bytes (its zstd frame says), more than the {limit:,} bytes allowed")
        if size >= 0:
            return decompress(compression, data, size, limit=limit)
    out = _inflate(compression, data, limit)
    if len(out) > limit:
        raise ValueError(f"it inflates to more than the {limit:,} bytes allowed")
    return out


def salvage(
    compression: str,
    data: bytes | memoryview,
    *,
    limit: int,
    supported: tuple[str, ...] | None = None,
) -> bytes | memoryview:
    """What decompresses of a cut or damaged chunk — every whole compressed block up to the end of
    the data or the first corrupt block — but never more than ``limit`` bytes.

    For a chunk the file ends inside this is every whole block's records, cut at ``limit``; at a
    corrupt block it may keep a few more whole blocks than a decompressor fed large pieces would
    (it feeds smaller pieces). Nothing for an unsupported or unknown compression.

    Args:
        compression: as for :func:`decompress`.
        data: the compressed records, as far as they go.
        limit: the most bytes returned: the chunk's declared size, capped by the caller's limit.
        supported: as for :func:`decompress`.
    """
    if compression not in (supported if supported is not None else _KNOWN) or limit <= 0:
        return b""
    if compression in _UNCOMPRESSED:
        return data[:limit]
    out = bytearray()
    if compression == "zstd":
        import zstandard

        feed = zstandard.ZstdDecompressor().decompressobj().decompress
        for at in range(0, len(data), _ZSTD_PIECE):
            try:
                out += feed(data[at : at + _ZSTD_PIECE])
            except zstandard.ZstdError:
                break
            if len(out) >= limit:
                break
        del out[limit:]
        return memoryview(out)
    decompressor, errors = _streaming(compression)
    try:
        for at in range(0, len(data), _PIECE):
            if decompressor.eof:
                break
            _drain(decompressor, data[at : at + _PIECE], out, limit)
            if len(out) >= limit:
                break
    except errors:
        pass  # keep what came out before the corrupt block
    return memoryview(out)


class _Streaming(Protocol):
    """What lz4's ``LZ4FrameDecompressor`` and ``bz2.BZ2Decompressor`` have in common."""

    @property
    def eof(self) -> bool: ...

    @property
    def needs_input(self) -> bool: ...

    @property
    def unused_data(self) -> bytes | None: ...

    def decompress(self, data: bytes | memoryview, max_length: int = -1, /) -> bytes: ...


def _streaming(compression: str) -> tuple[_Streaming, tuple[type[Exception], ...]]:
    """A fresh lz4 or bz2 decompressor, and the errors it reports corrupt data with."""
    if compression == "lz4":
        import lz4.frame

        return lz4.frame.LZ4FrameDecompressor(), (RuntimeError, EOFError)  # lz4: corrupt frames are RuntimeError
    import bz2

    return bz2.BZ2Decompressor(), (OSError, EOFError, ValueError)


def _drain(decompressor: _Streaming, data: bytes | memoryview, out: bytearray, bound: int) -> None:
    """Feed ``data`` and append what comes out to ``out``, until it holds ``bound`` bytes, the
    stream ends, or the decompressor needs more input — at most ``_STEP`` bytes a call."""
    out += decompressor.decompress(data, min(_STEP, bound - len(out)))
    while len(out) < bound and not decompressor.eof and not decompressor.needs_input:
        out += decompressor.decompress(b"", min(_STEP, bound - len(out)))


def _check_supported(compression: str, supported: tuple[str, ...] | None) -> None:
    if compression not in (supported if supported is not None else _KNOWN):
        raise ValueError(f"unsupported chunk compression '{compression}'")


def _inflate(compression: str, data: bytes | memoryview, declared_size: int) -> bytes | memoryview:
    """At most ``declared_size + 1`` bytes of the data, decompressed (one more tells it inflates past)."""
    if compression == "zstd":
        return _inflate_zstd(data, declared_size)
    if compression not in ("lz4", "bz2"):
        raise ValueError(f"unsupported chunk compression '{compression}'")
    bound = declared_size + 1
    out = bytearray()
    view = memoryview(data)
    at = 0
    decompressor, errors = _streaming(compression)
    started = False  # whether the current decompressor was given data
    try:
        while at < len(view) and len(out) < bound:
            piece = view[at : at + _FEED]  # in pieces: a decompressor keeps a copy of what it has not used
            _drain(decompressor, piece, out, bound)
            started = True
            if not decompressor.eof:
                at += len(piece)
                continue
            at += len(piece) - len(decompressor.unused_data or b"")
            if compression == "lz4":
                break  # lz4.frame.decompress reads the first frame; bz2.decompress every stream
            decompressor, errors = _streaming(compression)
            started = False
    except errors as err:
        raise ValueError(f"{compression}: {err}") from err
    if len(out) < bound and started and not decompressor.eof:
        raise ValueError(f"{compression}: the data ends inside the compressed stream")
    return memoryview(out)


def _inflate_zstd(data: bytes | memoryview, declared_size: int) -> bytes | memoryview:
    import zstandard

    try:
        header_size = zstandard.frame_content_size(data)
    except zstandard.ZstdError as err:
        raise ValueError(f"zstd: {err}") from err
    if header_size >= 0 and header_size != declared_size:
        if header_size > declared_size:
            raise ValueError(f"its records inflate to more than the {declared_size:,} bytes declared "
                             f"(the zstd frame declares {header_size:,})")
        raise ValueError(f"its records decompress to {header_size:,} bytes, not {declared_size:,}")
    try:
        if header_size == declared_size:  # the decoder holds the frame to its header: bounded
            out: bytes = zstandard.ZstdDecompressor().decompress(data, max_output_size=declared_size)
            return out
        reader = zstandard.ZstdDecompressor().stream_reader(data, read_across_frames=False)
        buffer = bytearray()
        bound = declared_size + 1
        while len(buffer) < bound:
            piece = reader.read(min(_STEP, bound - len(buffer)))
            if not piece:
                break
            buffer += piece
        return memoryview(buffer)
    except zstandard.ZstdError as err:
        raise ValueError(f"zstd: {err}") from err
