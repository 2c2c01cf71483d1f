"""Bounded decompression: a chunk never inflates past what it declares or the limit — checked on
4 GiB bombs of zeros (zstd, lz4, bz2) that take milliseconds and a few MB — and whatever is within
bounds decompresses exactly as the unbounded functions tfrec had before (tests/formats/unbounded_reference.py) do."""

from __future__ import annotations

import bz2
import os
import resource
import time
import tracemalloc
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import lz4.frame
import pytest
import zstandard
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.formats.unbounded_reference import decompress, salvage
from tfrec.formats._compression import MAX_CHUNK_BYTES, inflate_at_most
from tfrec.formats._compression import decompress as decompress_bounded
from tfrec.formats._compression import salvage as salvage_bounded

GiB = 1 << 30
MiB = 1 << 20
ZEROS = bytes(4 * MiB)


def zstd_bomb(total: int, *, declare_size: bool) -> bytes:
    """``total`` zero bytes as one zstd frame, built piece by piece (never ``total`` bytes in memory)."""
    compressor = zstandard.ZstdCompressor(level=1, write_content_size=declare_size)
    stream = compressor.compressobj(size=total if declare_size else -1)
    parts = [stream.compress(ZEROS) for _ in range(total // len(ZEROS))]
    return b"".join([*parts, stream.flush()])


def lz4_bomb(total: int) -> bytes:
    compressor = lz4.frame.LZ4FrameCompressor()
    parts = [compressor.begin()] + [compressor.compress(ZEROS) for _ in range(total // len(ZEROS))]
    return b"".join([*parts, compressor.flush()])


def bz2_bomb(total: int) -> bytes:
    """``total`` zero bytes as concatenated bz2 streams of 64 MiB (79 bytes each)."""
    compressor = bz2.BZ2Compressor(9)
    parts = [compressor.compress(ZEROS) for _ in range(64 * MiB // len(ZEROS))]
    one = b"".join([*parts, compressor.flush()])
    return one * (total // (64 * MiB))


@pytest.fixture(scope="module")
def bombs() -> dict[str, bytes]:
    """4 GiB of zeros in each compression: zstd with and without the size in its frame header."""
    return {
        "zstd": zstd_bomb(4 * GiB, declare_size=True),
        "zstd-unsized": zstd_bomb(4 * GiB, declare_size=False),
        "lz4": lz4_bomb(4 * GiB),
        "bz2": bz2_bomb(4 * GiB),
    }


@contextmanager
def bounded_memory(limit: int, seconds: float = 30.0) -> Iterator[None]:
    """The block allocates under ``limit`` bytes of Python memory, grows the process's peak by
    under 512 MiB, and uses under ``seconds`` of CPU time (a hang guard: a bomb inflated in full
    would take minutes)."""
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    tracemalloc.start()
    start = time.process_time()
    try:
        yield
    finally:
        elapsed = time.process_time() - start
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    rss_growth_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss_before
    assert peak < limit, f"{peak:,} bytes allocated"
    assert rss_growth_kib < 512 * 1024, f"peak RSS grew by {rss_growth_kib:,} KiB"
    assert elapsed < seconds, f"{elapsed:.2f} s of CPU time"


def test_the_bombs_are_small(bombs: dict[str, bytes]) -> None:
    assert len(bombs["zstd"]) < 200_000 and len(bombs["zstd-unsized"]) < 200_000
    assert zstandard.frame_content_size(bombs["zstd"]) == 4 * GiB
    assert len(bombs["lz4"]) < 20 * MiB and len(bombs["bz2"]) < 10_000


@pytest.mark.parametrize("kind", ["zstd", "zstd-unsized", "lz4", "bz2"])
def test_a_bomb_declared_as_4_gib_is_refused_without_work(bombs: dict[str, bytes], kind: str) -> None:
    with bounded_memory(1 * MiB, seconds=0.1), pytest.raises(
            ValueError, match=r"^it declares 4,294,967,296 bytes of records, more than the 536,870,912 allowed$"):
        decompress_bounded(kind.split("-")[0], bombs[kind], 4 * GiB, limit=MAX_CHUNK_BYTES)


@pytest.mark.parametrize("kind", ["zstd", "zstd-unsized", "lz4", "bz2"])
def test_a_bomb_declared_as_1_kb_is_refused_quickly(bombs: dict[str, bytes], kind: str) -> None:
    with bounded_memory(4 * MiB), pytest.raises(ValueError, match=r"^its records inflate to more than the 1,000 "
                                                                  r"bytes declared"):
        decompress_bounded(kind.split("-")[0], bombs[kind], 1000, limit=MAX_CHUNK_BYTES)


@pytest.mark.parametrize("kind", ["zstd", "zstd-unsized", "lz4", "bz2"])
def test_a_bomb_declared_at_the_limit_inflates_to_the_limit_only(bombs: dict[str, bytes], kind: str) -> None:
    with bounded_memory(50_000_000 * 13 // 10), pytest.raises(ValueError, match=r"inflate to more than the 50,000,000 "):
        decompress_bounded(kind.split("-")[0], bombs[kind], 50_000_000, limit=50_000_000)


@pytest.mark.parametrize("kind", ["zstd", "zstd-unsized", "lz4", "bz2"])
def test_salvaging_a_bomb_stops_at_the_limit(bombs: dict[str, bytes], kind: str) -> None:
    compression = kind.split("-")[0]
    with bounded_memory(8 * MiB):
        records = salvage_bounded(compression, bombs[kind], limit=MiB)
    assert bytes(records) == bytes(MiB)
    half = memoryview(bombs[kind])[: len(bombs[kind]) // 2]
    with bounded_memory(8 * MiB):
        cut = salvage_bounded(compression, half, limit=1000)
    assert bytes(cut) == bytes(1000)


@pytest.mark.parametrize("kind", ["zstd", "zstd-unsized", "lz4", "bz2"])
def test_inflating_at_most_stops_a_bomb_at_the_limit(bombs: dict[str, bytes], kind: str) -> None:
    """What nothing declares the size of (a ROS 1 chunk as rosbags reads it, a rosbag2 message compressed on its
    own) is refused as soon as it passes the limit; a zstd frame that states 4 GiB without any work."""
    seconds = 0.1 if kind == "zstd" else 3.0
    with bounded_memory(50_000_000 * 13 // 10, seconds=seconds), pytest.raises(
            ValueError, match=r"^it inflates to (4,294,967,296 bytes \(its zstd frame says\), )?more than the "
                              r"50,000,000 bytes allowed$"):
        inflate_at_most(kind.split("-")[0], bombs[kind], 50_000_000)


# ---- within bounds: exactly what the unbounded functions give -----------------------------

COMPRESSORS: dict[str, Callable[[bytes], bytes]] = {
    "zstd": zstandard.ZstdCompressor().compress,
    "zstd-unsized": zstandard.ZstdCompressor(write_content_size=False).compress,
    "lz4": lz4.frame.compress,
    "bz2": bz2.compress,
}


def records(size: int) -> bytes:
    """Something like a chunk's records: a compressible pattern with random bytes in it."""
    pattern = b"\x05\x00\x00\x00/tf_static" + os.urandom(24)
    return (pattern * (size // len(pattern) + 1))[:size]


@pytest.mark.parametrize("kind", list(COMPRESSORS))
@pytest.mark.parametrize("size", [0, 1, 1000, 300_000, 3 * MiB])
def test_inflating_at_most_round_trips(kind: str, size: int) -> None:
    data = records(size)
    assert bytes(inflate_at_most(kind.split("-")[0], COMPRESSORS[kind](data), 3 * MiB)) == data


@pytest.mark.parametrize("kind", list(COMPRESSORS))
@pytest.mark.parametrize("size", [0, 1, 1000, 300_000, 3 * MiB])
def test_round_trips(kind: str, size: int) -> None:
    compression = kind.split("-")[0]
    data = records(size)
    packed = COMPRESSORS[kind](data)
    assert bytes(decompress_bounded(compression, packed, size, limit=MAX_CHUNK_BYTES)) == data
    assert bytes(decompress_bounded(compression, packed, size, limit=size)) == data
    if size:  # the unbounded zstd path cannot read an empty frame without a content size
        assert bytes(decompress(compression, packed, size, supported=(compression,))) == data


def test_uncompressed_chunks() -> None:
    data = memoryview(records(5000))
    for name in ("", "none"):
        assert decompress_bounded(name, data, 5000, limit=5000) is data
        with pytest.raises(ValueError, match=r"^its records are 5,000 bytes, not the 4,000 declared$"):
            decompress_bounded(name, data, 4000, limit=5000)
        with pytest.raises(ValueError, match=r"^it declares 5,000 bytes of records, more than the 4,999 allowed$"):
            decompress_bounded(name, data, 5000, limit=4999)
        assert bytes(salvage_bounded(name, data, limit=100)) == bytes(data[:100])


@pytest.mark.parametrize("kind", list(COMPRESSORS))
def test_a_short_chunk_is_refused(kind: str) -> None:
    compression = kind.split("-")[0]
    packed = COMPRESSORS[kind](records(10_000))
    with pytest.raises(ValueError, match=r"(decompress to 10,000 bytes, not 20,000|frame|end)"):
        decompress_bounded(compression, packed, 20_000, limit=MAX_CHUNK_BYTES)
    with pytest.raises(ValueError):
        decompress_bounded(compression, packed[: len(packed) // 2], 10_000, limit=MAX_CHUNK_BYTES)


@pytest.mark.parametrize("kind", list(COMPRESSORS))
def test_corrupt_data_is_a_value_error(kind: str) -> None:
    compression = kind.split("-")[0]
    packed = bytearray(COMPRESSORS[kind](records(100_000)))
    packed[len(packed) // 2 : len(packed) // 2 + 64] = os.urandom(64)
    with pytest.raises(ValueError):
        decompress_bounded(compression, bytes(packed), 100_000, limit=MAX_CHUNK_BYTES)
    with pytest.raises(ValueError, match=r"^(zstd|lz4|bz2): "):
        decompress_bounded(compression, b"\x00" * 64, 100, limit=MAX_CHUNK_BYTES)


def test_unsupported_compressions() -> None:
    with pytest.raises(ValueError, match=r"^unsupported chunk compression 'brotli'$"):
        decompress_bounded("brotli", b"", 0, limit=1)
    with pytest.raises(ValueError, match=r"^unsupported chunk compression 'bz2'$"):
        decompress_bounded("bz2", b"", 0, limit=1, supported=("", "zstd", "lz4"))
    assert salvage_bounded("brotli", b"abc", limit=10) == b""
    assert salvage_bounded("bz2", bz2.compress(b"abc"), limit=10, supported=("zstd",)) == b""


def test_concatenated_bz2_streams_decompress_as_bz2_does() -> None:
    data = bz2.compress(b"first ") + bz2.compress(b"second")
    assert bytes(decompress_bounded("bz2", data, 12, limit=100)) == bz2.decompress(data) == b"first second"


def test_lz4_reads_the_first_frame_as_lz4_frame_does() -> None:
    data = lz4.frame.compress(b"first") + lz4.frame.compress(b"second")
    assert bytes(decompress_bounded("lz4", data, 5, limit=100)) == lz4.frame.decompress(data) == b"first"


def zstd_in_blocks(data: bytes, block: int = 128 * 1024) -> bytes:
    """zstd as tfrec's MCAP writer makes it: a block ended every 128 KiB of records."""
    stream = zstandard.ZstdCompressor().compressobj()
    parts = []
    for at in range(0, len(data), block):
        parts.append(stream.compress(data[at : at + block]))
        parts.append(stream.flush(zstandard.COMPRESSOBJ_FLUSH_BLOCK))
    return b"".join([*parts, stream.flush()])


@settings(max_examples=60, deadline=None)
@given(kind=st.sampled_from([*COMPRESSORS, "zstd-blocks"]), size=st.integers(0, 700_000),
       cut=st.floats(0, 1), limit=st.integers(0, 800_000))
def test_salvage_of_a_cut_chunk_is_salvage_up_to_the_limit(kind: str, size: int, cut: float, limit: int) -> None:
    compression = kind.split("-")[0]
    data = records(size)
    packed = zstd_in_blocks(data) if kind == "zstd-blocks" else COMPRESSORS[kind](data)
    part = packed[: int(len(packed) * cut)]
    expected = bytes(salvage(compression, part, supported=(compression,)))[:limit]
    got = bytes(salvage_bounded(compression, part, limit=limit))
    # the same records, or a few more of them: the bounded salvage feeds smaller pieces, so an lz4 frame's
    # last, uncompressed block can come out in part where the reference's larger piece gives none of it
    assert got.startswith(expected) and data.startswith(got) and len(got) <= limit
