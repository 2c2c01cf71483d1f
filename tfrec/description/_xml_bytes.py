"""XML files as bytes: in the encoding they declare, as xacro would read them if it could.

Stock xacro opens a file as text in the locale's encoding (UTF-8), so a UTF-16 or latin-1 file
with a correct ``<?xml … encoding="…"?>`` declaration fails with ``UnicodeDecodeError``.
:func:`parse_xml` and :func:`decode_xml` read bytes: UTF-8 exactly as before, anything else as
expat reads it (UTF-16/32 by the byte order mark or the first characters, 8-bit encodings by the
declaration).
"""

from __future__ import annotations

import re
import xml.dom.minidom
import xml.parsers.expat

from tfrec.errors import DescriptionError

__all__ = ["decode_xml", "parse_xml"]


def parse_xml(data: bytes) -> xml.dom.minidom.Document:
    """An XML document as a DOM, in the encoding it declares.

    UTF-8 text parses exactly as xacro parses a file it opened as text; other bytes (UTF-16 or
    UTF-32 with or without a byte order mark, latin-1, windows-1252 …) are given to expat, which
    follows the XML declaration.

    Raises:
        xml.parsers.expat.ExpatError: not well-formed XML (as xacro's own parse).
    """
    text = _utf8(data)
    return xml.dom.minidom.parseString(text if text is not None else data)


def decode_xml(data: bytes, *, where: str, declare_utf8: bool = False) -> str:
    """The text of an XML document, decoded as it declares (UTF-8 when valid, else as expat reads
    it: UTF-16 by its byte order mark, latin-1 by its declaration…).

    Args:
        data: the file's bytes.
        where: the file, for messages.
        declare_utf8: rewrite the declaration's ``encoding="…"`` to ``UTF-8``, for text that will
            be stored or sent as UTF-8 (``/robot_description``); otherwise it is kept as written.

    Raises:
        DescriptionError: bytes that are not well-formed XML in any encoding expat knows.
    """
    text = _utf8(data)
    if text is not None:
        return text
    parser = xml.parsers.expat.ParserCreate()
    parts: list[str] = []
    parser.DefaultHandler = parts.append  # with no other handler: every piece of the document, verbatim
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as err:
        raise DescriptionError(f"{where}:{err.lineno}:{err.offset}: malformed XML: "
                               f"{xml.parsers.expat.ErrorString(err.code)}") from err
    text = "".join(parts)
    return _DECLARED_ENCODING.sub(r"\1\2UTF-8\2", text, count=1) if declare_utf8 else text


_DECLARED_ENCODING = re.compile(r"""\A(<\?xml[^>]*?\sencoding\s*=\s*)(["'])[^"']*\2""")


def _utf8(data: bytes) -> str | None:
    """The text of UTF-8 bytes (without a byte order mark); None for other encodings."""
    if data[:2] in (b"\xff\xfe", b"\xfe\xff") or b"\x00" in data[:4]:
        return None  # UTF-16 or UTF-32 (a byte order mark, or '<' next to NUL bytes)
    try:
        return data.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError:
        return None
