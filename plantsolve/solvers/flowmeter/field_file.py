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

import re
from dataclasses import dataclass, field

import numpy as np

LENGTH_M = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "in": 0.0254, "ft": 0.3048}
FIELD_T = {"T": 1.0, "mT": 1e-3, "uT": 1e-6, "µT": 1e-6, "μT": 1e-6, "nT": 1e-9, "G": 1e-4, "Gs": 1e-4,
           "gauss": 1e-4, "kG": 0.1}
ROLES = ("x", "y", "z", "bx", "by", "bz")
# a header token: a name, its unit in brackets, and COMSOL's '@ t=0.1' of a solution in a sweep
TOKEN = re.compile(r"[^\s()\[\]]+(?:\s*[(\[][^)\]]*[)\]])?(?:\s*@\s*\S+)?")
# COMSOL's header keys (its .csv export writes '% Length unit,mm': known by the key, not the colon)
COMSOL_META = {"model", "version", "date", "dimension", "nodes", "expressions", "description", "length unit", "table"}
META = re.compile(r"^\s*([A-Za-z][A-Za-z ]*?)\s*[:,]\s*(.*)$")
UNIT = re.compile(r"[(\[]\s*([^)\]]*?)\s*[)\]]")


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


def _role(token: str) -> str | None:
    name = UNIT.sub("", token.split("@")[0]).strip()
    name = name.rsplit(".", 1)[-1].replace("_", "").replace(" ", "").lower()
    return name if name in ROLES else None


def _unit(token: str) -> str | None:
    found = UNIT.search(token.split("@")[0])
    return found.group(1) if found and found.group(1) else None


def _split(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return [part.strip() for part in line.split(delimiter)]


def _delimiter(line: str) -> str | None:
    for candidate in ("\t", ";", ","):
        if candidate in line:
            return candidate
    return None


def read_field_file(text: str, units: str) -> FieldTable:
    """The rows of a field file, converted to the request's ``units`` and tesla."""
    lines = text.lstrip("\ufeff").splitlines()  # a byte-order mark a Windows tool left before the first line
    meta: dict[str, str] = {}
    header: tuple[int, str] | None = None
    comsol = False
    first_data = None
    for number, raw in enumerate(lines, start=1):
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
            first_data = number
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
    delimiter = _delimiter(lines[first_data - 1].strip())
    header_delimiter = _delimiter(header[1])
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
        raise FieldFileError(f"line {header[0]}: the header names no column {', '.join(missing)} (it names "
                             f"{', '.join(repr(t) for t in tokens)}); a field file needs x, y, z, Bx and By")
    length_unit = _length_unit(tokens, roles, meta, header[0])
    field_unit = _field_unit(tokens, roles, header[0])
    used = [roles[r][0] for r in ROLES if r in roles]
    decimal_comma = delimiter == ";"
    data, numbers = [], []
    for number in range(first_data, len(lines) + 1):
        line = lines[number - 1].strip()
        if not line or line.startswith(("%", "#")):
            continue
        parts = _split(line, delimiter)
        if len(parts) != len(tokens):
            raise FieldFileError(f"line {number}: {len(parts)} values for the header's {len(tokens)} columns (line "
                                 f"{header[0]}){'; a cut file?' if number == len(lines) else ''}")
        try:
            values = [float(parts[c].replace(",", ".") if decimal_comma else parts[c]) for c in used]
        except ValueError:
            raise FieldFileError(f"line {number}: '{line[:60]}' is not a row of numbers") from None
        if not all(np.isfinite(values)):
            raise FieldFileError(f"line {number}: a value is {'NaN' if any(np.isnan(values)) else 'infinite'} (COMSOL "
                                 "writes NaN at points outside its geometry): export the field on a grid inside the "
                                 "model, around the liner section")
        data.append(values)
        numbers.append(number)
    rows = np.asarray(data, dtype=float)
    length_factor = 1.0 if length_unit is None else LENGTH_M[length_unit] / LENGTH_M[units]
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
    return FieldTable(rows, np.asarray(numbers), length_unit, field_unit, conversions,
                      f"{kind}, {len(rows)} rows, columns {', '.join(tokens[c] for c in used)}")


def _length_unit(tokens: list[str], roles: dict[str, list[int]], meta: dict[str, str], line: int) -> str | None:
    stated = {_unit(tokens[roles[r][0]]) for r in ("x", "y", "z")} - {None}
    if "length unit" in meta:
        stated.add(meta["length unit"])
    if len(stated) > 1:
        raise FieldFileError(f"line {line}: the coordinates are given in {' and '.join(sorted(stated))}: which is meant "
                             "is not known")
    unit = next(iter(stated), None)
    if unit is not None and unit not in LENGTH_M:
        raise FieldFileError(f"line {line}: length unit '{unit}' is not known (m, cm, mm, um, in, ft)")
    return unit


def _field_unit(tokens: list[str], roles: dict[str, list[int]], line: int) -> str | None:
    stated = {_unit(tokens[roles[r][0]]) for r in ("bx", "by", "bz") if r in roles}
    if len(stated - {None}) > 1 or (len(stated) > 1 and None in stated):
        raise FieldFileError(f"line {line}: the field's columns state different units "
                             f"({', '.join(tokens[roles[r][0]] for r in ('bx', 'by', 'bz') if r in roles)})")
    unit = next(iter(stated), None)
    if unit is not None and unit not in FIELD_T:
        raise FieldFileError(f"line {line}: field unit '{unit}' is not known (T, mT, uT, G)")
    return unit
