"""The Volume and Floor Area an EnergyPlus ``Space`` object states (EnergyPlus 9.6+: the rooms a zone is made of).

EnergyPlus takes a Space's Floor Area, when given, instead of the area of its floor surfaces, and a zone's floor area
is the sum of its spaces' unless the Zone object states its own (Input Output Reference, Space, "Field: Floor Area").
So a zone whose every Space states a floor area (or a volume) declares their sum, which the solver sets against what
it measures, as it does a Zone's own Volume and Floor Area. A zone with surfaces that name no Space has one more space,
EnergyPlus' '<zone>-Remainder', which states nothing: its floor area is that of its Floor surfaces, which EnergyPlus
adds to the Spaces' (the reader measures them the same way), and its volume is EnergyPlus' own reckoning, so such a
zone declares no volume.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

SPACE_FIELDS = {"volume": 3, "floor_area": 4}  # after Name, Zone Name and Ceiling Height


def _positive(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:  # blank, autocalculate
        return None
    return value if math.isfinite(value) and value > 0 else None


def space_claims(objects: list, remainders: Mapping[str, float] | None = None) -> dict[str, dict[str, float]]:
    """Zone (lower case) → {quantity: the sum its spaces state}, for the quantities every Space of the zone states,
    from the objects (class, fields, field lines, line); ``remainders``: the zones (lower case) with surfaces in no
    Space → the floor area of those surfaces, added to the floor area claimed (and no volume claimed)."""
    remainders = remainders or {}
    stated: dict[str, dict[str, list[float | None]]] = {}
    for cls, fields, _, _ in objects:
        if cls != "space" or len(fields) < 2 or not fields[1]:
            continue
        zone = stated.setdefault(fields[1].lower(), {key: [] for key in SPACE_FIELDS})
        for key, index in SPACE_FIELDS.items():
            zone[key].append(_positive(fields[index]) if index < len(fields) else None)
    claims: dict[str, dict[str, float]] = {}
    for zone, values in stated.items():
        claim = {key: sum(v) for key, v in values.items() if v and all(x is not None for x in v)}
        if zone in remainders:
            claim.pop("volume", None)
            if "floor_area" in claim:
                claim["floor_area"] += remainders[zone]
        if claim:
            claims[zone] = claim
    return claims
