"""The matching tolerance judged against the model it is used on: in the file's length unit (the project's
``IfcUnitAssignment``), set against the sizes of the products and the model's extent. A tolerance meant in
millimetres given to a metre model (``1``) would share products that differ by most of a metre: refused, naming
the tolerance, the unit, the product sizes and the model's extent. The ranges are the README's table (dedup)."""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from typing import IO

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.base import reject
from plantsolve.solvers.length_units import METRES

INTAKE_REFUSE_M = 0.1  # refused at submission: no two products 10 cm apart are one shape
WARN_M = 0.005  # a tolerance above 5 mm merges what a drawing tells apart
WARN_OF_SIZE = 0.005  # … or above 0.5 % of the median product size
REFUSE_OF_SIZE = 0.05  # from 5 % of the median product size on, different shapes verify as one: refused
FLOAT_RESOLUTION = 1e-14  # a tolerance below this many times the coordinates' magnitude cannot verify anything


def product_boxes(points: Iterable[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Each product's bounding box, (lower corners, upper corners) as (n, 3) arrays in the order given."""
    parts = list(points)
    if not parts:
        return np.zeros((0, 3)), np.zeros((0, 3))
    counts = np.array([len(p) for p in parts])
    if not counts.all():  # an empty product has no box (min of nothing): as the products one by one would say
        raise ValueError("a product without points has no size")
    # every product's box at once (minima and maxima are exact, whatever the grouping)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    together = np.concatenate(parts)
    return np.minimum.reduceat(together, starts, axis=0), np.maximum.reduceat(together, starts, axis=0)


def model_sizes(boxes: tuple[np.ndarray, np.ndarray]) -> tuple[float, float, float]:
    """(median product size, model extent, largest coordinate magnitude), in file units, of the products' ``boxes``
    (:func:`product_boxes`): sizes are bounding-box diagonals."""
    a, b = boxes
    if not len(a):
        return 0.0, 0.0, 0.0
    sizes = [math.sqrt(d.dot(d)) for d in b - a]  # np.linalg.norm of a vector: the same dot product, the same root
    far = max(float(np.abs(a).max()), float(np.abs(b).max()))  # a box's corners hold its points' extremes
    return float(np.median(sizes)), float(np.linalg.norm(b.max(axis=0) - a.min(axis=0))), far


# The median product's size (bounding-box diagonal) of a real model: bolts and fittings of a few centimetres to
# slabs and girders of tens of metres. Outside it, the numbers are in another unit than the IfcUnitAssignment says.
PRODUCT_SIZE_M = (0.005, 200.0)


def judge_product_size(median: float, unit_name: str, metres_per_unit: float) -> list[Diagnostic]:
    """A warning when the median product, read in the file's stated length unit, is smaller than 5 mm or larger
    than 200 m: a model whose IFCSIUNIT says MILLI over numbers written in metres has 2 mm doors (and every length,
    tolerance and deviation of the result is then 1000 times off in `units`)."""
    metres = median * metres_per_unit
    low, high = PRODUCT_SIZE_M
    if not (metres > 0 and (metres < low or metres > high)):
        return []
    likely = [name for name in ("m", "mm", "ft", "in", "cm") if METRES[name] != metres_per_unit
              and 0.05 <= median * METRES[name] <= 20.0]
    meant = (f"; the numbers read as {likely[0]} give {median * METRES[likely[0]]:.3g} m: written in {likely[0]}?"
             if likely else ".")
    return [Diagnostic(code="implausible_product_size", message=(
        f"The median product measures {median:.4g} {unit_name} across (= {metres:.3g} m, in the length unit the "
        f"file's IfcUnitAssignment states), outside {low * 1000:g} mm - {high:g} m: the coordinates are likely in "
        f"another unit than the file states, and the result's lengths, tolerance and deviations with them{meant}"),
        details={"quantity": "median product size", "value": median, "unit": unit_name, "metres": metres,
                 "plausible_range_m": [low, high], "likely_units": likely})]


def _meant(tolerance: float, metres_per_unit: float) -> str:
    """The unit the number was likely meant in: the largest smaller unit in which it is at most WARN_M."""
    for name in ("mm", "cm", "in"):
        if METRES[name] < metres_per_unit and tolerance * METRES[name] <= WARN_M:
            return f"; meant in {name} ({tolerance:g} {name} = {tolerance * METRES[name] / metres_per_unit:g} " \
                   "in the file's unit)?"
    return ""


def judge(tolerance: float, explicit: bool, unit_name: str, metres_per_unit: float,
          sizes: tuple[float, float, float]) -> list[Diagnostic]:
    """Warnings on a tolerance out of its plausible range; a 422 on ``options.tolerance`` when it would let
    different shapes verify as one."""
    median, extent, far = sizes
    metres = tolerance * metres_per_unit
    of_size = tolerance / median if median > 0 else 0.0
    in_metres = f" = {metres:g} m" if unit_name != "m" else ""
    said = (f"tolerance {tolerance:g} {unit_name}{in_metres} (a tolerance is in the file's length unit, {unit_name}, "
            "from its IfcUnitAssignment)")
    facts = (f"the median product measures {median:.4g} {unit_name} across and the model {extent:.4g} {unit_name}")
    details = {"tolerance": tolerance, "unit": unit_name, "metres_per_unit": metres_per_unit, "tolerance_m": metres,
               "median_product_size": median, "model_extent": extent, "fraction_of_product_size": of_size}
    where = "options.tolerance" if explicit else "the model context's Precision"
    if of_size >= REFUSE_OF_SIZE and explicit:
        raise reject(f"{said} is {of_size:.0%} of a product's size: {facts}, and products that differ by that much "
                     f"would share one geometry{_meant(tolerance, metres_per_unit)} Give it in {unit_name}, below "
                     f"{REFUSE_OF_SIZE * median:.3g} {unit_name}",
                     ("options", "tolerance"))
    if metres > WARN_M or of_size > WARN_OF_SIZE:
        return [Diagnostic(code="implausible_tolerance", message=(
            f"The {said}, from {where}, is more than {WARN_M * 1000:g} mm or {WARN_OF_SIZE:.1%} of a product's size: "
            f"{facts}; products that differ by up to it share geometry (see each class's max_deviation)"
            f"{_meant(tolerance, metres_per_unit) or '.'}"), details=details)]
    if tolerance < FLOAT_RESOLUTION * far or metres < 1e-9:
        return [Diagnostic(code="implausible_tolerance", message=(
            f"The {said}, from {where}, is below what coordinates up to {far:.3g} {unit_name} resolve "
            f"({FLOAT_RESOLUTION * far:.3g} {unit_name}) or below a nanometre: only bit-identical copies can verify. "
            "Meant in a larger unit (metres given to a millimetre model)?"), details=details)]
    return []


def from_precision(precision: float | None, default: float, unit_name: str, metres_per_unit: float,
                   sizes: tuple[float, float, float]) -> tuple[float, str, list[Diagnostic]]:
    """The tolerance when the options give none: the model context's Precision (file units), unless it is none,
    not a positive number, or so large that the solve would refuse it as ``options.tolerance`` (a Precision is the
    kernel's, not a statement that products that far apart are one shape); then ``default``, with a warning
    naming the Precision. Returns (tolerance, where it came from, warnings)."""
    if precision is None:
        return default, f"{default * metres_per_unit:g} m", []
    median = sizes[0]
    why = None
    if not math.isfinite(precision) or precision <= 0:
        why = "is not a positive length"
    elif precision * metres_per_unit > INTAKE_REFUSE_M:
        why = f"is more than {INTAKE_REFUSE_M:g} m"
    elif median > 0 and precision >= REFUSE_OF_SIZE * median:
        why = (f"is {precision / median:.0%} of the median product's size ({median:.4g} {unit_name}): products that "
               "differ by that much would share one geometry")
    if why is None:
        return precision, "the model context's Precision", []
    origin = f"{default * metres_per_unit:g} m (the model context's Precision {precision:g} {unit_name} {why})"
    return default, origin, [Diagnostic(code="implausible_precision", message=(
        f"The model context's Precision {precision:g} {unit_name} {why}: not used as the matching tolerance; "
        f"{default:g} {unit_name}" + (f" ({default * metres_per_unit:g} m)" if unit_name != "m" else "")
        + " was used instead. Give options.tolerance to choose another."), details={"precision": precision, "unit": unit_name, "tolerance": default})]


_SI_LENGTH = re.compile(rb"IFCSIUNIT\s*\(\s*\*\s*,\s*\.LENGTHUNIT\.\s*,\s*(?:\.(\w+)\.|\$)\s*,\s*\.METRE\.\s*\)",
                        re.IGNORECASE)
_NAMED_LENGTH = re.compile(rb"IFCCONVERSIONBASEDUNIT\s*\(\s*#\d+\s*,\s*\.LENGTHUNIT\.\s*,\s*'([^']*)'", re.IGNORECASE)
_PREFIX = {b"": ("m", 1.0), b"MILLI": ("mm", 1e-3), b"CENTI": ("cm", 1e-2), b"DECI": ("dm", 0.1),
           b"KILO": ("km", 1e3), b"MICRO": ("um", 1e-6)}
_NAMED = {b"FOOT": ("ft", 0.3048), b"FEET": ("ft", 0.3048), b"INCH": ("in", 0.0254), b"YARD": ("yd", 0.9144),
          b"MILE": ("mi", 1609.344)}
CHUNK = 1 << 20


def stated_length_unit(stream: IO[bytes]) -> tuple[str, float] | None:
    """The one length unit the STEP text defines (its symbol, metres), read in chunks without parsing
    the model; None when it defines none, several, or one this scan does not know (the solve reads it properly)."""
    found: set[tuple[str, float]] = set()
    carry = b""
    while chunk := stream.read(CHUNK):
        text = carry + chunk
        carry = text[-200:]  # a definition across the chunks' border is seen whole in the next text
        if b"LENGTHUNIT" not in text and b"lengthunit" not in text.lower():  # STEP writes keywords in capitals
            continue
        for match in _SI_LENGTH.finditer(text):
            prefix = (match.group(1) or b"").upper()
            if prefix not in _PREFIX:
                return None
            found.add(_PREFIX[prefix])
        for match in _NAMED_LENGTH.finditer(text):
            name = match.group(1).strip().upper()
            if name not in _NAMED:
                return None
            found.add(_NAMED[name])
    return found.pop() if len(found) == 1 else None


def refuse_at_intake(tolerance: float, unit: tuple[str, float]) -> None:
    """A 422 on ``options.tolerance`` when it is beyond any plausible tolerance whatever the model."""
    name, metres = unit
    if tolerance * metres > INTAKE_REFUSE_M:
        in_metres = f" = {tolerance * metres:g} m" if name != "m" else ""
        raise reject(f"tolerance {tolerance:g} {name}{in_metres} (a tolerance is in the file's length "
                     f"unit, {name}, from its IfcUnitAssignment): more than {INTAKE_REFUSE_M:g} m, products that "
                     f"differ by that much are not copies of one shape{_meant(tolerance, metres)} Give it in {name}",
                     ("options", "tolerance"))
