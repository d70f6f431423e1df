"""What the totals and net areas count more than once, or leave out, as EnergyPlus counts them: a zone standing
for several (Zone Multiplier), a zone outside the total floor area (Part of Total Floor Area = No), a subsurface
standing for several on its host (a window's or door's Multiplier). Each named in a warning, since a sum of the
listed measures is then not the total."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.polyhedra.file_units import METRES
from plantsolve.solvers.polyhedra.polygons import Polygons

# EnergyPlus takes any whole Zone Multiplier from 1 (its IDD sets no maximum), but a multiplier counts identical zones:
# more of them than the largest hotels have rooms (some 7,000), or copies of one zone that together outgrow the
# largest buildings (Boeing's Everett plant, 1.3e7 m³; 1.7e6 m² of floor), is a typing slip (10 typed 1000000) or
# another field shifted into the Multiplier's place, not a building
MAX_COPIES = 10_000
MAX_COPIES_VOLUME = 3e7  # m³
MAX_COPIES_FLOOR_AREA = 3e6  # m²


def multipliers_applied(zones: list[dict]) -> list[Diagnostic]:
    """The zones the totals count more than once: a sum of the listed zones' measures is not the total."""
    repeated = [z for z in zones if z["multiplier"] > 1]
    if not repeated:
        return []
    listed = ", ".join(f"{z['id']!r} ×{z['multiplier']}" for z in repeated[:10]) + (" …" if len(repeated) > 10 else "")
    return [Diagnostic(code="zone_multipliers_applied", message=(
        f"{len(repeated)} zone(s) stand for several identical zones (EnergyPlus' Zone Multiplier): {listed}. "
        "total_volume and total_floor_area count each that many times, as EnergyPlus counts floor area; the zones' "
        "own measures are one copy's."),
        details={"zones": {z["id"]: z["multiplier"] for z in repeated[:100]}})]


def implausible_multipliers(zones: list[dict], units: str, source: dict | None) -> list[Diagnostic]:
    """``implausible_zone_multiplier`` naming the zones whose multiplier no building has (above :data:`MAX_COPIES`,
    or copies together above the largest buildings' volume or floor area), their ``Zone`` objects' lines (the IDF
    reader's ``source.multiplied_zone_lines``) and what they add to the totals."""
    k = METRES[units]
    said = source.get("multiplied_zone_lines") if isinstance(source, dict) else None
    # a JSON body's own 'source' is free text: only the IDF reader's {zone: line} counts
    lines = {z: n for z, n in said.items() if isinstance(n, int)} if isinstance(said, dict) else {}
    # a zone counted once is no multiplier's doing (a zone too large alone is implausible_zone_volume's)
    found = [z for z in zones if z["multiplier"] > 1 and (
        z["multiplier"] > MAX_COPIES or (z["volume"] or 0.0) * z["multiplier"] * k ** 3 > MAX_COPIES_VOLUME
        or z["floor_area"] * z["multiplier"] * k ** 2 > MAX_COPIES_FLOOR_AREA)]
    if not found:
        return []
    at = {z["id"]: f" (its Zone at line {lines[z['id']]})" if lines.get(z["id"]) else "" for z in found}
    listed = ", ".join(f"{z['id']!r}{at[z['id']]} ×{z['multiplier']:,} ({(z['volume'] or 0.0) * z['multiplier']:.3g} "
                       f"{units}³, {z['floor_area'] * z['multiplier']:.3g} {units}² of floor)" for z in found[:10])
    added = sum((z["volume"] or 0.0) * (z["multiplier"] - 1) for z in found)
    return [Diagnostic(code="implausible_zone_multiplier", message=(
        f"{len(found)} zone multiplier(s) (Zone Multiplier times its ZoneGroup's) no building has: {listed}"
        f"{' …' if len(found) > 10 else ''}. A multiplier counts identical zones: at most {MAX_COPIES:,} of them, "
        f"whose copies together stay within the largest buildings' {MAX_COPIES_VOLUME / k ** 3:.3g} {units}³ and "
        f"{MAX_COPIES_FLOOR_AREA / k ** 2:.3g} {units}² of floor. Their copies add {added:.4g} {units}³ to "
        "total_volume and their floors to total_floor_area: check the Zone's Multiplier field (a typing slip, or "
        "another field shifted into its place) and its ZoneGroup's Zone List Multiplier."),
        details={"quantity": "zone multiplier", "units": units, "plausible_maximum": MAX_COPIES,
                 "copies_volume_maximum": MAX_COPIES_VOLUME / k ** 3,
                 "copies_floor_area_maximum": MAX_COPIES_FLOOR_AREA / k ** 2,
                 "zones": {z["id"]: z["multiplier"] for z in found[:100]},
                 "lines": [lines.get(z["id"]) for z in found[:100]], "volume_added": added,
                 "count": len(found)})]


def subsurface_copies(request: PolyhedraRequest, n_faces: int) -> np.ndarray:
    """Per face, how many copies of it its host holds (1 but for the subsurfaces subsurface_multipliers names)."""
    copies = np.ones(n_faces)
    if request.subsurface_multipliers:  # the faces come first, in request order, a mesh's triangles after them
        for i, face in enumerate(request.faces):
            copies[i] = request.subsurface_multipliers.get(face.id, 1)
    return copies


def subsurface_multipliers_applied(request: PolyhedraRequest, poly: Polygons, area: np.ndarray) -> list[Diagnostic]:
    """The subsurfaces the hosts' net areas subtract more than once: a sum of the listed faces is not the host's."""
    repeated = request.subsurface_multipliers
    if not repeated:
        return []
    index = {face.id: i for i, face in enumerate(request.faces) if face.id in repeated}
    listed = ", ".join(f"{name!r} ×{m} on {poly.face_ids[poly.face_parent[index[name]]]!r}"
                       for name, m in list(repeated.items())[:10]) + (" …" if len(repeated) > 10 else "")
    return [Diagnostic(code="subsurface_multipliers_applied", message=(
        f"{len(repeated)} subsurface(s) stand for several identical ones on their host (EnergyPlus' window or door "
        f"Multiplier): {listed}. The hosts' net_area and the zones' net_surface_area subtract each that many times, "
        "as EnergyPlus multiplies their area; the subsurfaces' own area is one copy's."),
        details={"faces": dict(list(repeated.items())[:100]),
                 "area_subtracted": {name: float(area[index[name]] * m) for name, m in list(repeated.items())[:100]}})]


def floor_areas_left_out(zones: list[dict], units: str) -> list[Diagnostic]:
    """The zones total_floor_area leaves out: a sum of the listed zones' floor areas is not the total."""
    left = [z for z in zones if not z["part_of_total_floor_area"]]
    if not left:
        return []
    listed = ", ".join(f"{z['id']!r} ({z['floor_area']:.6g} {units}² ×{z['multiplier']})" for z in left[:10])
    return [Diagnostic(code="zones_outside_total_floor_area", message=(
        f"{len(left)} zone(s) are not part of the total floor area (EnergyPlus' Part of Total Floor Area = No: "
        f"plenums, attics): {listed}{' …' if len(left) > 10 else ''}. total_floor_area leaves their floors out, as "
        "EnergyPlus' Building Area table does; total_volume counts them."),
        details={"zones": [z["id"] for z in left[:100]],
                 "floor_area_left_out": float(sum(z["floor_area"] * z["multiplier"] for z in left)),
                 "count": len(left)})]
