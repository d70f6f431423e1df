"""Checks at submission: a file is there, it is base64 (JSON), it looks like an IFC file, the sharing mode suits
its schema (read from the header without parsing the model), and a tolerance is no distance no copy could be off
by in the unit the file defines (its text scanned, the model not parsed)."""

from __future__ import annotations

import re

from ifcopenshell import ifcopenshell_wrapper

from plantsolve.solvers.base import reject
from plantsolve.solvers.dedup.source import IfcSource
from plantsolve.solvers.dedup.tolerance import refuse_at_intake, stated_length_unit
from plantsolve.solvers.other_kinds import file_holds

_SCHEMA = re.compile(rb"FILE_SCHEMA\s*\(\s*\(\s*'([A-Za-z0-9_]+)", re.IGNORECASE)


def header_schema(text: bytes) -> str | None:
    found = _SCHEMA.search(text[:65536])
    return found.group(1).decode().upper() if found else None


def _schema_definition(schema: str):
    try:
        return ifcopenshell_wrapper.schema_by_name(schema)
    except RuntimeError:  # IfcOpenShell knows IFC4X3 by its latest addendum's name
        return ifcopenshell_wrapper.schema_by_name("IFC4X3_ADD2") if schema.startswith("IFC4X3") else None


def _is_product(declaration) -> bool:
    while declaration is not None:
        if declaration.name() == "IfcProduct":
            return True
        declaration = declaration.supertype() if hasattr(declaration, "supertype") else None  # a type: no entity
    return False


def refuse_unknown_entity_types(names: list[str], schema: str) -> None:
    """A 422 naming ``options.entity_types[i]`` when it is no entity of the file's schema (a typing slip,
    ``IfcWal``; an IFC4 name in an IFC2X3 file), or no product: nothing would be selected, and the run would
    share nothing without a word on why."""
    definition = _schema_definition(schema)
    if definition is None:
        return
    for i, name in enumerate(names):
        try:
            declaration = definition.declaration_by_name(name)
        except RuntimeError:
            raise reject(f"{name!r} is no entity of the file's schema {schema}: no product would be selected",
                         ("options", "entity_types", i)) from None
        if not _is_product(declaration):
            raise reject(f"{declaration.name()} is no product (IfcProduct subtype) in {schema}: only products "
                         "share geometry; name product entities such as IfcWall or IfcFlowSegment",
                         ("options", "entity_types", i))


def check_input(source: IfcSource) -> None:
    schema = header_schema(source.header())
    if schema is None:
        raise reject("no FILE_SCHEMA in the STEP header")
    if not schema.startswith("IFC"):
        raise reject(f"not an IFC model: it holds {file_holds(source.header())} (FILE_SCHEMA {schema!r}); dedup reads "
                     "IFC2X3, IFC4 and IFC4X3 models")
    if schema.startswith("IFC4X3") and schema not in ifcopenshell_wrapper.schema_names():
        # IfcOpenShell parses IFC 4.3 by its final release's name only: 'IFC4X3' (a release candidate's label, some
        # exporters') failed in the parse as "No schema loaded", after a check that had listed IFC4X3 as accepted
        raise reject(f"FILE_SCHEMA {schema!r}: IFC 4.3 is read as its final release, 'IFC4X3_ADD2' (IfcOpenShell reads "
                     "no other 4.3 label); a model of IFC 4.3's entities can say FILE_SCHEMA(('IFC4X3_ADD2')) in its "
                     "header")
    if not (schema in ("IFC2X3", "IFC4") or schema.startswith("IFC4X3")):
        raise reject(f"unsupported IFC schema {schema!r}; accepted: IFC2X3, IFC4, IFC4X3_ADD2")
    if source.options.tolerance is not None:
        with source.stream() as stream:
            unit = stated_length_unit(stream)
        if unit is not None:
            refuse_at_intake(source.options.tolerance, unit)
    if source.options.entity_types:
        refuse_unknown_entity_types(source.options.entity_types, schema)
    if source.options.sharing == "product_shape" and schema == "IFC2X3":
        raise reject("'product_shape' needs IFC4 or later: in IFC2X3 an IfcProductDefinitionShape belongs to "
                     "exactly one product (ShapeOfProduct [1:1]); use 'mapped_item' or 'auto'", ("options", "sharing"))
