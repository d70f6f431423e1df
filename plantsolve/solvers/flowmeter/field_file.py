"""Field files as FE tools export them: COMSOL's spreadsheet export and CSVs with a header.

COMSOL (Results > Export > Data, spreadsheet format) writes header lines starting with '%' ('% Model:',
'% Version:', '% Date:', '% Dimension:', '% Nodes:', '% Expressions:', '% Description:', '% Length unit:')
and last the columns ('% x y z mf.Bx (T) mf.By (T) mf.Bz (T)', the unit of each expression in brackets),
then one row per point, blank separated (its .csv export: the same lines comma separated). Other tools
write a CSV whose first line names the columns ('x [mm], y [mm], z [mm], Bx [T], By [T]'). The columns are
found by name (a physics prefix such as 'mf.' or 'mfnc.' dropped), never by position; COMSOL's grid and
sectionwise formats (the values' order implied, not written) are refused naming the spreadsheet format.
"""

from __future__ import annotations

import io
import re
from dataclasses import dataclass, field

import numpy as np

from plantsolve.solvers.cut_number import last_lines, short_number, written
from plantsolve.solvers.length_units import SIZES, two_readings, unit_named
from plantsolve.solvers.skipped_input import ends_mid_line

FIELD_T = {"T": 1.0, "mT": 1e-3, "uT": 1e-6, "µT": 1e-6, "μT": 1e-6, "nT": 1e-9, "G": 1e-4, "Gs": 1e-4,
           "gauss": 1e-4, "kG": 0.1, "mG": 1e-7, "tesla": 1.0, "millitesla": 1e-3, "microtesla": 1e-6, "nanotesla": 1e-9,
           "milligauss": 1e-7, "kilogauss": 0.1,
           # the tesla in SI base spellings, as older FE tools and field mappers label it
           "Wb/m2": 1.0, "Wb/m^2": 1.0, "Wb/m²": 1.0, "Wb/m**2": 1.0, "V*s/m^2": 1.0, "Vs/m2": 1.0, "Vs/m^2": 1.0,
           "V*s/m2": 1.0, "V·s/m²": 1.0}
# units read only as written: mT (MT would be megatesla), kG (kg is a mass), mG (MG megagauss); the others in any case
# ([Gauss], [MM])
CASE_KEPT = {"mT", "kG", "mG"}
ROLES = ("x", "y", "z", "bx", "by", "bz")
# a header token: a name, its unit in brackets, and COMSOL's '@ t=0.1' of a solution in a sweep
# (a unit holds no bracket: each bracket ends a scan, so a line of unclosed brackets is read in linear time)
TOKEN = re.compile(r"[^\s()\[\]]+(?:\s*[(\[][^()\[\]]*[)\]])?(?:\s*@\s*\S+)?")
# COMSOL's header keys (its .csv export writes '% Length unit,mm': known by the key, not the colon)
COMSOL_META = {"model", "version", "date", "dimension", "nodes", "expressions", "description", "length unit", "table"}
# the key's letters and blanks cannot match the separator: one way to read a line, linear in its length
META = re.compile(r"([A-Za-z][A-Za-z ]*)[:,](.*)")
UNIT = re.compile(r"[(\[]([^()\[\]]*)[)\]]")


class FieldFileError(ValueError):
    """The file cannot be read as a field; the message names the line."""


@dataclass
class FieldTable:
    """The rows of a field file in the request's length unit and tesla."""

    rows: np.ndarray  # (n, 5 or 6): x, y, z, bx, by[, bz]
    lines: np.ndarray  # each row's line number in the file (1-based)
    length_unit: str | None  # as the file states it, None when it states none
    field_unit: str | None
    conversions: list[dict] = field(default_factory=list)
    description: str = ""
    cut: str | None = None  # why the last row's last value may be cut (the file ends inside it), else None


def _role(token: str) -> str | None:
    name = UNIT.sub("", token.split("@")[0]).strip()
    name = name.rsplit(".", 1)[-1].replace("_", "").replace(" ", "").lower()
    return name if name in ROLES else None


def _unit(token: str) -> str | None:
    found = UNIT.search(token.split("@")[0])
    return found.group(1).strip() or None if found else None


def _split(line: str, delimiter: str | None) -> list[str]:
    """A line's fields: quotes around a field (R's write.csv, pandas) and a delimiter ending the line dropped."""
    if delimiter is None:
        return line.split()
    parts = [part.strip().strip('"').strip() for part in line.split(delimiter)]
    return parts[:-1] if len(parts) > 1 and parts[-1] == "" and line.rstrip().endswith(delimiter) else parts


def _lines(text: str, start: int = 0, number: int = 1):
    """(line number, line, its offset, the next line's offset) from ``start`` on, one at a time: a field file of
    millions of rows is not split into millions of strings."""
    while start < len(text):
        end = text.find("\n", start)
        end = len(text) if end < 0 else end
        yield number, text[start:end].rstrip("\r"), start, end + 1
        start, number = end + 1, number + 1


def _delimiter(line: str) -> str | None:
    for candidate in ("\t", ";", ","):
        if candidate in line:
            return candidate
    return None


# a number as a decimal-comma locale writes it (an integer, or digits a comma digits), among blanks
_COMMA_NUMBER = re.compile(r"[-+]?\d+(?:,\d+)?(?:[eE][-+]?\d+)?")


def _blank_separated_decimal_commas(line: str) -> bool:
    """Whether a row separates its values by blanks and writes decimal commas ('-60  0,00092  0,0021'): every
    blank-separated field a number so written, at least one with a comma. '1, 2, 3' (comma separated, blanks after)
    is not: its fields end in the comma."""
    fields = line.split()
    return (len(fields) > 1 and any("," in f for f in fields)
            and all(_COMMA_NUMBER.fullmatch(f) for f in fields))


def read_field_file(text: str, units: str) -> FieldTable:
    """The rows of a field file, converted to the request's ``units`` and tesla."""
    text = text.lstrip("\ufeff")  # a byte-order mark a Windows tool left before the first line
    if "\n" not in text:
        text = text.replace("\r", "\n")  # a classic Mac file's line ends
    meta: dict[str, str] = {}
    header: tuple[int, str] | None = None
    comsol = False
    first_data = None
    for number, raw, offset, _ in _lines(text):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.startswith("%"):
            comsol = True
            body = line[1:].strip()
            if re.match(r"^(Grid|Coordinates|Elements|Data)\b", body):
                raise FieldFileError(
                    f"line {number}: '% {body.split()[0]}' is COMSOL's grid or sectionwise format, where the values' "
                    "order is implied, not written; export the data in the spreadsheet format (one row per point: "
                    "x, y, z and the expressions)")
            found = META.match(body)
            if found and (found.group(1).strip().lower() in COMSOL_META or ":" in body):
                meta[found.group(1).strip().lower()] = found.group(2).strip()
            else:
                header = (number, body)
            continue
        if re.match(r"^[-+.\d]", line) and not re.match(r"^[-+]?[A-Za-z]", line):
            first_data = (number, offset, line)
            break
        if header is not None and not comsol:
            raise FieldFileError(f"line {number}: '{line[:60]}' is neither a number row nor the header (line {header[0]})")
        header = (number, line)
    if header is None:
        raise FieldFileError("the file has no header naming its columns (x, y, z, Bx, By[, Bz], e.g. 'x [mm], y [mm], "
                             "z [mm], Bx [T], By [T]' or COMSOL's '% x y z mf.Bx (T) mf.By (T)'): the columns' order "
                             "is not guessed")
    if first_data is None:
        raise FieldFileError(f"the file has a header (line {header[0]}) but no rows of numbers")
    delimiter = _delimiter(first_data[2])
    header_delimiter = _delimiter(header[1])
    if header_delimiter is None and delimiter == "," and _blank_separated_decimal_commas(first_data[2]):
        delimiter = None  # COMSOL's blank-separated rows from a decimal-comma locale: its commas separate nothing
    tokens = _split(header[1], header_delimiter) if header_delimiter else TOKEN.findall(header[1])
    tokens = [t for t in tokens if t]
    roles: dict[str, list[int]] = {}
    for column, token in enumerate(tokens):
        role = _role(token)
        if role:
            roles.setdefault(role, []).append(column)
    for role, columns in roles.items():
        if len(columns) > 1:
            names = ", ".join(f"'{tokens[c]}'" for c in columns)
            raise FieldFileError(f"line {header[0]}: {len(columns)} columns give {role} ({names}): the file holds "
                                 "several solutions (a sweep or times); export one")
    missing = [r for r in ROLES[:5] if r not in roles]
    if missing:
        named = ", ".join(repr(t[:40]) for t in tokens[:10]) + (f" and {len(tokens) - 10} more" if len(tokens) > 10 else "")
        raise FieldFileError(f"line {header[0]}: the header names no column {', '.join(missing)} (it names "
                             f"{named}); a field file needs x, y, z, Bx and By")
    length_unit = _length_unit(tokens, roles, meta, header[0])
    field_unit = _field_unit(tokens, roles, header[0])
    used = [roles[r][0] for r in ROLES if r in roles]
    rows, numbers = _rows(text, first_data[:2], len(tokens), used, delimiter, header[0])
    length_factor = 1.0 if length_unit is None else SIZES[length_unit] / SIZES[units]
    field_factor = 1.0 if field_unit is None else FIELD_T[field_unit]
    conversions = []
    if length_unit is not None and length_factor != 1.0:
        rows[:, :3] *= length_factor
        conversions.append({"quantity": "magnetic field file: x, y, z", "from_unit": length_unit, "to_unit": units,
                            "factor": length_factor, "basis": "the file's header"})
    if field_unit is not None and field_factor != 1.0:
        rows[:, 3:] *= field_factor
        conversions.append({"quantity": "magnetic field file: B", "from_unit": field_unit, "to_unit": "T",
                            "factor": field_factor, "basis": "the file's header"})
    kind = "COMSOL spreadsheet export" if comsol else "CSV with a header"
    return FieldTable(rows, numbers, length_unit, field_unit, conversions,
                      f"{kind}, {len(rows)} rows, columns {', '.join(tokens[c] for c in used)}",
                      cut_last_value(text, delimiter, max(used)))


CUT_SAMPLE = 1000  # rows before the last whose digits the last value is held against
def cut_last_value(text: str, delimiter: str | None, column: int) -> str | None:
    """Why a file without a final line ending may end inside its last number (0.001641116268 -> 0.0016411), or
    None: its last value is shorter than its column's values above it by the file readers' one rule
    (:func:`~plantsolve.solvers.cut_number.short_number`: decimals, or significant digits between exponent-notation
    cells). Such a row reads whole, a number short of its digits (cut to '0.00', the field there is lost)."""
    if not ends_mid_line(text):
        return None
    lines = last_lines(text, CUT_SAMPLE + 1)
    if not lines:
        return None
    cells = [_split(line.strip(), delimiter) if delimiter else line.split() for line in lines]
    mark = "," if delimiter == ";" else None
    last = cells[-1][column] if len(cells[-1]) > column else None
    if last is None:
        return None
    short = short_number(written(last, mark), [written(c[column], mark) for c in cells[:-1] if len(c) > column])
    if short is None:
        return None
    return f"its last value {last.strip()!r} has {short.reason}"


def _rows(text: str, first: tuple[int, int], columns: int, used: list[int], delimiter: str | None,
           header: int) -> tuple[np.ndarray, np.ndarray]:
    """The number rows from line ``first`` (its number, its offset) on, the ``used`` columns, and each row's line
    number. numpy's reader takes a file of plain rows (at most 2,000,000, the grid's points) in one pass; any
    other file (comment lines among the rows, a row of text, NaN, a cut line) is read line by line, which names the
    line at fault."""
    number, start = first
    block = text[start:]
    # decimal commas: in a ';' file (Excel's CSV in a decimal-comma locale), and in a tab- or blank-separated one whose
    # numbers hold commas and no point (the same Excel's 'Text (tab delimited)', a blank-separated export from that
    # locale), where a comma can separate nothing
    decimal_comma = delimiter == ";" or (delimiter in ("\t", None) and "," in block and "." not in block)
    if decimal_comma:
        block = block.replace(",", ".")
    try:
        table = np.loadtxt(io.StringIO(block), delimiter=delimiter, comments=None, quotechar='"', ndmin=2)
    except ValueError:
        table = None
    if (table is not None and table.shape[1] == columns and np.all(np.isfinite(table[:, used]))
            and len(table) == block.count("\n", 0, len(block.rstrip())) + 1):
        return table[:, used], number + np.arange(len(table))
    return _rows_by_line(text, first, columns, used, delimiter, header, decimal_comma)


def _rows_by_line(text: str, first: tuple[int, int], columns: int, used: list[int], delimiter: str | None,
                  header: int, decimal_comma: bool) -> tuple[np.ndarray, np.ndarray]:
    first_number, start = first
    most = text.count("\n", start) + 1
    rows, numbers, count = np.empty((most, len(used))), np.empty(most, dtype=np.int64), 0
    for number, raw, _, after in _lines(text, start, first_number):
        line = raw.strip()
        if not line or line.startswith(("%", "#")):
            continue
        parts = _split(line, delimiter)
        if len(parts) != columns:
            raise FieldFileError(f"line {number}: {len(parts)} values for the header's {columns} columns (line "
                                 f"{header}){'; a cut file?' if not text[after:].strip() else ''}")
        try:
            values = [float(parts[c].replace(",", ".") if decimal_comma else parts[c]) for c in used]
        except ValueError:
            mixed = delimiter in ("\t", None) and not decimal_comma and "," in line
            raise FieldFileError(f"line {number}: '{line[:60]}' is not a row of numbers"
                                 + ("; decimal commas among decimal points: write the file in one" if mixed else "")
                                 ) from None
        if not all(np.isfinite(values)):
            raise FieldFileError(f"line {number}: a value is {'NaN' if any(np.isnan(values)) else 'infinite'} (COMSOL "
                                 "writes NaN at points outside its geometry): export the field on a grid inside the "
                                 "model, around the liner section")
        rows[count], numbers[count], count = values, number, count + 1
    return rows[:count], numbers[:count]


def _length_unit(tokens: list[str], roles: dict[str, list[int]], meta: dict[str, str], line: int) -> str | None:
    stated = {_unit(tokens[roles[r][0]]) for r in ("x", "y", "z")} - {None}
    if "length unit" in meta:
        stated.add(meta["length unit"])
    stated = {unit_named(unit, SIZES) or unit for unit in stated}  # [MM] and % Length unit: mm agree
    if len(stated) > 1:
        raise FieldFileError(f"line {line}: the coordinates are given in {' and '.join(sorted(stated))}: which is meant "
                             "is not known")
    unit = next(iter(stated), None)
    if unit is not None and (readings := two_readings(unit)) is not None:
        raise FieldFileError(f"line {line}: length unit {readings}")
    if unit is not None and unit_named(unit, SIZES) is None:
        raise FieldFileError(f"line {line}: length unit '{unit}' is not known (m, cm, mm, um, in, ft)")
    return None if unit is None else unit_named(unit, SIZES)


def _field_unit(tokens: list[str], roles: dict[str, list[int]], line: int) -> str | None:
    stated = {_unit(tokens[roles[r][0]]) for r in ("bx", "by", "bz") if r in roles}
    stated = {unit if unit is None else _known(unit, FIELD_T) or unit for unit in stated}
    if len(stated - {None}) > 1 or (len(stated) > 1 and None in stated):
        raise FieldFileError(f"line {line}: the field's columns state different units "
                             f"({', '.join(tokens[roles[r][0]] for r in ('bx', 'by', 'bz') if r in roles)})")
    unit = next(iter(stated), None)
    if unit is not None and _known(unit, FIELD_T) is None:
        raise FieldFileError(f"line {line}: field unit '{unit}' is not known (T, mT, uT, G, mG, Wb/m2, tesla, gauss)")
    return None if unit is None else _known(unit, FIELD_T)


def _known(unit: str, table: dict[str, float]) -> str | None:
    """The table's spelling of a unit: as written, else in another case where that is unambiguous."""
    if unit in table:
        return unit
    alike = {name for name in table if name.lower() == unit.lower() and name not in CASE_KEPT}
    return alike.pop() if len(alike) == 1 else None
