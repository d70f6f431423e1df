"""STEP physical files (ISO 10303-21, the text IFC models are written in): whether one ends where the standard
says it ends, and where one that was cut stops. Shared by the kinds that read IFC (dedup refuses a cut model,
polyhedra reads the spaces it holds and says the file was cut); the text of one instance, and how many attribute
values it writes (both hold it against the schema its header names)."""

from __future__ import annotations

import re

import numpy as np

TRAILER_BYTES = 256  # END-ISO-10303-21; is looked for this far from the end

_TRAILING_COMMENT = re.compile(rb"/\*(?:(?!\*/).)*\*/\s*$", re.DOTALL)
_ENTITY = re.compile(rb"#(\d+)\s*=")


def where_cut(tail: bytes) -> str | None:
    """None when the text whose last bytes are ``tail`` ends with 'END-ISO-10303-21;' (a comment after it is
    allowed); else where it stops, told by its last entity instance (the file's own numbering)."""
    trailer = tail[-TRAILER_BYTES:].rstrip(b" \t\r\n\x00\x1a")  # NUL padding, the DOS end-of-file mark
    trailer = _TRAILING_COMMENT.sub(b"", trailer).rstrip()
    if trailer.endswith(b"END-ISO-10303-21;"):
        return None
    last = _ENTITY.findall(trailer)
    if not last:
        return "it stops after " + repr(trailer[-40:].decode("latin-1"))
    if trailer.endswith(b";") and trailer.rsplit(b";", 2)[-2].lstrip().startswith(b"#" + last[-1]):
        return f"it stops after entity #{last[-1].decode()}, before 'ENDSEC;'"
    if trailer.rstrip().endswith(b"ENDSEC;"):
        return "it stops after its DATA section's 'ENDSEC;'"
    return f"it stops inside entity #{last[-1].decode()}"


_STRING = re.compile(r"'(?:[^']|'')*'")  # a STEP string, its quotes doubled inside


def written_attributes(line: str) -> int | None:
    """How many attribute values a STEP instance line writes (None: a complex instance, or no argument list): its
    commas outside strings at the first bracket level, counted with numpy (a point list's line can be megabytes)."""
    name, _, arguments = line.partition("=")[2].partition("(")
    if not name.strip() or not arguments:
        return None
    text = np.frombuffer(_STRING.sub("''", "(" + arguments).encode("latin-1", "replace"), dtype=np.uint8)
    depth = np.cumsum((text == ord("(")).astype(np.int32) - (text == ord(")")))
    if len(text) < 2 or depth[1] == 0 and text[1] == ord(")"):  # '()': no value at all
        return 0
    return int(np.count_nonzero((text == ord(",")) & (depth == 1))) + 1


def instance_text(text: str | bytes, start: int) -> str | bytes | None:
    """The instance whose '#' is at ``start`` of ``text``, up to its own closing ';' outside strings (a string doubles
    its quotes inside, so a ';' follows an even number of quotes exactly when it is outside one); None when ``text``
    ends before it closes. The standard puts no line breaks in the way: a file may write several instances on one
    line, one over several lines, or its lines ended by CR alone."""
    semicolon, quote = (b";", b"'") if isinstance(text, bytes) else (";", "'")
    quotes, at = 0, start
    while (end := text.find(semicolon, at)) >= 0:
        quotes += text.count(quote, at, end)
        if quotes % 2 == 0:
            return text[start:end + 1]
        at = end + 1
    return None
