"""How a table exported by a spreadsheet writes its numbers: the one rule the scan reader (``text_points``) and the
nominal reader (``nominal_files``) share to tell a decimal comma (``251,5``, as a European locale writes it) from a
comma between cells, and digit grouping (``2.515,5``, ``2 515,5``, ``2,515.5``) from separate numbers.

A file whose cells are separated by commas writes a decimal point (a locale whose list separator is the comma
uses the point); there a quoted ``"2,515.5"`` is grouped. A file separated by semicolons, tabs or blanks writes
either mark, and its cells say which: a cell's last separator before its final digits is its decimal mark. The
file's mark is the comma when more cells of its first rows end so than with a point; else the point.
A cell of the other mark (``12.5`` in a decimal-comma file: ``2.515`` there would be 2515 grouped, or 2.515 from
another tool) cannot be told and is not read: the caller names its line."""

from __future__ import annotations

import re
from collections import Counter

ROWS_LOOKED_AT = 20  # the first rows of numbers decide the mark (a file writes one mark throughout)
_GROUP_BLANKS = "\u00a0\u202f'"  # no-break and narrow no-break space (French), apostrophe (Swiss)
_COMMA_NUMBER = re.compile(r"^[+-]?(?:\d+,\d+|\d+)(?:[eE][+-]?\d+)?$")
_LAST_MARK = re.compile(r"([.,])\d+(?:[eE][+-]?\d+)?$")


def _grouped(mark: str, blank_is_delimiter: bool) -> re.Pattern:
    """Grouped digits: by the other mark only with decimals after it (``2.515`` alone may be 2.515 written by
    another tool), by blanks (``2 515``) with or without."""
    exp, m = r"(?:[eE][+-]?\d+)?", re.escape(mark)
    other = re.escape("." if mark == "," else ",")
    blanks = re.escape(_GROUP_BLANKS + ("" if blank_is_delimiter else " "))
    return re.compile(rf"^[+-]?\d{{1,3}}(?:(?:{other}\d{{3}})+{m}\d+|(?:[{blanks}]\d{{3}})+(?:{m}\d*)?){exp}$")


GROUPED = {(mark, blank): _grouped(mark, blank) for mark in ".," for blank in (False, True)}


def starts_number(row: str) -> bool:
    """Whether a row starts like a number (a quoted cell too: an Excel export's)."""
    first = row.lstrip().lstrip('"')[:1]
    return first.isdigit() or first in "+-."


def cell_delimiter(rows: list[str]) -> str | None:
    """What separates the cells of rows of numbers: a semicolon or tab wherever one stands, else the comma where
    one stands, unless every row is three or more decimal-comma numbers between blanks (``251,5 -112,4 30,6``);
    else blanks (None)."""
    for delimiter in (";", "\t"):
        if any(delimiter in r for r in rows):
            return delimiter
    if not any("," in r for r in rows):
        return None
    split = [r.split() for r in rows]
    return None if all(len(f) >= 3 and all(_COMMA_NUMBER.match(c) for c in f) for f in split) else ","


_FRACTION = re.compile(r"^\d+$")


def commas_split_decimals(rows: list[list[str]], names: int = 0) -> bool:
    """Whether comma-separated rows are numbers written with decimal commas in a file whose cells the comma also
    separates (``251,000,-112,446,30,572``: 251.000, -112.446, 30.572 split in six): every row holds twice the
    header's ``names`` cells, or, without one, an even number of at least six cells of which every second one is
    unsigned digits of one length (a fixed number of decimals) and none writes a decimal point. Read cell by cell
    such a row gives x = 251, y = 0, z = -112: a wrong point for every row."""
    if not rows or any("." in c for row in rows for c in row):
        return False
    if names:
        return all(len(row) == 2 * names for row in rows)
    widths = {len(row) for row in rows}
    if len(widths) != 1 or (width := widths.pop()) < 6 or width % 2:
        return False
    fractions = [row[k] for row in rows for k in range(1, width, 2)]
    return all(_FRACTION.match(c) for c in fractions) and len({len(c) for c in fractions}) == 1


def cell_mark(cell: str) -> str | None:
    """The decimal mark a cell writes (``,`` or ``.``), None for an integer or text."""
    m = _LAST_MARK.search(cell.strip())
    return m.group(1) if m else None


def decimal_mark(rows: list[list[str]], delimiter: str | None) -> str:
    """The decimal mark of rows of cells split at ``delimiter`` (None: blanks): the point for a comma-separated
    file, else the comma when more cells write it than a point."""
    if delimiter == ",":
        return "."
    marks = Counter(cell_mark(c) for row in rows[:ROWS_LOOKED_AT] for c in row)
    return "," if marks[","] > marks["."] else "."


def plain(cell: str, mark: str, blank_is_delimiter: bool = True) -> str:
    """A cell as Python writes the number (its digits kept: a cut last number is told by them), in a file whose
    decimal mark is ``mark``, its digit grouping removed. Raises ValueError on a cell written with the other mark."""
    s = cell.strip()
    if GROUPED[mark, blank_is_delimiter].match(s):
        return re.sub(r"[.,\s']", lambda g: "." if g.group(0) == mark else "", s)
    if mark == ",":
        if "." in s:
            raise ValueError(f"{s!r} writes a decimal point in a file written with decimal commas")
        return s.replace(",", ".")
    if "," in s:
        raise ValueError(f"{s!r} writes a comma in a file written with decimal points")
    return s


def number(cell: str, mark: str, blank_is_delimiter: bool = True) -> float:
    """A cell's value (see :func:`plain`). Raises ValueError on text and on a cell written with the other mark."""
    return float(plain(cell, mark, blank_is_delimiter))


def is_number(cell: str, blank_is_delimiter: bool = True) -> bool:
    """Whether a cell is a number in either decimal mark (``251,500`` or ``251.500``): a number is told from text
    so before a file's mark is known (plain ``float`` took a decimal comma for text)."""
    for mark in ".,":
        try:
            number(cell, mark, blank_is_delimiter)
        except ValueError:
            continue
        return True
    return False


def decimals(cell: str, mark: str = ".") -> int:
    """How many digits a number cell writes after its decimal mark, its exponent left out: a file printed with a
    fixed number of decimals writes them alike, so a last number with fewer was cut."""
    mantissa = cell.strip().strip('"').lower().split("e")[0]
    return len(mantissa.split(mark, 1)[1]) if mark in mantissa else 0
