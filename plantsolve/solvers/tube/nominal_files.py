"""The nominal of an inspection as a bender shop gives it: LRA rows, XYZ-CLR points, or the text of a CSV file
holding either (this service's own ``lra.csv`` and ``xyz_clr.csv`` included), read into LRA rows.

XYZ-CLR → LRA is the standard conversion (done by :func:`model_from_control_polygon`): L = straight between
the tangent points of consecutive bends (leg length minus CLR·tan(A/2) at each end), R = dihedral rotation
between consecutive bend planes, A = angle between consecutive straights. LRA → XYZ-CLR is its inverse
(:func:`control_polygon`).
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.tube import LraRow, TubeOptions
from plantsolve.solvers.base import FieldError
from plantsolve.solvers.length_units import SIZES, SPELLINGS
from plantsolve.solvers.tube.lra import model_from_rows, model_rows
from plantsolve.solvers.tube.model import control_polygon, model_from_control_polygon
from plantsolve.solvers.tube.number_cells import (
    ROWS_LOOKED_AT,
    cell_delimiter,
    decimal_mark,
    decimals,
    number,
    starts_number,
)

# millimetres per length unit, by each of its spellings (length_units' one table: 'inch', 'millimetres', 'µm' too)
UNIT_MM = MappingProxyType({spelling: SIZES[unit] * 1000.0 for unit, names in SPELLINGS.items() for spelling in names})
ANGLE_DEG = {"deg": 1.0, "°": 1.0, "degree": 1.0, "degrees": 1.0, "rad": float(np.degrees(1.0))}

# column names of the shops' tables (YBC: Y feed, B rotation, C bend angle), lower case, units stripped
COLUMNS = {
    "length": {"length", "l", "feed", "y", "len", "straight", "distance", "dist", "feed_length", "straight_length"},
    "rotation": {"rotation", "r", "rot", "b", "plane_rotation", "twist", "rotation_angle"},
    "angle": {"angle", "a", "c", "ang", "bend_angle"},
    "clr": {"clr", "bend_radius", "radius", "rad", "clr_radius", "centreline_radius", "centerline_radius",
            "cl_radius", "r_bend"},
    "x": {"x"}, "y_xyz": {"y"}, "z": {"z"},
    "index": {"row", "point", "pt", "no", "nr", "index", "idx", "#", "bend", "n", "id", "step"},
}
HEADER_UNIT = re.compile(r"^(?P<name>.*?)(?:[\s_]*[\[(]\s*(?P<u1>[a-zµμ°]+)\s*[\])]|_(?P<u2>mm|cm|m|in|ft|um|deg|rad))?$")
MIN_ANGLE_DEG = 1e-6


def _looks_numeric(cell: str) -> bool:
    """A cell that holds a number in either decimal mark (whether or not this file's reading accepts it)."""
    try:
        float(cell.strip().strip('"').replace(",", ".").replace(" ", ""))
    except ValueError:
        return False
    return True


class NominalError(ValueError):
    """A nominal that cannot be used: ``where`` is a line number (CSV) or a point index (XYZ-CLR)."""

    def __init__(self, where: int | None, field_name: str | None, msg: str):
        self.where, self.field_name, self.msg = where, field_name, msg
        super().__init__(msg)


@dataclass
class Nominal:
    rows: list[LraRow]
    source: str
    warnings: list[Diagnostic] = field(default_factory=list)


def xyz_clr_from_rows(rows: list[LraRow]) -> tuple[np.ndarray, np.ndarray]:
    """LRA → XYZ-CLR in the LRA's own frame (start at the origin, first straight along x)."""
    return control_polygon(model_from_rows(rows, 0.0))


def _check_end_clrs(first: float, last: float, count: int) -> None:
    """The start and end of an XYZ-CLR are no bends: a table that gives one of them a CLR and not the other was cut
    after a bend (its end point lost) or is an LRA table read as points. (A table that gives both the die's CLR, as
    some exports fill the column, says neither.)"""
    if (first > 0) == (last > 0):
        return
    if last > 0:
        raise NominalError(count - 1, "clr", f"the last point carries a CLR ({last:g}) but the first none: an end point "
                           "is no bend, so the table ends at a bend and its end point is missing (was it cut?)")
    raise NominalError(0, "clr", f"the first point carries a CLR ({first:g}) but the last none: the start point is no "
                       "bend; is this an LRA table (length, rotation, angle, CLR: set nominal_format to lra) or is "
                       "its start point missing?")


def rows_from_xyz_clr(points, clr, end_clrs: tuple[float, float] | None = None) -> list[LraRow]:
    """XYZ-CLR → LRA; ``points`` (n + 2, 3) start, intersection points, end; ``clr`` (n,) of the interior points;
    ``end_clrs`` the CLRs the table gives its first and last points (checked to be alike: see
    :func:`_check_end_clrs`). Raises NominalError naming the point (0-based) that makes it impossible."""
    pts = np.asarray(points, float).reshape(-1, 3)
    clr = np.asarray(clr, float)
    if end_clrs is not None:
        _check_end_clrs(*end_clrs, len(pts))
    if len(pts) < 2:
        raise NominalError(None, None, "at least two points (start and end) are needed")
    legs = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    scale = max(float(legs.sum()), 1e-300)
    for i in np.flatnonzero(legs <= 1e-12 * scale):
        raise NominalError(int(i) + 1, None, f"point {i + 1} coincides with point {i}")
    for i, c in enumerate(clr, 1):
        if not c > 0:
            raise NominalError(i, "clr", f"point {i} is a bend: it needs a CLR > 0")
    d = np.diff(pts, axis=0) / legs[:, None]
    for i in range(len(pts) - 2):
        a = float(np.degrees(np.arccos(np.clip(d[i] @ d[i + 1], -1, 1))))
        if a < MIN_ANGLE_DEG:
            raise NominalError(i + 1, None, f"points {i}, {i + 1}, {i + 2} are collinear: no bend at point {i + 1}")
        if a > 180 - MIN_ANGLE_DEG:
            raise NominalError(i + 1, None, f"the tube turns back on itself at point {i + 1} (180°): a 180° bend has "
                               "no intersection point; give such a tube as LRA")
    model = model_from_control_polygon(pts, clr)
    for i, length in enumerate(model.lengths):
        if length < -1e-9 * scale:
            raise NominalError(i + 1 if i < len(model.lengths) - 1 else i, None,
                               f"the bends at both ends of the straight to point {i + 1} overlap (their tangent "
                               f"lengths exceed the leg by {-length:.6g}): CLR too large for that leg")
    model.lengths = np.maximum(model.lengths, 0.0)
    return model_rows(model)


def _split(line: str, delim: str | None) -> list[str]:
    if delim is None:
        return line.split()
    return [c.strip() for c in next(csv.reader(io.StringIO(line), delimiter=delim))]


def _delimiter(lines: list[str]) -> str | None:
    sample = "\n".join(lines[:5])
    for d in (";", "\t", ","):
        if d in sample:
            return d
    return None


def _number(cell: str, mark: str, blank_delimited: bool) -> float | None:
    """A cell's value in a file of decimal mark ``mark`` (:mod:`.number_cells`); None when empty. Raises ValueError
    on text and on a cell of the other mark."""
    cell = cell.strip()
    if not cell:
        return None
    v = number(cell, mark, blank_delimited)
    if not np.isfinite(v):
        raise ValueError(f"{cell!r} is not finite")
    return v


def _header_columns(cells: list[str]) -> tuple[list[str | None], list[str | None]]:
    """Column roles and units from a header row; a role None is a column that is not read."""
    roles, units = [], []
    names = [c.strip().lower() for c in cells]
    plain = [HEADER_UNIT.match(n).group("name").strip().replace(" ", "_").replace("-", "_") for n in names]
    is_xyz = "x" in plain and "z" in plain
    for raw, name in zip(names, plain):
        m = HEADER_UNIT.match(raw)
        unit = m.group("u1") or m.group("u2")
        role = None
        for key, words in COLUMNS.items():
            if name in words:
                role = key
                break
        if role == "length" and name == "y" and is_xyz:
            role = "y_xyz"
        if role == "y_xyz" and not is_xyz:
            role = "length"
        roles.append(None if role == "index" else role)
        units.append(unit)
    return roles, units


def _plain_name(cell: str) -> str:
    m = HEADER_UNIT.match(cell.strip().lower())
    return m.group("name").strip().replace(" ", "_").replace("-", "_")


def _unit_row(cells: list[str], width: int) -> list[str | None] | None:
    """The units of a line of unit names under the header (``,mm,deg,deg,mm``; ``[in]`` or ``(in)`` too), None
    when the line is anything else."""
    if len(cells) > width:
        return None
    units = [c.strip().strip("[]()").strip().lower() or None for c in cells]
    known = [u for u in units if u is not None]
    if not known or any(u not in UNIT_MM and u not in ANGLE_DEG for u in known):
        return None
    return units + [None] * (width - len(units))


def _cut_number(rows: list[list[str]], line: int, mark: str) -> list[Diagnostic]:
    """A table that ends without a line ending, its last number written with fewer decimals than every number of
    its column above (printed with a fixed number of decimals), was cut inside that number: ``94.4`` of ``94.4211``
    moves the part's end. Refused naming the line: a nominal with a wrong end judges the part wrongly. A last number
    without a decimal mark may be a round value a spreadsheet writes so (a length ``80``) as well as ``94`` cut
    before the mark: warned, naming it; a last ``0`` (the end straight's angle or CLR) is said nothing of."""
    last = rows[-1]
    filled = [j for j, c in enumerate(last) if c.strip()]
    if not filled:
        return []
    j = filled[-1]
    above = {decimals(r[j], mark) for r in rows[:-1] if j < len(r) and r[j].strip()}
    cell = last[j].strip()
    if len(rows) <= 2 or len(above) != 1 or decimals(cell, mark) >= min(above):
        return []
    if mark in cell.strip('"').lower().split("e")[0]:
        raise NominalError(line, None, f"the table ends inside line {line} without a line ending, its last number "
                           f"({cell}) written with fewer decimals than the same column above ({min(above)}): "
                           "the file was cut? Give the whole table")
    try:
        if float(cell.strip('"')) == 0:
            return []
    except ValueError:
        return []
    return [Diagnostic(code="nominal_last_row_short", message=(
        f"the nominal CSV ends without a line ending inside line {line}, its last number ({cell}) written without "
        f"the {min(above)} decimals of the same column above: if the file was cut, that number is cut too. Check the "
        "end of the table."), details={"line": line, "value": cell, "decimals_above": min(above)})]


def _short_last_row(rows: list[list[str]], line: int) -> list[Diagnostic]:
    """A warning when a table ends without a line ending inside a last row holding fewer cells than every row above:
    a row may leave its trailing fields out (the end straight's angle and CLR), but a file cut there ends so too,
    and then its last value (``7`` of ``70``) is cut as well."""
    widths = {len([c for c in r if c.strip()]) for r in rows[:-1]}
    held = len([c for c in rows[-1] if c.strip()])
    if len(rows) < 3 or len(widths) != 1 or held >= min(widths):
        return []
    return [Diagnostic(code="nominal_last_row_short", message=(
        f"the nominal CSV ends without a line ending inside line {line}, which holds {held} of the {min(widths)} "
        f"values of the rows above: if the file was cut, its last value ({rows[-1][held - 1].strip()!r}) is cut too. "
        "Check the end of the table."), details={"line": line, "values": held, "values_above": min(widths)})]


def _row_number(cells: list[str], col: int | None, value) -> float | None:
    if col is None or col >= len(cells):
        return None
    try:
        return value(cells[col])
    except ValueError:
        return None


def _in_row_number_order(values: list[dict], lines: list[int], numbers: list[float], column: str,
                         warnings: list[Diagnostic]) -> tuple[list[dict], list[int]]:
    """The rows in the order their row-number column gives. A table sorted by another column in a spreadsheet
    keeps its row numbers: read in the file's order it describes another part (bends swapped), which the
    inspection would then judge the scan against. A number given twice cannot be ordered: refused."""
    seen: dict[float, int] = {}
    for n, line in zip(numbers, lines):
        if n in seen:
            raise NominalError(line, None, f"the {column!r} column numbers lines {seen[n]} and {line} alike ({n:g}): "
                               "a row written twice? Each row of the part needs its own number")
        seen[n] = line
    order = sorted(range(len(values)), key=lambda k: numbers[k])
    if order == list(range(len(values))):
        return values, lines
    moved = [lines[k] for i, k in enumerate(order) if k != i]
    warnings.append(Diagnostic(code="nominal_rows_reordered", message=(
        f"the nominal CSV's rows are not in the order of its {column!r} column (lines "
        f"{', '.join(map(str, moved[:8]))}{', ...' if len(moved) > 8 else ''} stand elsewhere; sorted in a "
        f"spreadsheet?): read in the order of {column!r}."),
        details={"column": column, "lines_in_order": [lines[k] for k in order]}))
    return [values[k] for k in order], [lines[k] for k in order]


def _length_factor(unit: str | None, units: str, line: int, name: str) -> float:
    if unit is None:
        return 1.0
    if unit not in UNIT_MM:
        raise NominalError(line, name, f"unknown length unit {unit!r} in the header (mm, cm, m, in, ft)")
    return UNIT_MM[unit] / UNIT_MM[units]


def _angle_factor(unit: str | None, line: int, name: str) -> float:
    if unit is None:
        return 1.0
    if unit not in ANGLE_DEG:
        raise NominalError(line, name, f"unknown angle unit {unit!r} in the header (deg, rad)")
    return ANGLE_DEG[unit]


def read_nominal_csv(text: str, fmt: str = "auto", units: str = "mm") -> Nominal:
    """LRA rows from the text of an LRA or XYZ-CLR CSV (see ``TubeOptions.nominal_csv``). Unreadable lines are
    skipped with a warning naming the line; raises NominalError (with the line) when nothing usable is left."""
    text = text.removeprefix("\ufeff")  # a byte-order mark read into the text: not part of the first column's name
    lines = [(i, ln) for i, ln in enumerate(text.splitlines(), 1) if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise NominalError(None, None, "the nominal CSV holds no rows")
    # the rule the scan reader follows (number_cells): the rows of numbers say their delimiter and decimal mark
    number_rows = [ln.strip() for _, ln in lines if starts_number(ln)][:ROWS_LOOKED_AT]
    delim = cell_delimiter(number_rows) if number_rows else _delimiter([ln for _, ln in lines])
    mark = decimal_mark([_split(ln, delim) for ln in number_rows], delim)

    def cell_value(cell: str) -> float | None:
        return _number(cell, mark, delim is None)

    def numeric(line: str) -> bool:
        try:
            [cell_value(c) for c in _split(line, delim)]
        except ValueError:
            return False
        return True

    warnings: list[Diagnostic] = []
    # title lines above the header (part number, customer, ...): text lines that name no column of ours
    while len(lines) > 2 and not numeric(lines[0][1]) and not numeric(lines[1][1]) and \
            not {"length", "x"} & set(_header_columns(_split(lines[0][1], delim))[0]):
        warnings.append(Diagnostic(code="nominal_line_skipped", message=f"nominal CSV line {lines[0][0]} skipped: "
                                   "text above the header", details={"line": lines[0][0], "text": lines[0][1][:120]}))
        lines = lines[1:]
    first_line, first = lines[0]
    # a header typed with another delimiter than the exported rows' (``length,angle`` over ``80;90``)
    head = _split(first, delim if delim is None or delim in first else _delimiter([first]))
    header = not numeric(first)
    index_col = None
    if header:
        roles, col_units = _header_columns(head)
        body = lines[1:]
        if body and (units_row := _unit_row(_split(body[0][1], delim), len(head))) is not None:
            # a second header line of units under the names (``length,angle`` then ``in,deg``): theirs
            for c, u in enumerate(units_row):
                if u and col_units[c] and u != col_units[c]:
                    raise NominalError(body[0][0], None, f"column {head[c]!r} states the unit {col_units[c]!r} in its "
                                       f"name and {u!r} in the units line below it")
                col_units[c] = col_units[c] or u
            body = body[1:]
        index_col = next((c for c, name in enumerate(head) if _plain_name(name) in COLUMNS["index"]), None)
        kind = "xyz_clr" if {"x", "y_xyz", "z"} <= set(roles) else "lra"
        if fmt != "auto" and fmt != kind:
            raise NominalError(first_line, None, f"the header names {kind} columns ({', '.join(head)}), not {fmt}")
        need = ["x", "y_xyz", "z", "clr"] if kind == "xyz_clr" else ["length", "rotation", "angle", "clr"]
        missing = [n for n in need if n not in roles and not (kind == "xyz_clr" and n == "clr")]
        if missing:
            raise NominalError(first_line, None, f"the header ({', '.join(head)}) has no column for "
                               f"{', '.join(m.replace('_xyz', '') for m in missing)}")
        cols = {r: roles.index(r) for r in need if r in roles}
        fac = {r: (_angle_factor(col_units[c], first_line, head[c]) if r in ("rotation", "angle")
                   else _length_factor(col_units[c], units, first_line, head[c])) for r, c in cols.items()}
        described = f"header {', '.join(head)}"
    else:
        body = lines
        width = max(len(_split(ln, delim)) for _, ln in lines[:10])
        if width not in (4, 5):
            raise NominalError(first_line, None, f"{width} columns without a header: expected 4 (L, R, A, CLR or "
                               "x, y, z, CLR) or 5 (a row number first); add a header naming the columns")
        off = width - 4
        kind = fmt
        if kind == "auto":
            # an LRA's first row is a bend (CLR > 0) unless the tube is straight; an XYZ-CLR's first point is an end
            c0 = cell_value(head[off + 3]) if len(head) > off + 3 else None
            kind = "xyz_clr" if (c0 is None or c0 == 0) and len(lines) > 2 else "lra"
        need = ["x", "y_xyz", "z", "clr"] if kind == "xyz_clr" else ["length", "rotation", "angle", "clr"]
        cols = {r: off + k for k, r in enumerate(need)}
        fac = {r: 1.0 for r in need}
        described = f"no header, {width} columns read as {'x, y, z, CLR' if kind == 'xyz_clr' else 'L, R, A, CLR'}"
    values: list[dict] = []
    value_lines: list[int] = []
    numbers: list[float | None] = []  # of the row-number column, where there is one
    value_cells: list[list[str]] = []
    unread: list[tuple[int, str, str]] = []  # the body's lines that could not be read: line, text, why
    for line_no, ln in body:
        cells = _split(ln, delim)
        try:
            row = {}
            for r, c in cols.items():
                # a trailing field left out is empty (an end point's CLR, the last row's angle)
                v = cell_value(cells[c]) if c < len(cells) else None
                row[r] = None if v is None else v * fac[r]
            if kind == "xyz_clr" and any(row[r] is None for r in ("x", "y_xyz", "z")):
                raise ValueError("x, y and z are needed")
            if kind == "lra" and row["length"] is None:
                raise ValueError("no length")
        except ValueError as exc:
            warnings.append(Diagnostic(code="nominal_line_skipped", message=f"nominal CSV line {line_no} skipped: "
                                       f"{exc}", details={"line": line_no, "text": ln[:120]}))
            unread.append((line_no, ln, str(exc)))
            continue
        values.append(row)
        value_lines.append(line_no)
        value_cells.append(cells)
        numbers.append(_row_number(cells, index_col, cell_value))
    if not values:
        raise NominalError(None, None, "no row of the nominal CSV could be read" +
                           (f" ({warnings[0].message})" if warnings else ""))
    # a row of numbers is a point or a bend of the part: leaving one out describes another part (a bend fewer, no
    # end straight), which the inspection would then judge the scan against; lines of text (a units row, a
    # signature) are only skipped
    for line, text, reason in unread:
        if sum(_looks_numeric(c) for c in _split(text, delim)) >= 2:
            raise NominalError(line, None, f"nominal CSV line {line} cannot be read ({reason}): a row of numbers "
                               "left out would describe another part; correct or delete it")
    if value_lines and value_lines[-1] == len(text.splitlines()) and not text.endswith(("\n", "\r")):
        cut = _cut_number(value_cells, value_lines[-1], mark)
        warnings.extend(_short_last_row(value_cells, value_lines[-1]) or cut)
    if index_col is not None and values and None not in numbers:
        values, value_lines = _in_row_number_order(values, value_lines, numbers, head[index_col], warnings)
    if kind == "xyz_clr":
        pts = np.array([[v["x"], v["y_xyz"], v["z"]] for v in values])
        clr = np.array([v.get("clr") or 0.0 for v in values[1:-1]])
        try:
            rows = rows_from_xyz_clr(pts, clr, (values[0].get("clr") or 0.0, values[-1].get("clr") or 0.0))
        except NominalError as exc:
            line = value_lines[exc.where] if exc.where is not None and exc.where < len(value_lines) else None
            raise NominalError(line, exc.field_name, exc.msg) from None
        return Nominal(rows, f"nominal_csv: XYZ-CLR, {len(pts)} points ({described})", warnings)
    rows = []
    for i, v in enumerate(values):
        last = i == len(values) - 1
        rows.append({"length": v["length"], "rotation": v.get("rotation") or 0.0,
                         "angle": 0.0 if last else (v.get("angle") or 0.0),
                         "bend_radius": 0.0 if last else (v.get("clr") or 0.0)})
        if last and (v.get("angle") or 0.0) != 0:
            raise NominalError(value_lines[i], "angle", "the last LRA row is the final straight: its angle must be 0 "
                               "(add the final straight as a row of its own)")
    blank = [line for line, v in zip(value_lines[1:-1], values[1:-1]) if v.get("rotation") is None]
    if blank:
        # a rotation left out (a cell deleted, a value lost in the export) is read as 0°: said, since the inspection
        # then fails a right part by the rotation the cell held
        warnings.append(Diagnostic(code="nominal_rotation_empty", message=(
            f"nominal CSV line{'s' if len(blank) > 1 else ''} {', '.join(map(str, blank[:8]))}"
            f"{', ...' if len(blank) > 8 else ''}: the rotation cell is empty, read as 0°. Write 0 where the bend "
            "plane does not turn; a lost value makes the inspection judge that row against 0°."),
            details={"lines": blank}))
    if rows[0]["rotation"] != 0:
        warnings.append(Diagnostic(code="nominal_first_rotation", message=f"nominal CSV line {value_lines[0]}: the "
                                   f"first rotation ({rows[0]['rotation']:g}°) turns the whole part only; read as 0",
                                   details={"line": value_lines[0]}))
        rows[0]["rotation"] = 0.0
    if rows[-1]["rotation"] != 0:
        rows[-1]["rotation"] = 0.0
    out = []
    for line_no, r in zip(value_lines, rows):
        try:
            out.append(LraRow(**r))
        except ValueError as exc:
            raise NominalError(line_no, None, f"not a valid LRA row: {exc.errors()[0]['msg']}") from None
    for line_no, r in zip(value_lines[:-1], out[:-1]):
        if r.angle <= 0 or r.bend_radius <= 0:
            raise NominalError(line_no, "angle" if r.angle <= 0 else "bend_radius",
                               "every LRA row but the last needs a bend angle > 0 and a CLR > 0")
    return Nominal(out, f"nominal_csv: LRA, {len(out)} rows ({described})", warnings)


def resolve_nominal(opts: TubeOptions, units: str = "mm") -> Nominal | None:
    """The nominal of the options as LRA rows (None without one); raises NominalError."""
    if opts.nominal:
        return Nominal(list(opts.nominal), "nominal: LRA rows")
    if opts.nominal_xyz_clr:
        p = opts.nominal_xyz_clr
        rows = rows_from_xyz_clr([[q.x, q.y, q.z] for q in p], [q.clr or 0.0 for q in p[1:-1]],
                                 (p[0].clr or 0.0, p[-1].clr or 0.0))
        return Nominal(rows, f"nominal_xyz_clr: {len(p)} points")
    if opts.nominal_csv:
        return read_nominal_csv(opts.nominal_csv, opts.nominal_format, units)
    return None


def nominal_errors(opts: TubeOptions, units: str = "mm") -> list[FieldError]:
    """The 422 errors of an unusable XYZ-CLR or CSV nominal, naming the point or the line."""
    try:
        resolve_nominal(opts, units)
    except NominalError as exc:
        if opts.nominal_xyz_clr:
            loc = ("options", "nominal_xyz_clr") + ((exc.where,) if exc.where is not None else ()) + \
                ((exc.field_name,) if exc.field_name else ())
            return [FieldError(loc=loc, msg=exc.msg)]
        where = f"line {exc.where}: " if exc.where is not None else ""
        return [FieldError(loc=("options", "nominal_csv"), msg=where + exc.msg)]
    return []
