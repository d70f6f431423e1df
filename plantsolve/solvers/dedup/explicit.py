"""World points of products whose body is explicit mesh geometry, read straight from the file (the
issue's "or the explicit points"): face sets (``IfcPolygonalFaceSet``, ``IfcTriangulatedFaceSet``),
faceted B-reps and face/shell-based surface models, through any depth of ``IfcMappedItem``, placed
with IfcOpenShell's own placement and mapping maths (``ifcopenshell.util.placement``). Thousands of
times cheaper than tessellating; a product with anything else (an extrusion, a boolean) returns None
and goes to the geometry kernel instead, before and after alike.

An ``ExplicitReader`` reads one model and remembers what it read: each body representation's points in
its own frame, each placement's matrix and each mapped item's operator and mapping origin, so products that
share them are read once and placed each on its own (the optimized model: one representation for a whole
class; with ``mapped_item`` sharing, an item per member whose operator, once the post-pass merged those of
equal values, is a ring's for the members of every class); and, when asked, the ids of every instance under
each body item it walked (the sharing phase finds the old geometry it detached from them, without walking
millions of instances again)."""

from __future__ import annotations

from collections import Counter

import numpy as np

import ifcopenshell
import ifcopenshell.util.placement

from plantsolve.solvers.dedup.sharing import Placements, shape_body
from plantsolve.solvers.dedup.skeleton import Skeleton

FACE_SETS = ("IfcPolygonalFaceSet", "IfcTriangulatedFaceSet")
FACE_MODELS = ("IfcFacetedBrep", "IfcFaceBasedSurfaceModel", "IfcShellBasedSurfaceModel")
_OTHER, _POINT, _FACE, _CURVED = range(4)


def _role(name: str) -> int:
    """What an instance under a faceted item is to the reader: edge loops and curved geometry are the kernel's job."""
    if name == "IfcCartesianPoint":
        return _POINT
    if name == "IfcFace":
        return _FACE
    if name in ("IfcEdgeLoop", "IfcVertexLoop", "IfcAdvancedFace", "IfcFaceSurface") or "Curve" in name or (
            "Surface" in name and name not in ("IfcFaceBasedSurfaceModel", "IfcShellBasedSurfaceModel")):
        return _CURVED
    return _OTHER


class ExplicitReader:
    """Explicit geometry of one model (see the module's docstring). The model must not change while
    a reader is in use: what it remembers is keyed by instance id."""

    def __init__(self, model: ifcopenshell.file, *, record_closures: bool = False, streamed: Skeleton | None = None):
        self.model = model
        self.streamed = streamed  # the faceted items read from the file's text, absent from ``model``
        # a product the kernel would tessellate holds a streamed item (whose instances ``model`` lacks)
        self.needs_whole_model = False
        self.closures: dict[int, np.ndarray] | None = {} if record_closures else None
        self.closure_entities: dict[int, Counter] = {}  # item id → entity counts of its closure
        self._roles: dict[str, int] = {}
        self._bodies: dict[int, tuple[np.ndarray, int] | None] = {}
        self._items: dict[int, tuple[np.ndarray, int] | None] = {}
        self._operators: dict[int, np.ndarray] = {}  # transformation operator id → its matrix
        self._origins: dict[int, np.ndarray] = {}  # representation map id → its mapping origin's matrix
        self._shape_bodies: dict[int, object] = {}  # product shape id → its body representation
        self.placements = Placements()  # the sharing places the same products again

    def forget_points(self) -> None:
        """Drop the points read so far (each body's and item's, in their own frames), keeping the closures
        and the placements: what the phases after the geometry still ask of the reader."""
        self._bodies.clear()
        self._items.clear()

    def _loop_points(self, item) -> tuple[list, int] | None:
        """(points, face count) of a faceted item: every IfcCartesianPoint under it (each once)."""
        instances = self.model.traverse(item)
        names = list(map(ifcopenshell.entity_instance.is_a, instances))
        entities = Counter(names)
        if self.closures is not None:
            self.closures[item.id()] = np.fromiter(map(ifcopenshell.entity_instance.id, instances), dtype=np.int64,
                                                   count=len(instances))
            self.closure_entities[item.id()] = entities
        roles = self._roles
        for name in entities:
            role = roles.get(name)
            if role is None:
                role = roles[name] = _role(name)
            if role == _CURVED:
                return None
        points = [inst.get_argument(0) for inst, name in zip(instances, names) if name == "IfcCartesianPoint"]
        return points, entities.get("IfcFace", 0)

    def item_points(self, item, depth: int = 0) -> tuple[np.ndarray, int] | None:
        """(points in the item's representation frame, face count), or None when not explicit. An item
        is read once (a representation map's items, mapped by every member)."""
        if depth > 8:
            return None
        key = item.id()
        if key in self._items:
            return self._items[key]
        got = self._items[key] = self._item_points(item, depth)
        return got

    def _item_points(self, item, depth: int) -> tuple[np.ndarray, int] | None:
        if item.is_a("IfcMappedItem"):
            source, target = item.MappingSource, item.MappingTarget
            if not target.is_a("IfcCartesianTransformationOperator3D"):
                return None
            got = self.items_points(source.MappedRepresentation.Items or (), depth + 1)
            if got is None:
                return None
            m = self._mapping(source, target)
            pts, faces = got
            return pts @ m[:3, :3].T + m[:3, 3], faces
        if any(item.is_a(t) for t in FACE_SETS):
            coords = np.asarray(item.Coordinates.CoordList, dtype=float)
            if coords.ndim != 2 or coords.shape[1] != 3:
                return None
            faces = item.Faces if item.is_a("IfcPolygonalFaceSet") else item.CoordIndex
            return coords, len(faces)
        if any(item.is_a(t) for t in FACE_MODELS):
            if self.streamed is not None and item.id() in self.streamed.points:
                return self.streamed.points[item.id()]
            got = self._loop_points(item)
            if got is None or not got[0] or any(len(p) != 3 for p in got[0]):
                return None
            return np.asarray(got[0], dtype=float), got[1]
        return None

    def _mapping(self, source, target) -> np.ndarray:
        """``get_mappeditem_transformation`` of an item mapping ``source`` by ``target``: the same product of the
        same two matrices, each worked out once per instance."""
        operator = self._operators.get(target.id())
        if operator is None:
            operator = self._operators[target.id()] = ifcopenshell.util.placement.get_cartesiantransformationoperator3d(
                target)
        origin = self._origins.get(source.id())
        if origin is None:
            origin = self._origins[source.id()] = ifcopenshell.util.placement.get_axis2placement(source.MappingOrigin)
        return np.asarray(operator @ origin, dtype=float)

    def items_points(self, items, depth: int = 0) -> tuple[np.ndarray, int] | None:
        parts, faces = [], 0
        for item in items:
            got = self.item_points(item, depth)
            if got is None:
                return None
            parts.append(got[0])
            faces += got[1]
        if not parts:
            return None
        return np.concatenate(parts), faces

    def body(self, product):
        """``sharing.body_representation(product)``, found once per product shape (the grouping asks again; the
        members of a written class share one)."""
        shape = product.Representation
        if shape is None:
            return None
        key = shape.id()
        if key not in self._shape_bodies:
            self._shape_bodies[key] = shape_body(shape)
        return self._shape_bodies[key]

    def product_points(self, product, *, unique: bool = True) -> tuple[np.ndarray, int] | None:
        """(unique world points in file units, face count) of the product's body, or None; ``unique=False``: the
        world points as read, each product's made unique by the caller (:func:`unique_rows_each`)."""
        body = self.body(product)
        if body is None:
            return None
        key = body.id()
        if key in self._bodies:
            got = self._bodies[key]
        else:
            got = self._bodies[key] = self.items_points(body.Items or ())
        if got is None:
            if self.streamed is not None and any(i.id() in self.streamed.closures for i in self.model.traverse(body)):
                self.needs_whole_model = True
            return None
        pts, faces = got
        p = self.placements.of(product)
        with np.errstate(invalid="ignore"):  # a placement the file cannot resolve: its product is left unchanged later
            world = pts @ p[:3, :3].T + p[:3, 3]
        return (unique_rows(world) if unique else world), faces


def unique_rows(points: np.ndarray) -> np.ndarray:
    """``np.unique(points, axis=0)`` (rows sorted lexicographically, each once), by one lexsort: half
    the time on a product's few hundred points."""
    if len(points) == 0:
        return points
    ordered = points[np.lexsort(points.T[::-1])]
    keep = np.empty(len(ordered), dtype=bool)
    keep[0] = True
    np.any(ordered[1:] != ordered[:-1], axis=1, out=keep[1:])
    return ordered[keep]


def unique_rows_each(parts: list[np.ndarray]) -> list[np.ndarray]:
    """:func:`unique_rows` of each array, in one lexsort of them all (the array it came from first): the same rows
    in the same order as one by one, without a sort call per product."""
    if not parts:
        return []
    sizes = np.array([len(p) for p in parts])
    owner = np.repeat(np.arange(len(parts)), sizes)
    points = np.concatenate(parts)
    order = np.lexsort((points[:, 2], points[:, 1], points[:, 0], owner))
    ordered, owner = points[order], owner[order]
    keep = np.ones(len(ordered), dtype=bool)
    np.any(ordered[1:] != ordered[:-1], axis=1, out=keep[1:])
    keep[1:] |= owner[1:] != owner[:-1]
    kept = np.bincount(owner[keep], minlength=len(parts))
    return np.split(ordered[keep], np.cumsum(kept)[:-1])


def product_points(model: ifcopenshell.file, product) -> tuple[np.ndarray, int] | None:
    """(unique world points in file units, face count) of one product's body, or None."""
    return ExplicitReader(model).product_points(product)

