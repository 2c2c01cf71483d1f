"""Hypothesis strategies that mutate real inputs: bytes, XML descriptions, CSV, YAML, MCAP records, ROS 1
bag headers and the messages of a sqlite3 bag; and what a user may have where an output goes (their files and
folders, names near the file system's limits).

Each strategy takes a seed (a real file's content) and draws a short list of mutations applied in turn, so
that most examples stay close enough to the original to reach deep into tfrec (a flipped byte inside a
message, a joint whose axis became ``1e200 1e200 1e200``) rather than being refused at the first check.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.dom import minidom

import xacro.xmlutils  # noqa: F401 — xacro replaces minidom's Element.writexml when imported: import it before
from hypothesis import strategies as st  # the first serialization, so that every example serializes alike

__all__ = [
    "FOREIGN_NAMES",
    "HOSTILE_NAMES",
    "HOSTILE_NUMBERS",
    "HOSTILE_TEXT",
    "HOSTILE_URIS",
    "OddRecording",
    "chain_urdf",
    "csv_text",
    "foreign_bytes",
    "foreign_tree",
    "long_name",
    "many_channels_mcap",
    "mutated_bytes",
    "mutated_mcap",
    "mutated_ros1_bag",
    "mutated_sqlite_bag",
    "odd_recording",
    "relisted_files",
    "tf_graph",
    "write_odd_recording",
    "write_tree",
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

HOSTILE_URIS = [
    "package://inline_robot/meshes/part%00.stl", "package://inline_robot/meshes/%00", "file:///etc/passwd%00.stl",
    "file:///dev/zero%00", "package://inline_robot/%2e%2e/%2e%2e/etc/passwd", "package://inline_robot/meshes%2F..%2F..%2F..",
    "package://inline_robot/meshes/%2E%2E/%2e%2E/config/limits.yaml", "package://inline_robot/meshes/%5C..%5C..%5Cpart.stl",
    "package://inline_robot/meshes/%zz%2.stl", "package://inline_robot/meshes/%ff%fe.stl", "package://../etc/passwd",
    "package://./meshes/part.stl", "package:///etc/passwd", "package://%2e%2e/etc/passwd", "package://inline%00robot/x.stl",
    "package://inline_robot/meshes/%E2%80%AEpart.stl", "package://inline_robot/meshes/%1B%5B2Jpart.stl",
    "file://localhost/etc/passwd", "file://%2e%2e/%2e%2e/etc/passwd", "file:///proc/self/environ", "file:",
    "package://inline_robot/meshes/part.stl%00.png", "package://inline_robot/meshes/part.stl?x=%00#%00",
]
"""Mesh and file URIs whose percent-encoding hides a NUL, a way out of the package, an invalid escape, a terminal
escape sequence: each is a warning (the visual skipped) or one line, and confinement holds."""

HOSTILE_NAMES = ["\x1b[2J", "\r", "\x07", "\x1b]0;title\x07", "\u202e", "\x1b[31mFAIL\x1b[0m", "\n", "\x00", "\x9b2J",
                 "\udcff"]
"""Pieces of topic, frame, joint and file names that would drive a terminal: clear the screen, return to the line's
start, ring, set the window title, reverse the text, recolour, break the line; and a byte that is not UTF-8."""

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
               "origin", "axis", "limit", "mimic", "parent", "child", "robot", "visual", "geometry", "box",
               # the Kinetic-era dialect (xacro <= 1.13): its tags without the prefix (docs/xacro.md)
               "include", "property", "arg", "if", "unless", "macro", "insert_block", "gazebo"]
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
                                     "delete", "duplicate", "move", "rename", "unprefix", "empty", "nest", "mesh",
                                     "name"]))
        parent = element.parentNode
        is_root = parent is doc
        if kind in ("value", "number", "drop-attr") and not element.attributes.length:
            kind = "add-attr"
        if kind == "mesh":  # a mesh (any, or a new one) with a hostile URI
            meshes = doc.getElementsByTagName("mesh")
            target = meshes[draw(st.integers(0, len(meshes) - 1))] if meshes else element
            target.setAttribute("filename", draw(st.sampled_from(HOSTILE_URIS)))
        elif kind == "name":  # a link, joint or robot name with a character XML may hold but a terminal acts on
            named = [e for e in elements if e.hasAttribute("name") or e.hasAttribute("link")] or [element]
            target = named[draw(st.integers(0, len(named) - 1))]
            attribute = "name" if target.hasAttribute("name") else "link"
            target.setAttribute(attribute, target.getAttribute(attribute) + draw(st.sampled_from(
                ["\u202e", "\u200f", "\ufeff", "\u2028", "&#x202E;", "\t"])))
        elif kind == "value":
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
        elif kind == "unprefix":  # a xacro tag or a macro call written as the course's Kinetic-era slides do
            element.tagName = element.nodeName = element.tagName.removeprefix("xacro:")
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


# ---- what a user has where an output goes ------------------------------------------------------------------------

FOREIGN_NAMES = ["notes.txt", "thesis.tex", "metadata.yaml", "out_0.mcap", "bag_0.mcap", "run.mcap", ".hidden",
                 ".tfrec-1-0123abcd", "sub", "é名前", "a b", "-rf", "x" * 255, "\u202etxt.exe", "\x1b[31m"]
"""Names a user's folder may hold: ordinary ones, a bag's own, hidden, a temporary's, multibyte, 255 bytes long,
control characters."""

Tree = dict[str, "bytes | Tree"]


@st.composite
def foreign_bytes(draw: st.DrawFn) -> bytes:
    """A user's file: it never begins as anything tfrec writes (``user …``)."""
    return b"user " + draw(st.binary(max_size=256))


@st.composite
def foreign_tree(draw: st.DrawFn, *, depth: int = 2) -> Tree:
    """A user's folder: files of their own and subfolders (maybe none: an empty folder)."""
    tree: Tree = {}
    for name in draw(st.lists(st.sampled_from(FOREIGN_NAMES), max_size=4, unique=True)):
        tree[name] = draw(foreign_tree(depth=depth - 1)) if depth and draw(st.integers(0, 3)) == 0 else \
            draw(foreign_bytes())
    return tree


def write_tree(folder: Path, tree: Tree) -> None:
    """Make ``tree`` in ``folder`` (which may exist: what it holds already is kept)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, content in tree.items():
        if os.path.lexists(folder / name):
            continue
        if isinstance(content, dict):
            write_tree(folder / name, content)
        else:
            (folder / name).write_bytes(content)


@st.composite
def long_name(draw: st.DrawFn, suffix: str) -> str:
    """An output's name near the file system's limit of 255 bytes (``é`` counts 2, ``名`` 3), ending in ``suffix``."""
    size = draw(st.sampled_from([200, 240, 248, 249, 250, 254, 255, 256, 300]))
    char = draw(st.sampled_from(["x", "é", "名"]))
    room = size - len(suffix.encode())
    width = len(char.encode())
    return char * (room // width) + "x" * (room % width) + suffix


# ---- odd but well-formed recordings ------------------------------------------------------------------------------

_SEPARATOR = "=" * 80 + "\n"


@dataclass(frozen=True)
class OddRecording:
    """A well-formed recording whose content is odd (issue 20): what :func:`write_odd_recording` writes.

    Attributes:
        kind: ``mcap`` or ``ros1``.
        file_piece: put in the file's name (a terminal escape sequence, a byte that is not UTF-8).
        repeat: (the joint a /joint_states message names a second time, where the second name goes, how far its
            second position is from its first); None: no joint named twice.
        renames: (what — ``joint``, ``frame``, ``topic``, ``namespace`` —, the piece added to its name).
        redefine: topic → (its definition as the file gives it, the md5sum as the file gives it — ``own``, ``*``,
            ``""``, ``known`` —, its messages: ``standard`` or ``ints``, the MCAP channel's type hash: ``none``,
            ``right``, ``wrong``).
    """

    kind: str
    file_piece: str
    repeat: tuple[int, int, float] | None
    renames: tuple[tuple[str, str], ...]
    redefine: tuple[tuple[str, tuple[str, str, str, str]], ...]


def _chain(n: int) -> str:
    return _SEPARATOR.join(["pkg/T0 f\n"] + [f"MSG: pkg/T{i}\npkg/T{i + 1} f\n" for i in range(n)] + [f"MSG: pkg/T{n}\nint32 v\n"])


def _definitions(msgtype: str) -> list[str]:
    """Definitions of a type tfrec reads, other than ROS's (and ROS's with comments and constants: still its layout)."""
    short = msgtype.replace("/msg/", "/")
    return [
        "int32 x\n", "", "%%% not a definition\n", f"{short}[] self\n", f"{short} child\nint32 v\n",
        "pkg/Edge[] edges\n" + _SEPARATOR + f"MSG: pkg/Edge\n{short} to\n",
        "geometry_msgs/TransformStamped[] transforms\n" + _SEPARATOR +
        "MSG: geometry_msgs/TransformStamped\ngeometry_msgs/TransformStamped[] next\n",
        _chain(65), _chain(900), _chain(5000), "".join(f"float64 f{i}\n" for i in range(3000)),
        "STANDARD-RENAMED", "STANDARD-RETYPED", "STANDARD-COMMENTED",
    ]


@st.composite
def odd_recording(draw: st.DrawFn) -> OddRecording:
    """What an odd recording holds: a joint named twice in /joint_states, names with terminal escape sequences (a
    joint, a frame, a topic, a namespace, the file), robot topics whose type is defined with another layout — a
    field renamed or retyped, a type that contains itself (directly, through an array, through another type), types
    nested 65 to 5,000 deep or 3,000 wide, no definition, one that does not parse — with md5sums that match it, ROS's,
    ``*`` or none, and MCAP type hashes."""
    kind = draw(st.sampled_from(["mcap", "ros1"]))
    repeat = None
    if draw(st.booleans()):
        repeat = (draw(st.integers(0, 7)), draw(st.integers(0, 9)), draw(st.sampled_from([0.0, 0.5, float("nan")])))
    names = [name for name in HOSTILE_NAMES if name != "\udcff"]  # a message's strings are UTF-8
    renames = tuple(draw(st.lists(st.tuples(st.sampled_from(["joint", "frame", "topic", "namespace"]),
                                            st.sampled_from(names)), max_size=3)))
    topics = draw(st.lists(st.sampled_from(["/tf", "/tf_static", "/joint_states", "/robot_description"]),
                           max_size=2, unique=True))
    redefine = []
    for topic in topics:
        msgtype = {"/tf": "tf2_msgs/msg/TFMessage", "/tf_static": "tf2_msgs/msg/TFMessage",
                   "/joint_states": "sensor_msgs/msg/JointState", "/robot_description": "std_msgs/msg/String"}[topic]
        redefine.append((topic, (draw(st.sampled_from(_definitions(msgtype))),
                                 draw(st.sampled_from(["own", "*", "", "known"])),
                                 draw(st.sampled_from(["standard", "ints"])),
                                 draw(st.sampled_from(["none", "right", "wrong"])))))
    piece = draw(st.sampled_from(["", "", *HOSTILE_NAMES]))
    return OddRecording(kind, piece.replace("/", "").replace("\x00", ""), repeat, renames, tuple(redefine))


def _odd_data(plan: OddRecording, rec: Any) -> tuple[Any, list[Any], str]:
    """The recording's data with the joint named twice and the names changed; the extra messages; the namespace."""
    from dataclasses import replace

    import numpy as np

    from tfrec.recording import JointStates

    js = rec.joint_states
    names, positions = list(js.names), [js.positions[:, k] for k in range(len(js.names))]
    if plan.repeat is not None:
        k, at, offset = plan.repeat
        k %= len(names)
        names.insert(at % (len(names) + 1), names[k])
        positions.insert(at % (len(positions) + 1), positions[k] + offset)
    tf, namespace, extra_topics = dict(rec.tf), "", []
    for what, piece in plan.renames:
        if what == "joint":
            names[0] += piece
        elif what == "frame" and tf:
            parent, child = next(iter(tf))
            tf[(parent, child + piece)] = tf.pop((parent, child))
        elif what == "topic":
            extra_topics.append("/t" + piece)
        else:
            namespace = "/ns" + piece
    data = replace(rec, joint_states=JointStates(js.time_ns, tuple(names), np.stack(positions, axis=1)), tf=tf)
    return data, extra_topics, namespace


def write_odd_recording(plan: OddRecording, rec: Any, folder: Path) -> Path:
    """Write ``plan`` of the recording ``rec`` (a :class:`tfrec.recording.Recording`) into ``folder``: an MCAP
    written by mcap's writer, or a ROS 1 bag written by tfrec's (which writes an md5sum or a definition that is
    empty, as rosbags' does not); returns its path."""
    import hashlib

    from tests.bag_builders import Robot, robot_messages
    from tests.recording_helpers import _typestore

    ros1 = plan.kind == "ros1"
    store = _typestore(ros1)
    data, extra_topics, namespace = _odd_data(plan, rec)
    messages = robot_messages(Robot(data, namespace=namespace), ros1=ros1)
    start = rec.start_ns or 0
    messages += [(topic, "std_msgs/msg/String", start, store.types["std_msgs/msg/String"](data=topic))
                 for topic in extra_topics]
    messages.sort(key=lambda m: m[2])
    redefined = dict(plan.redefine)
    path = folder / ("in" + plan.file_piece + (".bag" if ros1 else ".mcap"))
    channels: dict[str, tuple[str, str, str, dict[str, str]]] = {}
    for topic, msgtype, _, _ in messages:
        if topic in channels:
            continue
        text, md5sum = store.generate_msgdef(msgtype, ros_version=1 if ros1 else 2)
        metadata: dict[str, str] = {}
        change = redefined.get(topic.removeprefix(namespace))
        if change is not None:
            definition, md5_mode, _, type_hash = change
            definition = _standard_variant(definition, text)
            md5sum = {"own": hashlib.md5(definition.encode()).hexdigest(), "known": md5sum}.get(md5_mode, md5_mode)
            text = definition
            if type_hash != "none" and not ros1:
                metadata["topic_type_hash"] = store.hash_rihs01(msgtype) if type_hash == "right" else "RIHS01_" + "0" * 64
        channels[topic] = (msgtype, text, md5sum, metadata)
    rows = []
    for i, (topic, msgtype, time_ns, msg) in enumerate(messages):
        raw = bytes(store.serialize_ros1(msg, msgtype) if ros1 else store.serialize_cdr(msg, msgtype))
        change = redefined.get(topic.removeprefix(namespace))
        if change is not None and change[2] == "ints":
            raw = struct.pack("<i", i) if ros1 else b"\x00\x01\x00\x00" + struct.pack("<i", i)
        rows.append((topic, time_ns, raw))
    (_write_ros1 if ros1 else _write_mcap)(path, channels, rows)
    return path


def _standard_variant(definition: str, standard: str) -> str:
    """ROS's definition with a field renamed or retyped, or with comments and constants (still ROS's layout)."""
    lines = standard.split("\n")
    first = next(i for i, line in enumerate(lines) if line and not line.startswith(("#", "=")) and "=" not in line)
    kind, _, name = lines[first].partition(" ")
    if definition == "STANDARD-RENAMED":
        lines[first] = f"{kind} {name}_renamed"
    elif definition == "STANDARD-RETYPED":
        lines[first] = f"int8 {name}"
    elif definition == "STANDARD-COMMENTED":
        lines[first] = f"# a comment\n\nint32 UNUSED=7\n{lines[first]}   # why"
    else:
        return definition
    return "\n".join(lines)


def _write_mcap(path: Path, channels: dict[str, tuple[str, str, str, dict[str, str]]],
                rows: list[tuple[str, int, bytes]]) -> None:
    from mcap.writer import Writer

    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2")
        ids = {topic: writer.register_channel(topic, "cdr", writer.register_schema(msgtype, "ros2msg", text.encode()),
                                              metadata=metadata)
               for topic, (msgtype, text, _, metadata) in channels.items()}
        for topic, time_ns, raw in rows:
            writer.add_message(ids[topic], log_time=time_ns, data=raw, publish_time=time_ns)
        writer.finish()


def _write_ros1(path: Path, channels: dict[str, tuple[str, str, str, dict[str, str]]],
                rows: list[tuple[str, int, bytes]]) -> None:
    from tfrec.formats.rosbag1.writer import Ros1BagWriter

    with Ros1BagWriter(path) as writer:
        ids = {topic: writer.add_connection(topic, msgtype, msgdef=text, md5sum=md5sum,
                                            latching=topic.endswith(("tf_static", "robot_description")))
               for topic, (msgtype, text, md5sum, _) in channels.items()}
        for topic, time_ns, raw in rows:
            writer.write(ids[topic], time_ns, raw)
