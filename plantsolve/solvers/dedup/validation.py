"""Checks at submission: a file is there, it is base64 (JSON), it looks like an IFC file, the sharing mode suits
its schema (read from the header without parsing the model), and a tolerance is no distance no copy could be off
by in the unit the file defines (its text scanned, the model not parsed)."""

from __future__ import annotations

import re

from plantsolve.solvers.base import reject
from plantsolve.solvers.dedup.source import IfcSource
from plantsolve.solvers.dedup.tolerance import refuse_at_intake, stated_length_unit
from plantsolve.solvers.other_kinds import file_holds

_SCHEMA = re.compile(rb"FILE_SCHEMA\s*\(\s*\(\s*'([A-Za-z0-9_]+)", re.IGNORECASE)


def header_schema(text: bytes) -> str | None:
    found = _SCHEMA.search(text[:65536])
    return found.group(1).decode().upper() if found else None


def check_input(source: IfcSource) -> None:
    schema = header_schema(source.header())
    if schema is None:
        raise reject("no FILE_SCHEMA in the STEP header")
    if not schema.startswith("IFC"):
        raise reject(f"not an IFC model: it holds {file_holds(source.header())} (FILE_SCHEMA {schema!r}); dedup reads "
                     "IFC2X3, IFC4 and IFC4X3 models")
    if not (schema in ("IFC2X3", "IFC4") or schema.startswith("IFC4X3")):
        raise reject(f"unsupported IFC schema {schema!r}; accepted: IFC2X3, IFC4, IFC4X3")
    if source.options.tolerance is not None:
        with source.stream() as stream:
            unit = stated_length_unit(stream)
        if unit is not None:
            refuse_at_intake(source.options.tolerance, unit)
    if source.options.sharing == "product_shape" and schema == "IFC2X3":
        raise reject("'product_shape' needs IFC4 or later: in IFC2X3 an IfcProductDefinitionShape belongs to "
                     "exactly one product (ShapeOfProduct [1:1]); use 'mapped_item' or 'auto'", ("options", "sharing"))
