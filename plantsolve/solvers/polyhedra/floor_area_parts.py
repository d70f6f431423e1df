"""EnergyPlus' Zone field Part of Total Floor Area: No (a plenum, an attic) leaves the zone's floor area out of the
building's total and conditioned floor area (Input Output Reference, Zone, "Field: Part of Total Floor Area").

The field is a choice of Yes or No, default Yes; EnergyPlus refuses anything else, so does this reader: a misspelt
"N" read as Yes would count a plenum's floor in the total, no word.
"""

from __future__ import annotations

from plantsolve.solvers.base import reject

PART_OF_TOTAL_FLOOR_AREA_FIELD = 12  # after Multiplier, Ceiling Height, Volume, Floor Area and two convection fields


def zones_outside_total_floor_area(objects: list) -> set[str]:
    """The zones (lower case) whose ``Zone`` object says Part of Total Floor Area = No, from the objects (class,
    fields, field lines, line)."""
    outside: set[str] = set()
    index = PART_OF_TOTAL_FLOOR_AREA_FIELD
    for cls, fields, lines, line in objects:
        if cls != "zone" or not fields or not fields[0] or len(fields) <= index:
            continue
        value = fields[index].strip().lower()
        if value == "no":
            outside.add(fields[0].lower())
        elif value not in ("", "yes"):
            at = lines[index] or line
            where = ("file", "line", at) if at else ("file",)
            raise reject(f"Zone {fields[0]!r} Part of Total Floor Area{f' (line {at})' if at else ''} is "
                         f"{fields[index]!r}: EnergyPlus takes Yes or No (whether the building's total floor area "
                         "counts the zone's floor)", where)
    return outside
