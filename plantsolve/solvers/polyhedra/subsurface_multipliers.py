"""EnergyPlus' Multiplier of a window, glass door or door: the number of identical items on the base surface.

EnergyPlus multiplies the subsurface's area by it, so the base surface's net area loses that many copies (Input
Output Reference, FenestrationSurface:Detailed, "Field: Multiplier"). The field is a number of at least 1, default
1, non-integer values truncated to an integer (the IDD's notes); EnergyPlus refuses less than 1, so does this reader.
Tubular daylighting devices do not use the field.
"""

from __future__ import annotations

import math

from plantsolve.schemas.polyhedra import MAX_ZONE_MULTIPLIER
from plantsolve.solvers.base import reject

UNUSED_BY = ("tubulardaylightdome", "tubulardaylightdiffuser")  # FenestrationSurface:Detailed's Surface Type


def simple_multiplier_index(fields: list[str]) -> int:
    """Where a Window's, GlassDoor's or Door's (or their :Interzone forms') Multiplier is: before its last four
    fields (Starting X and Z Coordinates, Length, Height), blank trailing fields not counted."""
    n = len(fields)
    while n and not fields[n - 1].strip():
        n -= 1
    return n - 5


def subsurface_multiplier(cls: str, fields: list[str], lines: list, line: int | None, index: int) -> int:
    """The multiplier in ``fields[index]`` of the subsurface object (class, fields, field lines, line)."""
    if cls == "fenestrationsurface:detailed" and len(fields) > 1 and fields[1].strip().lower() in UNUSED_BY:
        return 1
    text = fields[index].strip() if 0 <= index < len(fields) else ""
    if not text:
        return 1
    try:
        number = float(text)
    except ValueError:
        number = math.nan
    if not 1 <= number < MAX_ZONE_MULTIPLIER + 1:  # NaN and infinity fail the range too
        at = (lines[index] if 0 <= index < len(lines) else None) or line
        raise reject(f"{cls} {fields[0]!r} Multiplier{f' (line {at})' if at else ''} is {fields[index]!r}: EnergyPlus "
                     f"takes a number from 1 to {MAX_ZONE_MULTIPLIER} (how many identical items the base surface "
                     "holds)", ("file", "line", at) if at else ("file",))
    return int(number)  # EnergyPlus truncates
