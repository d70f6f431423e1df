"""STL meshes (binary and ASCII), read so that a damaged file says so.

A general STL reader gives nothing at all for a file cut short; this one keeps every complete triangle before
the cut and logs the rest (``ReadLog``): a binary file holding fewer triangles than its header declares, an ASCII
facet cut off at the end of the file or holding a vertex line that cannot be read (NaN, cut, not numbers)."""

from __future__ import annotations

import math

import numpy as np

from plantsolve.solvers.base import reject
from plantsolve.solvers.tube.read_log import ReadLog

BINARY_HEADER, BINARY_TRIANGLE = 84, 50  # bytes: 80 header + uint32 count; 12 float32 + uint16 per triangle
_TRIANGLE = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def read_stl(content: bytes, log: ReadLog) -> np.ndarray:
    """The triangles' corners, (M, 3, 3)."""
    if len(content) >= BINARY_HEADER:
        count = int(np.frombuffer(content, "<u4", 1, offset=80)[0])
        if BINARY_HEADER + BINARY_TRIANGLE * count == len(content) or not _looks_ascii(content):
            return _binary(content, count, log)
    return _ascii(content, log)


def _looks_ascii(content: bytes) -> bool:
    return content.lstrip()[:5].lower() == b"solid" and b"facet" in content[:1000]


def _binary(content: bytes, count: int, log: ReadLog) -> np.ndarray:
    available = (len(content) - BINARY_HEADER) // BINARY_TRIANGLE
    n = min(count, available)
    if n < count:
        log.truncate(f"the file ends after {n} of {count} triangles", element="triangle", read=n, declared=count)
    tri = np.frombuffer(content, _TRIANGLE, n, offset=BINARY_HEADER)["corners"].astype(np.float64)
    ok = np.isfinite(tri).all((1, 2))
    for _ in range(int((~ok).sum())):
        log.skip(None, "non-finite coordinate")
    return tri[ok]


def _ascii(content: bytes, log: ReadLog) -> np.ndarray:
    lines = content.decode("utf-8", errors="replace").splitlines()
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
                elif not all(math.isfinite(v) for v in xyz):
                    bad = bad or (lineno, "non-finite coordinate")
                corners.append(xyz)
            except ValueError:
                bad = bad or (lineno, "vertex not numbers")
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
