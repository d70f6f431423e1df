"""An IDF's field notes (``!- X,Y,Z Vertex 1 {ft}``) stating a length unit other than EnergyPlus' metres, and its
tables asked for in inch-pound units.

EnergyPlus reads every IDF length in metres and ignores comments, so the reader does too; but notes in feet or inches
are what a hand-made or scripted IP export writes beside numbers in feet: read as metres, every volume is 35 times too
large and plausible still (a 15 × 15 × 10 ft room becomes a 15 × 15 × 10 m hall). The notes are named in a warning.
"""

from __future__ import annotations

import re

from plantsolve.schemas.common import Diagnostic

# the note of a geometry field (vertex, origin, coordinate, length, height, width, area, volume) with a length, area or
# volume unit in braces, as the IDD writes {m}, {m2}, {m3}: any but metres
_NOTE_UNIT = re.compile(r"!-[^{]*(?:vertex|origin|coordinate|length|height|width|area|volume)[^{]*"
                        r"\{\s*(ft|in|mm|cm|km|yd|mi)([23]?)\s*\}", re.IGNORECASE)
MAX_LINES_LISTED = 20


def notes_in_other_units(text: str) -> list[Diagnostic]:
    """A warning naming the lines whose field notes state a length unit other than metres (none if no line does)."""
    found: dict[str, list[int]] = {}
    for number, line in enumerate(text.splitlines(), 1):
        match = _NOTE_UNIT.search(line)
        if match:
            found.setdefault(match.group(1).lower(), []).append(number)
    if not found:
        return []
    units = sorted(found, key=lambda u: -len(found[u]))
    lines = sorted(n for u in units for n in found[u])
    first = units[0]
    return [Diagnostic(code="idf_notes_other_units", message=(
        f"{len(lines)} field note(s) of this IDF state lengths in {', '.join(units)} (first at line {lines[0]}, e.g. "
        f"'{{{first}}}'), but EnergyPlus reads every IDF length in metres whatever a note says: the numbers were read "
        f"as metres. If they are in {first} (an IP export), give options.file_units = '{first}'."),
        details={"units": units, "lines": lines[:MAX_LINES_LISTED], "count": len(lines), "read_as": "m"})]


def followed(warnings: list[dict], file_units: str | None) -> list[dict]:
    """The reader's warnings with the notes' one saying the numbers were read in their unit when options.file_units
    names it (the advice to give it would be followed already)."""
    out = []
    for w in warnings:
        if isinstance(w, dict) and w.get("code") == "idf_notes_other_units" and file_units is not None and \
                file_units in (w.get("details") or {}).get("units", []):
            details = {**w["details"], "read_as": file_units}
            lines = details.get("lines") or [None]
            w = {**w, "details": details, "message": (
                f"{details.get('count')} field note(s) of this IDF state lengths in {', '.join(details['units'])} "
                f"(first at line {lines[0]}); EnergyPlus would read the numbers as metres, they were read as "
                f"{file_units} as options.file_units says.")}
        out.append(w)
    return out


def _inch_pound_note(line: int, conversion: str, file_unit: str, request_unit: str | None) -> Diagnostic:
    read = ("metres, as EnergyPlus reads every IDF" if file_unit == "m" else
            f"read as {file_unit}, as options.file_units says")
    given = ("the request's unit (metres unless options.units names another)" if request_unit is None else
             f"{request_unit} (volumes in {request_unit}3, areas in {request_unit}2)")
    return Diagnostic(code="idf_tables_inch_pound", message=(
        f"line {line}: OutputControl:Table:Style asks EnergyPlus for {conversion} tables (volumes in ft3, areas in "
        f"ft2), but the IDF's lengths are {read}: these results are in {given}; give options.units = 'ft' to have "
        "them in the tables' feet."),
        details={"line": line, "unit_conversion": conversion, "file_unit": file_unit})


def tables_in_inch_pound(objects: list[tuple[str, list[str], list[int], int]]) -> list[Diagnostic]:
    """A warning when the IDF's OutputControl:Table:Style asks EnergyPlus for inch-pound tables: its user reads zone
    volumes in ft3 and areas in ft2 there, while the file's lengths (and so these results, unless the request asks for
    feet) are metres; a 120 m3 zone next to a table's 4238 ft3 looks like a disagreement, and a metre number read as
    feet is 35 times off in volume."""
    for cls, fields, _, line in objects:
        if cls == "outputcontrol:table:style" and len(fields) > 1 and fields[1].lower().startswith("inchpound"):
            return [_inch_pound_note(line, fields[1], "m", None)]
    return []


def tables_answered(warnings: list[dict], units: dict) -> list[dict]:
    """The reader's warnings with the inch-pound tables' one said in the units the lengths were read in and the results
    are given in (``units``: the source's ``file_unit`` and ``request_unit``), or without it when the request is in
    the tables' feet."""
    out = []
    for w in warnings:
        if isinstance(w, dict) and w.get("code") == "idf_tables_inch_pound":
            if units["request_unit"] == "ft":
                continue
            details = w.get("details") or {}
            w = _inch_pound_note(details["line"], details["unit_conversion"], units["file_unit"],
                                 units["request_unit"]).model_dump()
        out.append(w)
    return out
