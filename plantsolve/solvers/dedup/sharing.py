"""Phase 3 (paper Sections "Sharing data using implicit flyweights" and the explicit IfcMappedItem
concept): each class's geometry is written once and reused, with IfcOpenShell.

- ``mapped_item`` (IFC2X3 and later): the representative's body representation becomes the
  ``MappedRepresentation`` of one ``IfcRepresentationMap`` (made by ``ifcopenshell.api``'s
  ``geometry.map_representation``); every member, the representative included, gets a new body
  ``IfcShapeRepresentation`` holding one ``IfcMappedItem`` whose ``IfcCartesianTransformationOperator3D``
  carries the member's transform expressed in its own object frame
  (``P_member⁻¹ · T · P_representative``); mirror and scale only ever go here.
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
        tells -0.0 from 0.0, so the matrix is the one the library computes from them, bit for bit."""
        location = axes.Location if axes.is_a() == "IfcAxis2Placement3D" else None
        coordinates = getattr(location, "Coordinates", None) if location is not None else None
        if not coordinates:  # another kind of placement, or a location the library asks the kernel for
            return ifcopenshell.util.placement.get_axis2placement(axes)
        z, x = axes.Axis, axes.RefDirection
        key = repr((coordinates, z.DirectionRatios if z else None, x.DirectionRatios if x else None))
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


def operator(model: ifcopenshell.file, t: np.ndarray):
    """``IfcCartesianTransformationOperator3D`` of 4×4 ``t`` = s·R (R orthogonal, maybe improper) + translation."""
    a = t[:3, :3]
    s = float(abs(np.linalg.det(a)) ** (1.0 / 3.0))
    r = a / s
    return model.create_entity(
        "IfcCartesianTransformationOperator3D",
        model.create_entity("IfcDirection", _floats(r[:, 0])),
        model.create_entity("IfcDirection", _floats(r[:, 1])),
        model.create_entity("IfcCartesianPoint", _floats(t[:3, 3])),
        s, model.create_entity("IfcDirection", _floats(r[:, 2])))


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


class SharedPlacements:
    """The post-pass's merge of the members' new placements, done as they are made (product_shape with the
    post-pass): a ring's members all get placements of the same values, which the post-pass would merge into
    one (``postpass``: identical instances, the first in its topological order kept). Each set of values is
    made once; every member's placement is numbered as if all had been made (so everything else keeps its
    number), and the post-pass, once it knows its order, gives the kept placement the numbers of the member
    whose expansion reaches it (:meth:`renumbered`): the output is the one making them all would give.

    Values are keyed by their bits (the post-pass would also merge -0.0 with 0.0: those stay apart here and
    are merged there as before); a placement whose values are not all finite is made for its member alone."""

    def __init__(self, model: ifcopenshell.file):
        self.next = model.get_max_id() + 1  # the number the next instance would have had
        self.made: dict[bytes, int] = {}  # parent id and values → index of the group
        self.groups: list[list[tuple[int, int]]] = []  # per group: (member product id, its first number)
        self.skipped: list[int] = []  # numbers of the instances not made

    @staticmethod
    def applies(model: ifcopenshell.file) -> bool:
        """Whether the post-pass merges such placements in this schema (none of their references pins them)."""
        schema = wrapper.schema_by_name(model.schema_identifier)
        return not any(inv.bound2() == 1 and inv.attribute_reference().name() in _PLACEMENT_REFERENCES
                       for name in set(PLACEMENT_PARTS) for inv in schema.declaration_by_name(name).all_inverse_attributes())

    def placement(self, model: ifcopenshell.file, member, parent, t: np.ndarray):
        first = max(self.next, model.get_max_id() + 1)
        ids = range(first, first + len(PLACEMENT_PARTS))
        self.next = first + len(PLACEMENT_PARTS)
        values = np.ascontiguousarray(t[:3, [3, 2, 0]])
        if not np.isfinite(values).all():
            return transform_placement(model, parent, t, ids)
        key = (parent.id() if parent is not None else 0).to_bytes(8, "little") + values.tobytes()
        group = self.made.get(key)
        if group is None:
            self.made[key] = len(self.groups)
            self.groups.append([(member.id(), first)])
            return transform_placement(model, parent, t, ids)
        self.groups[group].append((member.id(), first))
        self.skipped.extend(ids)
        return model.by_id(self.groups[group][0][1] + len(PLACEMENT_PARTS) - 1)

    def numbered_on(self, model: ifcopenshell.file) -> None:
        """Before the core numbers an instance itself: it numbers after the largest, which is then the one
        before ``next`` (made and removed at once when the last numbers were skipped)."""
        if model.get_max_id() + 1 < self.next:
            model.remove(model.create_entity("IfcCartesianPoint", (0.0, 0.0, 0.0), id=self.next - 1))

    def watched(self) -> set[int]:
        """The numbers of the placements made for several members."""
        parts = len(PLACEMENT_PARTS)
        return {members[0][1] + parts - 1 for members in self.groups if len(members) > 1}

    def renumbered(self, model: ifcopenshell.file, order: list, reached: dict[int, int]) -> list:
        """``order`` (the post-pass's topological order of ``model``, the sharing's model compacted: the same
        numbers) with each placement made for several members numbered as the placement of the member whose
        expansion reached it (``reached``: placement → that member): had each member its own, that member's
        would be the first of them in the order, the one the post-pass keeps."""
        parts = len(PLACEMENT_PARTS)
        moves = {}  # made placement's first number → (its group's members, the first number it takes)
        for members in self.groups:
            made_first = members[0][1]
            if len(members) > 1:
                by = reached[made_first + parts - 1]
                first = next(first for product, first in members if product == by)
                if first != made_first:
                    moves[made_first] = (members, first)
        moving = {made_first + k for made_first in moves for k in range(parts)}
        where = {}  # number of a part to renumber → its position in the order
        if moving:
            for position, inst in enumerate(order):
                if inst.id() in moving:
                    where[inst.id()] = position
        old = []
        by_id = model.by_id
        for made_first, (members, first) in moves.items():
            point, axis, ref, axes, placement = (by_id(made_first + k) for k in range(parts))
            new = local_placement(model, placement.PlacementRelTo, point.Coordinates, axis.DirectionRatios,
                                  ref.DirectionRatios, range(first, first + parts))
            for product, _ in members:
                by_id(product).ObjectPlacement = new[4]
            for k, inst in enumerate(new):
                order[where[made_first + k]] = inst
            old += [point, axis, ref, axes, placement]
        remove_batch(model, old)
        return order

    def counts(self) -> dict[str, int]:
        """What was not made, per entity (what the post-pass would have removed)."""
        out: dict[str, int] = {}
        n = len(self.skipped) // len(PLACEMENT_PARTS)
        for name in PLACEMENT_PARTS:
            out[name] = out.get(name, 0) + n
        return out


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
          shared: SharedPlacements | None = None) -> dict[str, int]:
    """Rewrite every class with at least two members; returns counts of what was written. What the
    rewrite detached is deleted from ``model`` before returning, or, given ``detached``, recorded there
    for the caller to delete (``compaction.compacted``). ``placements``: the matrices the geometry reader
    already evaluated (members of a ring share its placement: each is evaluated once either way).
    ``shared``: the members' new placements made once per set of values, for the post-pass to number."""
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
           shared: SharedPlacements | None) -> None:
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
            if shared is None:
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
            item = model.create_entity("IfcMappedItem", source, operator(model, local))
            new = model.create_entity("IfcShapeRepresentation", old.ContextOfItems, old.RepresentationIdentifier,
                                      "MappedRepresentation", [item])
            _replace_in_list(member.Representation, "Representations", old, new)
            garbage.replace_representation(old, new)
            counts["mapped_items"] += 1
