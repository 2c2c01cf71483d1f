"""Hypothesis strategies that mutate real inputs: bytes, XML descriptions, CSV, YAML, MCAP records, ROS 1
bag headers and the messages of a sqlite3 bag.

Each strategy takes a seed (a real file's content) and draws a short list of mutations applied in turn, so
that most examples stay close enough to the original to reach deep into tfrec (a flipped byte inside a
message, a joint whose axis became ``1e200 1e200 1e200``) rather than being refused at the first check.
"""

from __future__ import annotations

import contextlib
import sqlite3
import struct
import zlib
from pathlib import Path
from typing import Any
from xml.dom import minidom

import xacro.xmlutils  # noqa: F401 — xacro replaces minidom's Element.writexml when imported: import it before
from hypothesis import strategies as st  # the first serialization, so that every example serializes alike

__all__ = [
    "HOSTILE_NUMBERS",
    "HOSTILE_TEXT",
    "chain_urdf",
    "csv_text",
    "many_channels_mcap",
    "mutated_bytes",
    "mutated_mcap",
    "mutated_ros1_bag",
    "mutated_sqlite_bag",
    "relisted_files",
    "tf_graph",
    "xml_text",
    "yaml_text",
]

HOSTILE_NUMBERS = [
    "1e200", "-1e200", "1e308", "-1e308", "1.79769e+308", "-1.79769e+308", "1e400", "-1e400", "1e-320", "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "0",
    "-0", "0.0", "1e20", "-1e20", "9" * 400, "0x10", "1_000", "1,5", "+", "-", ".", "e5", "3.14159265358979e-300",
    "18446744073709551616", "-9223372036854775809", "1e200 1e200 1e200", "nan nan nan", "0 0 0", "1 2", "1 2 3 4",
    "inf 0 0", "1e-300 1e-300 1e-300",
]
"""Values that overflow, underflow, are not finite, or are not numbers at all."""

HOSTILE_TEXT = [
    "", " ", "\t", "é", "ä ö ü", "名前", "\u202e", "\ufeff", "x" * 5000, "a b", "a/b", "/", "//", "&amp;", "&lt;x&gt;",
    "${1/0}", "${10**10**9}", "${'x'*10**9}", "${[1]*10**9}", "${undefined_name}", "${().__class__}",
    "${(lambda: 1)()}", "$(find nowhere_pkg)", "$(arg undefined_arg)", "$(env HOME)", "$(optenv NOPE x)",
    "$(eval 1+)", "${", "$(", "$(find robot)/../../../../etc/passwd", "package://robot/../../etc/passwd",
    "package://robot/%2e%2e/%2e%2e/etc/passwd", "package://../etc/passwd", "file:///etc/passwd", "/etc/passwd",
    "/dev/zero", "/proc/self/environ", "package://robot/meshes/none.stl", "file:///dev/zero",
]
"""Strings a description should reject or take literally, never run, read from elsewhere, or hang on."""

_INTERESTING_INTS = [0, 1, 0x7F, 0x80, 0xFF, 0x7FFF, 0xFFFF, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 1 << 32, 1 << 40,
                     (1 << 62), (1 << 63) - 1, 1 << 63, (1 << 64) - 1]


@st.composite
def mutated_bytes(draw: st.DrawFn, data: bytes, *, max_ops: int = 4) -> bytes:
    """``data`` with 1 to ``max_ops`` byte-level mutations: bit flips, bytes set, truncations, insertions,
    deletions, duplications, and integers (lengths, counts, offsets) overwritten with extreme values."""
    out = bytearray(data)
    for _ in range(draw(st.integers(1, max_ops))):
        size = len(out)
        kind = draw(st.sampled_from(["flip", "set", "truncate", "insert", "delete", "duplicate", "integer"]))
        if size == 0:
            kind = "insert"
        pos = draw(st.integers(0, max(size - 1, 0)))
        if kind == "flip":
            out[pos] ^= 1 << draw(st.integers(0, 7))
        elif kind == "set":
            out[pos] = draw(st.sampled_from([0x00, 0xFF, 0x7F, 0x80, 0x20, 0x0A, 0x22, 0x3C]))
        elif kind == "truncate":
            del out[pos:]
        elif kind == "insert":
            out[pos:pos] = draw(st.binary(min_size=1, max_size=16))
        elif kind == "delete":
            del out[pos:pos + draw(st.integers(1, 64))]
        elif kind == "duplicate":
            length = draw(st.integers(1, 256))
            out[pos:pos] = out[pos:pos + length]
        else:
            width = draw(st.sampled_from([2, 4, 8]))
            value = draw(st.sampled_from(_INTERESTING_INTS)) & ((1 << (8 * width)) - 1)
            out[pos:pos + width] = value.to_bytes(width, "little")
    return bytes(out)


# ---- XML -----------------------------------------------------------------------------------------------------

_XACRO_TAGS = ["xacro:include", "xacro:property", "xacro:arg", "xacro:if", "xacro:unless", "xacro:macro",
               "xacro:insert_block", "xacro:element", "xacro:attribute", "xacro:call", "link", "joint", "mesh",
               "origin", "axis", "limit", "mimic", "parent", "child", "robot", "visual", "geometry", "box"]
_ATTRIBUTES = ["name", "value", "filename", "type", "xyz", "rpy", "link", "joint", "lower", "upper", "effort",
               "velocity", "params", "default", "macro", "multiplier", "offset", "size", "radius", "length",
               "scale", "ns", "optional", "xacro:name", "soft_lower_limit", "k_position", "rgba"]


def _elements(doc: minidom.Document) -> list[minidom.Element]:
    return [node for node in doc.getElementsByTagName("*")]


@st.composite
def xml_text(draw: st.DrawFn, text: str, *, max_ops: int = 3) -> bytes:
    """A description with element- and attribute-level mutations: elements deleted, duplicated, moved, renamed
    or nested deeply; attributes deleted, added, or their values replaced by hostile numbers and strings. Then
    sometimes byte-level mutations on top, or the text in another encoding (with its declaration)."""
    doc = minidom.parseString(text.encode("utf-8"))
    nested: list[str] = []
    for _ in range(draw(st.integers(1, max_ops))):
        elements = _elements(doc)
        element = elements[draw(st.integers(0, len(elements) - 1))]
        kind = draw(st.sampled_from(["value", "value", "value", "number", "number", "drop-attr", "add-attr",
                                     "delete", "duplicate", "move", "rename", "empty", "nest"]))
        parent = element.parentNode
        is_root = parent is doc
        if kind in ("value", "number", "drop-attr") and not element.attributes.length:
            kind = "add-attr"
        if kind == "value":
            name = draw(st.sampled_from(sorted(element.attributes.keys())))
            element.setAttribute(name, draw(st.sampled_from(HOSTILE_TEXT + HOSTILE_NUMBERS)))
        elif kind == "number":
            name = draw(st.sampled_from(sorted(element.attributes.keys())))
            element.setAttribute(name, draw(st.sampled_from(HOSTILE_NUMBERS)))
        elif kind == "drop-attr":
            element.removeAttribute(draw(st.sampled_from(sorted(element.attributes.keys()))))
        elif kind == "add-attr":
            element.setAttribute(draw(st.sampled_from(_ATTRIBUTES)), draw(st.sampled_from(HOSTILE_TEXT + HOSTILE_NUMBERS)))
        elif is_root:
            continue
        elif kind == "delete":
            parent.removeChild(element)
        elif kind == "duplicate":
            parent.insertBefore(element.cloneNode(True), element)
        elif kind == "move":
            target = elements[draw(st.integers(0, len(elements) - 1))]
            ancestors = set()
            node: Any = target
            while node is not None:
                ancestors.add(id(node))
                node = node.parentNode
            if id(element) not in ancestors:
                parent.removeChild(element)
                target.appendChild(element)
        elif kind == "rename":
            element.tagName = element.nodeName = draw(st.sampled_from(_XACRO_TAGS))
        elif kind == "empty":
            for child in list(element.childNodes):
                element.removeChild(child)
            for name in list(element.attributes.keys()):
                element.removeAttribute(name)
        else:  # nest: the element wrapped in many levels of <n> (spliced into the text: minidom recurses)
            depth = draw(st.sampled_from([10, 150, 250, 5000]))
            placeholder = doc.createComment(f"NEST{len(nested)}")
            parent.replaceChild(placeholder, element)
            nested.append("<n>" * depth + element.toxml() + "</n>" * depth)
    xml = doc.toxml()
    for k, splice in enumerate(nested):
        xml = xml.replace(f"<!--NEST{k}-->", splice)
    out = xml.encode("utf-8")
    encoding = draw(st.sampled_from(["utf-8"] * 8 + ["utf-16", "latin-1"]))
    if encoding != "utf-8":
        declared = xml.replace('<?xml version="1.0" ?>', f'<?xml version="1.0" encoding="{encoding.upper()}"?>', 1)
        out = declared.encode(encoding, errors="replace")
    if draw(st.integers(0, 4)) == 0:
        out = draw(mutated_bytes(out, max_ops=2))
    return out


# ---- CSV --------------------------------------------------------------------------------------------------------

@st.composite
def csv_text(draw: st.DrawFn, text: str, *, max_ops: int = 3) -> bytes:
    """A CSV trajectory with rows deleted, duplicated or swapped, cells and header names replaced by hostile
    values, columns added or removed, a very long line, odd line endings; sometimes byte mutations on top."""
    rows = [line.split(",") for line in text.splitlines()]
    for _ in range(draw(st.integers(1, max_ops))):
        kind = draw(st.sampled_from(["cell", "cell", "header", "delete-row", "duplicate-row", "swap", "add-column",
                                     "drop-column", "long-line", "blank", "many-rows"]))
        r = draw(st.integers(0, len(rows) - 1)) if rows else 0
        if not rows:
            rows.append(["time"])
        row = rows[min(r, len(rows) - 1)]
        if kind == "cell" and row:
            row[draw(st.integers(0, len(row) - 1))] = draw(st.sampled_from(HOSTILE_NUMBERS + ["", " ", "é", '"1"',
                                                                                            "1e5", "-1", "0.01"]))
        elif kind == "header" and rows[0]:
            rows[0][draw(st.integers(0, len(rows[0]) - 1))] = draw(st.sampled_from(
                ["time", "joint1", "joint2", "gripper_joint", "finger_joint2", "nope", "", " time", "TIME", "é",
                 '"time"', "time\x00"]))
        elif kind == "delete-row":
            del rows[r]
        elif kind == "duplicate-row":
            rows.insert(r, list(row))
        elif kind == "swap" and len(rows) > 2:
            s = draw(st.integers(1, len(rows) - 1))
            rows[r], rows[s] = rows[s], rows[r]
        elif kind == "add-column":
            for each in rows:
                each.append(draw(st.sampled_from(["0", "joint3", "1e200", ""])))
        elif kind == "drop-column" and row:
            c = draw(st.integers(0, len(row) - 1))
            for each in rows:
                del each[c:c + 1]
        elif kind == "long-line":
            rows.insert(r, ["0." + "1" * draw(st.sampled_from([1000, 100_000, 2_000_000, 100_000_000]))])
        elif kind == "blank":
            rows.insert(r, [])
        elif kind == "many-rows" and len(rows) > 1:
            step, start = 0.001, float(len(rows))
            rows.extend([[f"{start + i * step:.3f}"] + row[1:] for i in range(draw(st.sampled_from([1000, 50_000])))])
    ending = draw(st.sampled_from(["\n", "\r\n", "\r", "\n\n"]))
    out = (ending.join(",".join(row) for row in rows) + ending).encode("utf-8")
    if draw(st.integers(0, 5)) == 0:
        out = b"\xef\xbb\xbf" + out
    if draw(st.integers(0, 4)) == 0:
        out = draw(mutated_bytes(out, max_ops=2))
    return out


# ---- YAML -------------------------------------------------------------------------------------------------------

_YAML_VALUES = ["-1", "0", "1e400", ".nan", ".inf", "~", "null", "[]", "{}", "''", "'x'", "99999999999999999999999",
                "-9223372036854775809", "18446744073709551616", "2.5", "true", "[1, 2]", "{a: 1}", "!!binary aGk=",
                "!!python/object/apply:os.system ['true']", "*undefined", "&a x", "|\n  text", "'\u202e'",
                "/etc/passwd", "../../etc/passwd", "x" * 3000]


def _bomb(levels: int, width: int) -> str:
    lines = ["lol0: &l0 [lol]"]
    lines += [f"lol{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * width) + "]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


@st.composite
def yaml_text(draw: st.DrawFn, text: str, *, max_ops: int = 3) -> bytes:
    """A YAML document (a rosbag2 ``metadata.yaml``) with values replaced by hostile ones (huge, negative, not
    finite, wrong type, tags, undefined aliases), lines deleted, duplicated or re-indented, an alias bomb or deep
    nesting added; sometimes byte mutations on top."""
    lines = text.splitlines()
    for _ in range(draw(st.integers(1, max_ops))):
        kind = draw(st.sampled_from(["value", "value", "value", "delete", "duplicate", "indent", "bomb", "deep",
                                     "anchor", "files"]))
        i = draw(st.integers(0, max(len(lines) - 1, 0)))
        if not lines:
            lines.append("x: 1")
        line = lines[min(i, len(lines) - 1)]
        if kind == "value" and ":" in line:
            key = line.split(":", 1)[0]
            lines[i] = f"{key}: {draw(st.sampled_from(_YAML_VALUES))}"
        elif kind == "delete":
            del lines[i:i + draw(st.integers(1, 3))]
        elif kind == "duplicate":
            lines.insert(i, line)
        elif kind == "indent":
            lines[i] = " " * draw(st.sampled_from([1, 2, 4, 7])) + line
        elif kind == "bomb":
            levels, width = draw(st.sampled_from([(4, 4), (9, 9), (12, 10)]))
            lines[:0] = _bomb(levels, width).splitlines()
        elif kind == "deep":
            depth = draw(st.sampled_from([50, 150, 20_000]))
            key = line.split(":", 1)[0] if ":" in line else "x"
            lines[i] = f"{key}: " + "[" * depth + "1" + "]" * depth
        elif kind == "files":  # a storage file listed many times, spelled otherwise, or outside the folder
            _relist_files(draw, lines)
        else:  # an anchor on one value, the alias of it elsewhere (shared nodes, as PyYAML builds them)
            if ":" in line and len(lines) > 1:
                key, _, value = line.partition(":")
                lines[i] = f"{key}: &shared {value.strip() or '{}'}"
                j = draw(st.integers(0, len(lines) - 1))
                if j != i and ":" in lines[j]:
                    lines[j] = f"{lines[j].split(':', 1)[0]}: *shared"
    out = ("\n".join(lines) + "\n").encode("utf-8")
    if draw(st.integers(0, 4)) == 0:
        out = draw(mutated_bytes(out, max_ops=2))
    return out


def _relist_files(draw: st.DrawFn, lines: list[str]) -> None:
    """``relative_file_paths`` of a metadata.yaml (its lines, in place) with its first file listed again and again
    (up to 100,000 times, 1.4 MB), spelled ``./x``, ``sub/../x``, ``../x``, or names outside the folder added."""
    start = next((i for i, line in enumerate(lines) if line.strip() == "relative_file_paths:"), None)
    if start is None or start + 1 >= len(lines) or not lines[start + 1].lstrip().startswith("- "):
        return
    indent, name = lines[start + 1].split("- ", 1)
    times = draw(st.sampled_from([2, 100, 100_000]))
    spellings = draw(st.sampled_from([[name], [name, f"./{name}", f"sub/../{name}"], [f"../{name}", name],
                                      [name, "../../etc/passwd", "/etc/passwd"], [f"{name}_{{}}"]]))
    listed = [spellings[k % len(spellings)].replace("{}", str(k)) for k in range(times)]
    lines[start + 1:start + 2] = [f"{indent}- {entry}" for entry in listed]


@st.composite
def relisted_files(draw: st.DrawFn, text: str) -> bytes:
    """A metadata.yaml whose ``relative_file_paths`` lists its file again and again (:func:`_relist_files`)."""
    lines = text.splitlines()
    _relist_files(draw, lines)
    return ("\n".join(lines) + "\n").encode("utf-8")


# ---- unbounded work from small inputs (issue 20) -------------------------------------------------------------

FRAMES = ["world", "base", "a", "b", "c", "x", "y"]


@st.composite
def tf_graph(draw: st.DrawFn) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """(/tf_static pairs, /tf pairs) of a TF that is often no tree: a chain world → base → a → b → c, then pairs
    added that make a frame its own parent, a 2-cycle, a cycle through the root, a cycle apart from the tree, a
    second parent; some pairs moved to /tf_static."""
    pairs = [("world", "base"), ("base", "a"), ("a", "b"), ("b", "c")]
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["self", "two", "root", "apart", "parent", "random"]))
        frame = draw(st.sampled_from(FRAMES))
        if kind == "self":
            pairs.append((frame, frame))
        elif kind == "two":
            pairs.append(("b", "a"))
        elif kind == "root":
            pairs.append((draw(st.sampled_from(["base", "a", "c"])), "world"))
        elif kind == "apart":
            pairs += [("x", "y"), ("y", "x")]
        elif kind == "parent":
            pairs.append((draw(st.sampled_from(["world", "x"])), frame))
        else:
            pairs.append((frame, draw(st.sampled_from(FRAMES))))
    pairs = list(dict.fromkeys(pairs))
    static = [pair for pair in pairs if draw(st.integers(0, 3)) == 0]
    return static, [pair for pair in pairs if pair not in static]


def chain_urdf(links: int, *, branches: int = 0) -> str:
    """A chain of ``links`` joints (every other one revolute), and ``branches`` leaves hanging off its links."""
    parts = ['<robot name="chain">', '<link name="l0"/>']
    limit = '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
    for i in range(1, links + 1):
        kind = "revolute" if i % 2 else "fixed"
        parts.append(f'<link name="l{i}"/><joint name="j{i}" type="{kind}"><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><origin xyz="0 0 0.001"/>{limit if kind == "revolute" else ""}</joint>')
    for k in range(branches):
        parts.append(f'<link name="leaf{k}"/><joint name="leaf{k}_joint" type="fixed"><parent link="l{k % (links + 1)}"/>'
                     f'<child link="leaf{k}"/></joint>')
    parts.append("</robot>")
    return "\n".join(parts)


def many_channels_mcap(channels: int, *, schemas: int = 1) -> bytes:
    """An MCAP of ``channels`` channels (at most 65,535: channel ids are 16 bits) of ``schemas`` schemas, one
    std_msgs/String message each, written by mcap's own writer."""
    import io

    from mcap.writer import Writer

    stream = io.BytesIO()
    writer = Writer(stream)
    writer.start(profile="ros2", library="fuzz")
    ids = [writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data\n" + b"#" * k)
           for k in range(schemas)]
    for i in range(channels):
        channel = writer.register_channel(f"/topic_{i}", "cdr", ids[i % schemas])
        writer.add_message(channel, log_time=1_700_000_000_000_000_000 + i, publish_time=0,
                           data=b"\x00\x01\x00\x00\x02\x00\x00\x00x\x00")
    writer.finish()
    return stream.getvalue()


# ---- MCAP -------------------------------------------------------------------------------------------------------

_MAGIC = b"\x89MCAP0\r\n"
_CHUNK = 0x06
_MESSAGE = 0x05


def _records(data: bytes, start: int, end: int) -> list[tuple[int, int, int]]:
    """(opcode, offset of the record, offset past it) of the records in data[start:end], as far as they parse."""
    out = []
    pos = start
    while pos + 9 <= end:
        opcode = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        if pos + 9 + length > end:
            break
        out.append((opcode, pos, pos + 9 + length))
        pos += 9 + length
    return out


def _record(opcode: int, body: bytes) -> bytes:
    return bytes([opcode]) + struct.pack("<Q", len(body)) + body


def _rebuild_chunk(body: bytes, records: bytes) -> bytes | None:
    """A chunk body with new (uncompressed) records: sizes and CRC made right again; None for a compressed chunk."""
    start, end, _size, _crc = struct.unpack_from("<QQQI", body, 0)
    (clen,) = struct.unpack_from("<I", body, 28)
    compression = body[32:32 + clen]
    if compression:
        return None
    head = struct.pack("<QQQI", start, end, len(records), zlib.crc32(records)) + struct.pack("<I", 0)
    return head + struct.pack("<Q", len(records)) + records


@st.composite
def mutated_mcap(draw: st.DrawFn, data: bytes) -> bytes:
    """An MCAP file mutated by its structure: a top-level record's length or body changed, a record deleted or
    duplicated; in an uncompressed chunk, a message's data mutated (or a message deleted, duplicated, its channel
    changed) and the chunk's sizes and CRC made right again, so that the damage reaches the message decoders.
    The summary section is not updated (its offsets become stale, as after a careless edit)."""
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 2))):
        records = _records(bytes(out), len(_MAGIC), len(out))
        if not records:
            return draw(mutated_bytes(bytes(out)))
        opcode, begin, end = records[draw(st.integers(0, len(records) - 1))]
        kind = draw(st.sampled_from(["inside", "inside", "inside", "length", "body", "delete", "duplicate"]))
        if kind == "inside" and opcode != _CHUNK:
            chunks = [r for r in records if r[0] == _CHUNK]
            if chunks:
                opcode, begin, end = chunks[draw(st.integers(0, len(chunks) - 1))]
            else:
                kind = "body"
        if kind == "inside":
            body = bytes(out[begin + 9:end])
            clen = struct.unpack_from("<I", body, 28)[0] if len(body) >= 40 else len(body)
            rstart = 32 + clen + 8
            inner = _records(body, rstart, len(body)) if rstart <= len(body) else []
            if not inner or _rebuild_chunk(body, b"") is None:
                kind = "body"
            else:
                iop, ib, ie = inner[draw(st.integers(0, len(inner) - 1))]
                messages = [r for r in inner if r[0] == _MESSAGE]
                if messages and draw(st.booleans()):
                    iop, ib, ie = messages[draw(st.integers(0, len(messages) - 1))]
                action = draw(st.sampled_from(["data", "data", "data", "delete", "duplicate", "channel", "time"]))
                record = body[ib:ie]
                if action == "data" and iop == _MESSAGE:
                    head, payload = record[9:9 + 22], record[9 + 22:]
                    record = _record(iop, head + draw(mutated_bytes(payload, max_ops=3)))
                elif action == "data":
                    record = _record(iop, draw(mutated_bytes(record[9:], max_ops=2)))
                elif action == "delete":
                    record = b""
                elif action == "duplicate":
                    record = record + record
                elif action == "channel" and iop == _MESSAGE:
                    record = record[:9] + struct.pack("<H", draw(st.sampled_from([0, 1, 2, 3, 4, 99, 65535]))) + \
                        record[11:]
                elif action == "time" and iop == _MESSAGE:
                    stamp = draw(st.sampled_from([0, 1, (1 << 63) - 1, (1 << 64) - 1, 1 << 62]))
                    record = record[:15] + struct.pack("<QQ", stamp, stamp) + record[31:]
                rebuilt = _rebuild_chunk(body, body[rstart:ib] + record + body[ie:])
                assert rebuilt is not None
                out[begin:end] = _record(_CHUNK, rebuilt)
                continue
        if kind == "length":
            value = draw(st.sampled_from(_INTERESTING_INTS + [end - begin - 9 + d for d in (-9, -1, 1, 8)]))
            out[begin + 1:begin + 9] = (value & ((1 << 64) - 1)).to_bytes(8, "little")
        elif kind == "body":
            body = bytes(out[begin + 9:end])
            if body:
                out[begin:end] = _record(opcode, draw(mutated_bytes(body, max_ops=2)))
        elif kind == "delete":
            del out[begin:end]
        else:
            out[begin:begin] = out[begin:end]
    return bytes(out)


# ---- ROS 1 bags -------------------------------------------------------------------------------------------------

_ROS1_FIELDS = [b"size=", b"count=", b"chunk_pos=", b"index_pos=", b"conn_count=", b"chunk_count=", b"ver=",
                b"conn=", b"op=", b"start_time=", b"end_time=", b"time=", b"compression="]


@st.composite
def mutated_ros1_bag(draw: st.DrawFn, data: bytes) -> bytes:
    """A ROS 1 bag with a header field's value (a size, count, position, opcode, time, compression) overwritten,
    or byte-level mutations."""
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 3))):
        field = draw(st.sampled_from(_ROS1_FIELDS))
        places = []
        at = out.find(field)
        while at >= 0 and len(places) < 200:
            places.append(at + len(field))
            at = out.find(field, at + 1)
        if not places or draw(st.integers(0, 3)) == 0:
            out = bytearray(draw(mutated_bytes(bytes(out), max_ops=2)))
            continue
        pos = places[draw(st.integers(0, len(places) - 1))]
        if field == b"compression=":
            # the value runs to the end of its header field: same length, another name
            value = draw(st.sampled_from([b"none", b"bz2", b"lz4", b"zst", b"xxx", b"\x00\x00\x00"]))
            out[pos:pos + 3] = value[:3].ljust(3, b"\x00")
            continue
        width = {b"op=": 1, b"ver=": 4, b"conn=": 4, b"count=": 4, b"size=": 4, b"conn_count=": 4,
                 b"chunk_count=": 4}.get(field, 8)
        value = draw(st.sampled_from(_INTERESTING_INTS)) & ((1 << (8 * width)) - 1)
        out[pos:pos + width] = value.to_bytes(width, "little")
    return bytes(out)


# ---- sqlite3 bags -----------------------------------------------------------------------------------------------

@st.composite
def mutated_sqlite_bag(draw: st.DrawFn, db3: Path) -> list[tuple[str, tuple[Any, ...]]]:
    """SQL statements that damage a rosbag2 sqlite3 bag's tables: message data mutated or emptied, rows deleted or
    duplicated, timestamps extreme, topic ids dangling, topic types and serialization formats replaced. Apply them
    with :func:`apply_sql`."""
    with contextlib.closing(sqlite3.connect(f"file:{db3}?immutable=1", uri=True)) as db:
        ids = [row[0] for row in db.execute("SELECT id FROM messages ORDER BY id LIMIT 2000")]
        topics = [row[0] for row in db.execute("SELECT id FROM topics")]
    statements: list[tuple[str, tuple[Any, ...]]] = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["data", "data", "data", "empty", "delete", "time", "topic-id", "type",
                                     "format", "drop-topic"]))
        if kind in ("data", "empty", "delete", "time", "topic-id") and not ids:
            kind = "type"
        if kind in ("type", "format", "drop-topic") and not topics:
            continue
        if kind == "data":
            row = ids[draw(st.integers(0, len(ids) - 1))]
            with contextlib.closing(sqlite3.connect(f"file:{db3}?immutable=1", uri=True)) as db:
                (payload,) = db.execute("SELECT data FROM messages WHERE id = ?", (row,)).fetchone()
            statements.append(("UPDATE messages SET data = ? WHERE id = ?",
                               (draw(mutated_bytes(bytes(payload), max_ops=3)), row)))
        elif kind == "empty":
            statements.append(("UPDATE messages SET data = ? WHERE id = ?", (b"", ids[draw(st.integers(0, len(ids) - 1))])))
        elif kind == "delete":
            statements.append(("DELETE FROM messages WHERE id = ?", (ids[draw(st.integers(0, len(ids) - 1))],)))
        elif kind == "time":
            stamp = draw(st.sampled_from([-1, 0, (1 << 63) - 1, -(1 << 63), 1 << 62]))
            statements.append(("UPDATE messages SET timestamp = ? WHERE id = ?",
                               (stamp, ids[draw(st.integers(0, len(ids) - 1))])))
        elif kind == "topic-id":
            statements.append(("UPDATE messages SET topic_id = ? WHERE id = ?",
                               (draw(st.sampled_from([0, 99, -1])), ids[draw(st.integers(0, len(ids) - 1))])))
        elif kind == "type":
            statements.append(("UPDATE topics SET type = ? WHERE id = ?",
                               (draw(st.sampled_from(["", "nope/msg/Nope", "std_msgs/msg/String",
                                                      "sensor_msgs/msg/JointState", "tf2_msgs/msg/TFMessage",
                                                      "x"])), topics[draw(st.integers(0, len(topics) - 1))])))
        elif kind == "format":
            statements.append(("UPDATE topics SET serialization_format = ? WHERE id = ?",
                               (draw(st.sampled_from(["", "ros1", "json"])), topics[draw(st.integers(0, len(topics) - 1))])))
        else:
            statements.append(("DELETE FROM topics WHERE id = ?", (topics[draw(st.integers(0, len(topics) - 1))],)))
    return statements


def apply_sql(db3: Path, statements: list[tuple[str, tuple[Any, ...]]]) -> None:
    """Run the statements of :func:`mutated_sqlite_bag` on ``db3`` (a copy)."""
    with contextlib.closing(sqlite3.connect(db3)) as db, db:
        for sql, params in statements:
            db.execute(sql, params)
