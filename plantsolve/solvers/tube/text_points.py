"""XYZ, CSV and TXT point lists: one point a line, ``x y z`` first (more columns allowed, e.g. colour or intensity).

A line that cannot be read — cut short (fewer columns than the file's other rows), not numbers, a NaN or an
infinite coordinate, stray bytes — is left out and logged with its line number; the file is refused only when no
point is left. Text is read as exporters write it (UTF-8, UTF-16 with its mark, else Windows-1252). Non-numeric
lines before the first point are a header; lines starting with # or % are comments (``//X,Y,Z``, CloudCompare's
header, is one too). Numbers written as a spreadsheet exports them — a decimal comma (``251,5;-112,4;30,6`` or
blank-separated), digit grouping (``2.515,5``, ``2 515,5``, a quoted ``"2,515.5"``) — are read as such by the rule
the nominal reader shares (:mod:`.number_cells`): split at the commas they would be six numbers a row, and a wrong
point. A row written with the file's other decimal mark is left out and named.

A header line with one name per column is read: columns named x, y, z (``X``, ``x_mm``, ``x [m]``, ``point_x``, or
easting, northing, elevation) are the coordinates wherever they stand (an index column first is common), and a unit
they all state is the file's unit, in their names or in a line of units under them (``x,y,z`` then ``mm,mm,mm``); a
column of text beside them (a point's name, ``Point,X,Y,Z`` over ``P12,...``, also under a line of units, in a
``#`` header naming x, y, z, with decimal commas or quoted cells) is left out, said in a warning. Without a header,
a first column that counts the rows (0 or 1, 2, 3, ...) is a row number: x, y, z are the next three columns (said
in a warning). A header that names no x, y and z is a table of something else — a compressor map, an LRA or XYZ-CLR
nominal — and is refused at intake naming its columns, as is a short table of four or five numbers a row (a nominal
without a header): a tube scan is three coordinates per sample."""

from __future__ import annotations

import csv
import math
import re
from collections import Counter
from dataclasses import dataclass, replace
from itertools import islice, product

import numpy as np

from plantsolve.schemas.common import MAX_COORDINATE, Diagnostic
from plantsolve.solvers.base import InputRejected, decode_text, reject
from plantsolve.solvers.length_units import SIZES, comment_unit, two_readings, unit_named
from plantsolve.solvers.tube.number_cells import (
    GROUPED,
    ROWS_LOOKED_AT,
    cell_delimiter,
    commas_split_decimals,
    decimal_mark,
    is_number,
    plain,
    starts_number,
)
from plantsolve.solvers.tube.number_cells import (
    decimals as cell_decimals,
)
from plantsolve.solvers.tube.read_log import ReadLog

_SPLIT = re.compile(r"[,;\s]+")
_BRACKETED = re.compile(r"[\[(][^\])]*[\])]")  # a unit in brackets: ``[mm]``, ``(in)``
_NOT_PLAIN_COMMA = ('"', ".", "'", "\u00a0", "\u202f")  # a row of a decimal-comma file read cell by cell
_UNIT_SUFFIX = re.compile(r"^(?P<name>.*?)(?:[\s_]*[\[(]\s*(?P<u1>[a-zµμ]+)\s*[\])]|_(?P<u2>mm|cm|m|in|ft|um|µm|μm))$",
                          re.IGNORECASE)
_COORDINATE = re.compile(r"^(?:point|pos|position|coord|coordinate)?[_ ]?(?P<axis>[xyz])(?:[_ ]?(?:coord|coordinate))?$")
SURVEY_AXES = {"easting": "x", "east": "x", "northing": "y", "north": "y", "elevation": "z", "elev": "z",
               "height": "z"}  # a surveyor's export names the axes so
# ... or in letters alone (``E N H``, ``E (m) N (m) H (m)``), read so only when no column is x, y or z
SHORT_SURVEY_NAMES = ({"e", "n"}, {"h", "u"})
NOMINAL_NAMES = {"clr", "bend_radius", "radius", "length", "rotation", "angle", "feed", "twist", "bend_angle"}
MIN_SCAN_ROWS = 100  # the solver's minimum (``validation.MIN_POINTS``)


@dataclass
class Columns:
    """Where x, y, z stand in each row, and the unit the header states for them (None: none)."""

    index: tuple[int, int, int] = (0, 1, 2)
    unit: str | None = None
    names: list[str] | None = None
    conflict: str | None = None  # why the header's units cannot be taken (only options.file_units reads the file)
    stated_by: str | None = None  # the comment line that states ``unit``, when no column name does


def _header_names(line: str) -> list[str]:
    """A header line split as its delimiter says (a comma, semicolon or tab, else blanks): ``x [mm]`` is one name,
    also between blanks (``x [m] y [m] z [m]``: split at every blank, its units were columns of their own, the
    header no column header, and the file read in the request's unit) when the bracketed word is a length unit."""
    s = line.strip().lstrip("/#").strip()
    if (delimiter := _header_delimiter(s)) is not None:
        return _split_at(s, delimiter)
    names: list[str] = []
    for word in s.split():
        if names and _BRACKETED.fullmatch(word) and word[1:-1].strip() and \
                (_length_unit(word[1:-1]) or not _axis_name(names[-1])):
            names[-1] = f"{names[-1]} {word}"
        else:
            names.append(word)
    return names


def _length_unit(word: str) -> bool:
    """Whether ``word`` spells a length unit (of two readings too, refused where the header's unit is read): only
    such a bracketed word is a coordinate column's unit. ``x (east)`` and ``z []`` are names and words of their own
    (taken for units, the header's x, y, z stated units that are none and the file was refused)."""
    return bool(unit_named(word.strip(), SIZES) or two_readings(word))


def _axis_name(name: str) -> bool:
    """Whether a blank-separated header's ``name`` names a coordinate (x, easting, E, ...)."""
    n = name.strip().lower()
    return bool(_COORDINATE.match(n)) or n in SURVEY_AXES or n in set.union(*SHORT_SURVEY_NAMES)


def _name_and_unit(name: str) -> tuple[str, str | None]:
    """A column's name (lower case) and the unit it states, in lower case but for a spelling of two readings
    ('Mm'), which keeps its case to be refused where the header's unit is read."""
    m = _UNIT_SUFFIX.match(name.strip())
    if m is None:
        return name.strip().lower(), None
    unit = m.group("u1") or m.group("u2")
    return m.group("name").strip().lower(), unit if unit is None or two_readings(unit) else unit.lower()


def _axes(names: list[str]) -> dict[str, int]:
    """The column of each axis (x, y, z) the column ``names`` (lower case, units left out) name."""
    axes: dict[str, int] = {}
    for i, n in enumerate(names):
        m = _COORDINATE.match(n)
        axis = m.group("axis") if m else SURVEY_AXES.get(n)
        if axis and axis not in axes:
            axes[axis] = i
    if not axes and SHORT_SURVEY_NAMES[0] <= set(names) and SHORT_SURVEY_NAMES[1] & set(names):
        short = {n: i for i, n in reversed(list(enumerate(names)))}  # each name's first column
        axes = {"x": short["e"], "y": short["n"], "z": min(short[n] for n in SHORT_SURVEY_NAMES[1] if n in short)}
    return axes


def _columns(header: str | None, width: int, header_line: int) -> Columns:
    """The coordinate columns of rows ``width`` numbers wide under ``header`` (the last header line before them).
    A header is a column header when it names as many columns as the rows hold, each name starting with a
    letter; refused (a file of another kind) when such a header names no x, y, z, or names a nominal's CLR."""
    names = _header_names(header) if header else []
    if not names or len(names) != width or not all(n[:1].isalpha() for n in names):
        return Columns()
    commented = header.startswith(("//", "#"))  # a comment names columns only when it names x, y, z
    parsed = [_name_and_unit(n) for n in names]
    axes = _axes([n for n, _ in parsed])
    plain = [n for n, _ in parsed]
    nominal = sorted(NOMINAL_NAMES & set(plain))
    if commented and (nominal or len(axes) < 3):
        return Columns()
    if nominal:
        raise reject(f"line {header_line}: the columns are {', '.join(names)}: a nominal table (its "
                     f"{', '.join(nominal)} column), not scan points. Give it as options.nominal_csv (or "
                     "nominal_xyz_clr) with the scan as the file; a scan holds x, y, z per sample")
    if len(axes) < 3:
        raise reject(f"line {header_line}: the file's columns are {', '.join(names)}: "
                     f"{'no' if not axes else 'not all of'} x, y, z. A tube scan holds three coordinates per "
                     "sample (x, y, z columns); is this a file for another kind (a rig or compressor-map table?)")
    index = (axes["x"], axes["y"], axes["z"])
    stated = [parsed[i][1] for i in index]
    last = index.index(max(index))
    if stated[last] is not None and all(u is None for k, u in enumerate(stated) if k != last):
        stated = [stated[last]] * 3  # ``X Y Z [mm]``: a unit after the last coordinate is the three's
    units = set(stated)
    unit = None
    if len(units) > 1:  # x in mm and y in m (or x in m, y and z without one): no one unit is the header's
        return Columns(index, None, names, conflict=(
            f"line {header_line}: its coordinate columns {', '.join(names[i] for i in index)} state different units "
            "(or only some of them one)"))
    if len(units) == 1 and None not in units:
        (u,) = units
        unit = unit_named(u, SIZES)
        if unit is None and (readings := two_readings(u)) is not None:
            raise reject(f"line {header_line}: the coordinate columns state the unit {readings}")
        if unit is None:
            raise reject(f"line {header_line}: the coordinate columns state the unit {u!r}, which is not a length "
                         f"unit read here ({', '.join(SIZES)})")
    return Columns(index, unit, names)


# A comment before the first row that states the coordinates' unit (``# units: in``, ``// Unit = millimetres``), as
# PLY headers' comments do: read as the file's unit (it was ignored, and a scan in inches read as millimetres gave a
# tube 25.4 times too small whose size could still pass for one); a word naming no unit read here refuses the file
# unless options.file_units says the unit, as a column header's does.
_COMMENT = re.compile(r"^(?:#|//|%)\s*(.*)$")


def _with_comment_unit(cols: Columns, lines: list[str]) -> Columns:
    """``cols`` with the unit a comment before the first row states (``length_units.comment_unit``); a conflict
    when it names no unit read here or another than the column header's or another comment's."""
    found = []
    for lineno, line in enumerate(lines, 1):
        s = line.strip()
        if s and s[0] not in "#/%" and starts_number(s):
            break
        comment = _COMMENT.match(s)
        stated = comment_unit(comment.group(1), SIZES) if comment else None
        if stated is None:
            continue
        word, unit = stated
        if unit is None:
            what = two_readings(word) or f"{word!r}, which is no length unit read here"
            return replace(cols, unit=None, conflict=(
                f"line {lineno}: its comment {s!r} states the unit {what} ({', '.join(SIZES)})"))
        found.append((unit, lineno, s))
    if not found or cols.conflict is not None:
        return cols
    units = {u for u, _, _ in found} | ({cols.unit} if cols.unit else set())
    if len(units) > 1:
        said = [f"line {n}: {text!r}" for _, n, text in found[:3]]
        if cols.unit:
            said.append(f"the columns {', '.join(cols.names or [])}")
        return replace(cols, unit=None, conflict="it states different units (" + "; ".join(said) + ")")
    if cols.unit:
        return cols
    unit, lineno, text = found[0]
    return replace(cols, unit=unit, stated_by=f"its comment on line {lineno}: {text!r}")


HEADER_LINES_LOOKED_AT = 100  # a header stands within the file's first lines


def _header_delimiter(line: str) -> str | None:
    """What separates a header's names (:func:`_header_names`): a comma, semicolon or tab, else blanks (None)."""
    return next((d for d in (",", ";", "\t") if d in line), None)


def _split_at(line: str, delimiter: str | None) -> list[str]:
    """A line's cells between ``delimiter`` (blanks: None), quoted cells read as a spreadsheet writes them, and
    without the empty cells a trailing delimiter leaves (``Point,X,Y,Z,``: no column of its own)."""
    if delimiter is None:
        return line.split()
    cells = [c.strip() for c in (next(csv.reader([line], delimiter=delimiter)) if '"' in line
                                 else line.split(delimiter))]
    while cells and not cells[-1]:
        cells.pop()
    return cells


def _joined(cells: list[str], delimiter: str | None) -> str:
    """``cells`` written again between ``delimiter``, a cell holding the delimiter quoted (``"2,515.5"``)."""
    if delimiter is None:
        return " ".join(cells)
    return delimiter.join(f'"{c}"' if delimiter in c else c for c in cells)


def _is_comment(line: str) -> bool:
    """Whether a (stripped, not blank) line before the rows is a comment: ``%``, a single ``/``, or ``#`` unless it
    names x, y and z (``# name x y z``, a header as :func:`_columns` reads one)."""
    if line[0] == "%" or (line[0] == "/" and not line.startswith("//")):
        return True
    return line[0] == "#" and len(_axes([_name_and_unit(n)[0] for n in _header_names(line)])) < 3


def _without_text_columns(lines: list[str], log: ReadLog) -> tuple[list[str], str | None]:
    """The lines without the cells of columns that hold text (a point's name: ``Point,X,Y,Z`` over ``P12,...``,
    ``name x y z``) when a header names x, y and z and the first row under it holds numbers in those columns, with
    a warning naming the columns left out. A line of text under a header was taken for more header, and the file
    was refused as holding no readable rows. Other files are returned as they are, with the header naming x, y, z
    and the first line under it that matches none of this (said when the file is refused for want of rows)."""
    header_at = None
    unmatched = None
    looked_at = 0
    for at, line in enumerate(lines):
        s = line.strip()
        if not s or _is_comment(s):
            continue
        looked_at += 1
        if looked_at > HEADER_LINES_LOOKED_AT or all(is_number(f) for f in _SPLIT.split(s.lstrip("/")) if f):
            return lines, unmatched  # the rows start, or no header was found: no text column
        if header_at is not None:
            if _with_units_line(lines[header_at], s):
                continue  # ``Point,X,Y,Z`` over ``,mm,mm,mm``: the rows start under the units
            text = _text_columns(lines[header_at], s)
            if text:
                return _cells_left_out(lines, header_at, at, text, log), None
            names = _header_names(lines[header_at])
            if unmatched is None and len(_axes([_name_and_unit(n)[0] for n in names])) == 3:
                cells = _split_at(s, _header_delimiter(lines[header_at].strip().lstrip("/#").strip()))
                unmatched = (f"the header on line {header_at + 1} names {len(names)} columns ({', '.join(names)}), "
                             f"line {at + 1} holds {len(cells)} cells ({s[:60]!r}) that do not read as a row of "
                             "them (numbers under x, y, z)")
        header_at = at
    return lines, unmatched


def _text_columns(header: str, row: str) -> list[int]:
    """The columns of ``row`` that hold text where ``header`` names x, y, z and ``row`` holds numbers in those
    (none when it does not)."""
    names = _header_names(header)
    delimiter = _header_delimiter(header.strip().lstrip("/#").strip())
    cells = _split_at(row, delimiter)
    axes = _axes([_name_and_unit(n)[0] for n in names])
    if len(cells) != len(names) or len(axes) < 3 or not all(is_number(cells[i], delimiter is None) for i in axes.values()):
        return []
    return [k for k, c in enumerate(cells) if k not in axes.values() and c and not is_number(c, delimiter is None)]


def _cells_left_out(lines: list[str], header_at: int, first_row: int, text: list[int], log: ReadLog) -> list[str]:
    """``lines`` with the cells of the columns ``text`` left out of the header (at ``header_at``) and of every row
    as wide as it, and the warning that says so."""
    header = lines[header_at].strip()
    prefix = header[:len(header) - len(header.lstrip("/#"))]
    names = _header_names(header)
    delimiter = _header_delimiter(header.lstrip("/#").strip())
    joint = delimiter or " "
    out = list(lines)
    out[header_at] = prefix + joint.join(n for k, n in enumerate(names) if k not in text)
    for at in range(header_at + 1, len(lines)):
        cells = _split_at(lines[at].strip(), delimiter)
        if len(cells) == len(names):
            out[at] = _joined([c for k, c in enumerate(cells) if k not in text], delimiter)
    left_out = [names[k] for k in text]
    example = _split_at(lines[first_row].strip(), delimiter)[text[0]]
    log.warn(Diagnostic(code="text_column_skipped", message=(
        f"the column{'s' if len(text) > 1 else ''} {', '.join(repr(n) for n in left_out)} of the header on line "
        f"{header_at + 1} hold{'' if len(text) > 1 else 's'} text (line {first_row + 1}: {example!r}), not "
        "coordinates: left out, x, y, z read from the columns the header names so."),
        details={"columns": left_out, "header_line": header_at + 1}))
    return out


def _first_row(lines: list[str]) -> tuple[str | None, int, int]:
    """The last header line before the first row of numbers, its line number, and that row's width."""
    header, header_line = None, 0
    for lineno, line in enumerate(lines, 1):
        s = line.strip()
        if not s or _is_comment(s):
            continue
        fields = [f for f in _SPLIT.split(s.lstrip("/#")) if f]
        try:
            [float(f) for f in fields]
        except ValueError:
            named = _with_units_line(header, s) if header else None
            header, header_line = (named, header_line) if named else (s, lineno)
            continue
        return header, header_line, len(fields)
    return header, header_line, 0


def _with_units_line(names_line: str, units_line: str) -> str | None:
    """The header of a names line followed by a line of their units (``x,y,z`` over ``mm,mm,mm``, as instruments
    and spreadsheets export two header lines), None when ``units_line`` is no such line."""
    names, units = _header_names(names_line), _header_names(units_line)
    if len(names) != len(units):
        return None
    units = [u.strip("[]()").strip() for u in units]  # case kept: 'Mm' is refused where the header's unit is read
    named_at_all = [unit_named(u, SIZES) or two_readings(u) for u in units]
    if not any(named_at_all) or any(u and u != "-" and not n for u, n in zip(units, named_at_all)):
        return None
    for n, u in zip(names, units):
        stated = _name_and_unit(n)[1]
        said = unit_named(stated, SIZES) if stated else None
        if said and unit_named(u, SIZES) and said != unit_named(u, SIZES):
            raise reject(f"the column {n!r} states the unit {stated!r} in its name and {u!r} in the line of units under "
                         "it: say which one the numbers are in")
    named = [f"{n} [{u}]" if k and _name_and_unit(n)[1] is None else n for n, u, k in zip(names, units, named_at_all)]
    return ("//" if names_line.strip().startswith("//") else "") + ",".join(named)


_WHOLE = re.compile(r"^[-+]?\d+$")


def _counts_rows(lines: list[str]) -> bool:
    """Whether the first column of the rows of numbers counts them (0, 1, 2, ... or 1, 2, 3, ...): a row number
    written before x, y, z by a file without a header. A scan's x is hardly a run of consecutive integers; where it
    is one (points sampled a unit apart along x) and the fourth column is a constant attribute (an intensity), the
    columns after the count cannot be x, y, z: no point of a tube's surface shares one coordinate."""
    rows = []
    for line in lines:
        s = line.strip()
        if not s or not starts_number(s):
            continue
        try:
            rows.append([float(f) for f in _SPLIT.split(s) if f][:4])
        except ValueError:
            return False
        if len(rows) == ROWS_LOOKED_AT:
            break
    if len(rows) < 10 or any(len(r) < 4 for r in rows):
        return False
    first = np.array([r[0] for r in rows])
    fourth = np.array([r[3] for r in rows])
    return first[0] in (0.0, 1.0) and bool(np.all(np.diff(first) == 1.0)) and bool(np.ptp(fourth) > 0)


_DECIMAL = re.compile(r"^[-+]?(?:\d+\.\d*|\.\d+)(?:[eE][-+]?\d+)?$")


def _whole_then_decimals(lines: list[str]) -> bool:
    """Whether the first column of the rows of numbers is written as whole numbers (no decimal mark) and the next
    three with decimals, in every row looked at: an attribute written before x, y, z by a file without a header (an
    intensity, a class, a point number that does not count the rows). A writer prints a scan's three coordinates
    alike; read as x, the attribute made the tube of an intensity, x and y (a straight of 4,095 mm with status
    ok). Not where the first column runs up or is held over runs of rows (x sampled a unit apart, a profile
    scanner's steps, up or down), where the fourth is constant (an attribute after x, y, z: no point of a tube's
    surface shares a coordinate with its neighbours), where the next three are not written alike (the same
    number of decimals, most often): then the fourth is an attribute after y and z, nor where the next three are
    flat (:data:`FLAT`) and the first three not (a reflectance of 0 to 1 after y and z, read as z, made a tube of
    no thickness; a long straight tube is flat either way)."""
    rows = []
    for line in lines:
        s = line.strip()
        if not s or not starts_number(s):
            continue
        rows.append([f for f in _SPLIT.split(s) if f])
        if len(rows) == ROWS_LOOKED_AT:
            break
    if len(rows) < 10 or any(len(r) < 4 for r in rows):
        return False
    if not all(_WHOLE.match(r[0]) and all(_DECIMAL.match(c) for c in r[1:4]) for r in rows):
        return False
    first = np.array([float(r[0]) for r in rows])
    fourth = np.array([float(r[3]) for r in rows])
    held = float(np.mean(np.diff(first) == 0))
    written = {Counter(cell_decimals(r[k]) for r in rows).most_common(1)[0][0] for k in (1, 2, 3)}
    values = np.array([[float(c) for c in r[:4]] for r in rows])
    return (bool(np.any(np.diff(first) < 0)) and held < 0.5 and bool(np.ptp(fourth) > 0) and len(written) == 1
            and not (_flat(values[:, 1:4]) and not _flat(values[:, :3])))


# A scan whose smallest extent is less than this share of its largest is flat: no tube of a length under a hundred
# diameters (a reflectance of 0 to 1 beside coordinates of a hundred millimetres is)
FLAT = 0.01


def _flat(xyz: np.ndarray) -> bool:
    extent = np.ptp(xyz, axis=0)
    return bool(extent.min() < FLAT * extent.max())


def _number_rows(lines: list[str]) -> list[str]:
    """The first rows that start like numbers and write a decimal mark or a separator (rows of integers say
    neither), else the first rows that start like numbers."""
    def rows():
        return (s for s in (line.strip() for line in lines) if starts_number(s))

    marked = list(islice((r for r in rows() if "," in r or "." in r), ROWS_LOOKED_AT))
    return marked or list(islice(rows(), ROWS_LOOKED_AT))


def _cells(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    cells = next(csv.reader([line], delimiter=delimiter)) if '"' in line else line.split(delimiter)
    return [c for c in (c.strip() for c in cells) if c]  # Excel's trailing empty columns


def _plain_rows(lines: list[str]) -> tuple[list[str], dict[int, str]]:
    """The lines with each row of numbers rewritten as plain numbers between blanks when the file writes them as
    a spreadsheet does (a decimal comma, digit grouping, quoted cells: :mod:`.number_cells`), and the rows that
    cannot be read so (a cell of the other decimal mark), by line number. Other files are returned as they are."""
    sample = _number_rows(lines)
    delimiter = cell_delimiter(sample)
    rows = [_cells(r, delimiter) for r in sample]
    mark = decimal_mark(rows, delimiter)
    blank = delimiter is None
    if mark == "." and not any('"' in r for r in sample) and \
            not any(GROUPED[mark, blank].match(c) for row in rows for c in row):
        return lines, {}
    out, unreadable = [], {}
    written = "commas" if mark == "," else "points"
    not_plain = _NOT_PLAIN_COMMA + (() if blank else (" ",))  # a blank between cells or grouping digits
    for lineno, line in enumerate(lines, 1):
        s = line.strip()
        if not starts_number(s):
            out.append(line)
            continue
        if mark == "," and not any(c in s for c in not_plain):  # most rows: only commas to replace
            out.append(s.replace(",", "."))
            continue
        try:
            out.append(" ".join(plain(c, mark, blank) for c in _cells(s, delimiter)))
        except ValueError:
            unreadable[lineno] = f"a number of the other decimal mark (the file writes decimal {written})"
            out.append("")
    return out, unreadable


def _refuse_split_decimals(lines: list[str], header: str | None, header_line: int) -> None:
    """A comma-separated file whose numbers write decimal commas is refused naming its first row: each number is
    two cells there, and no rule tells which commas separate cells (read cell by cell, every point was wrong)."""
    sample = _number_rows(lines)
    if not sample or cell_delimiter(sample) != ",":
        return
    names = _header_names(header) if header else []
    named = len(names) if names and all(n[:1].isalpha() for n in names) else 0
    if not commas_split_decimals([_cells(r, ",") for r in sample], named):
        return
    first = next(n for n, line in enumerate(lines, 1) if line.strip() == sample[0])
    under = f" under the {named} columns of line {header_line}" if named else ""
    raise reject(f"line {first}: {len(_cells(sample[0], ','))} comma-separated cells{under} ({sample[0][:60]}): "
                 "numbers written with decimal commas in a file whose cells commas also separate? They cannot be told "
                 "apart: save the file with ';' between the cells (or with decimal points)", ("file", "line", first))


def read_text_points(content: bytes, log: ReadLog) -> tuple[np.ndarray, Columns]:
    # UTF-8, UTF-16 with its mark or Windows-1252: a line of stray bytes is one unreadable line, not the file's end
    try:
        text = decode_text(content, "point list")
    except InputRejected as e:
        raise reject(f"the file is not text in UTF-8, UTF-16 or Windows-1252: {e.errors[0].msg}") from None
    named_lines, unmatched = _without_text_columns(text.splitlines(), log)
    lines, unreadable = _plain_rows(named_lines)
    counts = _pts_counts(lines)
    for lineno in counts:
        lines[lineno - 1] = ""
    header, header_line, width = _first_row(lines)
    _refuse_split_decimals(lines, header, header_line)
    cols = _with_comment_unit(_columns(header, width, header_line), lines)
    if cols.names is None and width >= 4 and _counts_rows(lines):
        cols = replace(cols, index=(1, 2, 3))  # the unit a comment states (or its conflict) kept
        log.warn(Diagnostic(code="row_numbers_skipped", message=(
            f"the rows of {width} numbers have no header and their first column counts them (0 or 1, 2, 3, ...): "
            "it was read as row numbers, x, y, z from the next three columns. Add a header (e.g. 'n x y z') if "
            "the columns are otherwise."), details={"columns": width, "x_y_z_columns": [2, 3, 4]}))
    elif cols.names is None and width >= 4 and _whole_then_decimals(lines):
        cols = replace(cols, index=(1, 2, 3))
        log.warn(Diagnostic(code="first_column_skipped", message=(
            f"the rows of {width} numbers have no header; their first column is written as whole numbers and the "
            "next three with decimals, as a scanner writes an intensity, a class or a point number before x, y, z: "
            "it was left out, x, y, z read from the next three columns. Add a header (e.g. 'i x y z') if the "
            "columns are otherwise."), details={"columns": width, "x_y_z_columns": [2, 3, 4]}))
    need = max(cols.index) + 1
    ends_mid_line = bool(text) and not text.endswith(("\n", "\r"))
    rows: list[tuple[int, list[float], int]] = []  # line number, x y z, number of columns
    texts: list[str] = []  # each row's line
    decimals: list[int] = []  # of each row's last number
    bad: list[tuple[int, str]] = []
    for lineno, line in enumerate(lines, 1):
        if lineno in unreadable:
            bad.append((lineno, unreadable[lineno]))
            continue
        s = line.strip()
        if not s or s[0] in "#/%":
            continue
        fields = [f for f in _SPLIT.split(s) if f]
        try:
            vals = [float(f) for f in fields[:need]]
        except ValueError:
            if rows or bad:  # only lines before the first point can be a header
                bad.append((lineno, "not numbers"))
            continue
        vals = [vals[i] for i in cols.index] if len(vals) >= need else vals
        if len(vals) < 3:
            bad.append((lineno, "fewer than 3 coordinates"))
        elif not all(math.isfinite(v) for v in vals):
            bad.append((lineno, "non-finite coordinate"))
        elif not all(abs(v) <= MAX_COORDINATE for v in vals):  # a float the writer never meant
            bad.append((lineno, f"coordinate beyond {MAX_COORDINATE:g}"))
        else:
            rows.append((lineno, vals, len(fields)))
            texts.append(s)
            decimals.append(cell_decimals(fields[-1]))
    # a row with fewer columns than the file's other rows was cut (its last number may be cut too)
    usual = Counter(n for _, _, n in rows).most_common(1)[0][0] if rows else 3
    short = [(ln, f"cut short ({n} of {usual} columns)") for ln, _, n in rows if n < usual]
    if ends_mid_line and rows and rows[-1][2] >= usual and rows[-1][0] == len(lines) and _cut_number(decimals):
        short.append((rows[-1][0], "cut short (its last number has fewer decimals than the other rows')"))
        rows[-1] = (rows[-1][0], rows[-1][1], -1)
    if cols.names is None and len(rows) == 3 and not bad and usual >= MIN_SCAN_ROWS:
        transposed = _rows_as_columns([lines[ln - 1] for ln, _, _ in rows], log)
        if transposed is not None:
            return transposed, cols
    whole = [n >= usual for _, _, n in rows]
    kept = [v for (_, v, _), w in zip(rows, whole) if w]
    if usual > 3:
        kept = _without_copied_lines(kept, [t for t, w in zip(texts, whole) if w], cols, log)
    for ln, reason in sorted(bad + short):
        log.skip(ln, reason)
    last_point_line = max([ln for ln, _, _ in rows] + [ln for ln, _ in bad], default=0)
    if ends_mid_line and any(ln == last_point_line for ln, _ in bad + short):
        log.truncate(f"the file ends mid-line (line {last_point_line})", line=last_point_line)
    _check_pts_counts(counts, [ln for ln, _, _ in rows] + [ln for ln, _ in bad], log)
    if not kept:
        raise reject(f"no readable 'x y z' rows found{log.summary()}" + (f": {unmatched}" if unmatched else ""))
    if len(kept) < MIN_SCAN_ROWS and usual in (4, 5):
        raise reject(f"the file holds {len(kept)} rows of {usual} numbers: a nominal table (LRA or XYZ-CLR), not a "
                     f"scan, which needs at least {MIN_SCAN_ROWS} x, y, z samples. Give a nominal as "
                     "options.nominal_csv with the scan as the file")
    return np.array(kept, dtype=np.float64), cols


_COUNT = re.compile(r"^\d+$")


# A file's columns beside x, y, z (intensity, colour) that take at least this many values tell samples at one printed
# position apart: two rows equal in every column are then one sample written twice, in whatever order
INFORMATIVE_VALUES = 64
# ... and left out when they are at least this share of the rows (a few coincidences of every column are harmless)
COPIED_SHARE = 0.01
# ... and when two rows at one printed position agree in every other column at least this many times as often as
# two rows at neighbouring positions do. The neighbours are the control: intensity drifts along a surface (angle of
# incidence, range), so rows close together agree more often than any two of the file, and a dense scan printed to
# 1 mm (50,000 samples, intensities of sd 8, constant colour) repeats 3,773 earlier rows in every column: 1.0 times
# its neighbours' rate (1.3 with the intensity drifting ±160 over the tube; 8.5 times what the whole file's value
# shares give), where half of it pasted again gives 3.4 (4.8 drifting), sd 30 gives 10.
SAME_PLACE_FACTOR = 2.0
# fewer pairs of rows at neighbouring positions give no rate (a print to 0.001 mm): the file's value shares do
NEAR_PAIRS_MIN = 1000


def _without_copied_lines(kept: list[list[float]], texts: list[str], cols: Columns, log: ReadLog) -> list[list[float]]:
    """The rows (``kept``, their lines ``texts``) without those that repeat an earlier line, when the columns beside
    x, y, z take :data:`INFORMATIVE_VALUES` values or more, the copies are :data:`COPIED_SHARE` of the rows or more
    and rows at one position agree :data:`SAME_PLACE_FACTOR` times as often as chance (:func:`agreement_over_chance`),
    with a warning. Half of a file pasted again in another order, printed to 1 mm, holds no more coincident positions
    than a denser scan would (every cell of a dense print holds several samples): the positions alone cannot tell
    it, but a sample's intensity and colour differ from its neighbour's more often than a copy's."""
    seen: set[str] = set()
    copy = []
    for text in texts:
        copy.append(text in seen)
        seen.add(text)
    copies = sum(copy)
    if copies < COPIED_SHARE * len(kept):
        return kept
    others = {tuple(f for k, f in enumerate([f for f in _SPLIT.split(t) if f]) if k not in cols.index) for t in seen}
    if len(others) < INFORMATIVE_VALUES:  # intensity and colour of one value (a writer's constant): no telling
        return kept
    if agreement_over_chance(kept, texts, cols) < SAME_PLACE_FACTOR:
        return kept
    width = len(next(iter(others)))
    log.warn(Diagnostic(code="duplicate_points", message=(
        f"{copies:,} of the file's {len(kept):,} rows repeat an earlier row in every column (x, y, z and the "
        f"{width} beside them): a file or scan pasted twice; each was read once. Counted twice, they would have "
        "made every sigma of the result too small."),
        details={"repeated": copies, "samples": len(kept), "kept": len(kept) - copies}))
    return [xyz for xyz, c in zip(kept, copy) if not c]


def agreement_over_chance(kept: list[list[float]], texts: list[str], cols: Columns) -> float:
    """How many times as often two rows at one printed position agree in every column beside x, y, z as chance
    has them agree: chance is the rate of two rows at neighbouring positions (one print step apart on each axis:
    the 26 around), or, with fewer than :data:`NEAR_PAIRS_MIN` such pairs, Σ p_v², p_v the share of the rows whose
    other columns read v."""
    # each row's other columns numbered (by their tuple's hash: two tuples share one with a chance of 2^-64)
    _, value = np.unique([hash(tuple(f for k, f in enumerate([f for f in _SPLIT.split(t) if f]) if k not in cols.index))
                          for t in texts], return_inverse=True)
    value = value.ravel().astype(np.int64)
    values = int(value.max()) + 1
    places, place = np.unique(np.asarray(kept), axis=0, return_inverse=True)
    place = place.ravel()
    n_place = np.bincount(place).astype(np.float64)
    pairs = float((n_place * (n_place - 1)).sum() / 2)
    place_value, n_place_value = np.unique(place * values + value, return_counts=True)
    agree = float((n_place_value * (n_place_value - 1.0)).sum() / 2)
    if pairs == 0:
        return 0.0
    near = _near_rate(places, n_place, place_value // values, place_value % values, n_place_value.astype(np.float64))
    if near is None:
        p = np.bincount(value) / len(value)
        near = float(p @ p)
    return agree / pairs / near if near > 0 else math.inf


def _near_rate(places: np.ndarray, n_place: np.ndarray, pv_place: np.ndarray, pv_value: np.ndarray,
               n_pv: np.ndarray) -> float | None:
    """The share of the pairs of rows at neighbouring printed positions that agree beside x, y, z (None: fewer than
    :data:`NEAR_PAIRS_MIN` pairs, or a grid too fine to number)."""
    steps = []
    for k in range(3):
        levels = np.unique(places[:, k])
        steps.append(float(np.diff(levels).min()) if len(levels) > 1 else 1.0)
    grid = np.rint((places - places.min(0)) / steps) + 1
    dims = grid.max(0) + 2
    values = int(pv_value.max()) + 1
    if float(np.prod(dims)) * values >= 2.0 ** 62:
        return None
    dims = dims.astype(np.int64)
    key = ((grid[:, 0].astype(np.int64) * dims[1] + grid[:, 1].astype(np.int64)) * dims[2]
           + grid[:, 2].astype(np.int64))
    order = np.argsort(key)
    sorted_key, sorted_n = key[order], n_place[order]
    pv_key = key[pv_place] * values + pv_value
    pv_order = np.argsort(pv_key)
    pv_key, n_pv = pv_key[pv_order], n_pv[pv_order]
    pairs = agree = 0.0
    for d in product((-1, 0, 1), repeat=3):
        if d <= (0, 0, 0):  # each neighbouring pair once
            continue
        shift = (d[0] * int(dims[1]) + d[1]) * int(dims[2]) + d[2]
        pairs += _paired(sorted_key, sorted_n, shift)
        agree += _paired(pv_key, n_pv, shift * values)
    return agree / pairs if pairs >= NEAR_PAIRS_MIN else None


def _paired(keys: np.ndarray, counts: np.ndarray, shift: int) -> float:
    """Σ counts[k] · counts[k + shift] over the sorted ``keys``."""
    j = np.minimum(np.searchsorted(keys, keys + shift), len(keys) - 1)
    hit = keys[j] == keys + shift
    return float(counts[hit] @ counts[j[hit]])


def _rows_as_columns(three: list[str], log: ReadLog) -> np.ndarray | None:
    """x, y, z written as three rows of N numbers (a table saved transposed, MATLAB's column-major habit), read as
    N points with a warning; None when the rows are not numbers of one length. Read row by row they were three
    points, refused as too few without naming the mix-up."""
    try:
        values = [[float(f) for f in _SPLIT.split(line.strip()) if f] for line in three]
    except ValueError:
        return None
    if len({len(v) for v in values}) != 1:
        return None
    log.warn(Diagnostic(code="text_transposed", message=(
        f"the file holds three rows of {len(values[0])} numbers and no header: read as {len(values[0])} points "
        "(x, y, z in its rows). Write one point a line to say so."), details={"rows": 3, "columns": len(values[0])}))
    return np.array(values, dtype=np.float64).T


def _pts_counts(lines: list[str]) -> dict[int, int]:
    """The point counts of a Leica PTS file renamed .txt or .xyz (line number -> count): its first line counts the
    rows of x, y, z (intensity, r, g, b) under it, and a file of several scans writes a count above each. Read as
    rows, each count was a record 'with fewer than 3 coordinates' and the counts were never compared with the rows.
    Only a file whose first line is such a count has them."""
    def next_row(i: int) -> list[str]:
        following = next((t.strip() for t in lines[i + 1:] if t.strip()), "")
        return [f for f in _SPLIT.split(following) if f]

    first = next((i for i, t in enumerate(lines) if t.strip()), None)
    if first is None or not _COUNT.match(lines[first].strip()) or len(next_row(first)) < 3:
        return {}
    return {i + 1: int(t.strip()) for i, t in enumerate(lines) if _COUNT.match(t.strip()) and len(next_row(i)) >= 3}


def _check_pts_counts(counts: dict[int, int], row_lines: list[int], log: ReadLog) -> None:
    """Each PTS count against the rows under it (up to the next count): a last scan holding fewer rows than its
    count was cut; any other disagreement is said too (a count edited by hand, or scans joined)."""
    starts = sorted(counts)
    for k, start in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else math.inf
        held = sum(start < ln < end for ln in row_lines)
        declared = counts[start]
        if held == declared:
            continue
        if held < declared and end == math.inf:
            log.truncate(f"the point count on line {start} says {declared} rows follow, the file holds {held} (the "
                         "file was cut?); those were read.", declared=declared, read=held, line=start)
        else:
            log.warn(Diagnostic(code="point_count_disagrees", message=(
                f"the point count on line {start} says {declared} rows follow, {held} do before "
                f"{'the next count' if end != math.inf else 'the end of the file'}: every row was read. Check "
                "that no scan was cut or joined to another."),
                details={"line": start, "declared": declared, "read": held}))


def _cut_number(decimals: list[int]) -> bool:
    """Whether the last row's last number was cut: a file written with a fixed number of decimals (nine rows in
    ten alike) whose last row has fewer. Only asked of a file that ends without a newline."""
    if len(decimals) < 10:
        return False
    usual, n = Counter(decimals[:-1]).most_common(1)[0]
    return n >= 0.9 * (len(decimals) - 1) and decimals[-1] < usual
