"""STL meshes (binary and ASCII), read so that a damaged file says so.

A general STL reader gives nothing at all for a file cut short; this one keeps every complete triangle before
the cut and logs the rest (``ReadLog``): a binary file holding fewer triangles than its header declares, an ASCII
facet cut off at the end of the file or holding a vertex line that cannot be read (NaN, cut, not numbers)."""

from __future__ import annotations

import codecs

import numpy as np

from plantsolve.schemas.common import MAX_COORDINATE, Diagnostic
from plantsolve.solvers.base import reject
from plantsolve.solvers.decimal_comma import is_decimal_comma
from plantsolve.solvers.other_kinds import file_holds
from plantsolve.solvers.skipped_input import refuse_noise_stl
from plantsolve.solvers.tube.read_log import ReadLog

BINARY_HEADER, BINARY_TRIANGLE = 84, 50  # bytes: 80 header + uint32 count; 12 float32 + uint16 per triangle
_TRIANGLE = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def read_stl(content: bytes, log: ReadLog) -> np.ndarray:
    """The triangles' corners, (M, 3, 3)."""
    if len(content) >= BINARY_HEADER:
        count = int(np.frombuffer(content, "<u4", 1, offset=80)[0])
        if BINARY_HEADER + BINARY_TRIANGLE * count == len(content):
            return _binary(content, count, log)
    text = _ascii_text(content)
    if text is None and len(content) >= BINARY_HEADER:
        _refuse_text(content)
        return _binary(content, count, log)
    return _ascii(text or "", log)


def _refuse_text(content: bytes) -> None:
    """A 422 for text that is no ASCII STL (a point list, a PCF renamed .stl): read as binary, its characters
    would be a triangle count of hundreds of millions and triangles of garbage. A binary STL's floats hold
    control bytes (a zero byte in nearly every coordinate); text holds none."""
    body = content[BINARY_HEADER:BINARY_HEADER + 4096]
    if any(b < 9 or 13 < b < 32 for b in body):
        return
    holds = file_holds(content[:65536])
    raise reject(f"not an STL file: it is text{f' holding {holds}' if holds else ''}, and not an ASCII STL (which "
                 "starts with 'solid' and holds 'facet' records)")


def _ascii_text(content: bytes) -> str | None:
    """The text of an ASCII STL (behind a UTF-8 mark, or re-saved as UTF-16 by a Windows editor, which a binary
    reader would take for triangles of garbage), or None when the content is not one (its start is looked at
    first: a binary file is not decoded whole)."""
    if content[:2] in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE):
        encoding = "utf-16"
    elif content[1:8:2] == b"\0\0\0\0" and content[:8:2].isalpha():  # UTF-16 LE without its mark
        encoding = "utf-16-le"
    elif content[0:8:2] == b"\0\0\0\0" and content[1:8:2].isalpha():  # UTF-16 BE without its mark
        encoding = "utf-16-be"
    else:
        encoding, content = "utf-8", content.removeprefix(codecs.BOM_UTF8)
    head = content[:2000].decode(encoding, errors="replace").lower()
    if not (head.lstrip().startswith("solid") and "facet" in head):
        return None
    return content.decode(encoding, errors="replace")


def _binary(content: bytes, count: int, log: ReadLog) -> np.ndarray:
    available = (len(content) - BINARY_HEADER) // BINARY_TRIANGLE
    n = min(count, available)
    if available > count:  # the header's count is smaller than what the exporter wrote: part of the scan unread
        log.warn(Diagnostic(code="records_beyond_header", message=(
            f"STL file: after the {count} triangles its header declares it holds {available - count} more whole "
            "ones, which were not read; is the header's triangle count wrong? Only the declared triangles were "
            "used."), details={"declared": {"triangle": count}, "beyond": available - count}))
    if n < count:
        log.truncate(f"the file ends after {n} of {count} triangles", element="triangle", read=n, declared=count)
    with np.errstate(invalid="ignore"):  # a signalling NaN of a damaged file: sorted out on the next line
        tri = np.frombuffer(content, _TRIANGLE, n, offset=BINARY_HEADER)["corners"].astype(np.float64)
    ok = (np.abs(tri) <= MAX_COORDINATE).all((1, 2))  # NaN fails too: a float the writer never meant
    if n < count:
        refuse_noise_stl(count, n, int((~ok).sum()), f"non-finite coordinates or coordinates beyond {MAX_COORDINATE:g}")
    log.skip(None, f"non-finite coordinate or one beyond {MAX_COORDINATE:g}", count=int((~ok).sum()))
    return tri[ok]


def _ascii(text: str, log: ReadLog) -> np.ndarray:
    lines = text.splitlines()
    triangles, corners, facet_line, bad = [], [], None, None
    ended = False
    for lineno, line in enumerate(lines, 1):
        words = line.split()
        if not words:
            continue
        key = words[0].lower()
        if key == "facet":
            corners, facet_line, bad = [], lineno, None
        elif key == "vertex" and facet_line is not None:
            try:
                xyz = [float(w) for w in words[1:4]]
                if len(xyz) < 3:
                    bad = bad or (lineno, "vertex cut short")
                elif not all(abs(v) <= MAX_COORDINATE for v in xyz):  # NaN fails too
                    bad = bad or (lineno, f"non-finite coordinate or one beyond {MAX_COORDINATE:g}")
                corners.append(xyz)
            except ValueError:
                comma = any(is_decimal_comma(w) for w in words[1:4])  # a fixed reason: the log counts by it
                bad = bad or (lineno, "vertex written with decimal commas (STL numbers take a decimal point)" if comma
                              else "vertex not numbers")
        elif key == "endfacet" and facet_line is not None:
            if bad:
                log.skip(*bad)
            elif len(corners) != 3:
                log.skip(facet_line, f"facet with {len(corners)} vertices")
            else:
                triangles.append(corners)
            facet_line = None
        elif key == "endsolid":
            ended = True
    if facet_line is not None:
        log.skip(bad[0] if bad else facet_line, bad[1] if bad else "facet cut short")
        log.truncate(f"the file ends inside a facet (line {len(lines)})", line=len(lines))
    elif not ended and triangles:
        log.truncate(f"the file ends without 'endsolid' (line {len(lines)})", line=len(lines))
    if not triangles:
        raise reject(f"STL file holds no vertices{log.summary()}")
    return np.asarray(triangles, dtype=np.float64)
