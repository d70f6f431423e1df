"""The file's length unit judged by what every plant model has: pipes of standard outside diameters. A plant model
(pipes, valves, no doors, walls or storeys) written in metres under a FOOT assignment has products of plausible size
either way (a 0.3 m valve read as 0.3 ft is 9 cm), so the median product and the building heights say nothing; but a
pipe's outside diameter is a catalogue number: 114.3 mm for every 4-inch pipe (ASME B36.10M) and every DN 100 tube of
ISO 4200's series 1, which read as 0.1143 ft is 34.8 mm, no standard pipe.

A pipe segment's outside diameter is measured from its world points: the axis is the principal axis whose spread
differs from the other two (equal, across a circle's section), the diameter twice the largest distance from it (a
circle's tessellation has its vertices on the circle). Only when at least three different diameters are measured, and
most of them are no standard size in the stated unit while nearly all are in another, is the unit called wrong: one
or two diameters can match a table by chance, and a model drawing its pipes at nominal size (DN 100 as 100 mm) matches
in no unit, and is no unit mistake."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from plantsolve.schemas.common import Diagnostic

# outside diameters in mm: ASME B36.10M (NPS 1/8 to 48) and ISO 4200 / EN 10220 series 1 (the metric tubes)
ASME_B36_10M_MM = (10.3, 13.7, 17.1, 21.3, 26.7, 33.4, 42.2, 48.3, 60.3, 73.0, 88.9, 101.6, 114.3, 141.3, 168.3,
                   219.1, 273.0, 323.8, 355.6, 406.4, 457.0, 508.0, 559.0, 610.0, 660.0, 711.0, 762.0, 813.0, 864.0,
                   914.0, 965.0, 1016.0, 1067.0, 1118.0, 1168.0, 1219.0)
ISO_4200_SERIES_1_MM = (10.2, 13.5, 17.2, 21.3, 26.9, 33.7, 42.4, 48.3, 60.3, 76.1, 88.9, 114.3, 139.7, 168.3, 219.1,
                        273.0, 323.9, 355.6, 406.4, 457.0, 508.0, 610.0, 711.0, 813.0, 914.0, 1016.0, 1219.0)
# tubes a plant is also piped in, each size standard in the unit it is drawn in: copper EN 1057 (mm) and ASTM B88
# (inches: the nominal size and 1/8), thermoplastic ISO 161-1 / ISO 4065, multilayer
EN_1057_MM = (6.0, 8.0, 10.0, 12.0, 14.0, 15.0, 16.0, 18.0, 22.0, 28.0, 35.0, 42.0, 54.0, 64.0, 66.7, 76.1, 88.9,
              108.0, 133.0, 159.0, 219.0, 267.0)
ASTM_B88_IN = (0.375, 0.5, 0.625, 0.75, 0.875, 1.125, 1.375, 1.625, 2.125, 2.625, 3.125, 3.625, 4.125, 5.125, 6.125,
               8.125, 10.125, 12.125)
ISO_161_MM = (10.0, 12.0, 16.0, 20.0, 25.0, 32.0, 40.0, 50.0, 63.0, 75.0, 90.0, 110.0, 125.0, 140.0, 160.0, 180.0,
              200.0, 225.0, 250.0, 280.0, 315.0, 355.0, 400.0, 450.0, 500.0, 560.0, 630.0, 710.0, 800.0, 900.0, 1000.0,
              1200.0)
MULTILAYER_MM = (14.0, 16.0, 18.0, 20.0, 25.0, 26.0, 32.0, 40.0, 50.0, 63.0)
# Pipes are a unit's evidence only by the steel series: NPS 14 and up are whole inches (406.4 mm = 16 in), so a
# metric tube's even millimetres read as inches land on them; the tube series only keep an honest model from being
# called wrong (18, 22, 28 mm copper is no steel pipe in mm, and is standard there).
STANDARD_OD_M = np.array(sorted(set(ASME_B36_10M_MM + ISO_4200_SERIES_1_MM))) / 1000.0
PLAUSIBLE_OD_M = np.array(sorted(set(ASME_B36_10M_MM + ISO_4200_SERIES_1_MM + EN_1057_MM + ISO_161_MM + MULTILAYER_MM
                                     + tuple(25.4 * d for d in ASTM_B88_IN)))) / 1000.0
MATCH = 0.005  # relative: 273.0 and 273.1 mm are one size; a diameter read in the wrong unit is off by 3x or more
ROUND_SECTION = 0.02  # the two cross-section spreads of a round pipe agree within this (relative)
MIN_DIAMETERS = 3  # different diameters measured before a unit is judged
STATED_AT_MOST, OTHER_AT_LEAST = 0.5, 0.9  # the share of pipes of standard size in the stated and the other unit
PIPE_TYPES = ("IfcPipeSegmentType",)  # IFC2X3's pipes are IfcFlowSegments of this type


def outside_diameter(points: np.ndarray) -> float | None:
    """Twice the largest distance of ``points`` from their axis of revolution, or None when the points have no
    round section (the two spreads across the odd principal axis differ)."""
    if len(points) < 6:
        return None
    local = points - points.mean(axis=0)
    values, vectors = np.linalg.eigh(local.T @ local / len(local))
    # the section's two equal spreads: either the two smallest (a long pipe) or the two largest (a short one)
    for axis, (a, b) in ((2, (0, 1)), (0, (1, 2))):
        # the pair equal, the axis apart from them (a pipe as long as it is wide has no telling axis)
        if values[b] > 0 and abs(values[a] - values[b]) <= ROUND_SECTION * values[b] \
                and abs(values[axis] - values[b]) > 10 * ROUND_SECTION * values[b]:
            along = local @ vectors[:, axis]
            radial = local - np.outer(along, vectors[:, axis])
            return 2.0 * float(np.sqrt(np.max(np.sum(radial * radial, axis=1))))
    return None


def is_pipe(product) -> bool:
    if product.is_a("IfcPipeSegment"):
        return True
    if not product.is_a("IfcFlowSegment"):
        return False
    typed = [rel.RelatingType for rel in getattr(product, "IsDefinedBy", ()) or ()
             if rel.is_a("IfcRelDefinesByType")] + [rel.RelatingType for rel in getattr(product, "IsTypedBy", ()) or ()]
    return any(t is not None and t.is_a(name) for t in typed for name in PIPE_TYPES)


def standard_share(diameters: np.ndarray, metres_per_unit: float, sizes_m: np.ndarray = STANDARD_OD_M) -> float:
    """The share of ``diameters`` (file units) that are one of ``sizes_m`` (outside diameters, m) in a unit of that many
    metres."""
    metres = diameters * metres_per_unit
    nearest = np.abs(metres[:, None] - sizes_m[None, :]).min(axis=1)
    return float(np.mean(nearest <= MATCH * metres))


def judge_pipe_diameters(products: Iterable, points: Mapping[int, np.ndarray], unit_name: str, metres_per_unit: float,
                         units_m: Mapping[str, float]) -> list[Diagnostic]:
    """Warning ``implausible_product_size`` (its quantity: the pipe outside diameter) when the pipe segments' outside diameters, read in the file's stated
    unit, are mostly no standard pipe or tube size and read in another of ``units_m`` (name → metres) nearly all are
    steel pipe sizes."""
    measured = [d for d in (outside_diameter(points[p.id()]) for p in products if p.id() in points and is_pipe(p))
                if d is not None and d > 0]
    if len({round(d, 9) for d in measured}) < MIN_DIAMETERS:
        return []
    diameters = np.array(measured)
    stated = standard_share(diameters, metres_per_unit, PLAUSIBLE_OD_M)
    if stated > STATED_AT_MOST:
        return []
    likely = [name for name, size in units_m.items() if size != metres_per_unit
              and standard_share(diameters, size) >= OTHER_AT_LEAST]
    if not likely:  # no unit makes them catalogue pipes: drawn at nominal size, or insulated, not a unit
        return []
    shown = sorted({round(d, 6) for d in measured})[:6]
    said = ", ".join(f"{d:.4g}" for d in shown)
    return [Diagnostic(code="implausible_product_size", message=(
        f"In the length unit the file's IfcUnitAssignment states ({unit_name}), {1 - stated:.0%} of the "
        f"{len(measured)} pipe segments have an outside diameter no standard pipe or tube has (ASME B36.10M, ISO 4200, copper, plastic and multilayer tube series): "
        f"{said} {unit_name}; read as {likely[0]} they are standard sizes "
        f"({', '.join(f'{d * units_m[likely[0]] * 1000:.4g} mm' for d in shown)}). The coordinates are likely in "
        f"another unit than the file states, and the result's lengths, tolerance and deviations with them - "
        f"written in {likely[0]}?"),
        details={"quantity": "pipe outside diameter", "values": shown, "unit": unit_name,
                 "metres_per_unit": metres_per_unit, "standard_share": stated, "pipes_measured": len(measured),
                 "likely_units": likely})]
