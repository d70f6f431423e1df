"""Parsing uploaded measurement files (CSV table or JSON request) into a PerfmapRequest.

CSV rules (as rig software and Excel write them):

- encoding: UTF-8 with or without BOM, UTF-16 with BOM (Excel "Unicode text"), otherwise
  Windows-1252; binary files (NUL bytes, a zip/xlsx workbook) are rejected;
- line ends LF, CRLF or CR; blank lines, lines of separators only (",,,,") and lines whose
  first non-blank character is ``#`` are skipped (also before the header);
- separator: the one of an Excel ``sep=;`` first line, else tab if the header line holds
  one, else ``;`` if it holds one, else ``,``;
  with ``;`` or tab a comma inside a number is a decimal comma (European Excel:
  ``0,85``; ``1.234,5`` with thousands dots too);
- header: the first remaining line. A column's name is matched case-insensitively after
  stripping unit suffixes in brackets or parentheses (``Flow (m3/s)``, ``Theta [deg]``) and
  folding ``_``/``-``/blanks; accepted names per field are in :data:`HEADER_ALIASES`
  (e.g. ``pressure ratio`` for pressure, ``eta``/``η`` for efficiency). An efficiency
  column whose unit is ``%`` (``Efficiency [%]``) is divided by 100; efficiencies above 1
  without that unit are rejected (percent is not guessed). Other columns are ignored with a
  warning in the result's report;
- rows: any order; rows with equal (theta, phi) form one setting (in order of first
  appearance). Exact duplicate rows are merged with a warning; the same flow twice with
  different values is rejected (flow must increase along a characteristic after sorting).

Every rejection is an :class:`InputRejected` whose loc starts with ``"file"``: ``("file",)``
for the file as a whole, ``("file", "header")`` for the header, ``("file", "row", n,
field)`` for a value, where ``n`` is the 1-based line number in the file (what an editor or
Excel shows).
"""

from __future__ import annotations

import csv
import json
import math
import re

from pydantic import ValidationError

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import FieldError, InputRejected, reject
from plantsolve.solvers.perfmap.validation import prepare

UPLOAD_EXTENSIONS = (".csv", ".json")
CSV_COLUMNS = ("theta", "phi", "flow", "pressure", "efficiency")
HEADER_ALIASES = {
    "theta": ("theta", "θ", "igv", "igv angle", "igv setting", "inlet guide vane"),
    "phi": ("phi", "φ", "ϕ", "diffuser", "diffuser angle", "diffuser setting"),
    "flow": ("flow", "flow rate", "flowrate", "mass flow", "massflow", "mass flow rate",
             "volume flow", "volume flow rate", "corrected flow"),
    "pressure": ("pressure", "pressure ratio", "pressure rise", "total pressure ratio",
                 "pr", "pi"),
    "efficiency": ("efficiency", "eta", "η", "eff", "isentropic efficiency",
                   "polytropic efficiency", "adiabatic efficiency"),
}
_ALIAS = {a: field for field, names in HEADER_ALIASES.items() for a in names}
_UNIT_SUFFIX = re.compile(r"\s*[\[(]([^\[\]()]*)[\])]\s*$")
_DECIMAL_COMMA = re.compile(r"^[+-]?(\d+|\d{1,3}(\.\d{3})+),\d*([eE][+-]?\d+)?$")
_MAX_ROW_ERRORS = 20


def _decode(content: bytes) -> str:
    if content[:4] == b"PK\x03\x04":
        raise reject("this is a zip archive (an Excel .xlsx workbook?), not a CSV text "
                      "file: save the sheet as 'CSV (comma delimited)' or 'CSV UTF-8'")
    if content[:2] in (b"\xff\xfe", b"\xfe\xff"):
        try:
            return content.decode("utf-16")
        except UnicodeDecodeError:
            raise reject("the file starts with a UTF-16 mark but is not UTF-16 text") from None
    if b"\x00" in content:
        raise reject("this is a binary file (it contains NUL bytes), not a CSV text file")
    try:
        return content.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = content.decode("cp1252", errors="replace")  # Excel's "CSV" on Windows
    return text


def _header_field(name: str) -> tuple[str | None, str]:
    """(field or None, unit) of a header cell by the rules in the module docstring."""
    label, unit = name.strip().strip('"').strip(), ""
    while (m := _UNIT_SUFFIX.search(label)) and m.start() > 0:
        unit = unit or m.group(1).strip()
        label = label[: m.start()]
    if label.endswith("%") and len(label) > 1:  # "efficiency %"
        label, unit = label[:-1], unit or "%"
    key = re.sub(r"[\s_\-]+", " ", label.strip().lower()).strip()
    return _ALIAS.get(key), unit


def _is_number(cell: str) -> bool:
    try:
        _number(cell, True)
        return True
    except ValueError:
        return False


def _number(cell: str, decimal_comma: bool) -> float:
    s = cell.strip().strip('"').strip().replace("\u00a0", "").replace("\u2212", "-")
    if decimal_comma and "," in s and _DECIMAL_COMMA.match(s):
        s = s.replace(".", "").replace(",", ".")
    return float(s)


def _parse_csv(text: str) -> tuple[list[dict], list[list[int]], list[Diagnostic]]:
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
    header_line = lines[0][1]
    delim = (forced.group(1) if forced else
             "\t" if "\t" in header_line else ";" if ";" in header_line else ",")
    decimal_comma = delim != ","
    rows = list(csv.reader([ln for _, ln in lines], delimiter=delim))
    numbers = [n for n, _ in lines]

    col: dict[str, int] = {}
    scale = {c: 1.0 for c in CSV_COLUMNS}
    ignored = []
    for j, name in enumerate(rows[0]):
        field, unit = _header_field(name)
        if field is None:
            if name.strip():
                ignored.append(name.strip())
            continue
        if field in col:
            raise reject(f"columns {rows[0][col[field]].strip()!r} and {name.strip()!r} both "
                          f"name the {field}", ("file", "header"))
        col[field] = j
        if field == "efficiency" and unit == "%":
            scale[field] = 0.01
    missing = [c for c in CSV_COLUMNS if c not in col]
    if missing:
        raise reject(
            f"the header (line {numbers[0]}) must name the columns {', '.join(CSV_COLUMNS)} "
            f"(any order and case, units in brackets allowed, e.g. 'Flow (m3/s)'); missing: "
            f"{', '.join(missing)}; found: {', '.join(repr(h.strip()) for h in rows[0])}"
            + ("" if delim != "," or ";" not in text[:2000] else
               " — if the file uses ';' separators, put them in the header too")
            + (" — the first line that is not blank or '#' must be the header"
               if all(_is_number(h) for h in rows[0] if h.strip()) else ""),
            ("file", "header"))

    errors: list[FieldError] = []
    groups: dict[tuple[float, float], dict] = {}
    lines_of: dict[tuple[float, float], list[int]] = {}
    for n, r in zip(numbers[1:], rows[1:]):
        if len(errors) >= _MAX_ROW_ERRORS:
            break
        vals = {}
        for c in CSV_COLUMNS:
            j = col[c]
            cell = r[j].strip() if j < len(r) else ""
            if not cell:
                hint = (" (write the setting on every row, not only on the first row of "
                        "a speed line)" if c in ("theta", "phi") else "")
                errors.append(FieldError(("file", "row", n, c), f"line {n}: no {c} value "
                                         f"(column {j + 1}); every row needs all five "
                                         f"values{hint}"))
                continue
            try:
                v = _number(cell, decimal_comma) * scale[c]
            except ValueError:
                hint = (" (decimal comma with ',' separators? use ';' as separator)"
                        if delim == "," and re.fullmatch(r"-?\d+,\d+", cell) else "")
                errors.append(FieldError(("file", "row", n, c),
                                         f"line {n}: {c} {cell!r} is not a number{hint}"))
                continue
            if not math.isfinite(v):
                errors.append(FieldError(("file", "row", n, c),
                                         f"line {n}: {c} is {cell!r} (NaN or infinite)"))
                continue
            vals[c] = v
        if len(vals) < len(CSV_COLUMNS):
            continue
        key = (vals["theta"], vals["phi"])
        g = groups.setdefault(key, {"theta": key[0], "phi": key[1], "flow": [],
                                    "pressure": [], "efficiency": []})
        for c in ("flow", "pressure", "efficiency"):
            g[c].append(vals[c])
        lines_of.setdefault(key, []).append(n)
    if errors:
        raise InputRejected(errors)
    if not groups:
        raise reject(f"the CSV file has a header (line {numbers[0]}) but no data rows")
    notes = []
    if ignored:
        notes.append(Diagnostic(
            code="upload_columns_ignored",
            message=f"CSV columns ignored (not theta, phi, flow, pressure, efficiency): "
            f"{', '.join(ignored)}.", details={"columns": ignored}))
    if scale["efficiency"] != 1.0:
        notes.append(Diagnostic(code="upload_efficiency_percent",
                                message="Efficiency column given in % : divided by 100."))
    return list(groups.values()), list(lines_of.values()), notes


def _file_loc(loc: tuple, lines: list[list[int]], positions: list[dict]) -> tuple[tuple, str]:
    """A request loc ("positions", i, field, k) as ("file", "row", line, field) and a prefix
    naming the setting."""
    if len(loc) < 2 or loc[0] != "positions" or not isinstance(loc[1], int) \
            or loc[1] >= len(lines):
        return ("file",), ""
    i = loc[1]
    rows = lines[i]
    where = (f"setting theta={positions[i]['theta']:g}, phi={positions[i]['phi']:g} "
             f"(lines {', '.join(map(str, rows[:12]))}{', ...' if len(rows) > 12 else ''}): ")
    field = loc[2] if len(loc) > 2 and isinstance(loc[2], str) else None
    k = loc[3] if len(loc) > 3 and isinstance(loc[3], int) and loc[3] < len(rows) else 0
    return (("file", "row", rows[k], field) if field else ("file", "row", rows[k])), where


def parse_upload(filename: str, content: bytes, options: dict | None) -> PerfmapRequest:
    """CSV (columns theta, phi, flow, pressure, efficiency; rules in the module docstring)
    or a JSON request; ``options`` (the upload form's options) override options given
    inside a JSON file."""
    ext = "." + filename.rsplit(".", 1)[-1].lower() if "." in filename else ""
    if ext not in UPLOAD_EXTENSIONS:
        raise reject(f"unsupported file type {ext or '(none)'!r}; accepted: "
                      f"{', '.join(UPLOAD_EXTENSIONS)}")
    text = _decode(content)
    lines: list[list[int]] = []
    if ext == ".csv":
        positions, lines, notes = _parse_csv(text)
        body: dict = {"positions": positions}
        if notes:
            body["upload_warnings"] = [d.model_dump() for d in notes]
    else:
        try:
            body = json.loads(text)
        except json.JSONDecodeError as e:
            raise reject(f"invalid JSON: {e}") from None
        if isinstance(body, list):
            body = {"positions": body}
        if not isinstance(body, dict):
            raise reject("the JSON file must hold a request object or a list of positions")
    if options:
        body = {**body, "options": {**(body.get("options") or {}), **options}}
    try:
        request = PerfmapRequest.model_validate(body)
    except ValidationError as e:
        errs = []
        for err in e.errors():
            loc = tuple(err["loc"])
            if options and loc[:1] == ("options",):  # form options point at the options
                errs.append(FieldError(loc, f"{'/'.join(map(str, loc))}: {err['msg']}",
                                       err.get("type", "value_error")))
            elif lines:
                where, prefix = _file_loc(loc, lines, body["positions"])
                msg = err["msg"]
                if err.get("type") == "too_short" and len(loc) == 3:
                    msg, where = "needs at least 3 measured points (rows)", where[:3]
                errs.append(FieldError(where, prefix + msg, err.get("type", "value_error")))
            else:
                errs.append(FieldError(("file",), f"{'/'.join(map(str, loc))}: {err['msg']}",
                                       err.get("type", "value_error")))
        seen, unique = set(), []
        for fe in errs:  # the three lists of one short setting give one message
            if (fe.loc, fe.msg) not in seen:
                seen.add((fe.loc, fe.msg))
                unique.append(fe)
        raise InputRejected(unique) from None
    if lines:
        # Semantic checks here too, so that a CSV user is pointed at file rows rather than
        # at positions of a request they never wrote.
        try:
            prepare(request)
        except InputRejected as e:
            errs = []
            for fe in e.errors:
                where, prefix = _file_loc(tuple(fe.loc), lines, body["positions"])
                errs.append(FieldError(where, prefix + fe.msg, fe.type))
            raise InputRejected(errs) from None
    return request
