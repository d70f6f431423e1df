"""Phase 3 (paper Sections "Sharing data using implicit flyweights" and the explicit IfcMappedItem
concept): each class's geometry is written once and reused, with IfcOpenShell.

- ``mapped_item`` (IFC2X3 and later): the representative's body representation becomes the
  ``MappedRepresentation`` of one ``IfcRepresentationMap`` (made by ``ifcopenshell.api``'s
  ``geometry.map_representation``); every member, the representative included, gets a new body
  ``IfcShapeRepresentation`` holding one ``IfcMappedItem`` whose ``IfcCartesianTransformationOperator3D``
  carries the member's transform expressed in its own object frame
  (``P_member⁻¹ · T · P_representative``); mirror and scale only ever go here. With the post-pass, members
  whose operators hold the same values (a ring's segments of every class) get one operator, made once
  (:class:`SharedOperators`).
- ``product_shape`` (IFC4 and later; ``ShapeOfProduct`` is [1:1] in IFC2X3): rigid members share the
  representative's ``IfcProductDefinitionShape`` and get a new ``IfcLocalPlacement`` (same parent)
  carrying the transform. A member whose product shape holds more than its body representation, or
  whose transform mirrors or scales, falls back to a mapped item. With the post-pass, members whose new
  placements hold the same values (a ring's segments) get one placement, made once
  (:class:`SharedPlacements`): the file is the one the post-pass would have made of one per member.
- An ``IfcShapeRepresentation`` is never shared between product shapes (``IfcShapeModel.WR11``).

Old representations, product shapes and placements are deleted with the instances only they used
(what ``remove_deep2`` deletes, found for all of them at once after the rewrite: ``compaction``);
styled items of their items go with them (grouping guarantees the representative carries equal
styles); a presentation layer that held an old representation holds the new one.
"""

from __future__ import annotations

import numpy as np

import ifcopenshell
import ifcopenshell.api
import ifcopenshell.ifcopenshell_wrapper as wrapper
import ifcopenshell.util.placement

from plantsolve.solvers.base import Progress, no_progress
from plantsolve.solvers.dedup import compaction
from plantsolve.solvers.dedup.compaction import remove_batch
from plantsolve.solvers.dedup.congruence import CongruenceClass


class Placements:
    """``ifcopenshell.util.placement.get_local_placement``, each placement evaluated once (the same
    products in the same order as the library multiplies them): the members of a ring share its
    placement, and the proof's products their few parents."""

    def __init__(self):
        self._matrices: dict[int, np.ndarray] = {}
        self._axes: dict[str, np.ndarray] = {}  # an IfcAxis2Placement3D's values, written out → its matrix

    def matrix(self, placement) -> np.ndarray:
        if placement is None:
            return np.eye(4)
        key = placement.id()
        matrix = self._matrices.get(key)
        if matrix is None:
            if not placement.is_a("IfcLocalPlacement"):
                matrix = np.asarray(ifcopenshell.util.placement.get_local_placement(placement), dtype=float)
            else:
                parent = self.matrix(placement.PlacementRelTo)
                matrix = np.dot(parent, self.axes(placement.RelativePlacement))
            self._matrices[key] = matrix
        return matrix

    def axes(self, axes) -> np.ndarray:
        """``get_axis2placement(axes)``, worked out once per set of values (each of the tunnel's 4,240 products has
        a placement of its own, holding one of a few sets): the values are the key as ``repr`` writes them, which
        tells -0.0 from 0.0, so the matrix is the one the library computes from them, bit for bit. The values are read
        by attribute position (Location, Axis, RefDirection; Coordinates; DirectionRatios): half the cost of reading
        them by name, for each of the products' placements."""
        location = axes[0] if axes.is_a() == "IfcAxis2Placement3D" else None
        coordinates = location[0] if location is not None and location.is_a() == "IfcCartesianPoint" else None
        if not coordinates:  # another kind of placement, or a location the library asks the kernel for
            return ifcopenshell.util.placement.get_axis2placement(axes)
        z, x = axes[1], axes[2]
        key = repr((coordinates, z[0] if z else None, x[0] if x else None))
        matrix = self._axes.get(key)
        if matrix is None:
            matrix = self._axes[key] = ifcopenshell.util.placement.get_axis2placement(axes)
        return matrix

    def of(self, product) -> np.ndarray:
        return self.matrix(product.ObjectPlacement)


def body_representation(product):
    """The product's body ``IfcShapeRepresentation`` (identifier 'Body', or the only one), or None."""
    return shape_body(product.Representation)


def shape_body(shape):
    """:func:`body_representation` of the products whose ``Representation`` is ``shape``."""
    if shape is None or not shape.is_a("IfcProductDefinitionShape"):
        return None
    reps = [r for r in shape.Representations or () if r.is_a("IfcShapeRepresentation")]
    body = [r for r in reps if (r.RepresentationIdentifier or "").lower() == "body"]
    if len(body) == 1:
        return body[0]
    if len(reps) == 1 and not body:
        return reps[0]
    return None


def _floats(v) -> list[float]:
    return [float(x) for x in v]


def operator_values(t: np.ndarray) -> tuple[list[float], list[float], list[float], float, list[float]]:
    """The attribute values of the ``IfcCartesianTransformationOperator3D`` of 4×4 ``t`` = s·R (R orthogonal, maybe
    improper) + translation: Axis1, Axis2, LocalOrigin, Scale, Axis3."""
    a = t[:3, :3]
    s = float(abs(np.linalg.det(a)) ** (1.0 / 3.0))
    r = a / s
    return _floats(r[:, 0]), _floats(r[:, 1]), _floats(t[:3, 3]), s, _floats(r[:, 2])


def operator(model: ifcopenshell.file, t: np.ndarray, ids: range | None = None):
    """``IfcCartesianTransformationOperator3D`` of 4×4 ``t`` (:func:`operator_values`), its parts made in
    ``OPERATOR_PARTS`` order and numbered ``ids`` or by the library."""
    return operator_of(model, *operator_values(t), ids=ids)


def operator_of(model: ifcopenshell.file, axis1, axis2, origin, scale: float, axis3, ids: range | None = None):
    """The operator of these values (:func:`operator`)."""
    numbers = iter(ids) if ids is not None else None

    def create(entity: str, *values):
        return model.create_entity(entity, *values, **({"id": next(numbers)} if numbers is not None else {}))

    return create("IfcCartesianTransformationOperator3D", create("IfcDirection", axis1),
                  create("IfcDirection", axis2), create("IfcCartesianPoint", origin), scale,
                  create("IfcDirection", axis3))


# what a member's new operator consists of, in the order the instances are made (and numbered): Python evaluates
# the operator's arguments before making it
OPERATOR_PARTS = ("IfcDirection", "IfcDirection", "IfcCartesianPoint", "IfcDirection",
                  "IfcCartesianTransformationOperator3D")
_OPERATOR_REFERENCES = {"MappingTarget", "Axis1", "Axis2", "Axis3", "LocalOrigin"}
# a mapped member's instances: its operator's, then its IfcMappedItem and its IfcShapeRepresentation
MAPPED_PARTS = len(OPERATOR_PARTS) + 2
# what a member's new placement consists of, in the order the instances are made (and numbered)
PLACEMENT_PARTS = ("IfcCartesianPoint", "IfcDirection", "IfcDirection", "IfcAxis2Placement3D", "IfcLocalPlacement")
# the attributes through which those instances are referenced: an inverse of them bounded to one pins them
_PLACEMENT_REFERENCES = {"ObjectPlacement", "PlacementRelTo", "RelativePlacement", "Location", "Axis", "RefDirection"}


def local_placement(model: ifcopenshell.file, parent, location, axis, ref, ids: range | None = None) -> list:
    """The parts of a new ``IfcLocalPlacement`` relative to ``parent`` at ``location`` with its z ``axis`` and x
    ``ref`` direction, in ``PLACEMENT_PARTS`` order (the placement last), numbered ``ids`` or by the library."""
    numbers = iter(ids) if ids is not None else None

    def create(entity: str, *values):
        return model.create_entity(entity, *values, **({"id": next(numbers)} if numbers is not None else {}))

    parts = [create("IfcCartesianPoint", location), create("IfcDirection", axis), create("IfcDirection", ref)]
    parts.append(create("IfcAxis2Placement3D", *parts))
    parts.append(create("IfcLocalPlacement", parent, parts[3]))
    return parts


def transform_placement(model: ifcopenshell.file, parent, t: np.ndarray, ids: range | None = None):
    """The new ``IfcLocalPlacement`` of 4×4 transform ``t`` relative to ``parent`` (:func:`local_placement`)."""
    return local_placement(model, parent, _floats(t[:3, 3]), _floats(t[:3, 2]), _floats(t[:3, 0]), ids)[-1]


class _MadeOnce:
    """The post-pass's merge of instances the sharing makes for each member, done as they are made (with the
    post-pass): a ring's members all get instances of the same values, which the post-pass would merge into
    one (``postpass``: identical instances, the first in its topological order kept). Each set of values is
    made once; every member's instances are numbered as if all had been made (so everything else keeps its
    number), and the post-pass, once it knows its order, gives the kept instances the numbers of the member
    whose expansion reaches them first (:meth:`renumbered`): the output is the one making them all would give.

    Values are keyed by their bits (the post-pass would also merge -0.0 with 0.0: those stay apart here and
    are merged there as before); instances whose values are not all finite are made for their member alone.
    ``PARTS``: the entities made for one member, in the order they are made, the one its owner refers to last;
    ``WALKED``: the same in the order the post-pass's walk finishes them (it takes what an instance refers to
    from the last attribute on); ``REFERENCES``: the attributes through which they are referred to (an inverse
    of them bounded to one pins them)."""

    PARTS: tuple[str, ...] = ()
    WALKED: tuple[str, ...] = ()
    REFERENCES: frozenset[str] = frozenset()

    def __init__(self, model: ifcopenshell.file):
        self.next = model.get_max_id() + 1  # the number the next instance would have had
        self.made: dict[bytes, int] = {}  # the values' bits → index of the group
        self.groups: list[list[tuple[int, int]]] = []  # per group: (owner id, its parts' first number)
        self.skipped: list[int] = []  # numbers of the instances not made

    @classmethod
    def applies(cls, model: ifcopenshell.file) -> bool:
        """Whether the post-pass merges such instances in this schema (none of their references pins them)."""
        schema = wrapper.schema_by_name(model.schema_identifier)
        return not any(inv.bound2() == 1 and inv.attribute_reference().name() in cls.REFERENCES
                       for name in set(cls.PARTS) for inv in schema.declaration_by_name(name).all_inverse_attributes())

    def reserve(self, model: ifcopenshell.file, count: int) -> int:
        """The first of ``count`` numbers the next instances would have had."""
        first = max(self.next, model.get_max_id() + 1)
        self.next = first + count
        return first

    def made_once(self, model: ifcopenshell.file, key: bytes | None, owner: int, first: int, make):
        """The instance (the last part) of values ``key`` (None: not to be shared) for ``owner``, whose parts
        are numbered from ``first``: made by ``make(ids)`` for the first owner of those values, else the one
        made then, its numbers for this owner skipped."""
        ids = range(first, first + len(self.PARTS))
        if key is None:
            return make(ids)
        group = self.made.get(key)
        if group is None:
            self.made[key] = len(self.groups)
            self.groups.append([(owner, first)])
            return make(ids)
        self.groups[group].append((owner, first))
        self.skipped.extend(ids)
        return model.by_id(self.groups[group][0][1] + len(self.PARTS) - 1)

    def numbered_on(self, model: ifcopenshell.file) -> None:
        """Before the core numbers an instance itself: it numbers after the largest, which is then the one
        before ``next`` (made and removed at once when the last numbers were skipped)."""
        if model.get_max_id() + 1 < self.next:
            model.remove(model.create_entity("IfcCartesianPoint", (0.0, 0.0, 0.0), id=self.next - 1))

    def watched(self) -> set[int]:
        """The numbers of the instances made for several owners."""
        parts = len(self.PARTS)
        return {members[0][1] + parts - 1 for members in self.groups if len(members) > 1}

    def _remade(self, model: ifcopenshell.file, old: list, ids: range) -> list:
        """The parts ``old`` made again with the same values, numbered ``ids``."""
        raise NotImplementedError

    def _refer(self, owner, instance) -> None:
        """``owner`` refers to ``instance`` instead of the one made before."""
        raise NotImplementedError

    def renumbered(self, model: ifcopenshell.file, order: list, reached: dict[int, int]) -> list:
        """``order`` (the post-pass's topological order of ``model``, the sharing's model compacted: the same
        numbers) with each instance made for several owners numbered as the one of the owner whose expansion
        reached it (``reached``: instance → that owner): had each owner its own, that owner's would be the
        first of them in the order, the one the post-pass keeps."""
        parts = len(self.PARTS)
        moves = {}  # made instance's first number → (its group's owners, the first number it takes)
        for members in self.groups:
            made_first = members[0][1]
            if len(members) > 1:
                by = reached[made_first + parts - 1]
                first = next(first for owner, first in members if owner == by)
                if first != made_first:
                    moves[made_first] = (members, first)
        moving = {made_first + k for made_first in moves for k in range(parts)}
        where = {}  # number of a part to renumber → its position in the order
        if moving:
            for position, inst in enumerate(order):
                if inst.id() in moving:
                    where[inst.id()] = position
        old_parts = []
        by_id = model.by_id
        for made_first, (members, first) in moves.items():
            old = [by_id(made_first + k) for k in range(parts)]
            new = self._remade(model, old, range(first, first + parts))
            for owner, _ in members:
                self._refer(by_id(owner), new[-1])
            for k, inst in enumerate(new):
                order[where[made_first + k]] = inst
            old_parts += old
        remove_batch(model, old_parts)
        return order


def _bits(parent: int, values: np.ndarray) -> bytes | None:
    """The key of a set of values made once (``_MadeOnce``), None when they are not all finite."""
    if not np.isfinite(values).all():
        return None
    return parent.to_bytes(8, "little") + np.ascontiguousarray(values).tobytes()


class SharedPlacements(_MadeOnce):
    """The members' new placements (product_shape with the post-pass), made once per set of values and parent
    (:class:`_MadeOnce`; the owner is the member)."""

    PARTS = PLACEMENT_PARTS
    # the placement's RelativePlacement (its PlacementRelTo is met before), whose RefDirection, Axis, Location
    WALKED = ("IfcDirection", "IfcDirection", "IfcCartesianPoint", "IfcAxis2Placement3D", "IfcLocalPlacement")
    REFERENCES = frozenset(_PLACEMENT_REFERENCES)

    def placement(self, model: ifcopenshell.file, member, parent, t: np.ndarray):
        first = self.reserve(model, len(self.PARTS))
        key = _bits(parent.id() if parent is not None else 0, t[:3, [3, 2, 0]])
        return self.made_once(model, key, member.id(), first,
                              lambda ids: transform_placement(model, parent, t, ids))

    def _remade(self, model, old, ids):
        point, axis, ref, _, placement = old
        return local_placement(model, placement.PlacementRelTo, point.Coordinates, axis.DirectionRatios,
                               ref.DirectionRatios, ids)

    def _refer(self, owner, instance) -> None:
        owner.ObjectPlacement = instance


class SharedOperators(_MadeOnce):
    """The mapped members' transformation operators (mapped_item with the post-pass), made once per set of values
    (:class:`_MadeOnce`; the owner is the member's IfcMappedItem): a ring's transform is the same for its
    members of every class."""

    PARTS = OPERATOR_PARTS
    WALKED = ("IfcDirection", "IfcCartesianPoint", "IfcDirection", "IfcDirection", "IfcCartesianTransformationOperator3D")
    REFERENCES = frozenset(_OPERATOR_REFERENCES)

    def operator(self, model: ifcopenshell.file, item: int, first: int, t: np.ndarray):
        """The operator of ``t`` for the mapped item to be numbered ``item``, its parts numbered from ``first``."""
        values = operator_values(t)
        axis1, axis2, origin, scale, axis3 = values
        key = _bits(0, np.array([*axis1, *axis2, *origin, scale, *axis3]))
        return self.made_once(model, key, item, first, lambda ids: operator_of(model, *values, ids=ids))

    def _remade(self, model, old, ids):
        operator = old[-1]
        made = operator_of(model, operator.Axis1.DirectionRatios, operator.Axis2.DirectionRatios,
                           operator.LocalOrigin.Coordinates, operator.Scale, operator.Axis3.DirectionRatios, ids=ids)
        return [made.Axis1, made.Axis2, made.LocalOrigin, made.Axis3, made]

    def _refer(self, owner, instance) -> None:
        owner.MappingTarget = instance


def _replace_in_list(owner, attribute: str, old, new) -> None:
    values = list(getattr(owner, attribute))
    setattr(owner, attribute, [new if v == old else v for v in values if v != old or new is not None])


class Detached:
    """What the rewrite detached: old representations, product shapes and placements (``roots``),
    deleted together afterwards by ``compaction``. Layers that held an old representation are
    pointed at its replacement at once."""

    def __init__(self, model: ifcopenshell.file):
        self.model = model
        self.roots: list = []
        self.styled_by: dict[int, list] = {}
        for styled in model.by_type("IfcStyledItem"):
            if styled.Item is not None:
                self.styled_by.setdefault(styled.Item.id(), []).append(styled)
        self.layers_of: dict[int, list] = {}
        for layer in model.by_type("IfcPresentationLayerAssignment"):
            for item in layer.AssignedItems or ():
                self.layers_of.setdefault(item.id(), []).append(layer)

    def replace_representation(self, old, new) -> None:
        """``old`` is no longer referenced by its product shape; ``new`` (or None) takes its layers."""
        for layer in self.layers_of.pop(old.id(), ()):
            _replace_in_list(layer, "AssignedItems", old, new)
            if new is not None:
                self.layers_of.setdefault(new.id(), []).append(layer)
        self.roots.append(old)

    def detached(self, instance) -> None:
        self.roots.append(instance)


def _is_shared(model: ifcopenshell.file, instance, allowed: int = 1) -> bool:
    return model.get_total_inverses(instance) > allowed


def can_share_product_shape(model: ifcopenshell.file, cls: CongruenceClass) -> bool:
    rep = cls.representative.product
    return len(rep.Representation.Representations) == 1 and not _is_shared(model, rep.Representation)


def apply(model: ifcopenshell.file, classes: list[CongruenceClass], mode: str, *,
          progress: Progress = no_progress, span: tuple[float, float] = (0.0, 1.0),
          detached: Detached | None = None, placements: Placements | None = None,
          shared: _MadeOnce | None = None) -> dict[str, int]:
    """Rewrite every class with at least two members; returns counts of what was written. What the
    rewrite detached is deleted from ``model`` before returning, or, given ``detached``, recorded there
    for the caller to delete (``compaction.compacted``). ``placements``: the matrices the geometry reader
    already evaluated (members of a ring share its placement: each is evaluated once either way).
    ``shared``: the members' new placements (``SharedPlacements``) or mapped members' operators
    (``SharedOperators``) made once per set of values, for the post-pass to number."""
    counts = {"mapped_items": 0, "shared_product_shapes": 0, "fallback_to_mapped_item": 0}
    multi = [c for c in classes if len(c.members) > 1]
    garbage = detached if detached is not None else Detached(model)
    try:
        _apply(model, multi, mode, counts, progress, span, garbage, placements or Placements(), shared)
    finally:
        if detached is None:
            compaction.compacted(model, garbage.roots, garbage.styled_by, rebuild=False)
    return counts


def _apply(model, multi, mode, counts, progress, span, garbage: Detached, placements: Placements,
           shared: _MadeOnce | None) -> None:
    lo, hi = span
    inverses: dict[int, np.ndarray] = {}  # parent placement id → its matrix's inverse (a ring's members share one)

    for k, cls in enumerate(multi):
        if k % 8 == 0:
            progress(lo + (hi - lo) * k / max(len(multi), 1), "sharing")
        rep = cls.representative.product
        p_rep = placements.of(rep)
        shape_mode = mode == "product_shape" and can_share_product_shape(model, cls)
        mapped = []  # members written as mapped items
        for cand, m in cls.members[1:]:
            member = cand.product
            t_world = m.matrix
            rigid = not m.mirror and abs(m.scale - 1.0) < 1e-12
            old_shape, old_placement = member.Representation, member.ObjectPlacement
            member_ok = (shape_mode and rigid and len(old_shape.Representations) == 1
                         and not _is_shared(model, old_shape)
                         and (old_placement is None or old_placement.is_a("IfcLocalPlacement")))
            if not member_ok:
                if shape_mode:
                    counts["fallback_to_mapped_item"] += 1
                mapped.append((member, t_world))
                continue
            parent = old_placement.PlacementRelTo if old_placement is not None else None
            key = parent.id() if parent is not None else 0
            if key not in inverses:
                inverses[key] = np.linalg.inv(placements.matrix(parent))
            relative = inverses[key] @ t_world @ p_rep
            if not isinstance(shared, SharedPlacements):
                member.ObjectPlacement = transform_placement(model, parent, relative)
            else:
                member.ObjectPlacement = shared.placement(model, member, parent, relative)
            member.Representation = rep.Representation
            if old_placement is not None and model.get_total_inverses(old_placement) == 0:
                garbage.detached(old_placement)
            garbage.detached(old_shape)  # first: its traversal holds the old body's
            garbage.replace_representation(old_shape.Representations[0], None)
            counts["shared_product_shapes"] += 1
        if not mapped:
            continue
        if shared is not None:
            shared.numbered_on(model)
        body_rep = body_representation(rep)
        new_rep_repr = ifcopenshell.api.run("geometry.map_representation", model, representation=body_rep)
        _replace_in_list(rep.Representation, "Representations", body_rep, new_rep_repr)
        for layer in [i for i in model.get_inverse(body_rep) if i.is_a("IfcPresentationLayerAssignment")]:
            _replace_in_list(layer, "AssignedItems", body_rep, new_rep_repr)
        source = new_rep_repr.Items[0].MappingSource
        counts["mapped_items"] += 1
        for member, t_world in mapped:
            old = body_representation(member)
            local = np.linalg.inv(placements.of(member)) @ t_world @ p_rep
            if isinstance(shared, SharedOperators):
                first = shared.reserve(model, MAPPED_PARTS)
                item_id = first + len(OPERATOR_PARTS)
                item = model.create_entity("IfcMappedItem", source, shared.operator(model, item_id, first, local),
                                           id=item_id)
                numbered = {"id": item_id + 1}
            else:
                item = model.create_entity("IfcMappedItem", source, operator(model, local))
                numbered = {}
            new = model.create_entity("IfcShapeRepresentation", old.ContextOfItems, old.RepresentationIdentifier,
                                      "MappedRepresentation", [item], **numbered)
            _replace_in_list(member.Representation, "Representations", old, new)
            garbage.replace_representation(old, new)
            counts["mapped_items"] += 1
