"""EnergyPlus' interzone surfaces: a surface whose Outside Boundary Condition is ``Surface`` names its twin in the
neighbouring zone, the same wall seen from the other side. Read in world coordinates the two lie on one another; apart,
one of their zones is misplaced (an origin typed 50 for 5, a north axis, surfaces written in world coordinates under
Relative), which the zone volumes do not show but the adjacency does: the shared wall is lost, no word."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.common import Diagnostic

APART_M = 0.05  # twins' centres further apart than a rounding of the writer: not the same wall
MAX_LISTED = 5


def twins_apart(partners: dict[str, tuple[str, int | None]], loops: dict[str, list[list[float]]],
                names: dict[str, str]) -> list[Diagnostic]:
    """Warning ``interzone_surfaces_apart`` for each pair of twin surfaces (``partners``: surface, lower case → (the
    twin it names, its line)) whose centres lie more than 5 cm apart; ``loops``: surface (lower case) → its world
    vertices (m); ``names``: surface (lower case) → its name as written."""
    apart = []
    seen: set[frozenset[str]] = set()
    for surface, (twin, line) in partners.items():
        pair = frozenset((surface, twin.lower()))
        if twin.lower() not in loops or surface not in loops or pair in seen:
            continue
        seen.add(pair)
        distance = float(np.linalg.norm(np.mean(loops[surface], axis=0) - np.mean(loops[twin.lower()], axis=0)))
        if distance > APART_M:
            apart.append((names[surface], names[twin.lower()], line, distance))
    if not apart:
        return []
    listed = "; ".join(f"{a!r}{f' (line {line})' if line else ''} and {b!r}: {d:.3g} m" for a, b, line, d in
                       apart[:MAX_LISTED]) + (" …" if len(apart) > MAX_LISTED else "")
    return [Diagnostic(code="interzone_surfaces_apart", message=(
        f"{len(apart)} pair(s) of interzone surfaces (Outside Boundary Condition 'Surface', each naming the other) do "
        f"not lie on one another: {listed} between their centres. One of their zones is misplaced (its origin, north "
        "axis, or coordinates written for another coordinate system), and the adjacency between them is lost."),
        details={"quantity": "distance between interzone twins", "units": "m",
                 "pairs": [{"surface": a, "twin": b, "line": line, "distance": d} for a, b, line, d in apart[:100]]})]
