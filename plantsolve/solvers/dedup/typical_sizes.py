"""The file's length unit judged by what every building has: doors about 2 m high, walls a storey high, storeys
about 3 m apart. A model whose IfcUnitAssignment says CENTI over numbers written in metres has 2 cm doors, which the
median product's size (:func:`.tolerance.judge_product_size`, 5 mm - 200 m) lets through: a 2 cm door is no odd
product, but it is no door. Each range is wide (garage doors, double-height halls, mezzanines): only a unit off by a
factor of about ten or more leaves it."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np

from plantsolve.schemas.common import Diagnostic

# quantity → (the IFC class whose members it measures, plausible range of its median in metres)
HEIGHTS_M = {"door height": ("IfcDoor", (1.5, 6.0)), "wall height": ("IfcWall", (1.0, 50.0))}
STOREY_HEIGHT_M = (1.8, 20.0)  # the median step between storey elevations
MIN_MEMBERS = 2  # one odd door is a modelling choice, not a unit


def _medians(products: Iterable, points: Mapping[int, np.ndarray], storey_elevations: Iterable[float | None]
             ) -> dict[str, tuple[float, int]]:
    """Quantity → (median in file units, how many measured it)."""
    found: dict[str, tuple[float, int]] = {}
    for quantity, (entity, _) in HEIGHTS_M.items():
        heights = [float(np.ptp(points[p.id()][:, 2])) for p in products if p.id() in points and p.is_a(entity)]
        heights = [h for h in heights if h > 0]
        if len(heights) >= MIN_MEMBERS:
            found[quantity] = (float(np.median(heights)), len(heights))
    levels = sorted({round(float(e), 9) for e in storey_elevations if e is not None and math.isfinite(float(e))})
    steps = [b - a for a, b in zip(levels, levels[1:], strict=False)]
    if len(steps) >= 1:
        found["storey height"] = (float(np.median(steps)), len(levels))
    return found


def _plausible(quantity: str, metres: float) -> bool:
    low, high = HEIGHTS_M[quantity][1] if quantity in HEIGHTS_M else STOREY_HEIGHT_M
    return low <= metres <= high


def judge_typical_sizes(products: Iterable, points: Mapping[int, np.ndarray], storey_elevations: Iterable[float | None],
                        unit_name: str, metres_per_unit: float, units_m: Mapping[str, float]) -> list[Diagnostic]:
    """Warning ``implausible_product_size`` when doors, walls and storeys (those measured, doors or walls among
    them), read in the file's stated unit, are all outside what buildings have and another of ``units_m`` (name → metres: the length units the project names) makes every one
    of them plausible, naming that unit."""
    medians = _medians(products, points, storey_elevations)
    wrong = {q: v for q, (v, _) in medians.items() if not _plausible(q, v * metres_per_unit)}
    # a unit is wrong for the whole file: every quantity measured must say so, doors or walls among them (storey
    # levels alone mislead: a slab level 300 mm above its floor level, a foundation level 1.2 m below the ground's)
    if not wrong or len(wrong) < len(medians) or not any(q in HEIGHTS_M for q in wrong):
        return []
    likely = [name for name in ("m", "mm", "cm", "ft", "in") if units_m[name] != metres_per_unit
              and all(_plausible(q, v * units_m[name]) for q, (v, _) in medians.items())]
    if not likely:  # no unit makes the building plausible: odd elements (garden walls, hatches), not a unit
        return []
    said = "; ".join(f"the median {q} is {v:.4g} {unit_name} (= {v * metres_per_unit:.3g} m, of {medians[q][1]})"
                     for q, v in wrong.items())
    read_so = ", ".join(f"{v * units_m[likely[0]]:.3g} m" for v in wrong.values())
    meant = f": the numbers read as {likely[0]} give {read_so}"
    return [Diagnostic(code="implausible_product_size", message=(
        f"In the length unit the file's IfcUnitAssignment states ({unit_name}), {said}: outside what buildings have, "
        f"so the coordinates are likely in another unit, and the result's lengths, tolerance and deviations with "
        f"them{meant} - written in {likely[0]}?"),
        details={"quantity": ", ".join(wrong), "values": wrong, "unit": unit_name, "metres_per_unit": metres_per_unit,
                 "plausible_range_m": {q: list(HEIGHTS_M[q][1] if q in HEIGHTS_M else STOREY_HEIGHT_M) for q in wrong},
                 "likely_units": likely})]
