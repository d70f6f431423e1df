"""CSV rows of a million faces written by array operations instead of a ``repr`` per number.

Python formats a float in about half a microsecond; a face row has seven of them, so the per-face
table of a million-triangle mesh took seconds, more than reading the mesh. Here each column becomes
a matrix of characters at once: a number is written in scientific notation with 17 significant digits
(``-1.2345678901234567e-05``, trailing zeros dropped), its digits taken from a 17-digit integer
mantissa; the scaling by a power of ten is done in floating point and a 17-digit integer is not
exact in a double, so the last digit may be off by a few units (a relative difference below 1e-15,
far below any tolerance of the measures; smaller tables are written with ``repr``). Cells are
padded with NUL bytes to a fixed width and the NULs are removed from the text at the end.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

DIGITS = 17
_POW10 = 10 ** np.arange(DIGITS - 1, -1, -1, dtype=np.int64)  # 10^16 … 10^0
_NUL = 0


def _scaled(a: np.ndarray, e: np.ndarray) -> np.ndarray:
    """a · 10^(16 - e): one multiplication or division by an exact power of ten (|k| <= 22, every value
    between 1e-6 and 1e38), else two steps, so that no power overflows for the smallest or largest doubles."""
    k = DIGITS - 1 - e
    out = np.empty_like(a)
    up, down = (k >= 0) & (k <= 22), (k < 0) & (k >= -22)
    out[up] = a[up] * 10.0 ** k[up]
    out[down] = a[down] / 10.0 ** -k[down]
    rest = ~(up | down)
    half = k[rest] // 2
    out[rest] = a[rest] * 10.0 ** half * 10.0 ** (k[rest] - half)
    return out


def _four_digit_tables() -> tuple[np.ndarray, np.ndarray]:
    """ASCII of 0000 … 9999, and the same with trailing zeros as NULs."""
    values = np.arange(10_000)
    full = np.stack([(values // 10 ** p) % 10 for p in (3, 2, 1, 0)], axis=1).astype(np.uint8) + ord("0")
    stripped = full.copy()
    for p in (3, 2, 1):  # a digit is trailing when it and every digit after it are zero
        stripped[:, p][(values % 10 ** (4 - p)) == 0] = _NUL
    stripped[0] = _NUL
    return full, stripped


_FULL, _STRIPPED = _four_digit_tables()
_WORDS = np.concatenate([_FULL, _STRIPPED]).view(np.uint32).reshape(-1)  # 4 characters as one word


def number_cells(x: np.ndarray) -> np.ndarray:
    """(n, 24) uint8: each float of ``x`` in scientific notation, NUL-padded (finite values only)."""
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    a = np.abs(x)
    nonzero = a > 0
    e = np.zeros(n, dtype=np.int64)
    e[nonzero] = np.floor(np.log10(a[nonzero])).astype(np.int64)
    m = np.zeros(n, dtype=np.int64)
    m[nonzero] = np.rint(_scaled(a[nonzero], e[nonzero])).astype(np.int64)
    # log10 may land one decade off near a power of ten: rescale those few
    for _ in range(2):
        high = m >= 10 ** DIGITS
        low = nonzero & (m < 10 ** (DIGITS - 1))
        if not (high.any() or low.any()):
            break
        e[high] += 1
        e[low] -= 1
        fix = high | low
        m[fix] = np.rint(_scaled(a[fix], e[fix])).astype(np.int64)
    cells = np.full((n, 24), _NUL, dtype=np.uint8)
    cells[:, 0] = np.where(np.signbit(x) & nonzero, ord("-"), _NUL)
    cells[:, 1] = m // 10 ** 16 + ord("0")
    cells[:, 2] = ord(".")
    # the sixteen digits after the point in four groups of four, each one 4-byte word of a table (full, or
    # with its trailing zeros as NULs when every later group is zero)
    rest = m % 10 ** 16
    words = np.empty((n, 4), dtype=np.uint32)
    later_zero = np.ones(n, dtype=bool)
    for g in (3, 2, 1, 0):
        group = (rest // 10 ** (4 * (3 - g))) % 10_000
        words[:, g] = _WORDS[group + 10_000 * later_zero]
        later_zero &= group == 0
    cells[:, 3:19] = words.view(np.uint8)
    cells[:, 3][later_zero] = ord("0")  # one digit after the point stays
    cells[:, 19] = ord("e")
    cells[:, 20] = np.where(e < 0, ord("-"), ord("+"))
    ae = np.abs(e)
    cells[:, 21] = np.where(ae >= 100, ae // 100 + ord("0"), _NUL)
    cells[:, 22] = (ae // 10) % 10 + ord("0")
    cells[:, 23] = ae % 10 + ord("0")
    return cells


def numbered_cells(prefix: str, first: int, n: int) -> np.ndarray:
    """(n, w) uint8: ``<prefix><first>``, ``<prefix><first + 1>``, … (NUL-padded, leading zeros as NULs)."""
    k = np.arange(first, first + n, dtype=np.int64)
    width = max(len(str(first + n - 1)), 1)
    groups = -(-width // 4)
    digits = np.empty((n, 4 * groups), dtype=np.uint8)
    words = digits.view(np.uint32)
    for g in range(groups):
        words[:, g] = _WORDS[(k // 10 ** (4 * (groups - 1 - g))) % 10_000]
    leading = np.cumprod(digits == ord("0"), axis=1).astype(bool)
    leading[:, -1] = False
    digits[leading] = _NUL
    return np.concatenate([literal(prefix, n), digits], axis=1)


def _quoted(value: str) -> str:
    return '"' + value.replace('"', '""') + '"' if any(c in value for c in ',"\r\n') else value


def writable(values: Sequence[str]) -> bool:
    """Strings these cells can hold: no NUL (the padding)."""
    return "\x00" not in "".join(values)


def text_cells(values: Sequence[str]) -> np.ndarray:
    """(n, w) uint8: each string CSV-quoted where it needs to be, UTF-8, NUL-padded."""
    values = list(values)
    if any(c in "".join(values) for c in ',"\r\n'):
        values = [_quoted(v) for v in values]
    array = np.array([v.encode() for v in values], dtype=bytes)
    width = max(array.dtype.itemsize, 1)
    return np.frombuffer(array.astype(f"S{width}").tobytes(), dtype=np.uint8).reshape(len(values), width)


def literal(text: str, n: int) -> np.ndarray:
    return np.broadcast_to(np.frombuffer(text.encode(), dtype=np.uint8), (n, len(text.encode())))


def rows(columns: list[np.ndarray]) -> bytes:
    """The rows made of the given (n, w_i) cell matrices, side by side, NULs removed."""
    return np.concatenate(columns, axis=1).tobytes().replace(b"\x00", b"")
