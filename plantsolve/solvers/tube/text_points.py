"""XYZ, CSV and TXT point lists: one point a line, ``x y z`` first (more columns allowed, e.g. colour or intensity).

A line that cannot be read — cut short (fewer columns than the file's other rows), not numbers, a NaN or an
infinite coordinate, stray bytes — is left out and logged with its line number; the file is refused only when no
point is left. Text is read as exporters write it (UTF-8, UTF-16 with its mark, else Windows-1252). Non-numeric
lines before the first point are a header; lines starting with # / or % are comments."""

from __future__ import annotations

import math
import re
from collections import Counter

import numpy as np

from plantsolve.schemas.common import MAX_COORDINATE
from plantsolve.solvers.base import InputRejected, decode_text, reject
from plantsolve.solvers.tube.read_log import ReadLog

_SPLIT = re.compile(r"[,;\s]+")


def read_text_points(content: bytes, log: ReadLog) -> np.ndarray:
    # UTF-8, UTF-16 with its mark or Windows-1252: a line of stray bytes is one unreadable line, not the file's end
    try:
        text = decode_text(content, "point list")
    except InputRejected as e:
        raise reject(f"the file is not text in UTF-8, UTF-16 or Windows-1252: {e.errors[0].msg}") from None
    lines = text.splitlines()
    ends_mid_line = bool(text) and not text.endswith(("\n", "\r"))
    rows: list[tuple[int, list[float], int]] = []  # line number, x y z, number of columns
    decimals: list[int] = []  # of each row's last number
    bad: list[tuple[int, str]] = []
    for lineno, line in enumerate(lines, 1):
        s = line.strip()
        if not s or s[0] in "#/%":
            continue
        fields = [f for f in _SPLIT.split(s) if f]
        try:
            vals = [float(f) for f in fields[:3]]
        except ValueError:
            if rows or bad:  # only lines before the first point can be a header
                bad.append((lineno, "not numbers"))
            continue
        if len(vals) < 3:
            bad.append((lineno, "fewer than 3 coordinates"))
        elif not all(math.isfinite(v) for v in vals):
            bad.append((lineno, "non-finite coordinate"))
        elif not all(abs(v) <= MAX_COORDINATE for v in vals):  # a float the writer never meant
            bad.append((lineno, f"coordinate beyond {MAX_COORDINATE:g}"))
        else:
            rows.append((lineno, vals, len(fields)))
            decimals.append(_decimals(fields[-1]))
    # a row with fewer columns than the file's other rows was cut (its last number may be cut too)
    usual = Counter(n for _, _, n in rows).most_common(1)[0][0] if rows else 3
    short = [(ln, f"cut short ({n} of {usual} columns)") for ln, _, n in rows if n < usual]
    if ends_mid_line and rows and rows[-1][2] >= usual and rows[-1][0] == len(lines) and _cut_number(decimals):
        short.append((rows[-1][0], "cut short (its last number has fewer decimals than the other rows')"))
        rows[-1] = (rows[-1][0], rows[-1][1], -1)
    kept = [v for _, v, n in rows if n >= usual]
    for ln, reason in sorted(bad + short):
        log.skip(ln, reason)
    last_point_line = max([ln for ln, _, _ in rows] + [ln for ln, _ in bad], default=0)
    if ends_mid_line and any(ln == last_point_line for ln, _ in bad + short):
        log.truncate(f"the file ends mid-line (line {last_point_line})", line=last_point_line)
    if not kept:
        raise reject(f"no readable 'x y z' rows found{log.summary()}")
    return np.array(kept, dtype=np.float64)


def _decimals(field: str) -> int:
    mantissa = field.lower().split("e")[0]
    return len(mantissa.split(".", 1)[1]) if "." in mantissa else 0


def _cut_number(decimals: list[int]) -> bool:
    """Whether the last row's last number was cut: a file written with a fixed number of decimals (nine rows in
    ten alike) whose last row has fewer. Only asked of a file that ends without a newline."""
    if len(decimals) < 10:
        return False
    usual, n = Counter(decimals[:-1]).most_common(1)[0]
    return n >= 0.9 * (len(decimals) - 1) and decimals[-1] < usual
