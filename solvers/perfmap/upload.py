"""Parsing uploaded measurement files (CSV table or JSON request) into a PerfmapRequest."""

from __future__ import annotations

import csv
import io
import json
import math

from pydantic import ValidationError

from schemas.perfmap import PerfmapRequest
from solvers.base import FieldError, InputRejected

UPLOAD_EXTENSIONS = (".csv", ".json")
CSV_COLUMNS = ("theta", "phi", "flow", "pressure", "efficiency")


def _reject(msg: str) -> InputRejected:
    return InputRejected(FieldError(("file",), msg))


def _parse_csv(text: str) -> list[dict]:
    """One row per measured point; rows of the same (theta, phi) form one setting, in order
    of first appearance. Columns by header name (any order, case-insensitive)."""
    sample = text[:4096]
    try:
        dialect = csv.Sniffer().sniff(sample, delimiters=",;\t")
    except csv.Error:
        dialect = csv.excel
    reader = csv.reader(io.StringIO(text), dialect)
    rows = [r for r in reader if r and any(c.strip() for c in r)]
    if not rows:
        raise _reject("the CSV file is empty")
    header = [h.strip().lower() for h in rows[0]]
    missing = [c for c in CSV_COLUMNS if c not in header]
    if missing:
        raise _reject(f"CSV header must name the columns {', '.join(CSV_COLUMNS)}; "
                      f"missing: {', '.join(missing)}")
    col = {c: header.index(c) for c in CSV_COLUMNS}
    groups: dict[tuple[float, float], dict] = {}
    for line_no, r in enumerate(rows[1:], start=2):
        if r[0].lstrip().startswith("#"):
            continue
        try:
            vals = {c: float(r[col[c]]) for c in CSV_COLUMNS}
        except (ValueError, IndexError):
            raise _reject(f"CSV line {line_no}: expected 5 numbers "
                          f"({', '.join(CSV_COLUMNS)}), got {r!r}") from None
        if not all(math.isfinite(v) for v in vals.values()):
            raise _reject(f"CSV line {line_no}: NaN or infinite value")
        key = (vals["theta"], vals["phi"])
        g = groups.setdefault(key, {"theta": key[0], "phi": key[1], "flow": [],
                                    "pressure": [], "efficiency": []})
        for c in ("flow", "pressure", "efficiency"):
            g[c].append(vals[c])
    if not groups:
        raise _reject("the CSV file has a header but no data rows")
    return list(groups.values())


def parse_upload(filename: str, content: bytes, options: dict | None) -> PerfmapRequest:
    """CSV (columns theta,phi,flow,pressure,efficiency) or a JSON request; ``options``
    (the upload form's options) override options given inside a JSON file."""
    ext = "." + filename.rsplit(".", 1)[-1].lower() if "." in filename else ""
    if ext not in UPLOAD_EXTENSIONS:
        raise _reject(f"unsupported file type {ext or '(none)'!r}; accepted: "
                      f"{', '.join(UPLOAD_EXTENSIONS)}")
    try:
        text = content.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise _reject("the file is not UTF-8 text") from None
    if ext == ".csv":
        body: dict = {"positions": _parse_csv(text)}
    else:
        try:
            body = json.loads(text)
        except json.JSONDecodeError as e:
            raise _reject(f"invalid JSON: {e}") from None
        if isinstance(body, list):
            body = {"positions": body}
        if not isinstance(body, dict):
            raise _reject("the JSON file must hold a request object or a list of positions")
    if options:
        body = {**body, "options": {**(body.get("options") or {}), **options}}
    try:
        return PerfmapRequest.model_validate(body)
    except ValidationError as e:
        errs = []
        for err in e.errors():
            loc = tuple(err["loc"])
            # Errors in form options point at the options; everything else is in the file.
            where = loc if (options and loc[:1] == ("options",)) else ("file",)
            errs.append(FieldError(where, f"{'/'.join(map(str, loc))}: {err['msg']}",
                                   err.get("type", "value_error")))
        raise InputRejected(errs) from None
