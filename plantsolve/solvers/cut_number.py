"""Whether the last number of a file without a final line ending was cut (0.9278 -> 0.9): the file readers' one rule.

A cut number keeps fewer digits than its column's numbers; exporters write a column to a fixed number of decimals
(``%.6f``), so its decimals are what is compared: significant digits say nothing there ('0.000916' is a whole
``%.6f`` value with 3). Only a number in exponent notation ('1.2345E-4') carries its precision in its significant
digits, and those are compared with the other exponent-notation cells of the column only. Exporters drop a trailing
zero now and then, so a short cell among many is no proof: the share of the column's cells as short as the last one
decides, and a handful of cells decides nothing.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Sequence

# a last cell with fewer digits than all but this share of its column's cells ends a cut file
CUT_SHARE = 0.02
# ... than all but this share: the file may be cut there (a trailing zero dropped as often leaves a cell that short)
MAYBE_CUT_SHARE = 0.25
# ... for a last cell one digit short of the column's longest: one zero dropped leaves a tenth of the cells that short
MAYBE_CUT_SHARE_ONE = 0.05
MIN_COMPARABLE = 20  # cells of the column written alike (plain or exponent) below which no cut is told
TAIL_CHARS = 200_000  # the end of a file its last lines are taken from (a row of a table is some 100 characters)

_EXPONENT = re.compile(r"[-+]?\d*[.,]?\d+[eEdD][-+]?\d+")
_ZERO = re.compile(r"[-+]?0+")
_PLAIN = re.compile(r"[-+]?(?:\d+[.,]?\d*|[.,]\d+)")


def last_lines(text: str, count: int) -> list[str]:
    """The last ``count`` nonblank lines of a text, split from its last TAIL_CHARS characters only: a field file of
    2,000,000 rows split whole held some 200 MB of line strings to look at its end."""
    tail = text[-TAIL_CHARS:].rstrip(" \t\x00\x1a")
    lines = tail.splitlines()
    if len(text) > TAIL_CHARS:
        lines = lines[1:]  # the first may start mid-line
    return [line for line in lines[-count:] if line.strip()]


@dataclass(frozen=True)
class Written:
    """How a number cell is written: in exponent notation or plain, and its digits that tell a cut."""

    exponent: bool
    digits: int  # significant digits of an exponent form's mantissa, else decimals after the mark


def written(cell: str, mark: str | None = None) -> Written | None:
    """The digits of a number cell as written (None for no number, and for a zero written whole, '0' or '-0', as
    exporters that drop trailing zeros write it: it has no digits to lose nor says how many its column has);
    ``mark`` the decimal mark, if the file says ('.' or ','), else the cell's last '.' or ','."""
    s = cell.strip()
    if _ZERO.fullmatch(s):
        return None
    if _EXPONENT.fullmatch(s):
        mantissa = re.split(r"[eEdD]", s.lstrip("+-"))[0].replace(".", "").replace(",", "")
        return Written(True, len(mantissa.lstrip("0")))
    if not _PLAIN.fullmatch(s):
        return None
    at = s.rfind(mark) if mark else max(s.rfind("."), s.rfind(","))
    return Written(False, len(s) - at - 1 if at >= 0 else 0)


@dataclass(frozen=True)
class ShortNumber:
    """A last cell shorter than its column's: its digits, the column's (fewest, most), the share of the column's cells
    as short, and whether that share is small enough to call the number cut rather than maybe cut."""

    digits: int
    column: tuple[int, int]
    share: float
    exponent: bool

    @property
    def certain(self) -> bool:
        return self.share <= CUT_SHARE

    @property
    def reason(self) -> str:
        what = "significant digit(s)" if self.exponent else "decimal(s)"
        lo, hi = self.column
        return (f"{self.digits} {what} where the column's other values have {lo}" + (f" to {hi}" if hi != lo else "")
                + ("" if self.certain else f" ({100 * self.share:.2g} % of them {self.digits} or fewer)"))


def short_number(last: Written | None, column: Sequence[Written | None],
                 min_comparable: int = MIN_COMPARABLE) -> ShortNumber | None:
    """The last cell of a column as it compares with the column's other cells written alike, when it is short enough
    to be cut (:data:`MAYBE_CUT_SHARE`, :data:`MAYBE_CUT_SHARE_ONE`), else None."""
    if last is None:
        return None
    digits = [w.digits for w in column if w is not None and w.exponent == last.exponent]
    if len(digits) < min_comparable or last.digits >= max(digits):
        return None
    share = sum(d <= last.digits for d in digits) / len(digits)
    if share > (MAYBE_CUT_SHARE if max(digits) - last.digits >= 2 else MAYBE_CUT_SHARE_ONE):
        return None
    return ShortNumber(last.digits, (min(digits), max(digits)), share, last.exponent)
