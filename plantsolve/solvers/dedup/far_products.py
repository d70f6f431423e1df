"""Products whose placement tells on the result: one left out of sharing because where it is placed the doubles are
too far apart to match its shape within the tolerance, and one placed far from the rest of the model (judged
against the model's own extent, never against an absolute number: a georeferenced model, every product millions of
metres from the origin, has no product far from the rest)."""

from __future__ import annotations

import ifcopenshell.util.placement
import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.dedup.grouping import signatures

# A product's points are rounded to the spacing of the doubles at its placement: from an eighth of the tolerance on,
# the rounding takes a visible share of what the matching may deviate (at 2e11 m the spacing is 3e-5 m, three
# times a 1e-5 m Precision, and a congruent product no longer matches; at 5e10 m, 7.6e-6 m, it still does).
ROUNDING_SHARE = 1 / 8
# A look-alike: a product of the same group key whose signature lies within the grouping's own reach (4 tolerances)
# plus this many of the far product's rounding steps.
ROUNDING_STEPS = 16
# Far from the rest: the centre lies more than this many times the model's typical distance (the median distance of
# the products' centres from their median centre, at least the median product's size) from that median centre. A
# 50 m building's product 10 km off (200 times) is not named; a unit or exponent slip (1e3 to 1e12 times) is.
FAR_FACTOR = 1000.0
MIN_PRODUCTS = 3  # of two products neither is the outlier
LISTED = 10
MAX_LISTED = 200


def _who(product) -> str:
    name = getattr(product, "Name", None)
    return f"#{product.id()}={product.is_a()}" + (f" {name!r}" if name else "") + f" ({product.GlobalId})"


def placement_offset(product) -> float | None:
    """The length of the translation of ``product``'s placement chain (file units), None without one."""
    placement = getattr(product, "ObjectPlacement", None)
    if placement is None or not placement.is_a("IfcLocalPlacement"):
        return None
    try:
        matrix = ifcopenshell.util.placement.get_local_placement(placement)
    except (RuntimeError, ValueError, TypeError, AttributeError):
        return None
    offset = float(np.linalg.norm(np.asarray(matrix, dtype=float)[:3, 3]))
    return offset if np.isfinite(offset) else None


def _offset(found: dict) -> float:
    """The placement's magnitude, or the product's largest coordinate where its placement chain has none."""
    return found["placement_offset"] if found["placement_offset"] is not None else found["largest_coordinate"]


def left_out_by_placement(classes: list, tol: float, unit: str) -> list[Diagnostic]:
    """``placement_beyond_tolerance``: the products that share with no other (a class of one) although a product of
    their group looks alike (:data:`ROUNDING_STEPS`), placed where the doubles' spacing is at least
    :data:`ROUNDING_SHARE` of the tolerance, each named with its placement's magnitude and the look-alike."""
    steps = {id(cls): float(np.spacing(float(np.abs(cls.representative.shape.points).max())))
             for cls in classes if len(cls.members) == 1}
    coarse = {k: step for k, step in steps.items() if step >= ROUNDING_SHARE * tol}
    if not coarse:  # the common case: the signatures are not computed again
        return []
    by_key: dict[tuple, list] = {}
    for cls in classes:
        by_key.setdefault(cls.representative.key, []).append(cls)
    found = []
    for group in by_key.values():
        if len(group) < 2 or not any(id(cls) in coarse for cls in group):
            continue
        sig = signatures([cls.representative.shape for cls in group])
        for k, cls in enumerate(group):
            if id(cls) not in coarse:
                continue
            shape, step = cls.representative.shape, coarse[id(cls)]
            gaps = np.abs(sig - sig[k]).max(axis=1)
            gaps[k] = np.inf
            j = int(np.argmin(gaps))
            if gaps[j] > 4 * tol + ROUNDING_STEPS * step:
                continue
            product = cls.representative.product
            offset = placement_offset(product)
            found.append({"product": _who(product), "global_id": product.GlobalId,
                          "placement_offset": offset, "largest_coordinate": float(np.abs(shape.points).max()),
                          "spacing": step, "looks_like": group[j].representative.product.GlobalId})
    if not found:
        return []
    shown = "; ".join(f"{f['product']} placed {_offset(f):.3g} {unit} from the origin, doubles there "
                      f"{f['spacing']:.2g} {unit} apart, looks like {f['looks_like']}" for f in found[:LISTED])
    return [Diagnostic(code="placement_beyond_tolerance", message=(
        f"{len(found)} product(s) share no geometry because of where they are placed: their coordinates are so large "
        f"that the numbers next to them are at least {ROUNDING_SHARE:g} of the tolerance {tol:g} {unit} apart, so "
        f"their shape cannot be matched to a product it looks like within the tolerance: {shown}"
        f"{' …' if len(found) > LISTED else ''}. Placed by a unit or exponent slip?"),
        details={"quantity": "product placement", "products": found[:MAX_LISTED], "count": len(found),
                 "tolerance": tol, "unit": unit, "rounding_share": ROUNDING_SHARE})]


def placement_outliers(products: list, centres_by_id: dict, median_size: float, unit: str,
                       shared: set[str]) -> list[Diagnostic]:
    """``placement_outlier``: the products whose centre (``centres_by_id``: instance id -> the centre of its world
    points' box) lies more than :data:`FAR_FACTOR` times the model's typical distance from the median centre (module
    docstring), each named with its distance, its placement's magnitude and whether it shares geometry (``shared``:
    GlobalIds)."""
    placed = [p for p in products if p.id() in centres_by_id]
    if len(placed) < MIN_PRODUCTS:
        return []
    centres = np.array([centres_by_id[p.id()] for p in placed])
    middle = np.median(centres, axis=0)
    distances = np.linalg.norm(centres - middle, axis=1)
    typical = max(float(np.median(distances)), float(median_size))
    if not typical > 0:
        return []
    far = np.flatnonzero(distances > FAR_FACTOR * typical)
    if not len(far):
        return []
    far = far[np.argsort(-distances[far], kind="stable")]
    found = [{"product": _who(placed[i]), "global_id": placed[i].GlobalId, "distance": float(distances[i]),
              "times_typical": float(distances[i] / typical), "placement_offset": placement_offset(placed[i]),
              "shares_geometry": placed[i].GlobalId in shared} for i in far[:MAX_LISTED]]
    shown = "; ".join(f"{f['product']} {f['distance']:.3g} {unit} off ({f['times_typical']:.2g} times), "
                      + ("shares geometry" if f["shares_geometry"] else "shares none") for f in found[:LISTED])
    return [Diagnostic(code="placement_outlier", message=(
        f"{len(far)} product(s) lie far from the rest of the model: more than {FAR_FACTOR:g} times the model's "
        f"typical distance ({typical:.3g} {unit}: the median distance of the products' centres from their median "
        f"centre, at least the median product's size) from that centre: {shown}{' …' if len(far) > LISTED else ''}. "
        "Placed by a unit or exponent slip? Their "
        "matching and deviations are as exact as the doubles where they lie allow."),
        details={"quantity": "product placement", "products": found, "count": len(far), "typical_distance": typical,
                 "median_centre": [float(v) for v in middle], "far_factor": FAR_FACTOR, "unit": unit})]
