"""World points of products whose body is explicit mesh geometry, read straight from the file (the
issue's "or the explicit points"): face sets (``IfcPolygonalFaceSet``, ``IfcTriangulatedFaceSet``),
faceted B-reps and face/shell-based surface models, through any depth of ``IfcMappedItem``, placed
with IfcOpenShell's own placement and mapping maths (``ifcopenshell.util.placement``). Thousands of
times cheaper than tessellating; a product with anything else (an extrusion, a boolean) returns None
and goes to the geometry kernel instead, before and after alike."""

from __future__ import annotations

import numpy as np

import ifcopenshell
import ifcopenshell.util.placement

from plantsolve.solvers.dedup.sharing import body_representation, placement_matrix

FACE_SETS = ("IfcPolygonalFaceSet", "IfcTriangulatedFaceSet")
FACE_MODELS = ("IfcFacetedBrep", "IfcFaceBasedSurfaceModel", "IfcShellBasedSurfaceModel")


def _loop_points(model: ifcopenshell.file, item) -> tuple[list, int] | None:
    """(points, face count) of a faceted item: every IfcCartesianPoint under it (each once)."""
    points, faces = [], 0
    for inst in model.traverse(item):
        name = inst.is_a()
        if name == "IfcCartesianPoint":
            points.append(inst.Coordinates)
        elif name == "IfcFace":
            faces += 1
        elif name in ("IfcEdgeLoop", "IfcVertexLoop", "IfcAdvancedFace", "IfcFaceSurface") or "Curve" in name or (
                "Surface" in name and name not in ("IfcFaceBasedSurfaceModel", "IfcShellBasedSurfaceModel")):
            return None  # edge loops and curved geometry: the kernel's job
    return points, faces


def item_points(model: ifcopenshell.file, item, depth: int = 0) -> tuple[np.ndarray, int] | None:
    """(points in the item's representation frame, face count), or None when not explicit."""
    if depth > 8:
        return None
    if item.is_a("IfcMappedItem"):
        inner = item.MappingSource.MappedRepresentation
        if not item.MappingTarget.is_a("IfcCartesianTransformationOperator3D"):
            return None
        m = np.asarray(ifcopenshell.util.placement.get_mappeditem_transformation(item), dtype=float)
        got = items_points(model, inner.Items or (), depth + 1)
        if got is None:
            return None
        pts, faces = got
        return pts @ m[:3, :3].T + m[:3, 3], faces
    if any(item.is_a(t) for t in FACE_SETS):
        coords = np.asarray(item.Coordinates.CoordList, dtype=float)
        if coords.ndim != 2 or coords.shape[1] != 3:
            return None
        faces = item.Faces if item.is_a("IfcPolygonalFaceSet") else item.CoordIndex
        return coords, len(faces)
    if any(item.is_a(t) for t in FACE_MODELS):
        got = _loop_points(model, item)
        if got is None or not got[0] or any(len(p) != 3 for p in got[0]):
            return None
        return np.asarray(got[0], dtype=float), got[1]
    return None


def items_points(model: ifcopenshell.file, items, depth: int = 0) -> tuple[np.ndarray, int] | None:
    parts, faces = [], 0
    for item in items:
        got = item_points(model, item, depth)
        if got is None:
            return None
        parts.append(got[0])
        faces += got[1]
    if not parts:
        return None
    return np.concatenate(parts), faces


def product_points(model: ifcopenshell.file, product) -> tuple[np.ndarray, int] | None:
    """(unique world points in file units, face count) of the product's body, or None."""
    body = body_representation(product)
    if body is None:
        return None
    got = items_points(model, body.Items or ())
    if got is None:
        return None
    pts, faces = got
    p = placement_matrix(product)
    return np.unique(pts @ p[:3, :3].T + p[:3, 3], axis=0), faces
