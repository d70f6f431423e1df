"""The length unit an OBJ file's header comment states. OBJ has no unit of its own, but SketchUp writes
``# File units = inches`` (its export unit: the model's, or the one chosen) and other exporters ``# units: meter``
among the comments before the first statement. A room exported in inches (SketchUp's unit in its US templates)
and read as metres is a 1.8e6 m³ hall 96 m high, inside every plausible range; in feet, 3.28³ times its volume."""

from __future__ import annotations

import re

from plantsolve.solvers.length_units import unit_named

_STATEMENT = re.compile(r"^#\s*(?:file\s+|length\s+)?units?\s*[=:]\s*([^\s#]+)\s*$", re.IGNORECASE)


def header_unit(text: str) -> tuple[str, int, str] | None:
    """(unit, line, the comment) of the one unit the comments before the first statement state, when that is a
    unit the request can be in; None when they state none, one this reader cannot convert, or two."""
    found: dict[str, tuple[int, str]] = {}
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if not line.startswith("#"):
            break
        match = _STATEMENT.match(line)
        if match is None:
            continue
        unit = unit_named(match.group(1))
        if unit is None:
            return None
        found.setdefault(unit, (number, line))
    if len(found) != 1:
        return None
    ((unit, (number, line)),) = found.items()
    return unit, number, line
