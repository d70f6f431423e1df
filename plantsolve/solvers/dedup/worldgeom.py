"""Each product's world-space geometry, tessellated by ``ifcopenshell.geom`` with world coordinates:
the points the matching compares and the proof re-checks after the round trip through the written
file. IfcOpenShell returns metres; the points are converted back to the file's length unit."""

from __future__ import annotations

import numpy as np

import ifcopenshell
import ifcopenshell.geom

from plantsolve.schemas.common import MAX_COORDINATE
from plantsolve.solvers.base import Progress, no_progress
from plantsolve.solvers.dedup.explicit import ExplicitReader, unique_rows_each
from plantsolve.solvers.ifc_units import project_length_scale

DEPENDS = "the tolerance and every deviation are in it"  # what the project's length unit decides


def _usable(points: np.ndarray) -> bool:
    """Finite points within :data:`MAX_COORDINATE` of the file's unit: a product whose geometry is not is left
    unchanged (1e308 or NaN in one IfcCartesianPoint, a writer's garbage, overflowed the matching's signatures)."""
    with np.errstate(invalid="ignore"):
        return bool((np.abs(points) <= MAX_COORDINATE).all())


def geometry_settings() -> ifcopenshell.geom.settings:
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    return settings


def world_points(model: ifcopenshell.file, products: list, *, threads: int = 1,
                 progress: Progress = no_progress, span: tuple[float, float] = (0.0, 1.0),
                 message: str = "geometry", reader: ExplicitReader | None = None, unique: bool = True,
                 ) -> tuple[dict[int, np.ndarray], dict[int, int]]:
    """``{product id: unique world points (n, 3) in file units}`` and ``{product id: face count}``
    (explicit meshes: their points and polygons as written, through ``reader`` when given; anything
    else: the kernel's tessellation, its vertices and triangles); a product the kernel cannot
    tessellate, or whose points are not numbers, not finite or beyond :data:`MAX_COORDINATE`, is missing
    from both. ``unique=False``: each product's world points as read or tessellated, a point written twice kept
    twice (the proof's Hausdorff distances are those of the unique points, bit for bit: each row is the same
    product of the same numbers, and a repeat is as far as its twin; sorting 632 k points cost the tunnel's
    proof 0.15 s)."""
    points: dict[int, np.ndarray] = {}
    triangles: dict[int, int] = {}
    rest = []
    reader = reader or ExplicitReader(model)
    read: dict[int, np.ndarray] = {}
    for k, product in enumerate(products):
        try:
            got = reader.product_points(product, unique=False)
        except (ValueError, TypeError, IndexError, AttributeError):  # a point that is no triple of numbers
            continue  # missing from both, as the kernel's failures: left unchanged with a warning
        if got is None:
            rest.append(product)
        elif _usable(got[0]):
            read[product.id()], triangles[product.id()] = got
        if k % 500 == 0:
            progress(span[0] + (span[1] - span[0]) * 0.5 * k / len(products), message)
    points.update(zip(read, unique_rows_each(list(read.values()))) if unique else read)
    del read
    products = rest
    if not products:
        return points, triangles
    unit = project_length_scale(model, DEPENDS)
    try:
        iterator = ifcopenshell.geom.iterator(geometry_settings(), model, threads, include=products)
    except RuntimeError:  # a reference the file does not resolve refuses the whole batch: each product alone
        for product in products:
            try:
                one = ifcopenshell.geom.iterator(geometry_settings(), model, 1, include=[product])
            except RuntimeError:
                continue  # this one's geometry names a missing entity: left unchanged with a warning
            if one.initialize():
                verts = np.asarray(one.get().geometry.verts, dtype=float).reshape(-1, 3) / unit
                if len(verts) and _usable(verts):
                    points[product.id()] = np.unique(verts, axis=0) if unique else verts
                    triangles[product.id()] = len(one.get().geometry.faces) // 3
        return points, triangles
    total = len(products)
    done = len(points)
    if not iterator.initialize():
        return points, triangles
    lo, hi = span
    while True:
        shape = iterator.get()
        verts = np.asarray(shape.geometry.verts, dtype=float).reshape(-1, 3) / unit
        if len(verts) and _usable(verts):
            points[shape.id] = np.unique(verts, axis=0) if unique else verts
            triangles[shape.id] = len(shape.geometry.faces) // 3
        if (len(points) - done) % 200 == 0:
            progress(lo + (hi - lo) * min(0.5 + 0.5 * (len(points) - done) / total, 1.0), message)
        if not iterator.next():
            break
    return points, triangles
