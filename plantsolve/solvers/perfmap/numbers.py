"""Numbers in a rig table as locales write them: a decimal point with thousands commas (``1,104.338``) or a
decimal comma with thousands dots (``1.104,338``, ``0,9278``).

Each column follows one convention, decided from its cells: a cell that can only be read one way (``0.9278``,
``0,9278``, ``1,104.338``) says which; a cell such as ``1,104`` (1.104 or 1104?) is read by the column's
convention, else by the file's (other columns' cells), and refused naming the column when nothing says which.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

POINT, COMMA = "point", "comma"
_EXP = r"([eE][+-]?\d+)?"
_PLAIN = re.compile(rf"^[+-]?(\d+\.?\d*|\.\d+){_EXP}$")
_THOUSANDS_COMMA = re.compile(r"^[+-]?[1-9]\d{0,2}(,\d{3})+$")  # 1,104: 1104, or 1.104 with a decimal comma
_THOUSANDS_DOT = re.compile(r"^[+-]?[1-9]\d{0,2}(\.\d{3})+$")  # 1.104: 1.104, or 1104 with thousands dots
_POINT_GROUPED = re.compile(rf"^[+-]?[1-9]\d{{0,2}}(,\d{{3}})+\.\d*{_EXP}$")  # 1,104.338
_COMMA_GROUPED = re.compile(rf"^[+-]?[1-9]\d{{0,2}}(\.\d{{3}})+,\d*{_EXP}$")  # 1.104,338
_COMMA_DECIMAL = re.compile(rf"^[+-]?\d*,\d+{_EXP}$")  # 0,9278 (not a thousands group: checked first)


def clean(cell: str) -> str:
    return cell.strip().strip('"').strip().replace("\u00a0", "").replace("\u202f", "").replace("\u2212", "-")


def evidence(cell: str) -> str | None:
    """The convention a cell can only be read in (POINT, COMMA), or None when it reads in either or in none."""
    s = clean(cell)
    if "," in s and "." in s:
        return POINT if _POINT_GROUPED.match(s) else COMMA if _COMMA_GROUPED.match(s) else None
    if "," in s:
        return None if _THOUSANDS_COMMA.match(s) else COMMA if _COMMA_DECIMAL.match(s) else None
    if "." in s and not _THOUSANDS_DOT.match(s) and _PLAIN.match(s):
        return POINT
    return None


def ambiguous(cell: str) -> bool:
    """A cell whose value depends on the convention (``1,104``, ``1.104``)."""
    s = clean(cell)
    return bool(_THOUSANDS_COMMA.match(s) or _THOUSANDS_DOT.match(s))


def number(cell: str, convention: str | None) -> float:
    """The cell's value in ``convention`` (None: a decimal point, no grouping); ValueError when it does not read."""
    s = clean(cell)
    if convention == COMMA and "," in s:
        if not (_COMMA_DECIMAL.match(s) or _COMMA_GROUPED.match(s) or _THOUSANDS_COMMA.match(s)):
            raise ValueError(s)
        s = s.replace(".", "").replace(",", ".")
    elif convention == COMMA and _THOUSANDS_DOT.match(s):
        s = s.replace(".", "")
    elif convention == POINT and "," in s:
        if not (_POINT_GROUPED.match(s) or _THOUSANDS_COMMA.match(s)):
            raise ValueError(s)
        s = s.replace(",", "")
    return float(s)


@dataclass(frozen=True)
class Column:
    """What a column's cells say: the lines of cells that read only with a decimal point, only with a decimal
    comma, and in either (with a first example of each)."""

    point: list[int]
    comma: list[int]
    either: list[int]
    examples: dict[str, str]

    @property
    def convention(self) -> str | None:
        if self.point and self.comma:
            return None
        return POINT if self.point else COMMA if self.comma else None


def survey(cells: list[tuple[int, str]]) -> Column:
    """The evidence of one column's (line, cell) pairs."""
    point, comma, either, examples = [], [], [], {}
    for line, cell in cells:
        kind = evidence(cell)
        if kind is None and ambiguous(cell):
            kind = "either"
        if kind is None:
            continue
        {POINT: point, COMMA: comma, "either": either}[kind].append(line)
        examples.setdefault(kind, clean(cell))
    return Column(point, comma, either, examples)


def decimals(cell: str) -> int | None:
    """Digits after the decimal mark of a cell as written (None for an exponent form or no number)."""
    s = clean(cell)
    if "e" in s.lower():
        return None
    mark = "," if evidence(s) == COMMA else "."
    return len(s.rsplit(mark, 1)[1]) if mark in s else 0
