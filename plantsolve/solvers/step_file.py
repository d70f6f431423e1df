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


_PADDING = " \t\r\n\x00\x1a"  # what a transfer or a disk leaves after the last byte written: NULs, a DOS end-of-file
_TRAILER = "END-ISO-10303-21;"


def holds_every_instance(text: str) -> bool:
    """Whether a file (or its last bytes) that does not end with the trailer still holds its whole DATA section: all
    it lacks is (part of) 'END-ISO-10303-21;' after the last 'ENDSEC;'. ``text``: with its strings and comments
    blanked (or the comments after its end taken off)."""
    text = text.rstrip(_PADDING)
    end = text.rfind("ENDSEC;")
    return end >= 0 and _TRAILER.startswith(text[end + len("ENDSEC;"):].strip(_PADDING).upper())


def where_cut(tail: bytes) -> str | None:
    """None when the text whose last bytes are ``tail`` ends with 'END-ISO-10303-21;' (a comment after it is
    allowed); else where it stops, told by its last entity instance (the file's own numbering)."""
    padding = _PADDING.encode()  # NUL padding, the DOS end-of-file mark
    trailer = tail[-TRAILER_BYTES:].rstrip(padding)
    while (uncommented := _TRAILING_COMMENT.sub(b"", trailer).rstrip(padding)) != trailer:
        trailer = uncommented  # a comment after the trailer, or several
    if trailer.endswith(_TRAILER.encode()):
        return None
    if holds_every_instance(trailer.decode("latin-1")):
        return "it stops after its DATA section's 'ENDSEC;', every instance there: only its closing line is missing"
    last = _ENTITY.findall(trailer)
    if not last:
        return "it stops after " + repr(trailer[-40:].decode("latin-1"))
    if trailer.endswith(b";") and trailer.rsplit(b";", 2)[-2].lstrip().startswith(b"#" + last[-1]):
        return f"it stops after entity #{last[-1].decode()}, before 'ENDSEC;'"
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


# a string (its quotes doubled inside) or a comment; one the text ends inside runs to the end (a chunk may stop in it)
_LEXEMES = {str: re.compile(r"'(?:[^']|'')*+(?:'|\Z)|/\*(?:[^*]|\*(?!/))*+(?:\*/|\Z)"),
            bytes: re.compile(rb"'(?:[^']|'')*+(?:'|\Z)|/\*(?:[^*]|\*(?!/))*+(?:\*/|\Z)")}
_CLOSED = {str: re.compile(r"'(?:[^']|'')*'|/\*.*\*/", re.DOTALL), bytes: re.compile(rb"'(?:[^']|'')*'|/\*.*\*/", re.DOTALL)}
_NOT_LINE_END = {str: re.compile(r"[^\r\n]"), bytes: re.compile(rb"[^\r\n]")}


def _spaces(found: re.Match) -> str | bytes:
    lexeme = found.group()
    kind = type(lexeme)
    if (b"\n" if kind is bytes else "\n") in lexeme or (b"\r" if kind is bytes else "\r") in lexeme:
        return _NOT_LINE_END[kind].sub(b" " if kind is bytes else " ", lexeme)
    return (b" " if kind is bytes else " ") * len(lexeme)


def blank_strings_and_comments(text: str | bytes) -> str | bytes:
    """``text`` with each string and comment (one left open at its end too) written over by spaces of the same
    length, its line ends kept: offsets and line numbers stay those of ``text``, and a ';', '#12=' or quote inside a
    string or comment ('a;#3=B', /* exported; #3=IFCCOLUMN( */) no longer looks like the text's own. Scans of the
    instances read this."""
    return _LEXEMES[type(text)].sub(_spaces, text)


def left_open(text: str | bytes) -> int | None:
    """Where the string or comment ``text`` ends inside starts (a quote or '/*' never closed), None when it ends
    outside both."""
    last = None
    for last in _LEXEMES[type(text)].finditer(text):
        pass
    if last is None or last.end() < len(text) or _CLOSED[type(text)].fullmatch(last.group()):
        return None
    return last.start()


_NOT_SPLIT = (b"\r\n", b"''", b"/*", b"*/")  # a line end, a quote doubled in a string, a comment's marks


def carried_from(text: bytes, at: int) -> tuple[int, bytes, int | None]:
    """Where to cut ``text``, a chunk read without a ';' outside strings, to carry its rest from about ``at`` to the
    next: not inside a CR LF, a doubled quote or a comment's mark; the mark the rest is to start with when it starts
    inside a string or comment (b"'", b"/*", else b""), so it is read as it is; and where that string or comment
    starts in ``text`` (None: the rest starts outside both)."""
    while at > 0 and text[at - 1:at + 1] in _NOT_SPLIT:
        at -= 1
    for found in _LEXEMES[bytes].finditer(text):
        if found.start() >= at:
            break
        if at < found.end():
            return at, (b"'" if text[found.start():found.start() + 1] == b"'" else b"/*"), found.start()
    return at, b"", None


def line_ends(text: str | bytes, start: int = 0, end: int | None = None) -> int:
    """How many lines end in ``text[start:end]``, each by LF, CR or CR LF (a file may end its lines by CR alone)."""
    lf, cr, crlf = (b"\n", b"\r", b"\r\n") if isinstance(text, bytes) else ("\n", "\r", "\r\n")
    end = len(text) if end is None else end
    return text.count(lf, start, end) + text.count(cr, start, end) - text.count(crlf, start, end)


def instance_text(text: str | bytes, start: int, blanked: str | bytes | None = None) -> str | bytes | None:
    """The instance whose '#' is at ``start`` of ``text``, up to its own closing ';' outside strings and comments;
    None when ``text`` ends before it closes. ``blanked``: :func:`blank_strings_and_comments` of ``text``, made once
    by a caller that cuts many instances (else the rest of the text from ``start`` is blanked for this one). The
    standard puts no line breaks in the way: a file may write several instances on one line, one over several
    lines, or its lines ended by CR alone."""
    if blanked is None:
        end = blank_strings_and_comments(text[start:]).find(b";" if isinstance(text, bytes) else ";")
        return None if end < 0 else text[start:start + end + 1]
    end = blanked.find(b";" if isinstance(blanked, bytes) else ";", start)
    return None if end < 0 else text[start:end + 1]
