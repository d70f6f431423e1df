"""An IDF's field notes (``!- X,Y,Z Vertex 1 {ft}``) stating a length unit other than EnergyPlus' metres.

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
