"""Zone measures that no building has: a room written in millimetres and read as metres (6e10 m³), metres
read as millimetres (6e-8 m³), a header whose unit contradicts its numbers. Each quantity out of its physical
range is one warning ``implausible_<quantity>`` naming the zones, the values, the range and the unit mix-up that
would make them plausible (the ranges are the README's table, polyhedra section)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.polyhedra.file_units import METRES

MAX_ZONES_LISTED = 100


@dataclass(frozen=True)
class Range:
    code: str
    quantity: str
    power: int  # 1 length, 2 area, 3 volume
    low: float  # SI (m, m², m³)
    high: float
    typical: float  # what a room has: the mix-up named is the one that comes closest to it


RANGES = (
    # low ends below a riser shaft's or a plenum's, high ends above a stadium hall's
    Range("implausible_zone_volume", "volume", 3, 0.01, 1e7, 100.0),
    Range("implausible_floor_area", "floor area", 2, 0.01, 1e6, 30.0),
    Range("implausible_zone_height", "height", 1, 0.1, 300.0, 3.0),
    Range("implausible_zone_extent", "horizontal extent", 1, 0.1, 3000.0, 10.0),
)
ZONE_RANGE_CODES = frozenset(rng.code for rng in RANGES)
SUPERSCRIPT = {1: "", 2: "²", 3: "³"}
# a building's tallest zone: a plenum or a crawlspace may be 0.5 m high, but a building of several zones none of which
# a person stands in is feet (or inches) read as metres, which gives rooms of plausible volume one by one
TALLEST = Range("implausible_building_height", "tallest zone's height", 1, 1.8, 1000.0, 3.0)
# and the other way: a model whose every zone stands over 50 m high, each at least as wide as it is high, is rooms
# in inches read as metres, the unit an STL or an OBJ without a header leaves to the request: 2.4-4 m rooms read as
# 94-157 m ones, each under the single zone's 300 m and 1e7 m³. A zone taller than wide (a tower or an atrium drawn as
# one zone, a shaft, a silo) is not a room's shape, and is not named; a hall wider than high (a hangar, a stadium) is,
# the message saying what it would have to be
LOWEST = Range("implausible_lowest_zone_height", "lowest zone's height", 1, 1.8, 50.0, 3.0)
# the unit named for it brings the lowest zone to a storey's height (a tall ground floor's at most)
STOREY = Range(LOWEST.code, LOWEST.quantity, 1, 1.8, 10.0, 3.0)


def _mix_up(value_si: float, rng: Range, read_as: tuple[str, float]) -> tuple[str, float] | None:
    """The unit the file's numbers were more likely written in (plausible when read so, closest to a room's) than
    ``read_as`` (the unit they were read in: name, metres), and the value read so in SI; None when no other unit
    makes it plausible."""
    best = None
    for name, size in METRES.items():
        if abs(size - read_as[1]) <= 1e-12 * size:
            continue
        alt = value_si * (size / read_as[1]) ** rng.power
        if rng.low <= alt <= rng.high:
            distance = abs(math.log(alt / rng.typical))
            if best is None or distance < best[0]:
                best = (distance, name, alt)
    return (best[1], best[2]) if best else None


def _range_text(rng: Range, units: str) -> str:
    k = METRES[units] ** rng.power
    return f"{rng.low / k:.3g}–{rng.high / k:.3g} {units}{SUPERSCRIPT[rng.power]}"


def implausible(zones: Sequence[Mapping[str, Any]], measures: Mapping[str, Mapping[str, float]], units: str,
                hint: str, read_as: tuple[str, float] | None = None) -> list[Diagnostic]:
    """One warning per quantity out of range; ``measures`` per zone id holds ``height`` and ``extent`` (request
    units); ``hint`` says how to give the right unit (``options.file_units`` for an upload, ``units`` for JSON);
    ``read_as`` is the unit the file's numbers were read in (name, metres), the request's when not given."""
    read_as = read_as or (units, METRES[units])
    warnings = []
    for rng in RANGES:
        found = []
        for zone in zones:
            size = measures.get(zone["id"]) or {}
            value = {"volume": zone.get("volume"), "floor area": zone.get("floor_area"), "height": size.get("height"),
                     "horizontal extent": size.get("extent")}[rng.quantity]
            if value is None or (value <= 0 and rng.quantity != "volume"):  # not closed, no floor: nothing to judge
                continue  # a closed zone of no volume (a face listed both ways round, all in one plane) is judged
            si = value * METRES[units] ** rng.power
            if not rng.low <= si <= rng.high:
                found.append((zone["id"], value, si))
        if not found:
            continue
        zone_id, value, si = found[0]
        unit_text = f"{units}{SUPERSCRIPT[rng.power]}"
        mix = _mix_up(si, rng, read_as)
        power = SUPERSCRIPT[rng.power]
        in_si = f" = {mix[1]:.4g} m{power}" if mix and mix[0] != "m" else ""
        file_value = si / read_as[1] ** rng.power
        likely = (f"the numbers look like {mix[0]} read as {read_as[0]} ({file_value:.4g} {mix[0]}{power}{in_si}): "
                  f"{hint.format(unit=mix[0])}") if mix else (
            "its faces enclose nothing (a surface listed both ways round, or every vertex in one plane): check the "
            "faces" if si <= 0 else "no length unit makes it plausible: check the coordinates")
        more = f" (and {len(found) - 1} more zone(s))" if len(found) > 1 else ""
        warnings.append(Diagnostic(code=rng.code, message=(
            f"Zone {zone_id!r}{more}: {rng.quantity} {value:.4g} {unit_text} is outside the plausible "
            f"{_range_text(rng, units)} of a building zone; {likely}."),
            details={"quantity": rng.quantity, "units": unit_text, "plausible_range": [
                rng.low / METRES[units] ** rng.power, rng.high / METRES[units] ** rng.power],
                "likely_file_unit": mix[0] if mix else None,
                "zones": {z: v for z, v, _ in found[:MAX_ZONES_LISTED]}, "count": len(found)}))
    return warnings


def building_too_low(measures: Mapping[str, Mapping[str, float]], units: str, hint: str,
                     read_as: tuple[str, float] | None = None) -> list[Diagnostic]:
    """``implausible_building_height`` when two or more zones have a height and the tallest is under
    :data:`TALLEST`'s 1.8 m, naming it and the unit that would make it a storey's."""
    read_as = read_as or (units, METRES[units])
    heights = {zone: size["height"] for zone, size in measures.items() if size.get("height", 0) > 0}
    if len(heights) < 2:
        return []
    zone, value = max(heights.items(), key=lambda item: item[1])
    si = value * METRES[units]
    if si >= TALLEST.low:
        return []
    mix = _mix_up(si, TALLEST, read_as)
    likely = (f"the numbers look like {mix[0]} read as {read_as[0]} ({si / read_as[1]:.4g} {mix[0]}, a storey's "
              f"height): {hint.format(unit=mix[0])}") if mix else "check the coordinates' unit"
    return [Diagnostic(code=TALLEST.code, message=(
        f"The tallest of {len(heights)} zones, {zone!r}, is {value:.4g} {units} high: no zone of this building is "
        f"{TALLEST.low / METRES[units]:.3g} {units} high, as a room one stands in is; {likely}."),
        details={"quantity": TALLEST.quantity, "units": units, "tallest_zone": zone, "height": value,
                 "zones": len(heights), "plausible_minimum": TALLEST.low / METRES[units],
                 "likely_file_unit": mix[0] if mix else None})]


def zones_all_too_tall(measures: Mapping[str, Mapping[str, float]], units: str, hint: str,
                       read_as: tuple[str, float] | None = None) -> list[Diagnostic]:
    """``implausible_lowest_zone_height`` when every room-shaped zone (at least as wide as high) stands over
    :data:`LOWEST`'s 50 m, naming the lowest and the unit that would make it a storey's. A zone taller than wide (a
    stair, a shaft, an atrium) is left out rather than let it silence the check for the whole model."""
    read_as = read_as or (units, METRES[units])
    heights = {zone: size["height"] for zone, size in measures.items()
               if size.get("height", 0) > 0 and size.get("extent", 0) >= size["height"]}
    if not heights:
        return []
    zone, value = min(heights.items(), key=lambda item: item[1])
    si = value * METRES[units]
    if si <= LOWEST.high:
        return []
    mix = _mix_up(si, STOREY, read_as)
    likely = (f"the numbers look like {mix[0]} read as {read_as[0]} ({si / read_as[1]:.4g} {mix[0]} = {mix[1]:.3g} "
              f"m, a storey's height): {hint.format(unit=mix[0])}") if mix else "check the coordinates' unit"
    every = f"the lowest of {len(heights)} such zones, {zone!r}," if len(heights) > 1 else f"the one such zone, {zone!r},"
    return [Diagnostic(code=LOWEST.code, message=(
        f"Every zone wider than high stands over {LOWEST.high / METRES[units]:.3g} {units} high ({every} is "
        f"{value:.4g} {units} high): a hangar's or a stadium's height, never every room's; unless the model is such "
        f"a hall, {likely}."),
        details={"quantity": LOWEST.quantity, "units": units, "lowest_zone": zone, "height": value,
                 "zones": len(heights), "plausible_maximum": LOWEST.high / METRES[units],
                 "likely_file_unit": mix[0] if mix else None})]
