"""Why a product cannot be placed or named: a coordinate or direction of its placement chain that no
geometry kernel can use (a writer's 1e300, NaN or zero vector in a root placement leaves every product unplaced, and
the kernel says only that nothing could be processed), or a GlobalId it shares with another product."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from plantsolve.schemas.common import MAX_COORDINATE, Diagnostic
from plantsolve.solvers.dedup.ifcio import instance_line

MAX_CHAIN = 1000  # a placement chain longer than any model's (a cycle written by a broken exporter ends here)


def _coordinates_problem(point) -> str | None:
    values = list(point.Coordinates or ())
    for value in values:
        if not isinstance(value, (int, float)) or not math.isfinite(value) or abs(value) > MAX_COORDINATE:
            return (f"coordinate {value!r} is not a finite number within ±{MAX_COORDINATE:g} of the file's length "
                    "unit")
    return None


def _direction(direction) -> tuple[np.ndarray | None, str | None]:
    ratios = list(direction.DirectionRatios or ())
    if not all(isinstance(r, (int, float)) and math.isfinite(r) for r in ratios):
        return None, f"direction ratios {tuple(ratios)!r} are not finite numbers"
    vector = np.asarray(ratios, dtype=float)
    if not len(vector) or np.linalg.norm(vector) == 0:
        return None, f"direction ratios {tuple(ratios)!r} have no length"
    return vector / np.linalg.norm(vector), None


def _axis_placement_problem(placement) -> tuple[object, str] | None:
    """(the instance, what is wrong with it) of an IfcAxis2Placement2D/3D, or None."""
    location = getattr(placement, "Location", None)
    if location is not None and location.is_a("IfcCartesianPoint"):
        problem = _coordinates_problem(location)
        if problem:
            return location, problem
    found = {}
    for name in ("Axis", "RefDirection"):
        direction = getattr(placement, name, None)
        if direction is None:
            continue
        vector, problem = _direction(direction)
        if problem:
            return direction, problem
        found[name] = vector
    if len(found) == 2 and len(found["Axis"]) == len(found["RefDirection"]) == 3 and \
            np.linalg.norm(np.cross(found["Axis"], found["RefDirection"])) < 1e-12:
        return placement, "its Axis and RefDirection are parallel: they span no plane"
    return None


def _beyond_precision(placement, precision: float | None) -> tuple[object, str] | None:
    """(the location, why) when a coordinate of ``placement``'s Location is so large that the numbers next to it (a
    double's spacing there) are further apart than the context's Precision: a point placed in it cannot be told
    from one ``precision`` away."""
    location = getattr(placement, "Location", None)
    if not precision or not math.isfinite(precision) or precision <= 0 or location is None or \
            not location.is_a("IfcCartesianPoint"):
        return None
    for value in location.Coordinates or ():
        if np.spacing(abs(float(value))) > precision:
            return location, (f"coordinate {value!r} is so large that the numbers next to it are "
                              f"{np.spacing(abs(float(value))):g} apart, more than the context's Precision "
                              f"{precision:g}: nothing placed in it keeps that precision")
    return None


def _attribute_holding(placement, instance) -> str:
    """The attribute of an IfcAxis2Placement that holds ``instance`` ('' for the placement itself)."""
    for name in ("Location", "Axis", "RefDirection"):
        if getattr(placement, name, None) == instance:
            return name
    return ""


def world_refusal(problem: str) -> str:
    """The refusal of a model whose world coordinate system is ``problem`` (:func:`world_coordinate_problem`)."""
    return (f"the model's world coordinate system cannot place its products: {problem}; every product's geometry is "
            "placed in it, so no deviation could be verified (most exporters write it at 0,0,0 with its Axis along Z "
            "and its RefDirection along X)")


def world_coordinate_problem(model, path=None, text: bytes | None = None) -> str | None:
    """What is wrong with the WorldCoordinateSystem of a representation context, every product's geometry placed in
    it (a writer's 1e308, NaN, a zero or parallel axis, or a location beyond what the context's Precision can carry),
    named by the context's attribute and the instance with its line in the file at ``path`` (or in its ``text``);
    None when every context's is sound. The geometry kernel tessellates without it, so no product is left unplaced,
    and deviations measured without it would be claimed for a model whose every point is meaningless."""
    for context in model.by_type("IfcGeometricRepresentationContext"):
        if context.is_a("IfcGeometricRepresentationSubContext"):  # its parent's system, derived
            continue
        system = context.WorldCoordinateSystem
        if system is None:
            continue
        found = _axis_placement_problem(system) or _beyond_precision(system, context.Precision)
        if found is None:
            continue
        instance, problem = found
        held = _attribute_holding(system, instance)
        where = f", the WorldCoordinateSystem of #{context.id()}={context.is_a()}"
        if held:
            where = f", the {held} of #{system.id()}={system.is_a()}{where}"
        return describe(instance, problem, text if text is not None else _text(path), where)
    return None


def placement_problem(product) -> tuple[object, str] | None:
    """The first instance of ``product``'s placement chain (from the product up to the root) whose numbers no kernel
    can place with, and why; None when the chain is sound (or not a chain of local placements)."""
    placement = getattr(product, "ObjectPlacement", None)
    for _ in range(MAX_CHAIN):
        if placement is None or not placement.is_a("IfcLocalPlacement"):
            return None
        relative = placement.RelativePlacement
        if relative is not None:
            problem = _axis_placement_problem(relative)
            if problem:
                return problem
        placement = placement.PlacementRelTo
    return None


def describe(instance, problem: str, text: bytes | None = None, placing: str = "") -> str:
    """'#19=IfcCartesianPoint (line 26) in the placement of 15 of the 15 products with geometry: coordinate …'."""
    at = instance_line(text, instance.id()) if text is not None else None
    line = f" (line {at})" if at else ""
    return f"#{instance.id()}={instance.is_a()}{line}{placing}: {problem}"


def why_unprocessed(product) -> str:
    """A left-unchanged product's reason: its placement's fault when it has one."""
    found = placement_problem(product)
    return "geometry could not be processed" + (f": {describe(*found)}" if found else "")


def _text(path) -> bytes | None:
    try:
        with open(path, "rb") as stream:
            return stream.read()
    except OSError:
        return None


def why_nothing_placed(products: list, path) -> str:
    """The refusal of a model none of whose products the kernel could place: the placement instance most of them
    share a fault in (a root placement, usually), named with its line."""
    faults: Counter[int] = Counter()
    seen: dict[int, tuple[object, str]] = {}
    for product in products:
        found = placement_problem(product)
        if found:
            faults[found[0].id()] += 1
            seen[found[0].id()] = found
    message = "no product geometry could be processed by the geometry kernel"
    if not faults:
        return message
    worst, count = faults.most_common(1)[0]
    text = _text(path)
    placing = f" in the placement of {count} of the {len(products)} products with geometry"
    return f"{message}: {describe(*seen[worst], text, placing)}"


def repeated_global_ids(products: list) -> list[Diagnostic]:
    """``duplicate_global_ids`` naming the products that share a GlobalId (a copied object an exporter did not give a
    new one): the result names a class's members by GlobalId, so theirs say nothing of which product is meant."""
    by_id: dict[str, list] = {}
    for product in products:
        by_id.setdefault(product.GlobalId, []).append(product)
    repeated = {g: found for g, found in by_id.items() if len(found) > 1}
    if not repeated:
        return []
    listed = "; ".join(f"{g}: " + ", ".join(f"#{p.id()} {p.is_a()} {p.Name!r}" for p in found[:4])
                       for g, found in list(repeated.items())[:3])
    return [Diagnostic(code="duplicate_global_ids", message=(
        f"{sum(len(f) for f in repeated.values())} products share {len(repeated)} GlobalId(s) ({listed}"
        f"{' …' if len(repeated) > 3 else ''}), which IFC requires unique: the classes' members name them by GlobalId, "
        "so these do not say which product is meant (each is still optimized and verified by its instance)."),
        details={"global_ids": {g: [f"#{p.id()}" for p in found] for g, found in list(repeated.items())[:100]},
                 "count": len(repeated)})]
