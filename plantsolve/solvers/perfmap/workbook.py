"""Rig tables in Excel workbooks (.xlsx, read with openpyxl): each sheet as rows of cell texts, so that the
CSV rules (header detection, units, decimal commas, row messages) apply unchanged.

What exporters and people do to a sheet, and what it becomes here:
- merged cells (a title across the table, a speed value merged down its speed line): every cell of the
  range holds the range's value, as the sheet shows it; but a word merged down (a header cell spanning the
  header and the units row) is in the range's first row only: repeated, it made the units row no units row
  (its units dropped, the row refused as 'not a number');
- blank rows and rows whose first cell starts with ``#``: skipped (their numbers are kept for messages);
- numbers stored as text (``'0.85``, ``0,85``, ``65.85%``): parsed like CSV cells (decimal comma allowed);
- number formats: a cell is read as Excel shows it where its format changes the unit: a percentage (``0.00%``)
  as per cent with its ``%`` (0.8585 is ``85.85%``), a format writing a unit after the number (``0.00" kg/s"``,
  ``0.0 "bar"``, ``0.0\\%``) with that unit; the table reader reconciles such cells with the column's header
  (:mod:`plantsolve.solvers.perfmap.cell_units`). Other formats (decimals, thousands, colours) change nothing;
- formulas: their value as last saved by Excel; a formula never calculated (a workbook written by a
  script) has none and becomes ``=<formula>``, which the table parser refuses naming the cell's row;
- error values (``#DIV/0!``) and dates stay text and are refused as not numbers.
"""

from __future__ import annotations

import io
import re
import zipfile
from dataclasses import dataclass
from datetime import date, datetime, time
from decimal import Decimal

import openpyxl
from openpyxl.utils.exceptions import InvalidFileException

from plantsolve.solvers.base import reject
from plantsolve.solvers.perfmap.cell_units import cell_unit, split_cell


@dataclass
class Sheet:
    name: str
    rows: list[list[str]]  # cell texts of the non-blank rows
    numbers: list[int]  # 1-based sheet row of each


_FORMAT_CODES = re.compile(r'"([^"]*)"|\\(.)|_.|\*.|\[[^\]]*\]|(%)')


def format_unit(number_format: str) -> tuple[int, str]:
    """What a cell's number format (its first section, for positive numbers) says of the value: how many times it
    shows it as a percentage (Excel multiplies by 100 for each unquoted ``%``), and the literal text it writes
    after it (``0.00" kg/s"``, ``0.0\\ \\b\\a\\r``), stripped."""
    section = (number_format or "General").split(";")[0]
    percents, literal = 0, []
    for m in _FORMAT_CODES.finditer(section):
        quoted, escaped, percent = m.groups()
        if percent:
            percents += 1
        elif quoted is not None or escaped is not None:
            literal.append(quoted if quoted is not None else escaped)
    return percents, "".join(literal).strip()


def _text(value, number_format: str = "General") -> str:
    """A cell as Excel shows it, in the terms the table reader reads: a percentage as per cent with a ``%``
    (0.8585 formatted ``0.00%`` is ``85.85%``), a number whose format writes a unit after it with that unit."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(value).upper()
    if isinstance(value, (int, float)):
        text = repr(float(value)) if isinstance(value, float) else str(value)
        percents, literal = format_unit(number_format)
        if percents:
            # in decimal, so that 0.8585 is shown 85.85, not 85.85000000000001
            shown = Decimal(text).scaleb(2 * percents).normalize()
            return f"{shown:f}" + "%" * percents
        # a literal that is a unit ('kg/s', '%', '°'), not a word ('approx.'), is the cell's unit
        return f"{text} {literal}" if literal and cell_unit(literal) else text
    if isinstance(value, (datetime, date, time)):
        return value.isoformat()
    return str(value).strip()


def _label(text: str) -> bool:
    """Whether a cell holds a word, not a value: 'Flow' merged down over the header and the units row is one label
    (the units row under it then reads 'kg/s' beside a blank), while '100 rpm' merged down its speed line is a value of
    every row."""
    return any(ch.isalpha() for ch in text) and split_cell(text)[1] is None


def _directory_cut(content: bytes) -> bool:
    """Whether a zip archive lacks the whole end record of its directory (22 bytes and its comment, last in the
    file): the file was cut, even when the cut falls inside that record and leaves its signature."""
    end = content.rfind(b"PK\x05\x06", max(0, len(content) - (1 << 16) - 22))
    if end < 0 or end + 22 > len(content):
        return True
    return end + 22 + int.from_bytes(content[end + 20:end + 22], "little") > len(content)


def read_workbook(content: bytes, max_rows: int) -> list[Sheet]:
    """The workbook's sheets in order (hidden ones last); raises :class:`InputRejected` when it is not a
    readable .xlsx or a sheet is longer than ``max_rows``."""
    try:
        values = openpyxl.load_workbook(io.BytesIO(content), data_only=True)
        formulas = openpyxl.load_workbook(io.BytesIO(content), data_only=False)
    except (zipfile.BadZipFile, InvalidFileException, KeyError, ValueError, TypeError, OSError, EOFError,
            IndexError, AttributeError) as e:
        if content[:4] == b"PK\x03\x04" and _directory_cut(content):
            # a zip archive ends with its directory: without it the workbook was cut, and no sheet can be found
            raise reject(f"not a readable Excel .xlsx workbook: it is cut short, ending after {len(content):,} bytes, "
                         "before the zip directory every .xlsx ends with (an incomplete upload or copy?); send the "
                         "whole file") from None
        raise reject(f"not a readable Excel .xlsx workbook ({type(e).__name__}); save it from Excel as "
                     "'Excel Workbook (*.xlsx)' or as CSV") from None
    sheets = []
    order = sorted(values.worksheets, key=lambda ws: ws.sheet_state != "visible")
    for ws in order:
        if ws.max_row > max_rows:
            raise reject(f"sheet {ws.title!r} has {ws.max_row:,} rows; at most {max_rows:,} are read")
        grid = [[_text(c.value, c.number_format) for c in row] for row in ws.iter_rows()]
        fws = formulas[ws.title]
        for r, row in enumerate(grid):
            for c, cell in enumerate(row):
                if not cell:
                    f = fws.cell(row=r + 1, column=c + 1).value
                    if isinstance(f, str) and f.startswith("="):
                        row[c] = f
        for rng in ws.merged_cells.ranges:
            top = grid[rng.min_row - 1][rng.min_col - 1] if rng.min_row - 1 < len(grid) else ""
            last = rng.max_row if not _label(top) else rng.min_row
            for r in range(rng.min_row - 1, min(last, len(grid))):
                for c in range(rng.min_col - 1, min(rng.max_col, len(grid[r]))):
                    grid[r][c] = top
        rows, numbers = [], []
        for n, row in enumerate(grid, start=1):
            while row and not row[-1]:
                row = row[:-1]
            if any(row) and not row[0].lstrip().startswith("#"):
                rows.append(row)
                numbers.append(n)
        sheets.append(Sheet(ws.title, rows, numbers))
    return sheets
