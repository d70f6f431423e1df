"""EnergyPlus' zone multipliers: a Zone's Multiplier times the Zone List Multiplier of each ZoneGroup whose
ZoneList names it.

A multiplier says the zone stands for that many identical zones (a middle floor of a tower drawn once): EnergyPlus
multiplies floor area, loads and internal gains by it (Tips and Tricks, "Using Multipliers (Zone and/or Window)").
Both fields are integers of at least 1, default 1; EnergyPlus refuses anything else, so does this reader.
"""

from __future__ import annotations

from plantsolve.schemas.common import Diagnostic
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
    strays = _zones_not_in_file(objects, zone_names)
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
        if fields[1].lower() in strays:
            # EnergyPlus refuses the file; read, the zone meant (a misspelt name) would go unmultiplied
            name, at = strays[fields[1].lower()][0]
            raise reject(f"ZoneList {fields[1]!r}{f' (line {at})' if at else ''}, which ZoneGroup {fields[0]!r} "
                         f"multiplies, names zone {name!r}, which no Zone object of this file defines",
                         ("file", "line", at) if at else ("file",))
        for zone in lists[fields[1].lower()]:
            if zone in zone_names:
                multipliers[zone] = multipliers.get(zone, 1) * group
    return {zone: m for zone, m in multipliers.items() if m != 1}


def _zones_not_in_file(objects: list, zone_names: dict[str, str]) -> dict[str, list[tuple[str, int | None]]]:
    """ZoneList (lower case) → the (zone name, line) of each zone it names that no ``Zone`` object defines."""
    strays: dict[str, list[tuple[str, int | None]]] = {}
    for cls, fields, lines, line in objects:
        if cls != "zonelist" or not fields or not fields[0]:
            continue
        found = [(name, lines[k] or line) for k, name in enumerate(fields[1:], 1)
                 if name and name.lower() not in zone_names]
        if found:
            strays[fields[0].lower()] = found
    return strays


def zone_list_strays(objects: list, zone_names: dict[str, str]) -> list[Diagnostic]:
    """Warning ``zone_list_names_unknown_zone`` for each ZoneList naming a zone no ``Zone`` object defines (a misspelt
    name: EnergyPlus refuses the file; whatever the list assigns, people, lights or a multiplier, misses the zone
    meant). A ZoneGroup's list is refused by :func:`zone_multipliers` instead."""
    listed = {fields[0].lower(): fields[0] for cls, fields, *_ in objects if cls == "zonelist" and fields and fields[0]}
    return [Diagnostic(code="zone_list_names_unknown_zone", message=(
        f"ZoneList {listed[key]!r} names zone(s) no Zone object of this file defines: "
        + ", ".join(f"{name!r}" + (f" (line {at})" if at else "") for name, at in found[:5])
        + (" …" if len(found) > 5 else "") + ". EnergyPlus refuses such a list; a misspelt name leaves the zone meant "
        "out of it."), details={"zone_list": listed[key], "zones": [n for n, _ in found[:100]],
                                "lines": [at for _, at in found[:100]]})
        for key, found in _zones_not_in_file(objects, zone_names).items()]
