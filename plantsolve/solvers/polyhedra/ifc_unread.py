"""The lines of an IFC file IfcOpenShell left out of the model it read, and why; and those it read as the header's
schema though they are written in another's.

IfcOpenShell reads a STEP file against the schema its header's FILE_SCHEMA names and drops, without raising, every
instance it cannot read that way: an entity the schema lacks (an IFC4 ``IfcTriangulatedFaceSet`` in a file labelled
IFC2X3) or a line it cannot parse. A space whose body was such an instance came out of the kernel as 'no triangles':
the zone was gone from the result and its volume from the total, and the skipped space's reason did not say why.
Here the file's instance definitions are set against the model read, and one warning names the entities and lines
left out.
"""

from __future__ import annotations

import re
from typing import Any

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.ifc_schema import first_misfit
from plantsolve.solvers.step_file import line_ends

# an instance's definition: '#12=' after a line's start or the ';' ending the one before (several may share a line),
# looked for in the text with its strings and comments blanked
_DEFINITION = re.compile(r"(?:^|;)[ \t\r]*#(\d+)[ \t]*=[ \t]*([A-Za-z0-9_]*)", re.MULTILINE)
_NAMED = 5
_LISTED_LINES = 100


def lines_left_out(text: str, model: Any, cut: bool) -> Diagnostic | None:
    """The warning naming the entities and lines the model lacks, or None when it holds every instance the text
    defines. A ``cut`` file's last definition is not counted: the truncation warning says it. ``text``: its strings
    and comments blanked (a ';#3=B' in one defines nothing)."""
    import ifcopenshell  # noqa: PLC0415  (third-party, only needed for IFC)

    defined = sum(1 for _ in _DEFINITION.finditer(text)) - (1 if cut else 0)
    read = set(model.entity_names())
    if len(read) >= defined:
        return None
    schema = ifcopenshell.schema_by_name(model.schema_identifier)
    known: dict[str, bool] = {}
    foreign: dict[str, int] = {}
    unread: list[tuple[int, str]] = []
    line, counted_to = 1, 0  # lines are counted on from the last one found: the file is read once
    for k, match in enumerate(_DEFINITION.finditer(text)):
        number, name = int(match.group(1)), match.group(2).upper()
        if number in read or k >= defined:
            continue
        if name and name not in known:
            try:
                schema.declaration_by_name(name)
                known[name] = True
            except RuntimeError:
                known[name] = False
        is_foreign = bool(name) and not known[name]
        if (name not in foreign) if is_foreign else len(unread) < _LISTED_LINES:
            line += line_ends(text, counted_to, match.start(1))
            counted_to = match.start(1)
            if is_foreign:
                foreign[name] = line
            else:
                unread.append((line, name or "a complex instance"))
    said = []  # nothing to say when the count differs by an instance number defined twice, which is read once
    if foreign:
        listed = ", ".join(f"{name} (line {at})" for name, at in list(foreign.items())[:_NAMED])
        said.append(f"entities the header's FILE_SCHEMA {model.schema_identifier} does not have: {listed}")
    if unread:
        listed = ", ".join(f"{at} ({name})" for at, name in unread[:_NAMED])
        said.append(f"lines IfcOpenShell could not read as {model.schema_identifier}: {listed}")
    if not said:
        return None
    return Diagnostic(code="ifc_lines_not_read", message=(
        f"IfcOpenShell left {defined - len(read)} of the file's {defined} instances out of the model it read — "
        f"{'; '.join(said)}. Spaces built of them are missing or skipped; is the file of another schema than its "
        "header says?"),
        details={"schema": model.schema_identifier, "instances_defined": defined, "instances_read": len(read),
                 "foreign_entities": foreign, "unread_lines": [at for at, _ in unread]})


def lines_of_another_schema(text: str, model: Any) -> Diagnostic | None:
    """The warning naming the first line written with another number of attributes than its entity has in the
    header's FILE_SCHEMA (an IFC4 model labelled IFC2X3: its IfcQuantityArea has 5 values, IFC2X3's 4), or None.
    IfcOpenShell pads or drops the values without a word, and reads those it keeps by their place in the header's
    schema: a quantity or a geometry parameter may be read from another attribute. The first instance of each entity
    is looked at, the text read until each entity the model holds was met (an entity the schema lacks is
    :func:`lines_left_out`'s). ``text``: its strings and comments blanked."""
    schema = model.schema_identifier
    misfit = first_misfit(text, _DEFINITION.finditer(text), schema, unknown=False, limit=len(model.types()))
    if misfit is None:
        return None
    at = line_ends(text, 0, misfit.start) + 1
    fits = misfit.fits
    return Diagnostic(code="ifc_schema_misfit", message=(
        f"line {at}: #{misfit.number}={misfit.name} is written with {misfit.written} attribute value(s), and "
        f"{misfit.entity} has {misfit.expected} in the header's FILE_SCHEMA {schema}"
        + (f" (the count of {' and '.join(fits)})" if fits else "")
        + ": IfcOpenShell read the file as its header says, padding or dropping values, so a quantity or a "
        "shape parameter may be read from another attribute. Is the header's FILE_SCHEMA wrong? Write the schema "
        "the exporter wrote the model in."),
        details={"line": at, "entity": misfit.entity, "written": misfit.written, "expected": misfit.expected,
                 "schema": schema, "fits": fits})
