"""Parsing uploaded measurement files (CSV table, pyCycle/NPSS map, or JSON request) into a PerfmapRequest.

CSV rules (as rig software and Excel write them):

- encoding: UTF-8 with or without BOM, UTF-16 with BOM (Excel "Unicode text"), otherwise
  Windows-1252; binary files (NUL bytes, a zip/xlsx workbook) are rejected;
- line ends LF, CRLF or CR; blank lines, lines of separators only (",,,,") and lines whose
  first non-blank character is ``#`` are skipped (also before the header);
- separator: the one of an Excel ``sep=;`` first line, else tab if the header line holds
  one, else ``;`` if it holds one, else ``,``;
- numbers: one convention per column, read from its cells (:mod:`~plantsolve.solvers.perfmap.numbers`): a decimal
  point with thousands commas (``1,104.338``; unquoted in a comma-separated file its groups are joined back when
  the row then has the header's width) or a decimal comma with thousands dots (``0,85``, ``1.234,5``); a column
  whose cells read both ways with nothing in the file to decide, or that mixes both, is refused naming its lines;
  a row with more cells than the header is not read (its line named);
- cells that state their unit (``85.85%``, ``12.3 kg/s``; an .xlsx cell's number format says so too) are reconciled
  with their column's unit (:mod:`~plantsolve.solvers.perfmap.cell_units`) or refused naming the column;
- header: the first remaining line. A column's name is matched case-insensitively after
  stripping unit suffixes in brackets or parentheses (``Flow (m3/s)``, ``Theta [deg]``) and
  folding ``_``/``-``/blanks; accepted names per role are in :data:`HEADER_ALIASES` (rig and
  cycle-code names: ``Nc``, ``N/sqrt(theta)``, corrected speed; ``Wc``, corrected mass flow;
  ``PR``, pressure ratio; ``eff``, isentropic/polytropic efficiency; IGV, VGV, alpha,
  diffuser; ``R-line``/beta, recognised and not needed). The ``columns`` option maps any
  header to a role. A table needs flow, pressure, efficiency and one or two setting
  parameters: one is given as phi (theta = 0), two as (theta, phi) in the order of
  :data:`SETTING_ROLES`. An efficiency column whose unit is ``%`` (``Efficiency [%]``) is
  divided by 100, unless its values are all fractions already (within 1.5: read as they are, with a warning); a
  ``[-]`` efficiency holding 1.5..100 is per cent (warned); efficiencies above 1 without any unit are rejected
  (percent is not guessed). Other columns are reported in the result, not fatal;
- a file that is no rig table but another kind's (a point cloud, a bending table, an IDF …) is refused naming
  what it holds; a last row without a line ending that is short or cut inside its last number (fewer decimals
  than its column) is not read, with a ``truncated_file`` warning;
- rows: any order; rows with equal (theta, phi) form one setting (in order of first
  appearance). Exact duplicate rows are merged with a warning; the same flow twice with
  different values is rejected (flow must increase along a characteristic after sorting).

An ``.xlsx`` upload (Excel) is read sheet by sheet into rows of cell texts and then follows the same rules
(see :mod:`plantsolve.solvers.perfmap.workbook`): ``options.sheet`` names the sheet, else the first sheet
with a recognisable header is read. Rows of titles above the header are skipped (in CSV too), and a row
of units under the header (``[kg/s]``, ``bar``, ``%``) gives the columns their units.

Units (read with pint, :mod:`plantsolve.solvers.perfmap.units`) may also follow a comma (``Flow, kg/s``);
flow, pressure and efficiency units are checked against the quantity (``Flow [kg]`` is refused naming the
column) and stated in the request's ``units``; values are not converted (an efficiency in % or ‰ is made
a fraction).

A ``.py`` upload is a pyCycle/NPSS ``MapData`` map (see :func:`_parse_map_data`); its text is
read, never run.

Every rejection is an :class:`InputRejected` whose loc starts with ``"file"``: ``("file",)``
for the file as a whole, ``("file", "header")`` for the header, ``("file", "row", n,
field)`` for a value, where ``n`` is the 1-based line number in the file (what an editor or
Excel shows).
"""

from __future__ import annotations

import ast
import csv
import io
import math
import re
import zipfile
import zlib
from typing import Any, Callable

import numpy as np

from plantsolve.schemas.common import MAX_MEASURED, Diagnostic
from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import FieldError, InputRejected, StoredInput, decode_text, json_object, reject, validated
from plantsolve.solvers.cut_number import Written, short_number, written
from plantsolve.solvers.length_units import spellings
from plantsolve.solvers.perfmap.cell_units import reconcile
from plantsolve.solvers.perfmap.gasturb_map import MAX_DROPPED_NAMED, MAX_RELATIVE_SPEED
from plantsolve.solvers.perfmap.gasturb_map import request_body as gasturb_request_body
from plantsolve.solvers.other_kinds import refuse_other_kind
from plantsolve.solvers.perfmap.numbers import COMMA, POINT, decimals, number, survey
from plantsolve.solvers.perfmap.units import (
    AmbiguousUnit,
    StandardVolume,
    UnitError,
    check_quantity,
    fraction_factor,
    is_ratio_unit,
    parse_speed_unit,
    parse_unit,
    revolutions_per_minute,
)
from plantsolve.solvers.perfmap.validation import FRACTIONS, mixed_efficiency_strays, placed
from plantsolve.solvers.perfmap.workbook import read_workbook
from plantsolve.solvers.skipped_input import ends_mid_line, line_list, skipped_lines, truncated_file
from plantsolve.solvers.upload_form import Form, FormRules, form_beside, merged, read_form

UPLOAD_EXTENSIONS = (".csv", ".xlsx", ".json", ".py", ".map")
MEASURED = ("flow", "pressure", "efficiency")
# Names rig software and cycle codes give their columns (matched after units and separators are
# stripped, case-insensitively). Setting parameters have roles of their own; the solver takes the
# paper's two (theta, phi): a table with one setting parameter gives it as phi (theta = 0), two
# give (first, second) in the order of SETTING_ROLES.
HEADER_ALIASES = {
    "theta": ("theta", "θ"),
    "phi": ("phi", "φ", "ϕ"),
    "igv": ("igv", "igv angle", "igv setting", "inlet guide vane", "inlet guide vanes", "igv position"),
    "vgv": ("vgv", "vgv angle", "variable guide vane", "stator angle", "vsv"),
    "alpha": ("alpha", "α", "alphamap", "alpha map"),
    "speed": ("speed", "corrected speed", "nc", "n c", "nc map", "ncmap", "n/√θ", "n/sqrt(theta)", "n/sqrt theta",
              "n/sqrttheta", "n/√t", "n/sqrt(t)", "n/sqrt", "n/√", "relative speed", "rel speed", "speed line", "rpm", "n",
              "shaft speed", "rotational speed", "corrected rotational speed", "nmech", "pcn", "% speed",
              "percent speed"),
    "diffuser": ("diffuser", "diffuser angle", "diffuser setting", "diffuser vane", "diffuser position"),
    "flow": ("flow", "flow rate", "flowrate", "mass flow", "massflow", "mass flow rate",
             "volume flow", "volume flow rate", "corrected flow", "corrected mass flow",
             "corrected mass flow rate", "wc", "w c", "wcmap", "wc map", "w corr", "wcorr", "w", "m dot",
             "mdot", "corrected airflow", "airflow"),
    "pressure": ("pressure", "pressure ratio", "pressure rise", "total pressure ratio", "total pressure rise",
                 "total to total pressure ratio", "pr", "prmap", "pr map", "pi", "π", "p2/p1", "pt2/pt1",
                 "head", "delta p", "dp"),
    "efficiency": ("efficiency", "eta", "η", "eff", "effmap", "eff map", "isentropic efficiency",
                   "polytropic efficiency", "adiabatic efficiency", "eta is", "eta isentropic",
                   "eta polytropic", "efficiency isentropic", "total to total efficiency"),
    "rline": ("r line", "rline", "rlinemap", "r line map", "beta", "β", "beta line"),
}
SETTING_ROLES = ("theta", "igv", "vgv", "alpha", "phi", "speed", "diffuser")
ROLES = tuple(HEADER_ALIASES) + ("ignore",)
_ALIAS = {a: field for field, names in HEADER_ALIASES.items() for a in names}
# A unit in trailing brackets; a pressure's absolute or gauge mark may nest in them ('pressure [kPa(a)]').
_PRESSURE_MARK = re.compile(r"\s*(?:a|abs|g|gauge)\s*", re.IGNORECASE)  # the mark of 'kPa(a)', no unit alone
_UNIT_SUFFIX = re.compile(r"\s*[\[(]([^\[\]()]*(?:\(\s*(?:a|abs|g|gauge)\s*\))?)[\])]\s*$", re.IGNORECASE)
_MAX_ROW_ERRORS = 20
_HEADER_SEARCH_ROWS = 30
# Pressure names that are ratios: such a column without a unit is dimensionless.
_RATIO_NAMES = {"pressure ratio", "total pressure ratio", "total to total pressure ratio", "pr", "prmap", "pr map", "pi",
                "π", "p2/p1", "pt2/pt1"}


# What an upload of each text extension must be, as a refusal of binary content names it.
_TEXT_FORMATS = {".csv": "CSV text file", ".json": "JSON request (a text file)",
                 ".py": "pyCycle/NPSS map (a Python text file)"}


def _decode(content: bytes, extension: str) -> str:
    what = _TEXT_FORMATS[extension]
    if content[:4] == b"PK\x03\x04" and extension == ".csv":
        raise reject("this is a zip archive (an Excel .xlsx workbook?), not a CSV text "
                      "file: save the sheet as 'CSV (comma delimited)' or 'CSV UTF-8'")
    return decode_text(content, what)


def _trailing_unit(label: str) -> tuple[str, str] | None:
    """(label, unit) of a header that writes its unit after a comma or a spaced slash ('Flow, kg/s',
    'Flow / (kg/s)'), when what follows reads as a unit; None otherwise."""
    for sep in (",", " / "):
        if sep in label:
            head, tail = label.rsplit(sep, 1)
            if head.strip() and tail.strip():
                try:
                    parse_unit(tail)
                except (AmbiguousUnit, StandardVolume):
                    pass  # a unit, refused for its reason naming the column ('Flow, Nm3/h'), not an unnamed header
                except UnitError:
                    continue
                tail = tail.strip()
                if tail[:1] in "([" and tail[-1:] in ")]" and not _PRESSURE_MARK.fullmatch(tail[1:-1]):
                    tail = tail[1:-1]  # 'Flow / (kg/s)'; not the mark of 'kPa(a)'
                return head.strip(), tail.strip()
    return None


_MARK_AFTER = re.compile(r"(?P<label>.*?)\s*(?:[\[(](?P<unit>[^\[\]()]*)[\])])?"
                         r"\s*[\[(]\s*(?P<mark>a|abs|g|gauge)\s*[\])]\s*$", re.IGNORECASE)


def _mark_outside_unit(name: str) -> str | None:
    """Why a header whose pressure mark stands after its unit's brackets or alone ('pressure [kPa] (g)',
    'pressure (g)') is not read, or None: the mark belongs to the unit ('pressure [kPa(g)]'). Refused as 'missing:
    pressure' before, without naming the column."""
    m = _MARK_AFTER.fullmatch(name.strip().strip('"').strip())
    if m is None or _header_field(m["label"])[0] != "pressure" or _role_key(m["label"]) in _RATIO_NAMES:
        return None
    kind = "gauge" if m["mark"].lower().startswith("g") else "absolute"
    written = f"{m['label'].strip()} [{(m['unit'] or '').strip() or 'kPa'}({m['mark'].strip()})]"
    if not (m["unit"] or "").strip():
        return f"{kind} mark without a unit: write the unit with its mark, e.g. {written}"
    return f"{kind} mark outside the unit: write {written}"


def _alias_key(text: str) -> str:
    """A header name as ``_ALIAS`` keys it: lower case, runs of blanks, underscores and hyphens one blank, a word's
    abbreviation dot dropped ('Eff.', 'Rel. speed')."""
    return re.sub(r"[\s_\-]+", " ", re.sub(r"(?<=[a-z])\.(?=[\s_\-]|$)", "", text.strip().lower())).strip()


def _symbol(text: str) -> bool:
    """Whether bracketed text is the quantity's symbol or name ('PR (π)', 'efficiency (η)'), not its unit: pint
    reads π as the number 3.14..., which would multiply every pressure ratio by it."""
    if _alias_key(text) not in _ALIAS:
        return False
    try:
        unit = parse_unit(text)
    except UnitError:
        return True
    return unit.dimensionless and not is_ratio_unit(unit)


MAX_HEADER_CELL = 200  # characters: no column name with its unit is longer


def _header_field(name: str) -> tuple[str | None, str]:
    """(field or None, unit) of a header cell by the rules in the module docstring. A longer cell is no column name:
    the unit pattern's search from each blank of a long run of blanks is quadratic (a 200,000-character data cell
    met as a candidate header took 6 CPU minutes)."""
    label, unit = name.strip().strip('"').strip(), ""
    if len(label) > MAX_HEADER_CELL:
        return None, ""
    whole = _alias_key(label)
    if whole in _ALIAS:  # a name with brackets of its own, e.g. 'N/sqrt(theta)'
        return _ALIAS[whole], ""
    symbols = []
    while (m := _UNIT_SUFFIX.search(label)) and m.start() > 0 and not _PRESSURE_MARK.fullmatch(m.group(1)):
        if _symbol(m.group(1)):
            symbols.append(m.group(1).strip())
        else:
            unit = unit or m.group(1).strip()
        label = label[: m.start()]
        if label.rstrip().endswith(" /"):  # quantity calculus, ISO 80000-1: 'Flow / (kg/s)'
            label = label.rstrip()[:-1]
    if label.endswith("%") and len(label) > 1:  # "efficiency %"
        label, unit = label[:-1].rstrip(" ,/"), unit or "%"
    key = _alias_key(label)
    if key not in _ALIAS and not unit and (split := _trailing_unit(label)):
        label, unit = split
        key = _alias_key(label)
    # a symbol of another quantity ('flow [pi]') is no name of this one: it stays the unit, which the check refuses
    stray = [t for t in symbols if _ALIAS.get(_alias_key(t)) != _ALIAS.get(key)]
    return _ALIAS.get(key), unit or (stray[0] if stray else "")


def _stated_units(name: str) -> list[str]:
    """Every unit a header cell states in brackets ('Wc (lbm/s) [kg/s]' states two), symbols and words that are no
    unit ('(isentropic)') left out."""
    label, units = name.strip().strip('"').strip(), []
    while (m := _UNIT_SUFFIX.search(label)) and m.start() > 0:
        if not _symbol(m.group(1)) and _is_unit(m.group(1)):
            units.append(m.group(1).strip())
        label = label[: m.start()]
    return units


def _split_unit(name: str) -> tuple[str, str]:
    """A header's label and the unit in its trailing brackets ('Speed [rpm]' -> ('Speed', 'rpm'))."""
    label = name.strip().strip('"').strip()
    m = _UNIT_SUFFIX.search(label)
    if m and m.start() > 0 and re.sub(r"[\s_\-]+", " ", label.lower()) not in _ALIAS:
        return label[: m.start()].strip(), m.group(1).strip()
    split = _trailing_unit(label)
    if split and re.sub(r"[\s_\-]+", " ", label.lower()) not in _ALIAS:
        return split
    return label, ""


def _is_number(cell: str) -> bool:
    for convention in (POINT, COMMA):
        try:
            number(cell, convention)
            return True
        except ValueError:
            continue
    return False


def _role_key(name: str) -> str:
    return re.sub(r"[\s_\-]+", " ", name.strip().strip('"').strip().lower())


def _find_header(rows: list[list[str]], column_roles: dict | None) -> int:
    """Index of the header row: the first of the leading rows (titles, test conditions, merged banners
    above the table) whose cells name at least two of flow, pressure and efficiency; 0 when none does
    (the first row is then the header, and its message says what is missing)."""
    columns = {_role_key(k): v for k, v in (column_roles or {}).items()}
    for i, row in enumerate(rows[:_HEADER_SEARCH_ROWS]):
        fields = {columns.get(_role_key(c)) or _header_field(c)[0] for c in row if c.strip()}
        if len(fields & set(MEASURED)) >= 2:
            return i
    return 0


def _units_row(row: list[str]) -> bool:
    """A row of units under the header ('[kg/s]', 'bar', '%', '-', '1'): every cell either empty or a unit, and no
    number in it but the unit one ('1', as a pressure ratio's unit is written) beside a unit that is no number."""
    cells = [c.strip() for c in row if c.strip()]
    numbers = [c for c in cells if _is_number(c)]
    if not cells or len(numbers) == len(cells) or any(c.strip("[]()").strip() != "1" for c in numbers):
        return False
    for c in cells:
        try:
            parse_unit(c)
        except UnitError:
            return False
    return True


def _parse_csv(text: str, column_roles: dict | None = None) -> tuple[list[dict], list[list[int]], list[Diagnostic],
                                                                   dict]:
    """Positions (one per (theta, phi), in order of first appearance), the file line of
    each of their points, and notes for the report."""
    lines = [(n, ln) for n, ln in enumerate(text.splitlines(), start=1)
             if ln.strip() and not ln.lstrip().lstrip('"').startswith("#")
             and ln.strip(" \t,;\"")]
    if not lines:
        raise reject("the CSV file is empty (no header; only blank or '#' lines)")
    forced = re.fullmatch(r'\s*"?sep=(.)"?\s*', lines[0][1])  # Excel's "sep=;" first line
    if forced:
        lines = lines[1:]
        if not lines:
            raise reject("the CSV file has no header (only a 'sep=' line)")
    candidates = [forced.group(1)] if forced else []
    candidates += [d for d in ("\t", ";", ",") if d in lines[0][1]] + ["\t", ";", ","]
    for delim in candidates:  # the separator whose split finds a header (title lines may precede it)
        rows, numbers, ends = _head_rows(lines, delim)
        h = _find_header(rows, column_roles)
        if h or len(rows[0]) > 1 and len({_header_field(c)[0] for c in rows[0]} & set(MEASURED)) >= 2:
            break
    else:
        if (held := _what_it_holds(text, lines)) is not None:
            raise reject(f"this file holds {held}, not a compressor map: a perfmap table has a header naming flow, "
                         "pressure, efficiency and a setting (speed, IGV, ...), one row per measured point",
                         type="wrong_kind")
        h_line = lines[0][1]
        delim = (forced.group(1) if forced else "\t" if "\t" in h_line else ";" if ";" in h_line else ",")
        (rows, numbers, ends), h = _head_rows(lines, delim), 0
    rows, numbers = rows[:h + 1], numbers[:h + 1]
    i = ends[h]
    width = len(rows[h])
    while i < len(lines):  # row by row: a stray quote cannot swallow the lines after it
        number, line = lines[i]
        # without a quote the csv module splits a line at its separators, and has no field size limit to pass
        row, used = _data_row(lines, i, delim, width) if '"' in line else (line.split(delim), 1)
        rows.append(row)
        numbers.append(number)
        i += used
    hint = ("" if delim != "," or ";" not in text[:2000] else
            " — if the file uses ';' separators, put them in the header too")
    # exporters end every row: a last row without a line ending is where a copy or an export stopped
    cut = lines[-1][0] if ends_mid_line(text) and lines[-1][0] == len(text.splitlines()) else None
    return _parse_table(rows, numbers, column_roles, hint, comma_separated=delim == ",", header=h,
                        what="line", cut_line=cut)


# What files of other kinds look like, told by their text: (pattern, what it holds, where it goes)
_OTHER_FORMATS = (
    (re.compile(r"^\s*Version\s*,[^;\n]*;", re.M | re.I), "an EnergyPlus IDF model", "polyhedra"),
    (re.compile(r"^\s*(Zone|BuildingSurface:Detailed|FenestrationSurface:Detailed)\s*,", re.M | re.I),
     "an EnergyPlus IDF model", "polyhedra"),
    (re.compile(r"<gbXML\b"), "a gbXML model", "polyhedra"),
    (re.compile(r"ISO-10303-21"), "an IFC/STEP model", "dedup or polyhedra"),
    (re.compile(r"^\s*(ISOGEN-FILES|PIPELINE-REFERENCE|UNITS-BORE)\b", re.M), "a PCF piping file", "alignment"),
    (re.compile(r"\Aply\s*\n\s*format\b"), "a PLY point cloud or mesh", "tube"),
    (re.compile(r"\A\s*solid\b.*\n\s*facet normal\b", re.S), "an ASCII STL mesh", "polyhedra"),
    (re.compile(r"^\s*0\s+(FILE|Name:|!LDRAW_ORG)\b", re.M), "an LDraw model", "rigidity"),
    (re.compile(r"\A\s*[\[{]"), "a JSON document (upload it as .json)", "perfmap"),
)
# unit words tube tables append to their column names ('length_mm', 'angle_deg')
_UNIT_WORDS = spellings() | {"deg", "degree", "degrees", "rad"}
# a tube's bending table (LRA: length, rotation, angle; YBC: feed, rotation, bend) and its points (x y z, XYZ-CLR)
_BENDING_COLUMNS = ({"length", "rotation", "angle"}, {"l", "r", "a"}, {"y", "b", "c"}, {"feed", "rotation", "bend"})
_POINT_COLUMNS = {"x", "y", "z", "nx", "ny", "nz", "intensity", "i", "r", "g", "b", "point", "row", "index", "id", "no",
                  "clr", "bend radius", "radius"}


def _column_names(line: str) -> set[str]:
    """A header line's column names, lower case, without units in brackets or as a last word ('x_mm' -> 'x')."""
    names = set()
    for cell in re.split(r"[,;\t]", line):
        cell = re.sub(r"\s*[\[(].*$", "", cell.strip().strip('"')).lower()
        words = [w for w in re.split(r"[\s_\-]+", cell) if w]
        while len(words) > 1 and words[-1] in _UNIT_WORDS:
            words.pop()
        names.add(" ".join(words))
    return names - {""}


def _what_it_holds(text: str, lines: list[tuple[int, str]]) -> str | None:
    """A sentence naming what a file that is no rig table holds (another kind's file renamed or saved as .csv),
    or None when it looks like no other kind's file either."""
    head = text[:20_000]
    for pattern, held, kind in _OTHER_FORMATS:
        if pattern.search(head):
            return f"{held} (for {kind})" if kind != "perfmap" else held
    rows = [re.split(r"[\s,;]+", line.strip()) for _, line in lines[:20]]
    numeric = [r for r in rows if r and all(_is_number(c) for c in r)]
    # three (x y z) or six (and normals) numeric columns and no header; four or five may be a rig table whose header
    # is missing, which the header's own message explains
    if len(numeric) >= min(3, len(rows)) and numeric == rows[:len(numeric)] and len({len(r) for r in numeric}) == 1 \
            and len(numeric[0]) in (3, 6):
        return (f"an XYZ point cloud ({len(numeric[0])} numeric columns, no header: x y z"
                f"{' and normals' if len(numeric[0]) == 6 else ''}) (for tube)")
    names = _column_names(lines[0][1]) if lines else set()
    if any(columns <= names for columns in _BENDING_COLUMNS):
        return f"a tube's bending table (columns {', '.join(sorted(names))}) (for tube)"
    if {"x", "y", "z"} <= names and names <= _POINT_COLUMNS:
        return f"points in x, y, z (columns {', '.join(sorted(names))}: a point cloud or an XYZ-CLR nominal) (for tube)"
    return None


class _Unreadable(list):
    """A line the csv module cannot split (a field past its size limit): no cells, and the reason."""

    def __init__(self, reason: str):
        super().__init__()
        self.reason = reason


_CELL_LINES = 10  # most lines one quoted data cell may span (a note typed with Alt+Enter)


def _data_row(lines: list[tuple[int, str]], i: int, delim: str, width: int) -> tuple[list[str], int]:
    """The row that starts at ``lines[i]`` and how many lines it takes. A line that leaves a quote open goes on
    into the next lines only when they close it within :data:`_CELL_LINES` lines, none of them looks like a row of
    the table (as many separators as the header) and the row then has as many cells as the header (a quoted cell
    holding line breaks); otherwise the quote is a stray one and the line is a row of its own."""
    line = lines[i][1]
    try:
        cells = next(csv.reader([line], delimiter=delim), [])
    except csv.Error as e:
        return _Unreadable(f"the line cannot be split into cells ({e})"), 1
    if line.count('"') % 2 == 0:
        return cells, 1
    for extra in range(1, min(_CELL_LINES, len(lines) - i)):
        if lines[i + extra][1].count(delim) + 1 >= width:  # a row of the table, not the rest of a note
            break
        text = "\n".join(part for _, part in lines[i:i + extra + 1])
        if text.count('"') % 2 == 0:
            try:
                merged = next(csv.reader(io.StringIO(text), delimiter=delim), [])
            except csv.Error:
                break
            return (merged, extra + 1) if len(merged) == width else (cells, 1)
    return cells, 1


def _head_rows(lines: list[tuple[int, str]], delim: str) -> tuple[list[list[str]], list[int], list[int]]:
    """The first rows of the file as the csv module splits them (a quoted header cell may hold a line break, as
    Excel writes 'Speed<Alt+Enter>[rpm]'), enough to find the header and a units row under it: the rows, the
    file line each starts on, and the index into ``lines`` after each. A line the csv module refuses ends them;
    when that is the first, it is a header row that names nothing."""
    rows: list[list[str]] = []
    numbers: list[int] = []
    ends: list[int] = []
    reader = csv.reader((line for _, line in lines), delimiter=delim)
    while len(rows) < _HEADER_SEARCH_ROWS + 2 and reader.line_num < len(lines):
        start = reader.line_num
        try:
            row = next(reader)
        except csv.Error as e:
            if not rows:
                raise reject(f"line {lines[start][0]} cannot be split into cells ({e})", ("file", "header")) from None
            break
        except StopIteration:
            break
        rows.append(row)
        numbers.append(lines[start][0])
        ends.append(reader.line_num)
    return rows, numbers, ends


# Most bytes an .xlsx may inflate to, counted on the bytes the decompressor actually gives (a zip's declared
# sizes may lie): a rig table of MAX_CSV_ROWS rows is a few MB of XML; a zip bomb stops here.
MAX_XLSX_INFLATED = 64 * 1024 * 1024
_CHUNK = 1 << 20


def check_workbook_archive(content: bytes) -> None:
    """A workbook's archive read member by member, counting inflated bytes (refused past
    ``MAX_XLSX_INFLATED``) and looking for a DTD: an .xlsx never declares one, and its entities are how an
    XML bomb expands. Both are a 422 on ``file`` before openpyxl builds anything."""
    try:
        archive = zipfile.ZipFile(io.BytesIO(content))
        members = archive.infolist()
    except (zipfile.BadZipFile, zipfile.LargeZipFile, ValueError, EOFError, OSError):
        return  # not a readable zip: the workbook reader says why
    if sum(m.file_size for m in members) > MAX_XLSX_INFLATED:
        raise reject(f"the workbook inflates to {sum(m.file_size for m in members):,} bytes; an .xlsx may inflate to "
                     f"at most {MAX_XLSX_INFLATED:,} (a zip bomb?)")
    inflated = 0
    for member in members:
        try:
            with archive.open(member) as stream:
                head = b""
                while chunk := stream.read(_CHUNK):
                    inflated += len(chunk)
                    if inflated > MAX_XLSX_INFLATED:
                        raise reject(f"the workbook inflates to more than {MAX_XLSX_INFLATED:,} bytes, the most an "
                                     f".xlsx may (a zip bomb?)")
                    if len(head) < 4096:
                        head += chunk[:4096]
                        if member.filename.endswith((".xml", ".rels", ".vml")) and b"<!DOCTYPE" in head.upper():
                            raise reject(f"the workbook's {member.filename} declares a DTD (entity definitions); an "
                                         "Excel .xlsx never does: save it again from Excel or send CSV")
        except InputRejected:
            raise
        except (zipfile.BadZipFile, NotImplementedError, RuntimeError, ValueError, EOFError, OSError, zlib.error):
            raise reject(f"not a readable Excel .xlsx workbook: its member {member.filename!r} cannot be "
                         "decompressed (damaged or encrypted); save it again from Excel or send CSV") from None


def _parse_xlsx(content: bytes, column_roles: dict | None, sheet: str | None,
                ) -> tuple[list[dict], list[list[int]], list[Diagnostic], dict]:
    """An Excel workbook's rig table (:mod:`plantsolve.solvers.perfmap.workbook`): the named sheet, else the
    first sheet with a recognisable header, else the first sheet; then the CSV rules, rows named by their
    sheet row."""
    check_workbook_archive(content)
    sheets = read_workbook(content, MAX_CSV_ROWS)
    if sheet is not None:
        chosen = [s for s in sheets if s.name == sheet]
        if not chosen:
            raise reject(f"no sheet {sheet!r} in the workbook; its sheets: {', '.join(repr(s.name) for s in sheets)}",
                         ("options", "sheet"))
        ws = chosen[0]
    else:
        usable = [s for s in sheets if s.rows]
        if not usable:
            raise reject("the workbook's sheets are empty")
        found = [s for s in usable
                 if len({_header_field(c)[0] for c in s.rows[_find_header(s.rows, column_roles)]} & set(MEASURED)) >= 2]
        ws = (found or usable)[0]
    if not ws.rows:
        raise reject(f"sheet {ws.name!r} is empty", ("options", "sheet"))
    positions, lines, notes, meta = _parse_table(ws.rows, ws.numbers, column_roles,
                                                 header=_find_header(ws.rows, column_roles),
                                                 what=f"sheet {ws.name!r} row")
    if len(sheets) > 1:
        notes.insert(0, Diagnostic(code="upload_sheet", message=f"Sheet {ws.name!r} read (of "
                                   f"{', '.join(repr(s.name) for s in sheets)}; choose with options.sheet).",
                                   details={"sheet": ws.name, "sheets": [s.name for s in sheets]}))
    return positions, lines, notes, meta


def _parse_table(rows: list[list[str]], numbers: list[int], column_roles: dict | None,
                 hint: str = "", comma_separated: bool = False, header: int = 0, what: str = "line",
                 cut_line: int | None = None,
                 ) -> tuple[list[dict], list[list[int]], list[Diagnostic], dict]:
    """The table's rows (cells as text) from its header on; ``numbers`` are the file's line (or sheet row)
    numbers of the rows, used in every message. ``cut_line`` is the file's last line when it has no line
    ending: a row there with fewer cells than the header or a value that does not read was cut, and is
    skipped with a ``truncated_file`` warning instead of refusing the file."""
    notes_before = []
    if header:
        notes_before.append(Diagnostic(
            code="upload_rows_above_header",
            message=f"{header} row(s) above the header ({what} {numbers[header]}) skipped (titles, test "
            "conditions).", details={"rows": numbers[:header]}))
        rows, numbers = rows[header:], numbers[header:]
    header_units: list[str] = []
    units_line = numbers[1] if len(numbers) > 1 else None
    if len(rows) > 1 and _units_row(rows[1]):
        header_units = [c.strip().strip("[]()").strip() for c in rows[1]]
        notes_before.append(Diagnostic(code="upload_units_row",
                                       message=f"Units read from the row under the header ({what} {numbers[1]}).",
                                       details={"row": numbers[1], "units": header_units}))
        rows, numbers = [rows[0]] + rows[2:], [numbers[0]] + numbers[2:]

    col: dict[str, int] = {}
    scale: dict[str, float] = {}
    unit_of: dict[str, str] = {}
    basis_of: dict[str, str] = {}  # where each column's unit came from: its header or the row of units under it
    measured_units: dict[str, str] = {}
    cell_factors: dict[tuple[int, int], float] = {}  # (line, column) of a cell stating a unit: factor into the column's
    cell_conversions: list[dict] = []
    ignored, recognised = [], []
    columns = {re.sub(r"[\s_\-]+", " ", k.strip().lower()): v for k, v in (column_roles or {}).items()}
    for j, name in enumerate(rows[0]):
        field, unit = _header_field(name)
        key = re.sub(r"[\s_\-]+", " ", name.strip().strip('"').strip().lower())
        if key in columns:
            field = None if columns[key] == "ignore" else columns[key]
        if field is None and (marked := _mark_outside_unit(name)):
            raise reject(f"column {name.strip()!r} ({what} {numbers[0]}, column {j + 1}): {marked}",
                         ("file", "header"))
        if field is None:
            if name.strip():
                ignored.append(name.strip())
            continue
        if field == "rline":
            recognised.append(name.strip())
            continue
        if field in col:
            raise reject(f"columns {rows[0][col[field]].strip()!r} and {name.strip()!r} both "
                          f"name the {field}; say which is which with the 'columns' option", ("file", "header"))
        stated = _stated_units(name)
        if any(not _same_unit(stated[0], other) for other in stated[1:]):
            raise reject(f"column {name.strip()!r} ({what} {numbers[0]}, column {j + 1}) states the units "
                         f"{' and '.join(map(repr, stated[::-1]))}: which is meant? Give the unit once",
                         ("file", "header"))
        col[field] = j
        basis_of[field] = "header"
        if not unit and j < len(header_units):
            unit, basis_of[field] = header_units[j], "units_row"
        elif unit and j < len(header_units) and header_units[j] and not _same_unit(unit, header_units[j]):
            if _is_unit(unit) or not _is_unit(header_units[j]):
                raise reject(f"column {name.strip()!r} ({what} {numbers[0]}) states {unit!r} but the row of units "
                             f"under the header ({what} {units_line}) says {header_units[j]!r} for it: which is "
                             "meant? Give the unit once", ("file", "header"))
            # a header's parenthesis that is no unit ('efficiency (isentropic)') over a units row stating one
            unit, basis_of[field] = header_units[j], "units_row"
        cells = reconcile(rows[1:], numbers[1:], j, field, name.strip(), unit, what, _same_unit)
        if cells.error:
            raise InputRejected([cells.error])
        if cells.unit:
            unit, basis_of[field] = cells.unit, "cells"
        cell_factors.update({(n, j): f for n, f in cells.factors.items()})
        cell_conversions += [{"quantity": field, "column": name.strip(), "from_unit": k, "to_unit": _canonical(unit),
                              "factor": f, "basis": "cells"} for k, f in cells.converted.items()]
        unit_of[field] = unit
        scale[field] = 1.0
        if field in MEASURED:
            try:
                parsed = check_quantity(field, unit or None)
            except UnitError as e:
                raise reject(f"column {name.strip()!r} ({what} {numbers[0]}, column {j + 1}): {e}",
                             ("file", "header")) from None
            if field == "efficiency":
                scale[field] = fraction_factor(unit or None)
            elif parsed is not None:
                measured_units[field] = parsed.text
                if field == "pressure" and not parsed.dimensionless and _role_key(_split_unit(name)[0]) in _RATIO_NAMES:
                    notes_before.append(Diagnostic(
                        code="unit_contradicted_by_name",
                        message=f"Column {name.strip()!r} ({what} {numbers[0]}) is named as a pressure ratio but "
                        f"its unit {unit!r} is a pressure: read as pressures in {parsed.text}. If the values are "
                        "ratios (p2/p1), label the column '[-]'.",
                        details={"column": name.strip(), "unit": parsed.text, "reading": "pressure"}))
            elif field == "pressure" and _role_key(_split_unit(name)[0]) in _RATIO_NAMES:
                measured_units[field] = "1"
    unknown_roles = sorted(set(columns.values()) - set(ROLES))
    if unknown_roles:
        raise reject(f"options.columns names unknown roles {unknown_roles}; roles: {', '.join(ROLES)}",
                     ("options", "columns"))
    settings_found = [r for r in SETTING_ROLES if r in col]
    missing = [c for c in MEASURED if c not in col]
    keys = [_role_key(h) for h in rows[0]]
    # a mapping of a header the file lacks (a typo, another rig's file): the column it meant was not read so
    unmatched = {k: v for k, v in (column_roles or {}).items() if _role_key(k) not in keys}
    if unmatched:
        notes_before.append(Diagnostic(
            code="upload_columns_unmatched",
            message=f"options.columns maps {', '.join(f'{k!r} (to {v})' for k, v in unmatched.items())}, which no "
            f"header of the file ({what} {numbers[0]}) is: not used. The headers are "
            f"{', '.join(repr(h.strip()) for h in rows[0])}.",
            details={"columns": unmatched, "headers": [h.strip() for h in rows[0]]}))
    if (missing or not settings_found) and any(k.startswith("max efficiency") for k in keys) \
            and any(k.startswith("optimal ") for k in keys):
        raise reject(f"the header ({what} {numbers[0]}) is that of a perfmap map.csv (flow, pressure, 'max efficiency' "
                     "and the 'optimal' settings): a map's grid of best efficiencies, not measured speed lines; upload "
                     "the rig's data, or the job's curves.csv (its fitted speed lines)", ("file", "header"))
    if missing or not settings_found:
        need = missing + ([] if settings_found else ["a setting (speed, IGV, VGV, alpha, diffuser, theta or phi)"])
        raise reject(
            f"the header ({what} {numbers[0]}) must name the columns flow, pressure, efficiency and at least one "
            f"setting parameter (any order and case, units in brackets allowed, e.g. 'Wc [kg/s]'; or map any "
            f"header to a role with the 'columns' option); missing: {', '.join(need)}; found: "
            f"{', '.join(repr(h.strip()) for h in rows[0])}"
            + hint
            + (f" — options.columns names no header of the file: {', '.join(map(repr, unmatched))}" if unmatched else "")
            + (f" — the first {what} that is not blank or '#' must be the header"
               if all(_is_number(h) for h in rows[0] if h.strip()) else ""),
            ("file", "header"))
    if "theta" in col and "phi" in col:  # the paper's two settings named: other setting columns are extra
        setting_cols = ["theta", "phi"]
        ignored += [rows[0][col[r]].strip() for r in settings_found if r not in setting_cols]
    elif "theta" in col or "phi" in col:
        setting_cols = [r for r in ("theta", "phi") if r in col]
        setting_cols += [r for r in settings_found if r not in ("theta", "phi")]
    else:
        setting_cols = settings_found
    if len(setting_cols) > 3:
        raise reject(f"{len(setting_cols)} setting parameters ({', '.join(rows[0][col[r]].strip() for r in setting_cols)}):"
                     " at most three are supported; map the others to 'ignore' with the 'columns' option",
                     ("file", "header"))
    for r in setting_cols:
        scale.setdefault(r, 1.0)
    roles = tuple(setting_cols) + MEASURED

    _refuse_second_header(rows, numbers, col, unit_of, columns, what)
    width = len(rows[0])
    regrouped: list[int] = []
    data = []
    for n, r in zip(numbers[1:], rows[1:]):
        if not isinstance(r, _Unreadable) and any(c.strip() for c in r[width:]):
            merged = _thousands_regrouped(r, width) if comma_separated else None
            if merged is None:
                r = _Unreadable(f"{len([c for c in r if c.strip()])} cells where the header has {width}"
                                + (": a thousands separator or a decimal comma in a comma-separated file? Quote such "
                                   "numbers, or separate the columns with ';'" if comma_separated else ""))
            else:
                r = merged
                regrouped.append(n)
        data.append((n, r))
    convention, errors = _conventions(data, roles, col, rows[0], what)
    if errors:
        raise InputRejected(errors)
    groups: dict[tuple[float, float], dict] = {}
    lines_of: dict[tuple[float, float], list[int]] = {}
    cut_note: Diagnostic | None = None
    skipped: list[dict] = []  # rows that could not be read: skipped with a warning while others are usable
    skipped_count = 0
    for n, r in data:
        row_start = len(errors)
        vals = {}
        if isinstance(r, _Unreadable):
            errors.append(FieldError(("file", "row", n), f"{what} {n}: {r.reason}"))
        for c in () if isinstance(r, _Unreadable) else roles:
            j = col[c]
            cell = r[j].strip() if j < len(r) else ""
            if not cell:
                hint = (" (write the setting on every row, not only on the first row of "
                        "a speed line)" if c not in MEASURED else "")
                errors.append(FieldError(("file", "row", n, c), f"{what} {n}: no {c} value "
                                         f"(column {j + 1}); every row needs all "
                                         f"{len(roles)} values{hint}"))
                continue
            try:
                v = number(cell, convention.get(c))
            except ValueError:
                hint = (" (decimal comma with ',' separators? use ';' as separator)"
                        if comma_separated and re.fullmatch(r"-?\d+,\d+", cell) else
                        " (a formula never calculated: open and save the workbook in Excel, or paste values)"
                        if cell.startswith("=") else "")
                shown = cell if len(cell) <= 40 else cell[:40] + "…"  # a 100 KB cell is not repeated in the report
                errors.append(FieldError(("file", "row", n, c),
                                         f"{what} {n}: {c} {shown!r} is not a number{hint}"))
                continue
            v *= cell_factors.get((n, j), 1.0)
            if not math.isfinite(v):
                errors.append(FieldError(("file", "row", n, c),
                                         f"{what} {n}: {c} is {cell!r} (NaN or infinite)"))
                continue
            vals[c] = v
        cut_number = _cut_number(data, n, r) if n == cut_line and len(errors) == row_start else None
        if cut_number and not cut_number["certain"] and len(r) >= width:
            name = rows[0][cut_number["column"] - 1].strip() if cut_number["column"] <= len(rows[0]) else ""
            cut_note = truncated_file(n, f"its last row has no line ending, and its column {name!r} may be cut "
                                      f"({cut_number['reason']}): the row was read as written; check its last value "
                                      "against the source, and whether the table goes on beyond it.",
                                      column_name=name, cells=len(r), header_cells=width,
                                      **{k: v for k, v in cut_number.items() if k != "reason"})
            cut_number = None
        elif n == cut_line and (len(errors) > row_start or len(r) < width or cut_number):
            why = ([e.msg for e in errors[row_start:]] or ([cut_number["reason"]] if cut_number else [])
                   or [f"{len(r)} of the header's {width} cells"])
            del errors[row_start:]
            cut_note = truncated_file(n, f"its last row has no line ending and is incomplete ({why[0]}): the file "
                                      "was cut, and the table may go on beyond it? That row was not read.",
                                      reason=why[0], cells=len(r), header_cells=width,
                                      **{k: v for k, v in (cut_number or {}).items() if k != "reason"})
            continue
        if len(errors) > row_start:
            skipped_count += 1
            if len(skipped) < _MAX_ROW_ERRORS:
                skipped.append({"line": n, "reason": errors[row_start].msg})
            del errors[max(row_start, _MAX_ROW_ERRORS):]  # the refusal, if nothing is usable, lists the first rows
            continue
        if len(vals) < len(roles):
            continue
        key = tuple(vals[c] for c in setting_cols)
        paper = setting_cols == ["theta", "phi"]
        g = groups.setdefault(key, {**({"theta": key[0], "phi": key[1]} if paper else {"setting": list(key)}),
                                    "flow": [], "pressure": [], "efficiency": []})
        for c in ("flow", "pressure", "efficiency"):
            g[c].append(vals[c])
        lines_of.setdefault(key, []).append(n)
    if not groups:
        if errors:  # nothing usable is left: the file is refused, naming its first bad rows
            raise InputRejected(errors)
        cut = f" (its only data row, {what} {cut_line}, is cut short)" if cut_note else ""
        raise reject(f"the table has a header ({what} {numbers[0]}) but no data rows{cut}")
    names = {r: rows[0][col[r]].strip() for r in col}
    _refuse_row_settings(lines_of, setting_cols, names, what)
    if scale["efficiency"] != 1.0:
        _refuse_mixed_efficiency(groups, lines_of, names["efficiency"], unit_of["efficiency"], what)
    reading, contradictions = _values_against_units(groups, setting_cols, names, unit_of, scale)
    conversions = list(cell_conversions)
    if reading["efficiency"] != 1.0:
        for g in groups.values():
            g["efficiency"] = [v * reading["efficiency"] for v in g["efficiency"]]
    if reading["efficiency"] != 1.0:
        stated = scale["efficiency"] != 1.0
        conversions.append({"quantity": "efficiency", "column": names["efficiency"],
                            "from_unit": unit_of["efficiency"] if stated else "%", "to_unit": "1",
                            "factor": reading["efficiency"], "basis": basis_of["efficiency"] if stated else "values"})
    notes = notes_before + ([cut_note] if cut_note else []) + contradictions
    if regrouped:
        notes.append(Diagnostic(
            code="upload_thousands_separators",
            message=f"Numbers with thousands separators in a comma-separated file ({what} {line_list(regrouped)}): "
            "their groups, split at the separators, were read as one number each (1,104.338 as 1104.338).",
            details={"lines": regrouped[:10], "count": len(regrouped)}))
    if skipped_count:
        notes.append(skipped_lines(skipped, what=what, count=skipped_count, code="upload_rows_skipped"))
    order = [c.strip() for c in rows[0]]
    ignored.sort(key=order.index)
    labels, units = [], []
    for r in setting_cols:
        label, unit = _split_unit(names[r])
        labels.append(label or r)
        units.append("1" if r in reading and reading[r] == "1" else unit or unit_of.get(r, ""))
    meta: dict = {} if setting_cols == ["theta", "phi"] else {"setting_names": labels, "setting_units": units}
    if setting_cols == ["theta", "phi"] and any(units):
        meta["setting_units"] = units
    if reading.get("flow_unit"):
        measured_units["flow"] = reading["flow_unit"]
    meta["units"] = {**measured_units, "efficiency": "1"}
    meta["source"] = {"row_label": what, "conversions": conversions}
    if "setting_names" in meta:
        notes.append(Diagnostic(
            code="upload_settings",
            message=(f"One setting parameter ({labels[0]!r})." if len(labels) == 1 else
                     f"{len(labels)} setting parameters: {', '.join(map(repr, labels))}."),
            details={"names": labels, "units": units, "columns": [names[r] for r in setting_cols]}))
    if ignored:
        notes.append(Diagnostic(
            code="upload_columns_ignored",
            message=f"CSV columns not used (no known role; map them with the 'columns' option): "
            f"{', '.join(ignored)}.", details={"columns": ignored}))
    if recognised:
        notes.append(Diagnostic(
            code="upload_rline_not_needed",
            message=f"Column(s) {', '.join(recognised)} (R-line / beta) recognised and not needed: each line is "
            "parametrised by its flow.", details={"columns": recognised}))
    if scale["efficiency"] != 1.0 and reading["efficiency"] != 1.0:
        eff = np.concatenate([g["efficiency"] for g in groups.values()])
        notes.append(Diagnostic(code="upload_efficiency_percent",
                                message=f"Efficiency column {names['efficiency']!r} given in {unit_of['efficiency']}: "
                                f"converted to a fraction (× {scale['efficiency']:g}; now {eff.min():.4g}.."
                                f"{eff.max():.4g}).", details={"factor": scale["efficiency"],
                                                              "column": names["efficiency"]}))
    # the positions by their settings, not by the row each first appears on: a table whose rows come in another order
    # is the same request (the warnings' positions name the same speed line)
    keys = sorted(groups)
    return [groups[k] for k in keys], [lines_of[k] for k in keys], notes, meta


def _refuse_row_settings(lines_of: dict[tuple, list[int]], setting_cols: list[str], names: dict[str, str],
                         what: str) -> None:
    """A table whose rows mostly hold a setting of their own (measured speeds, 9497, 9503, …, where the speed line's
    set value was meant) is refused once, naming the column: each row would be a speed line of one point, refused
    one by one as too short, with no word of why."""
    counts = [len(n) for n in lines_of.values()]
    singles = counts.count(1)
    if singles < 3 or 2 * singles < sum(counts):
        return
    keys = sorted(lines_of, key=lambda k: lines_of[k][0])
    varying = [i for i, _ in enumerate(setting_cols) if 2 * len({k[i] for k in keys}) >= sum(counts)]
    shown = varying or list(range(len(setting_cols)))
    column = " and ".join(repr(names[setting_cols[i]]) for i in shown)
    examples = ", ".join(f"{keys[m][shown[0]]:g}" for m in range(min(3, len(keys))))
    raise reject(
        f"column {column}: {singles} of the {sum(counts)} rows each hold a setting of their own ({examples}, …), "
        "and a speed line needs at least 3 rows at one setting. Measured speeds? Round them to the speed line's set "
        "value, or give the set value's column as the setting and map the measured one to 'ignore' with the "
        f"'columns' option. First rows: {what} {', '.join(str(lines_of[k][0]) for k in keys[:3])}.",
        ("file", "header"))


_PERCENTS = (FRACTIONS, 100.0)  # a column whose values lie in here (none at or below 1.5) holds per cent


def _refuse_second_header(rows: list[list[str]], numbers: list[int], col: dict[str, int], unit_of: dict[str, str],
                          columns: dict[str, str], what: str) -> None:
    """A header further down (two tables pasted into one file or sheet, each under its own header) that puts a
    column elsewhere or states another unit than the first header, or a row of units under it that does, is refused
    naming its line: its rows were read under the first header's columns and units (flows in kg/s under a first
    header's lb/s, read 2.2 times too small, with only a note that one line was skipped). A header repeated as it is,
    its units too, is skipped as any unreadable row is; a unit where the first header states none must be '-' or '1'."""
    repeated = False
    for n, r in zip(numbers[1:], rows[1:]):
        if isinstance(r, _Unreadable) or all(_is_number(c) or not c.strip() for c in r):
            repeated = False
            continue
        if repeated and _units_row(r):
            changed = [f"{rows[0][j].strip()!r} in {c.strip()!r} (above: {unit_of[f] or 'no unit'!r})"
                       for f, j in col.items() if j < len(r) and (c := r[j].strip().strip("[]()").strip())
                       and f in unit_of and not _same_unit(unit_of[f] or "1", c)]
            if changed:
                raise reject(f"{what} {n}: a row of units under a second header that states other units than the "
                             f"first ({what} {numbers[0]}): {', '.join(changed)}; two tables in one file? Upload each "
                             "on its own, or write both in one unit", ("file", "row", n))
            continue
        fields = {}
        for j, name in enumerate(r):
            key = re.sub(r"[\s_\-]+", " ", name.strip().strip('"').strip().lower())
            field, unit = (columns[key], "") if key in columns else _header_field(name)
            if field in col and field not in fields:
                fields[field] = (j, unit, name.strip())
        repeated = len(set(fields) & set(MEASURED)) >= 2
        if not repeated:
            continue
        moved = [f"{f} in column {j + 1} (above: {col[f] + 1})" for f, (j, _, _) in fields.items() if j != col[f]]
        units = [f"{name!r} (above: {rows[0][col[f]].strip()!r})" for f, (_, unit, name) in fields.items()
                 if unit and not _same_unit(unit_of.get(f) or "1", unit)]
        if moved or units:
            raise reject(f"{what} {n} is a second header that reads its columns otherwise than the first ({what} "
                         f"{numbers[0]}): {', '.join(moved + units)}; two tables in one file? Upload each on its own, "
                         "or write them under one header", ("file", "row", n))


def _values_against_units(groups: dict, setting_cols: list[str], names: dict[str, str], unit_of: dict[str, str],
                          scale: dict[str, float]) -> tuple[dict, list[Diagnostic]]:
    """The reading the values support where a column's unit says otherwise: ``{"efficiency": factor to a
    fraction, setting role: "1" for a '%' setting holding fractions, "flow_unit": "1" for such a flow}`` and a
    warning naming each contradicted column with its values. A '%' efficiency holding fractions is not divided by
    100 again; a '-' (fraction) efficiency holding 1.5..100 is per cent."""
    reading: dict = {"efficiency": scale["efficiency"]}
    notes = []

    def note(role: str, values: np.ndarray, unit: str, used: str) -> None:
        notes.append(Diagnostic(
            code="unit_contradicted_by_values",
            message=f"Column {names[role]!r} says {unit!r} but its values lie in {values.min():.4g}..{values.max():.4g}"
            f": {used}.", details={"column": names[role], "unit": unit, "values": [float(values.min()),
                                                                                     float(values.max())],
                                   "reading": used}))

    eff = np.concatenate([g["efficiency"] for g in groups.values()])
    unit = unit_of.get("efficiency") or ""
    if scale["efficiency"] != 1.0 and np.all(np.abs(eff) <= FRACTIONS):
        reading["efficiency"] = 1.0
        note("efficiency", eff, unit, "fractions already, read as they are (not divided by "
             f"{1 / scale['efficiency']:g} again)")
    elif unit and scale["efficiency"] == 1.0 and eff.min() > _PERCENTS[0] and eff.max() <= _PERCENTS[1]:
        reading["efficiency"] = 0.01
        note("efficiency", eff, unit, "per cent, divided by 100")
    keys = list(groups)
    for k, role in enumerate(setting_cols):
        if _is_percent(unit_of.get(role)):
            values = np.array([key[k] for key in keys], dtype=float)
            if np.all(np.abs(values) <= FRACTIONS):
                reading[role] = "1"
                note(role, values, unit_of[role], "fractions (of design), stated as unit '1', not per cent")
    if _is_percent(unit_of.get("flow")):
        flow = np.concatenate([g["flow"] for g in groups.values()])
        if np.all(np.abs(flow) <= FRACTIONS):
            reading["flow_unit"] = "1"
            note("flow", flow, unit_of["flow"], "fractions, stated as unit '1', not per cent")
    return reading, notes


def _refuse_mixed_efficiency(groups: dict, lines_of: dict, name: str, unit: str, what: str) -> None:
    """A per-cent (or per-mille) efficiency column holding both fractions (at most 1.5) and per cent: one reading
    makes the others 100 times off (0.85 read as 0.85 % beside 85 %), so the rows of the fewer kind are refused,
    named, whichever way the column is read."""
    cells = [(line, v) for key, g in groups.items() for line, v in zip(lines_of[key], g["efficiency"])]
    column = np.array([v for _, v in cells], dtype=float)
    found = mixed_efficiency_strays(column, 1 / fraction_factor(unit))
    if found is None:
        return
    strays, odd_fractions = found
    values = column[(np.abs(column) <= FRACTIONS) != odd_fractions]
    odd = [cell for cell, stray in zip(cells, strays) if stray]
    kind = "a fraction" if odd_fractions else "a per-cent value"
    raise InputRejected([FieldError(("file", "row", line, "efficiency"), (
        f"{what} {line}: efficiency {v:g} in column {name!r} ({unit}), whose other values lie in {values.min():.4g}.."
        f"{values.max():.4g}: {kind} among {'per cent' if odd_fractions else 'fractions'}? One reading would "
        "make these rows or the others 100 times off: write the column in one unit")) for line, v in odd[:10]])


def _same_unit(a: str, b: str) -> bool:
    """Two spellings of one unit (``kg/s`` and ``kg s^-1``; ``lbm/s`` and ``lb/s``; ``Hz`` and ``1/s``; ``1/min`` and
    ``rpm``; ``-`` and ``1``), by value; as text when pint reads neither."""
    try:
        first, second = parse_speed_unit(a), parse_speed_unit(b)  # 'U/min' is rpm, not pint's enzyme units
    except UnitError:
        return a.strip().strip("[]()").strip().lower() == b.strip().strip("[]()").strip().lower()
    if first.unit == second.unit:
        return True
    if first.unit.dimensionality != second.unit.dimensionality:
        return False
    rpm = revolutions_per_minute(first.unit), revolutions_per_minute(second.unit)
    if rpm[0] is not None:  # shaft speeds: a bare frequency counts revolutions, as the speed check reads it
        return math.isclose(rpm[0], rpm[1], rel_tol=1e-9)
    return math.isclose(first.factor_to(second), 1.0, rel_tol=1e-9)


def _canonical(unit: str) -> str:
    """A unit as results state it ('-' and '' are '1'), or as written when pint does not read it."""
    try:
        return parse_unit(unit).text if unit else "1"
    except UnitError:
        return unit


def _is_unit(text: str) -> bool:
    try:
        parse_unit(text)
    except UnitError:
        return False
    return True


def _is_percent(unit: str | None) -> bool:
    return bool(unit) and unit.strip().strip("[]()").strip() == "%"


def _thousands_regrouped(row: list[str], width: int) -> list[str] | None:
    """A comma-separated row split inside its numbers' thousands separators (``1,104.338`` unquoted gives the
    cells ``1`` and ``104.338``) joined back to the header's width; None when the split is not exactly that (too
    few or too many places where a 1-3 digit cell is followed by a 3-digit group)."""
    extra = len(row) - width
    places = [i for i in range(len(row) - 1)
              if re.fullmatch(r"[+-]?[1-9]\d{0,2}", row[i].strip()) and re.fullmatch(r"\d{3}(\.\d*)?", row[i + 1].strip())]
    if len(places) != extra or any(b - a < 2 for a, b in zip(places, places[1:])):
        return None
    out, i = [], 0
    while i < len(row):
        if i in places:
            out.append(row[i].strip() + "," + row[i + 1].strip())
            i += 2
        else:
            out.append(row[i])
            i += 1
    return out


def _conventions(data: list[tuple[int, list[str]]], roles: tuple[str, ...], col: dict[str, int], header: list[str],
                 what: str) -> tuple[dict[str, str], list[FieldError]]:
    """The number convention of each column (:mod:`~plantsolve.solvers.perfmap.numbers`), and a refusal naming the
    column, its pattern and its lines where its cells mix conventions or nothing in the file says which applies."""
    surveys = {c: survey([(n, r[col[c]]) for n, r in data if not isinstance(r, _Unreadable) and col[c] < len(r)])
               for c in roles}
    file_point = any(sv.point for sv in surveys.values())
    file_comma = any(sv.comma for sv in surveys.values())
    fallback = POINT if file_point and not file_comma else COMMA if file_comma and not file_point else None
    convention, errors = {}, []
    for c, sv in surveys.items():
        name = header[col[c]].strip()
        if sv.point and sv.comma:
            minority = sv.comma if len(sv.comma) <= len(sv.point) else sv.point
            errors.append(FieldError(("file", "row", minority[0], c), (
                f"column {name!r} mixes decimal points ({what} {line_list(sv.point)}: e.g. {sv.examples[POINT]!r}) and "
                f"decimal commas ({what} {line_list(sv.comma)}: e.g. {sv.examples[COMMA]!r}): one convention per "
                "column"), "ambiguous_number"))
        elif sv.convention:
            convention[c] = sv.convention
        elif sv.either:
            example = sv.examples["either"]
            if fallback:
                convention[c] = fallback
            elif "," in example:
                whole = example.replace(",", "")
                errors.append(FieldError(("file", "row", sv.either[0], c), (
                    f"column {name!r}: {example!r} ({what} {line_list(sv.either)}) reads as "
                    f"{example.replace(',', '.')} with a decimal comma or {whole} with a thousands separator, and no "
                    "number of the file says which: write the numbers without thousands separators, or with a "
                    "decimal point"), "ambiguous_number"))
    return convention, errors


def _written(cell: str) -> Written | None:
    """A cell's digits as :mod:`~plantsolve.solvers.cut_number` compares them, its decimal mark read as the
    column's numbers are (:func:`~plantsolve.solvers.perfmap.numbers.decimals`)."""
    places = decimals(cell)
    return Written(False, places) if places is not None else written(cell)


def _cut_number(data: list[tuple[int, list[str]]], line: int, row: list[str]) -> dict | None:
    """The last row of a file without a final line ending, read whole, may still be cut inside its last number
    (0.9278 -> 0.9): its last cell is then shorter than (nearly) every other cell of its column
    (:func:`~plantsolve.solvers.cut_number.short_number`). The facts, or None."""
    j = max((i for i, c in enumerate(row) if c.strip()), default=None)
    if j is None:
        return None
    column = [_written(r[j]) for n, r in data if n != line and not isinstance(r, _Unreadable) and j < len(r)
              and r[j].strip()]
    short = short_number(_written(row[j]), column)
    if short is None:
        return None
    return {"column": j + 1, "value": row[j].strip(), "decimals": short.digits, "column_decimals": list(short.column),
            "short_share": short.share, "certain": short.certain,
            "reason": f"its last value {row[j].strip()!r} has {short.reason}"}


_MAP_ARRAY = re.compile(r"^\s*(?:\w+\.)?(alphaMap|NcMap|RlineMap|WcMap|PRmap|effMap)\s*=\s*(?:np\.|numpy\.)?array\(",
                        re.M)


def _bracketed(text: str, start: int) -> str:
    """The balanced [...] literal that starts at or after ``start``."""
    i = text.index("[", start)
    depth = 0
    for j in range(i, len(text)):
        if text[j] == "[":
            depth += 1
        elif text[j] == "]":
            depth -= 1
            if depth == 0:
                return text[i:j + 1]
    raise ValueError("unbalanced brackets")


def _floats(value):
    """A literal's nested lists with each number a float; an integer past the float range (400 digits) is
    infinite, so its point is dropped like any non-finite one instead of the array refused."""
    if isinstance(value, (list, tuple)):
        return [_floats(v) for v in value]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError("not a number")
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _not_a_number(literal: str) -> tuple[int, str] | None:
    """(line within ``literal``, its text) of the first element of an array literal that is no number, or None."""
    try:
        tree = ast.parse(literal, mode="eval")
    except SyntaxError as e:  # a word Python does not read ('1.2.3', '0,85')
        lines = literal.splitlines()
        if not e.lineno or e.lineno > len(lines):
            return None
        line, at = lines[e.lineno - 1], (e.offset or 1) - 1
        cells = [cell for cell in re.finditer(r"[^,\[\]()\s]+", line) if cell.start() <= at < cell.end() + 1]
        return e.lineno, (cells[0].group() if cells else line.strip())[:60]
    except (ValueError, MemoryError, RecursionError):
        return None
    # down through the brackets only: an element that is neither a bracket nor a number is a bad cell, and what is
    # inside it (a call's arguments) is not looked at, so the walk is linear in the cells
    outermost, stack = [], [tree.body]
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.List, ast.Tuple)):
            stack.extend(node.elts)
        elif not _numeric_literal(node):
            outermost.append(node)
    if not outermost:
        return None
    first = min(outermost, key=lambda node: (node.lineno, node.col_offset))
    return first.lineno, (ast.get_source_segment(literal, first) or "")[:60]


def _numeric_literal(node: ast.AST) -> bool:
    """A literal number, signed or not, as a map's arrays hold them (``-0.5``, ``1e3``)."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        node = node.operand
    return isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool)


def _refuse_beyond_bound(name: str, values: np.ndarray, literal: str, start: int) -> None:
    """A finite value beyond :data:`MAX_MEASURED` in a map's array (``1e308`` typed for a missing one, a run-away
    export) refused naming its line (``start`` lines precede the literal): a map holds nothing that large, and the
    request cannot hold it (it was refused at its place in the request, ``positions/0/flow/0``, no line named)."""
    finite = values[np.isfinite(values)]
    if not finite.size or np.abs(finite).max() <= MAX_MEASURED:
        return
    beyond = []
    for node in ast.walk(ast.parse(literal, mode="eval")):  # parsed before, by literal_eval
        if not isinstance(node, (ast.UnaryOp, ast.Constant)) or not _numeric_literal(node):
            continue
        value = _floats(ast.literal_eval(node))
        if math.isfinite(value) and abs(value) > MAX_MEASURED:
            beyond.append((node.lineno, node.col_offset, ast.get_source_segment(literal, node) or f"{value:g}"))
    line, _, written = min(beyond)
    line += start
    mend = ("a speed line's setting: correct it" if name in ("NcMap", "alphaMap") else
            "a placeholder for a missing value? Write 0 there: a point that is not positive is dropped, with a note")
    raise reject(f"{name}, line {line}: {written} is beyond {MAX_MEASURED:g}, no value of a map ({mend})",
                 ("file", "line", line))


def _parse_map_data(text: str) -> tuple[list[dict], list[Diagnostic], list[str]]:
    """A pyCycle/NPSS ``MapData`` compressor map (``alphaMap``, ``NcMap``, ``RlineMap`` and the tables
    ``WcMap``, ``PRmap``, ``effMap`` indexed [alpha][Nc][R-line], or [Nc][R-line] without alpha). The text is
    read, never run: only the array literals are evaluated (``ast.literal_eval``). Each (alpha, Nc) is a
    speed line (theta = alpha, phi = Nc); points whose values are not positive and finite are dropped and
    reported; a line with fewer than 3 points left is dropped and reported. A value beyond 1e12 is refused naming its
    line."""
    arrays: dict[str, np.ndarray] = {}
    text = text.replace("\r\n", "\n").replace("\r", "\n")  # classic Mac line ends: ``^`` sees only LF
    for m in _MAP_ARRAY.finditer(text):
        name = m.group(1)
        try:
            literal = _bracketed(text, m.end() - 1)
        except ValueError:  # the brackets never close: the file ends inside this array
            line = text.count("\n", 0, m.start(1)) + 1
            raise reject(f"{name} (line {line}) is not closed before the file ends: the file was cut? The map "
                         "needs the whole table.", ("file", name), type="truncated_file") from None
        start = text.count("\n", 0, text.index("[", m.end() - 1))
        try:
            arrays[name] = np.array(_floats(ast.literal_eval(literal)), dtype=float)
        except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
            where = _not_a_number(literal)
            if where is None:
                raise reject(f"{name}: not a numeric array literal (nested lists of numbers)", ("file", name)) from None
            line, written = start + where[0], where[1]
            raise reject(f"{name}, line {line}: {written!r} is not a number (the map's arrays are nested lists of "
                         "numbers)", ("file", "line", line)) from None
        _refuse_beyond_bound(name, arrays[name], literal, start)
    missing = [n for n in ("NcMap", "WcMap", "PRmap", "effMap") if n not in arrays]
    if missing:
        raise reject(f"no compressor MAP_DATA here: missing {', '.join(missing)} (a pyCycle/NPSS map defines "
                     "alphaMap, NcMap, RlineMap, WcMap, PRmap and effMap)")
    nc = arrays["NcMap"].ravel()
    alpha = arrays.get("alphaMap", np.zeros(1)).ravel()
    tables = {}
    for name in ("WcMap", "PRmap", "effMap"):
        a = arrays[name]
        if a.ndim == 2:
            a = a[None]
        if a.ndim != 3 or a.shape[:2] != (len(alpha), len(nc)):
            raise reject(f"{name} has shape {arrays[name].shape}; expected (alpha {len(alpha)}, Nc {len(nc)}, "
                         "R-lines)", ("file", name))
        tables[name] = a
    if not tables["WcMap"].shape == tables["PRmap"].shape == tables["effMap"].shape:
        raise reject("WcMap, PRmap and effMap differ in shape", ("file",))
    positions, dropped, short, dropped_at = [], 0, [], []
    for i, al in enumerate(alpha):
        for k, n in enumerate(nc):
            w, pr, eff = tables["WcMap"][i, k], tables["PRmap"][i, k], tables["effMap"][i, k]
            ok = np.isfinite(w) & np.isfinite(pr) & np.isfinite(eff) & (w > 0) & (pr > 0) & (eff > 0) & (eff <= 1)
            dropped += int(np.sum(~ok))
            for j in np.flatnonzero(~ok)[:max(0, MAX_DROPPED_NAMED - len(dropped_at))]:
                name = next(t for t, v in (("WcMap", w[j]), ("PRmap", pr[j]), ("effMap", eff[j]))
                            if not (np.isfinite(v) and v > 0) or (t == "effMap" and v > 1))
                dropped_at.append({"table": name, "index": [i, k, int(j)] if len(alpha) > 1 else [k, int(j)],
                                   "Nc": float(n), "value": str(tables[name][i, k, j])})
            if ok.sum() < 3:
                short.append({"alpha": float(al), "Nc": float(n), "points": int(ok.sum())})
                continue
            positions.append({"setting": [float(al), float(n)] if len(alpha) > 1 else [float(n)],
                              "flow": w[ok].tolist(), "pressure": pr[ok].tolist(), "efficiency": eff[ok].tolist()})
    if not positions:
        eff = tables["effMap"][np.isfinite(tables["effMap"])]
        if eff.size and np.all((eff > FRACTIONS) & (eff <= 100)):
            raise reject(f"effMap holds {eff.min():g}..{eff.max():g}: per cent, where pyCycle's effMap is a fraction "
                         "(0.85 for 85 %); divide it by 100", ("file", "effMap"))
        raise reject("no speed line of the map has 3 usable points (positive, finite, efficiency <= 1)")
    names = ["alpha", "Nc"] if len(alpha) > 1 else ["Nc"]
    notes = [Diagnostic(code="upload_settings", message=f"pyCycle/NPSS map: {len(positions)} speed lines over "
                        f"{' and '.join(names)}.", details={"names": names})]
    speeds = np.array(sorted({p["setting"][-1] for p in positions}))
    if speeds.max() > MAX_RELATIVE_SPEED:
        # pyCycle's NcMap is the corrected speed over its design value (its maps: 0.5 to 1.1, 1.0 at design); per
        # cent of design there reads 100 times the speed, and a query or the exports at a relative speed miss the map
        notes.append(Diagnostic(code="implausible_speed", message=(
            f"NcMap holds {speeds.min():g}..{speeds.max():g}: pyCycle's NcMap is the relative corrected speed (1.0 "
            f"at design; its maps hold 0.5 to 1.1), plausible up to {MAX_RELATIVE_SPEED:g}: per cent of design"
            f"{' (divide by 100)' if speeds.max() <= 150 else ''} or rpm? The speeds are kept as written, and "
            "queries and the cycle-code exports take them so."),
            details={"quantity": "Nc", "table": "NcMap", "values": [float(speeds.min()), float(speeds.max())],
                     "range": [0.0, MAX_RELATIVE_SPEED]}))
    if dropped or short:
        points_at = "; ".join(f"{d['table']}{d['index']} = {d['value']} (Nc {d['Nc']:g})" for d in dropped_at[:5])
        notes.append(Diagnostic(code="upload_points_dropped",
                                message=f"{dropped} map point(s) without positive finite values (or efficiency above "
                                f"1) dropped{': ' + points_at + ('; …' if dropped > 5 else '') if dropped else ''}; "
                                f"{len(short)} speed line(s) with fewer than 3 points left out.",
                                details={"points": dropped, "at": dropped_at, "lines": short[:100]}))
    return positions, notes, names


# pyCycle states its tables' units beside them: ``Map.units['WcMap'] = 'lbm/s'`` or ``units = {'WcMap': 'lbm/s'}``.
_MAP_FLOW_UNIT = re.compile(r"""(?:units\s*\[\s*|units\s*=\s*\{[^}]*?)['"]WcMap['"]\s*[\]:]\s*=?\s*['"]([^'"]+)['"]""")


def _names_units(node: ast.expr) -> bool:
    return isinstance(node, ast.Name) and node.id == "units" or isinstance(node, ast.Attribute) and node.attr == "units"


def _literal_text(node: ast.expr | None) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def _flow_unit_assignments(text: str) -> list[tuple[int, str | None]] | None:
    """(line, unit) of each statement that sets the WcMap unit, in the order Python runs them: ``units['WcMap'] =
    '...'``, and ``units = {...}`` (or ``dict(...)``), which leaves no unit when it holds no WcMap. None when the text
    is no Python (then the lines are searched, comments left out)."""
    try:
        tree = ast.parse(text)
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return None
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Assign):
            continue
        for target in node.targets:
            if isinstance(target, ast.Subscript) and _names_units(target.value) \
                    and _literal_text(target.slice) == "WcMap":
                found.append((node.lineno, node.col_offset, _literal_text(node.value)))
            elif _names_units(target):
                value = node.value
                if isinstance(value, ast.Dict):
                    pairs = dict(zip((_literal_text(k) for k in value.keys), value.values))
                elif isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id == "dict":
                    pairs = {k.arg: k.value for k in value.keywords}
                else:
                    pairs = {}
                found.append((node.lineno, node.col_offset, _literal_text(pairs.get("WcMap"))))
    return [(line, unit) for line, _, unit in sorted(found, key=lambda f: f[:2])]


def _map_data_flow_unit(text: str) -> str | None:
    """The unit a pyCycle map states for ``WcMap`` (read, so a map in lbm/s is not a flow without a unit) as pyCycle
    would hold it after importing the file: its last assignment counts, and a unit in a comment or a docstring (an
    old rig's, commented out) is no assignment. Its ``NcMap`` unit is not read: pyCycle's own maps label relative
    speeds 'rpm'."""
    assignments = _flow_unit_assignments(text)
    if assignments is None:
        uncommented = "\n".join(line.split("#", 1)[0] for line in text.splitlines())
        assignments = [(uncommented.count("\n", 0, m.start()) + 1, m.group(1))
                       for m in _MAP_FLOW_UNIT.finditer(uncommented)]
    if not assignments:
        return None
    line, unit = assignments[-1]
    if unit is None:
        return None
    try:
        check_quantity("flow", unit)
    except UnitError as e:
        raise reject(f"units['WcMap'] = {unit!r} (line {line}): {e}", ("file", "units", "WcMap")) from None
    return unit


def _map_data_cut(text: str) -> Diagnostic | None:
    """A pyCycle map whose file ends inside a statement after its tables (an array cut short is refused by
    :func:`_parse_map_data`): the tables are whole and read, but what followed them, the units pyCycle states
    (``units['WcMap'] = 'lbm/s'``), is lost; the flow then came out without its unit, and nothing said the file was
    cut. Cut there means: Python cannot parse the end of the file, or the file ends mid-line in a statement that
    does nothing (``Map.units['WcMap']``, an assignment without its value), which no map file writes."""
    try:
        tree = ast.parse(text)
    except SyntaxError as e:
        if not (ends_mid_line(text) or "never closed" in str(e.msg) or "EOF" in str(e.msg)):
            return None
        line = e.lineno or text.rstrip().count("\n") + 1
    except (ValueError, RecursionError, MemoryError):
        return None
    else:
        last = tree.body[-1] if tree.body else None
        if not (ends_mid_line(text) and isinstance(last, ast.Expr)
                and not isinstance(last.value, (ast.Call, ast.Constant))):
            return None
        line = last.lineno
    flow = _map_data_flow_unit(text)
    return truncated_file(line, "the statement there is cut (the file was cut after its tables?): the tables were "
                          "read whole, what follows them is not" + (
                              f"; the flow's unit was stated before the cut ({flow})" if flow else
                              "; no unit of the flow (WcMap) was read, so the flow has none (lbm/s as pyCycle's maps, "
                              "or kg/s?)"), what="pyCycle map statements after the tables")


MAX_CSV_ROWS = 200_000


FORM = FormRules(PerfmapRequest, units="quantities")


def parse_upload(source: StoredInput, options: dict | None) -> PerfmapRequest:
    """CSV (columns theta, phi, flow, pressure, efficiency; rules in the module docstring), an Excel
    workbook, a pyCycle/NPSS map or a JSON request, by the file's extension (the intake has checked it), with the
    upload form's ``options`` joined to it by the rules of :mod:`plantsolve.solvers.upload_form`: the form's
    ``units`` (``{"flow": "kg/s"}``) states what the file leaves unstated (:func:`_with_units_option`)."""
    if source.extension == ".json":
        text = _decode(source.read(), ".json")
        body = json_object(text, "the JSON file must hold a request object or a list of positions", list_as="positions",
                           refuse_cut=True)
        refuse_other_kind(body, "perfmap")
        form = form_beside(body, options, FORM)
        origin = {"format": "json", "document": "positions" if _bare_list(text) else "request"}
        own = body.get("source")
        own = {} if own is None else own  # a null source is none: the reader's is stated
        if isinstance(own, dict):  # anything else is refused naming file.source
            body = {**body, "source": {**own, **origin}}
        return _validated(_with_units_option(body, form.units, "JSON request"), form, origin=origin)
    form = read_form(options, FORM)
    try:
        return _parse(source, form)
    except InputRejected as rejected:  # a reading option the reader refused (a sheet the workbook lacks)
        raise InputRejected([form.named(e) or e for e in rejected.errors]) from None


def _parse(source: StoredInput, form: Form) -> PerfmapRequest:
    """The request of a table or map file (CSV, workbook, pyCycle or GasTurb map)."""
    ext = source.extension
    content = source.read()
    if ext == ".xlsx":
        positions, lines, notes, meta = _parse_xlsx(content, form.read.columns, form.read.sheet)
        body = {"positions": positions, **meta, "upload_warnings": [d.model_dump() for d in notes]}
        body["source"] = {**body["source"], "format": "xlsx", "rows": lines}
        return _validated(_with_units_option(body, form.units, "sheet"), form)
    if ext == ".map":  # GasTurb / GSP map tables (gasturb_map.py)
        body, speed_lines, _ = gasturb_request_body(content, None if form.units is None else {"units": form.units})
        body["source"] = {"format": "gasturb", "setting_lines": speed_lines}
        return _validated(body, form, places=lambda: _map_places(body, content))
    n_lines = content.count(b"\n") if ext == ".csv" else 0
    if n_lines > MAX_CSV_ROWS:
        # counted before any parsing: a table far beyond any rig's is refused in milliseconds
        raise reject(f"the table has {n_lines:,} lines; at most {MAX_CSV_ROWS:,} rows are read "
                     "(2,000 settings of 100 points)")
    text = _decode(content, ext)
    lines: list[list[int]] = []
    if ext == ".py":
        positions, notes, names = _parse_map_data(text)
        cut = _map_data_cut(text)
        notes = notes + ([cut] if cut else [])
        body = {"positions": positions, "setting_names": names,
                "units": {"flow": _map_data_flow_unit(text), "pressure": "1", "efficiency": "1"},
                "upload_warnings": [d.model_dump() for d in notes], "source": {"format": "pycycle"}}
    else:
        positions, lines, notes, meta = _parse_csv(text, form.read.columns)
        body: dict = {"positions": positions, **meta}
        body["source"] = {**body["source"], "format": "csv", "rows": lines}
        if notes:
            body["upload_warnings"] = [d.model_dump() for d in notes]
    return _validated(_with_units_option(body, form.units, "CSV" if ext == ".csv" else "pyCycle map"), form)


def _map_places(body: dict, content: bytes) -> dict[tuple, int]:
    """The file line of each value of a GasTurb/GSP map's request that is no point, for a refusal to name: the flow's
    unit (the line whose brackets state it, the Mass Flow table's or the title; a unit from the form is the form's)."""
    text, places = decode_text(content), {}
    if unit := (body.get("units") or {}).get("flow"):
        stated = re.compile(rf"\[\s*{re.escape(unit)}\s*\]")
        n = next((n for n, line in enumerate(text.splitlines(), 1) if stated.search(line)), None)
        if n is not None:
            places[("units", "flow")] = n
    return places


_OPTION_QUANTITIES = ("flow", "pressure")


def _with_units_option(body: dict, given: Any, what: str) -> dict:
    """``body`` with the upload form's ``units`` (``{"flow": "kg/s"}``, as a GasTurb map takes it) read into it: the
    unit of a quantity the file leaves unstated (a header 'flow' without brackets), said in a note; one contradicting
    the unit the file states is refused naming both. It was refused as 'extra inputs', while the message for
    ``result_units`` asked for ``units.flow``, which an upload had no way to give."""
    if given is None:
        return body
    if not isinstance(given, dict):
        raise reject("options.units must be an object such as {\"flow\": \"kg/s\"}", ("options", "units"))
    if not isinstance(body.get("units") or {}, dict):
        return body  # a request file's units that are no object: refused by the schema, naming file.units
    units = dict(body.get("units") or {})
    notes = list(body.get("upload_warnings") or [])
    for quantity, unit in given.items():
        loc = ("options", "units", quantity)
        if quantity not in _OPTION_QUANTITIES:
            raise reject(f"options.units.{quantity}: a {what}'s units given as an option are those of flow and "
                         "pressure" + (" (an efficiency's unit is its column's: 'efficiency [%]')"
                                       if quantity == "efficiency" else ""), loc)
        if not isinstance(unit, str):
            raise reject(f"options.units.{quantity} must be a unit text such as 'kg/s'", loc)
        try:
            check_quantity(quantity, unit)
        except UnitError as e:
            raise reject(f"options.units.{quantity}: {e}", loc) from None
        stated = units.get(quantity)
        if stated:
            if not isinstance(stated, str) or not _same_unit(stated, unit):
                raise reject(f"options.units.{quantity} {unit!r} contradicts the {what}, which states {stated!r}: say "
                             "which is right (leave the option out to use the file's, or correct the file)", loc)
            continue
        units[quantity] = unit
        notes.append(Diagnostic(code="upload_units_option", message=f"The {what} states no unit of its {quantity}: "
                                f"read in {unit}, as options.units.{quantity} says.",
                                details={"quantity": quantity, "unit": unit}).model_dump())
    return {**body, "units": units, "upload_warnings": notes}


def _validated(body: dict, form: Form, places: Callable[[], dict[tuple, int]] | None = None,
               origin: dict | None = None) -> PerfmapRequest:
    """The request of a parsed file with the form's options laid in, the form's places of its values kept in its
    ``source`` (a refusal when loading names them too); each bad value named where the user wrote it
    (:func:`placed`: the form's field, the JSON file's path, the table's row or the line ``places`` gives;
    ``origin``, what the reader found, where the file's own ``source`` is no object to keep it in)."""
    body = merged(body, form, FORM)
    if isinstance(body.get("source"), dict):
        body["source"] = {**body["source"], "form": _form_places(body, form)}
    try:
        return validated(PerfmapRequest, body, ())
    except InputRejected as e:
        where = body["source"] if isinstance(body.get("source"), dict) else (origin or {})
        at_line = places() if places else {}
        errs = [placed(fe, where, lambda i: _setting_of(body["positions"][i]), at_line) for fe in e.errors]
        seen, unique = set(), []
        for fe in errs:  # the three lists of one short setting give one message
            if (fe.loc, fe.msg) not in seen:
                seen.add((fe.loc, fe.msg))
                unique.append(fe)
        raise InputRejected(unique) from None


def _form_places(body: dict, form: Form) -> dict[str, list[str]]:
    """The request paths whose values the form gave ('options.beta_grid', 'units.flow') and their places in the
    form: its options, and the units it gave that the request uses (:func:`_units_from_form`)."""
    given = form.units if isinstance(form.units, dict) else {}
    return {**{f"options.{name}": list(at) for name, at in form.at.items()},
            **{f"units.{q}": ["options", "units", q] for q in given if q in _units_from_form(body)}}


def _units_from_form(body: dict) -> set[str]:
    """The quantities whose unit in the request is the form's: a table or JSON file keeps a unit it states (the
    form's, alike, was not used: a refusal of it is the file's) and takes the form's where it states none, said in an
    ``upload_units_option`` note; a GasTurb map takes the form's units over its own."""
    source = body.get("source") if isinstance(body.get("source"), dict) else {}
    if source.get("format") == "gasturb":
        return set(body.get("units") or {})
    return {d["details"]["quantity"] for d in body.get("upload_warnings") or []
            if isinstance(d, dict) and d.get("code") == "upload_units_option"}


def _bare_list(text: str) -> bool:
    """Whether a JSON file is a list of positions saved on its own (read as the request's ``positions``)."""
    return text.lstrip("\ufeff \t\r\n").startswith("[")


def _setting_of(position: dict) -> tuple:
    return tuple(position.get("setting") or (position["theta"], position["phi"]))
