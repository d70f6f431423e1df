"""Cells that state their own unit, as Excel shows them and writes them to CSV: ``85.85%`` (a cell formatted as a
percentage), ``12.30 kg/s`` (a number format such as ``0.00" kg/s"``).

Each column's cell units are reconciled with its unit from the header or the row of units:

- a column whose header states no unit takes its cells' unit when every cell states it (``Flow`` over ``12.3 kg/s``
  is a flow in kg/s); cells in per cent or per mille among plain numbers are fractions scaled (``85%`` beside
  ``0.85``: Excel writes a general cell as it is and a percentage cell times 100);
- a cell whose unit is the column's is read as it is; per cent, per mille and plain ratios convert into each other
  exactly (``85.85%`` under ``efficiency [-]`` is 0.8585);
- any other disagreement (``lb/s`` cells under ``flow [kg/s]``, two units in one column, ``kg/s`` cells beside plain
  numbers) is refused naming the column, the units and the lines: which is meant is not known.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Callable

from plantsolve.solvers.base import FieldError
from plantsolve.solvers.perfmap.units import (
    StandardVolume,
    Unit,
    UnitError,
    is_ratio_unit,
    parse_speed_unit,
    registry,
)
from plantsolve.solvers.skipped_input import line_list

# a number as the table reads it (either decimal convention, thousands groups, an exponent) and a unit after it
_NUMBER_AND_UNIT = re.compile(r"^(?P<number>[+\-\u2212]?[\d.,\u00a0\u202f]*\d(?:[eE][+\-]?\d+)?)\s*"
                              r"(?P<unit>(?:1\s*/\s*)?[^\d\s.,+\-].*)$")  # '1/min' begins with a digit
# a number with a unit after it is short ('-1,234.5678 kg/s'); a longer cell is no such thing, and is refused as no
# number without the unit pattern running over it
_LONGEST = 64
_RATIOS = {"%": "%", "‰": "‰", "percent": "%", "pct": "%", "permille": "‰"}


def cell_unit(text: str) -> str | None:
    """The unit ``text`` is when written after a number ('%' for 'pct'), or None: only a unit pint reads that has
    dimensions or is an angle, or a per cent or per mille; not a plain ratio word ('-', '1') or a word ('(est)')."""
    if text.lower() in _RATIOS:
        return _RATIOS[text.lower()]
    try:
        unit = parse_speed_unit(text)
    except StandardVolume:
        return text  # a unit all the same: the column is refused saying why, not its cells as 'not a number'
    except UnitError:
        return None
    if unit.dimensionless and not _angle(unit):
        return None
    return text


def _angle(unit: Unit) -> bool:
    """Whether a dimensionless unit is an angle (° , deg, rad), which pint counts as dimensionless."""
    return any(word in str(unit.unit) for word in ("degree", "radian", "arcminute", "arcsecond", "gradian"))


def split_cell(cell: str) -> tuple[str, str | None]:
    """(number, unit) of a cell that writes a unit after its number (:func:`cell_unit`), else (cell, None): '0.85
    (est)' or a date stays as written, and is refused as no number."""
    text = cell.strip().strip('"').strip()  # stripped at both ends: the unit runs to the end, no blank after it
    if not text or text[-1].isdigit() or len(text) > _LONGEST:  # nearly every cell: a plain number, no unit after it
        return cell, None
    m = _NUMBER_AND_UNIT.match(text)
    unit = cell_unit(m.group("unit")) if m else None
    return (m.group("number"), unit) if unit else (cell, None)


def _unit(text: str | None) -> Unit | None:
    if not text:
        return None
    try:
        return parse_speed_unit(text)
    except UnitError:
        return None


def _ratio_factor(src: Unit | None, dst: Unit | None) -> float | None:
    """Factor from one plain ratio unit (1, %, ‰; None is 1) to another, or None when either is no plain ratio (an
    angle is dimensionless to pint, but degrees are no per cent)."""
    one = Unit("1", registry().dimensionless)
    src, dst = src or one, dst or one
    if not (is_ratio_unit(src) and is_ratio_unit(dst)):
        return None
    return src.factor_to(dst)


@dataclass
class ColumnCells:
    """What a column's cells state: the column's unit when they give it (None when they leave the header's), the
    factor of each cell into the column's unit (by row line, only those not 1) and of each cell unit so converted, and
    a refusal."""

    unit: str | None = None
    factors: dict[int, float] = field(default_factory=dict)
    converted: dict[str, float] = field(default_factory=dict)  # a cell unit converted into the column's: its factor
    error: FieldError | None = None


def reconcile(rows: list[list[str]], numbers: list[int], j: int, role: str, name: str, stated: str,
              what: str, same: Callable[[str, str], bool]) -> ColumnCells:
    """Column ``j`` of the data ``rows`` (changed in place to their numbers where a cell states a unit), read as
    ``role``, headed ``name``, in the unit ``stated`` by the header or the units row ('' for none); ``numbers`` name
    the rows; ``same`` tells two spellings of one unit apart from two units."""
    units: dict[str, list[int]] = {}
    plain: list[int] = []
    for n, row in zip(numbers, rows):
        if j >= len(row) or not row[j].strip():
            continue
        number, unit = split_cell(row[j])
        if unit is None:
            plain.append(n)
            continue
        units.setdefault(unit, []).append(n)
        row[j] = number
    if not units:
        return ColumnCells()
    kinds = list(units)
    parsed = {k: _unit(k) for k in kinds}

    def refused(line: int, message: str) -> ColumnCells:
        return ColumnCells(error=FieldError(("file", "row", line, role), message, "cell_units"))

    ratios = all(_ratio_factor(parsed[k], None) is not None for k in kinds)
    if len(kinds) > 1 and not ratios and not all(same(k, kinds[0]) for k in kinds):
        first, second = kinds[:2]
        return refused(units[second][0], f"column {name!r} states its values in {first!r} ({what} "
                       f"{line_list(units[first])}) and in {second!r} ({what} {line_list(units[second])}): one unit "
                       "per column")
    result = ColumnCells()
    if not stated:
        if not plain and len(kinds) == 1:
            result.unit = stated = kinds[0]  # every cell says it: the column's unit
        elif not ratios:
            k = next(k for k in kinds if _ratio_factor(parsed[k], None) is None)
            return refused(plain[0], f"column {name!r} states {k!r} in some cells ({what} {line_list(units[k])}) but "
                           f"not in others ({what} {line_list(plain)}), and its header states no unit: in which unit "
                           f"are those? Give the unit in the header ('{name} [{k}]')")
    column = _unit(stated) if stated else None
    for k in kinds:
        if stated and same(k, stated):
            continue
        factor = _ratio_factor(parsed[k], column) if column is not None or not stated else None
        if factor is None:
            return refused(units[k][0], f"column {name!r} is in {stated!r} but cells state {k!r} ({what} "
                           f"{line_list(units[k])}): which is meant? Give the unit once, in the header or in the "
                           "cells' number format")
        if factor != 1.0:
            result.factors.update(dict.fromkeys(units[k], factor))
            result.converted[k] = factor
    return result
