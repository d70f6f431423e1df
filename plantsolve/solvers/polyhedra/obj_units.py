"""The length unit an OBJ file's header comment states. OBJ has no unit of its own, but SketchUp writes
``# File units = inches`` (its export unit: the model's, or the one chosen) and other exporters ``# units: meter``
among the comments before the first statement. A room exported in inches (SketchUp's unit in its US templates)
and read as metres is a 1.8e6 m³ hall 96 m high, inside every plausible range; in feet, 3.28³ times its volume."""

from __future__ import annotations

import re
from dataclasses import dataclass

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.length_units import METRES, unit_named

_STATEMENT = re.compile(r"^#\s*(?:file\s+|length\s+)?units?\s*[=:]\s*([^\s#]+)\s*$", re.IGNORECASE)
# SketchUp's other export unit, which no request is written in: converted to metres all the same
YARD_WORDS = ("yard", "yards", "yd")
YARD_M = 0.9144


@dataclass(frozen=True)
class HeaderUnit:
    name: str  # the request unit's name, or 'yd'
    metres: float
    line: int
    comment: str


def header_unit(text: str) -> tuple[HeaderUnit | None, list[Diagnostic]]:
    """The one unit the comments before the first statement state, and a warning naming the line of a unit this
    reader does not know or of a second unit (the numbers are then read in the request's units)."""
    found: dict[str, HeaderUnit] = {}
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if not line.startswith("#"):
            break
        match = _STATEMENT.match(line)
        if match is None:
            continue
        word = match.group(1)
        name = "yd" if word.lower() in YARD_WORDS else unit_named(word)
        if name is None:
            return None, [_unread(number, line, f"{word!r} is no length unit this reader converts")]
        found.setdefault(name, HeaderUnit(name, YARD_M if name == "yd" else METRES[name], number, line))
    if len(found) > 1:
        first, second = found.values()
        return None, [_unread(second.line, second.comment, f"it contradicts line {first.line} ({first.comment!r})")]
    return next(iter(found.values()), None), []


def _unread(line: int, comment: str, why: str) -> Diagnostic:
    return Diagnostic(code="file_unit_not_read", message=(
        f"The OBJ header's comment on line {line} ({comment!r}) states a unit, but {why}: the numbers were read in "
        "the request's units. Give options.file_units if they are in another."),
        details={"quantity": "length unit", "line": line, "comment": comment})
