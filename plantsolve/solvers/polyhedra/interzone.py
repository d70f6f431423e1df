"""EnergyPlus' interzone surfaces: a surface whose Outside Boundary Condition is ``Surface`` names its twin in the
neighbouring zone, the same wall seen from the other side. Read in world coordinates the two lie on one another; apart,
one of their zones is misplaced (an origin typed 50 for 5, a north axis, surfaces written in world coordinates under
Relative), which the zone volumes do not show but the adjacency does: the shared wall is lost, no word."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.common import Diagnostic

# twins' centres further apart than this are not paired by the solver (merge_tolerance, default 1e-6 m), and a writer's
# rounding stays far below it; a tenth of a millimetre's drift in a hand-edited file would lose the adjacency too
APART_M = 0.001
MAX_LISTED = 5


def twins_apart(partners: dict[str, tuple[str, int | None]], loops: dict[str, list[list[float]]],
                names: dict[str, str]) -> list[Diagnostic]:
    """Warning ``interzone_surfaces_apart`` for each pair of twin surfaces (``partners``: surface, lower case → (the
    twin it names, its line)) whose centres lie more than 1 mm apart; ``loops``: surface (lower case) → its world
    vertices (m); ``names``: surface (lower case) → its name as written."""
    apart = []
    seen: set[frozenset[str]] = set()
    for surface, (twin, line) in partners.items():
        pair = frozenset((surface, twin.lower()))
        if twin.lower() not in loops or surface not in loops or pair in seen:
            continue
        seen.add(pair)
        distance = float(np.linalg.norm(_centroid(loops[surface]) - _centroid(loops[twin.lower()])))
        if distance > APART_M:
            apart.append((names[surface], names[twin.lower()], line, distance))
    if not apart:
        return []
    listed = "; ".join(f"{a!r}{f' (line {line})' if line else ''} and {b!r}: {d:.3g} m" for a, b, line, d in
                       apart[:MAX_LISTED]) + (" …" if len(apart) > MAX_LISTED else "")
    return [Diagnostic(code="interzone_surfaces_apart", message=(
        f"{len(apart)} pair(s) of interzone surfaces (Outside Boundary Condition 'Surface', each naming the other) do "
        f"not lie on one another: {listed} between their centres. One of their zones is misplaced (its origin, north "
        "axis, or coordinates written for another coordinate system, or a coordinate typed with another rounding), and "
        "the adjacency between them is lost (faces are paired where they coincide within options.merge_tolerance)."),
        details={"quantity": "distance between interzone twins", "units": "m",
                 "pairs": [{"surface": a, "twin": b, "line": line, "distance": d} for a, b, line, d in apart[:100]]})]


def _centroid(points: list[list[float]]) -> np.ndarray:
    """The area centroid of a planar polygon (a twin written with an extra corner on an edge has the same one; the mean
    of the corners moves)."""
    loop = np.asarray(points, dtype=float)
    normal = np.cross(loop, np.roll(loop, -1, axis=0)).sum(axis=0)
    size = np.linalg.norm(normal)
    if size == 0:
        return loop.mean(axis=0)
    base, a, b = loop[0], loop[1:-1], loop[2:]
    areas = np.cross(a - base, b - base) @ (normal / size)
    return ((base + a + b) / 3 * areas[:, None]).sum(axis=0) / areas.sum()
