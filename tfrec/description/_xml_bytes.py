"""XML files as bytes: in the encoding they declare, as xacro would read them if it could.

Stock xacro opens a file as text in the locale's encoding (UTF-8), so a UTF-16 or latin-1 file
with a correct ``<?xml … encoding="…"?>`` declaration fails with ``UnicodeDecodeError``.
:func:`parse_xml` and :func:`decode_xml` read bytes: UTF-8 exactly as before, anything else as
expat reads it (UTF-16/32 by the byte order mark or the first characters, 8-bit encodings by the
declaration).

:func:`parse_xml` also notes where each element was written (:func:`origin`): the note is DOM
user data, which minidom copies to every clone (``cloneNode`` calls the handler), so the
elements xacro copies out of a macro body or a block still say which file and line they came from.
"""

from __future__ import annotations

import re
import xml.dom.expatbuilder
import xml.dom.minidom
import xml.parsers.expat
from typing import Any

from tfrec.errors import DescriptionError

__all__ = ["Origin", "decode_xml", "origin", "parse_xml"]

Origin = tuple[str, int]
"""Where an element was written: (file, line)."""

_ORIGIN = "tfrec.origin"


class _KeepOnClone:
    """A DOM ``UserDataHandler``: a clone of an element keeps the element's origin."""

    def handle(self, operation: int, key: str, data: Any, src: Any, dst: Any) -> None:
        if dst is not None and operation == self.NODE_CLONED:
            _note(dst, data)

    NODE_CLONED = xml.dom.UserDataHandler.NODE_CLONED


def _note(node: Any, where: Origin) -> None:
    """``node.setUserData(_ORIGIN, where, _KEEP)``, without its cost: minidom's ``setUserData`` looks for
    the node's user data by catching an AttributeError, which is most of an expansion's time when
    done for every element and copy. This is the dictionary ``getUserData`` and ``cloneNode`` read."""
    node._user_data = {_ORIGIN: (where, _KEEP)}


_KEEP = _KeepOnClone()


class _LocatingBuilder(xml.dom.expatbuilder.ExpatBuilderNS):
    """minidom's own builder (``minidom.parseString``), noting each element's start line."""

    def __init__(self, source: str) -> None:
        super().__init__()
        self._source = source

    def start_element_handler(self, name: str, attributes: Any) -> None:
        super().start_element_handler(name, attributes)
        _note(self.curNode, (self._source, self.getParser().CurrentLineNumber))


def parse_xml(data: bytes, *, source: str | None = None) -> xml.dom.minidom.Document:
    """An XML document as a DOM, in the encoding it declares.

    UTF-8 text parses exactly as xacro parses a file it opened as text; other bytes (UTF-16 or
    UTF-32 with or without a byte order mark, latin-1, windows-1252 …) are given to expat, which
    follows the XML declaration.

    Args:
        data: the file's bytes.
        source: the file as messages name it: each element then knows its :func:`origin`.

    Raises:
        xml.parsers.expat.ExpatError: not well-formed XML (as xacro's own parse).
    """
    text = _utf8(data)
    content = text if text is not None else data
    if source is None:
        return xml.dom.minidom.parseString(content)
    document: xml.dom.minidom.Document = _LocatingBuilder(source).parseString(content)
    return document


def origin(node: Any) -> Origin | None:
    """Where an element parsed by :func:`parse_xml` (or a copy of one) was written."""
    getter = getattr(node, "getUserData", None)
    found = getter(_ORIGIN) if getter is not None else None
    return found if isinstance(found, tuple) else None


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
