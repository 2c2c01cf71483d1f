"""Which messages have a learnt layout (tfrec.formats.ros.decode.match_layout): the one-pass comparison over
the bytes the rows span gives, message for message, what comparing each message's fixed bytes alone gives —
for rows lying evenly spaced in a chunk (a view), unevenly (a gathered copy), given as separate messages, and
past the size the one-pass comparison takes."""

from __future__ import annotations

import numpy as np
import pytest

from tfrec.formats.ros import decode
from tfrec.formats.ros.decode import MessageLayout, RawMessages, match_layout, message_layout
from tfrec.formats.ros.encode import JointStateEncoder, TFMessageEncoder

RNG_SEED = 20261126


def _messages(kind: str, n: int, *, ros1: bool) -> np.ndarray:
    rng = np.random.default_rng(RNG_SEED)
    stamps = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 10_000_000
    if kind == "tf":
        encoder = TFMessageEncoder(["base", "link1", "link2"], ["link1", "link2", "tool"], ros1=ros1)
        return encoder.encode(stamps, rng.normal(size=(n, 3, 3)), rng.normal(size=(n, 3, 4)))
    joints = JointStateEncoder(["joint1", "joint2", "finger_joint1"], ros1=ros1)
    return joints.encode(stamps, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)))


def _expected(layout: MessageLayout, messages: list[bytes]) -> list[bool]:
    """A message has the layout when it is as long and every fixed byte range is the template's."""
    template = layout.template.tobytes()
    return [len(m) == layout.size and all(m[a:b] == template[a:b] for a, b in layout.fixed) for m in messages]


def _damaged(rows: np.ndarray, layout: MessageLayout, seed: int) -> list[bytes]:
    """The messages with single bytes changed in some: fixed bytes, variable bytes; some cut short or longer."""
    rng = np.random.default_rng(seed)
    fixed = np.concatenate([np.arange(a, b) for a, b in layout.fixed])
    variable = np.setdiff1d(np.arange(layout.size), fixed)
    out = []
    for row in rows:
        data = bytearray(row.tobytes())
        what = rng.integers(0, 8)
        if what == 0:
            data[int(rng.choice(fixed))] ^= 1 << int(rng.integers(0, 8))
        elif what == 1 and len(variable):
            data[int(rng.choice(variable))] ^= 0xFF
        elif what == 2:
            data = data[:-1]
        elif what == 3:
            data += b"\0"
        out.append(bytes(data))
    return out


def _chunk(messages: list[bytes], gaps: list[int]) -> tuple[bytes, np.ndarray, np.ndarray]:
    """The messages in one buffer, each after ``gaps[i]`` bytes of other records."""
    buffer = bytearray()
    starts, stops = [], []
    for data, gap in zip(messages, gaps):
        buffer += bytes(range(gap % 256))[:gap].ljust(gap, b"\x07")
        starts.append(len(buffer))
        buffer += data
        stops.append(len(buffer))
    return bytes(buffer), np.array(starts, dtype=np.int64), np.array(stops, dtype=np.int64)


def _check(layout: MessageLayout, messages: list[bytes], datas: object) -> None:
    rows, good, others = match_layout(layout, datas)  # type: ignore[arg-type]
    expected = _expected(layout, messages)
    assert good.tolist() == [k for k, ok in enumerate(expected) if ok]
    assert others == [k for k, ok in enumerate(expected) if not ok]
    assert rows is not None
    assert [bytes(row) for row in rows] == [messages[k] for k in good.tolist()]


@pytest.mark.parametrize("ros1", [False, True], ids=["cdr", "ros1"])
@pytest.mark.parametrize("kind", ["tf", "joint_states"])
@pytest.mark.parametrize("spacing", ["even", "uneven", "separate", "one"])
def test_the_one_pass_match_is_the_per_message_match(kind: str, ros1: bool, spacing: str) -> None:
    clean = _messages(kind, 300, ros1=ros1)
    layout = message_layout(kind, clean[0].tobytes(), ros1=ros1)
    for seed in range(4):
        messages = _damaged(clean, layout, seed) if seed else [row.tobytes() for row in clean]
        if spacing == "one":
            messages = messages[seed : seed + 1]
        if spacing == "separate":
            _check(layout, messages, messages)
            continue
        gaps = [31] * len(messages) if spacing in ("even", "one") else [31 + (k % 3) for k in range(len(messages))]
        buffer, starts, stops = _chunk(messages, gaps)
        _check(layout, messages, RawMessages(buffer, starts, stops))


@pytest.mark.parametrize("rows_per_pass", [4, 0.5], ids=["blocks", "one-by-one"])
def test_rows_past_the_one_pass_size(monkeypatch: pytest.MonkeyPatch, rows_per_pass: float) -> None:
    """More rows than one pass takes are compared a block at a time; rows further apart than it takes (other
    messages between them), one by one."""
    clean = _messages("tf", 200, ros1=False)
    layout = message_layout("tf", clean[0].tobytes(), ros1=False)
    messages = _damaged(clean, layout, 7)
    buffer, starts, stops = _chunk(messages, [31] * len(messages))
    monkeypatch.setattr(decode, "TILED_BYTES", int(rows_per_pass * (layout.size + 31)))
    decode._TILED.clear()
    _check(layout, messages, RawMessages(buffer, starts, stops))
    assert all(len(template) <= 2 * decode.TILED_BYTES + layout.size for template, _ in decode._TILED.values())


def test_a_layout_learnt_again_reuses_the_repeated_template() -> None:
    """Each piece learns its layout from its first message (other stamps and values, the same fixed bytes):
    the template repeated along the rows is made once, and a longer run of rows makes it again."""
    clean = _messages("joint_states", 600, ros1=False)
    decode._TILED.clear()
    for first in (0, 1, 2):
        layout = message_layout("joint_states", clean[first].tobytes(), ros1=False)
        buffer, starts, stops = _chunk([row.tobytes() for row in clean[:100]], [31] * 100)
        _check(layout, [row.tobytes() for row in clean[:100]], RawMessages(buffer, starts, stops))
    assert len(decode._TILED) == 1
    buffer, starts, stops = _chunk([row.tobytes() for row in clean], [31] * len(clean))
    _check(layout, [row.tobytes() for row in clean], RawMessages(buffer, starts, stops))
    (template, _), = decode._TILED.values()
    assert len(template) >= (len(clean) - 1) * (layout.size + 31) + layout.size
