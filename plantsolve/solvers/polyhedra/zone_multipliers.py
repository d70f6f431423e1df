"""EnergyPlus' zone multipliers: a Zone's Multiplier times the Zone List Multiplier of each ZoneGroup whose
ZoneList names it.

A multiplier says the zone stands for that many identical zones (a middle floor of a tower drawn once): EnergyPlus
multiplies floor area, loads and internal gains by it (Tips and Tricks, "Using Multipliers (Zone and/or Window)").
Both fields are integers of at least 1, default 1; EnergyPlus refuses anything else, so does this reader.
"""

from __future__ import annotations

from plantsolve.solvers.base import reject

ZONE_MULTIPLIER_FIELD = 6  # Name, North, X, Y, Z Origin, Type, Multiplier: the index after the class name


def _whole(value: str, what: str, line: int | None) -> int:
    text = value.strip()
    if not text:
        return 1
    try:
        number = float(text)
    except ValueError:
        number = float("nan")
    if not 1 <= number <= 1e6 or number != int(number):  # NaN and infinity fail the range (int() of them raises)
        where = ("file", "line", line) if line else ("file",)
        raise reject(f"{what}{f' (line {line})' if line else ''} is {value!r}: EnergyPlus takes a whole number from "
                     "1 (how many identical zones this one stands for)", where)
    return int(number)


def zone_multipliers(objects: list, zone_names: dict[str, str]) -> dict[str, int]:
    """The multiplier of each zone (keys lower case) that is not 1, from the ``Zone``, ``ZoneList`` and
    ``ZoneGroup`` objects (class, fields, field lines, line)."""
    multipliers: dict[str, int] = {}
    lists: dict[str, list[str]] = {}
    for cls, fields, lines, line in objects:
        if cls == "zone" and fields and fields[0] and len(fields) > ZONE_MULTIPLIER_FIELD:
            index = ZONE_MULTIPLIER_FIELD
            multipliers[fields[0].lower()] = _whole(fields[index], f"Zone {fields[0]!r} Multiplier",
                                                    lines[index] or line)
        elif cls == "zonelist" and fields and fields[0]:
            lists[fields[0].lower()] = [f.lower() for f in fields[1:] if f]
    for cls, fields, lines, line in objects:
        if cls != "zonegroup" or len(fields) < 2:
            continue
        group = _whole(fields[2] if len(fields) > 2 else "", f"ZoneGroup {fields[0]!r} Zone List Multiplier",
                       (lines[2] if len(lines) > 2 else None) or line)
        if fields[1].lower() not in lists:
            raise reject(f"ZoneGroup {fields[0]!r}{f' (line {line})' if line else ''} multiplies ZoneList "
                         f"{fields[1]!r}, which this file does not hold", ("file", "line", line) if line else ("file",))
        for zone in lists[fields[1].lower()]:
            if zone in zone_names:
                multipliers[zone] = multipliers.get(zone, 1) * group
    return {zone: m for zone, m in multipliers.items() if m != 1}
