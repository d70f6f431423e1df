"""The schema-aware syntactic post-pass: identical non-rooted instances (points, directions,
placements, styles, owner histories, ...) are merged in one sweep in topological order (an instance
after everything it references, so each is keyed by its already-merged references and compared
once), as IFCCompressor and the Solibri optimizer do generically (paper Section "Related work").

It respects the file schema's inverse cardinalities: an instance that is referenced through an
inverse attribute bounded to one (IFC2X3: a placement's ``PlacesObject``, a product shape's
``ShapeOfProduct``; every schema: a representation item's ``StyledByItem``) is never merged, and
neither is one a style or a presentation layer points at (merging it with an undecorated twin would
restyle or re-layer the twin's users). Representations are never merged
(``IfcShapeModel.WR11``), rooted instances and contexts never.
"""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.ifcopenshell_wrapper as wrapper

from plantsolve.solvers.base import Progress, no_progress
from plantsolve.solvers.dedup.compaction import remove_batch

NEVER_MERGED = ("IfcRoot", "IfcRepresentation", "IfcRepresentationContext", "IfcProductRepresentation")


def _pinned(model: ifcopenshell.file) -> set[int]:
    """Ids of instances referenced through an inverse attribute whose upper bound is one, or styled or layered."""
    schema = wrapper.schema_by_name(model.schema_identifier if hasattr(model, "schema_identifier") else model.schema)
    pinned: set[int] = set()
    seen_types: set[str] = set()
    bounded: set[tuple[str, str]] = set()
    for inst in model:
        name = inst.is_a()
        if name in seen_types:
            continue
        seen_types.add(name)
        for inv in schema.declaration_by_name(name).all_inverse_attributes():
            if inv.bound2() == 1:
                bounded.add((inv.entity_reference().name(), inv.attribute_reference().name()))
    # decorations: a styled or layered instance must not absorb an undecorated one (nor the reverse)
    bounded |= {("IfcStyledItem", "Item"), ("IfcPresentationLayerAssignment", "AssignedItems")}
    for entity, attribute in bounded:
        try:
            referencers = model.by_type(entity)
        except RuntimeError:
            continue
        for ref in referencers:
            value = getattr(ref, attribute, None)
            for v in (value if isinstance(value, tuple) else (value,)):
                if isinstance(v, ifcopenshell.entity_instance) and v.id():
                    pinned.add(v.id())
    return pinned


def _topological(model: ifcopenshell.file, watched=frozenset()) -> tuple[list, dict[int, int], list[tuple[int, int]]]:
    """Every instance after what it references; roots taken in id order, so the first of identical
    instances (the one kept) does not depend on how the model's storage happens to be ordered. With it,
    for each id in ``watched`` reached from another instance: the id of the instance whose expansion
    reached it (the last to push it: the stack gives that entry first, and nothing pushes it once expanded);
    and where the others that refer to it would have met a copy of their own: (position in the order, referrer),
    a copy being met as the instance itself is, when the stack gives its referrer's entry."""
    order, state, reached, copies = [], {}, {}, []
    by_id = model.by_id
    for first in sorted(model.entity_names()):
        if first in state:
            continue
        root = by_id(first)
        stack = [(root, False, 0)]
        while stack:
            inst, expanded, pusher = stack.pop()
            key = inst.id()
            if expanded:
                if state.get(key) != 2:
                    state[key] = 2
                    order.append(inst)
                continue
            if key in state:
                if pusher and key in watched:
                    copies.append((len(order), pusher))
                continue
            state[key] = 1
            stack.append((inst, True, 0))
            for child in model.traverse(inst, max_levels=1)[1:]:
                c = child.id()
                if c and c not in state:
                    stack.append((child, False, key))
                    if watched and c in watched:
                        reached[c] = key
                elif c and watched and c in watched:
                    stack.append((child, False, key))
    return order, reached, copies


def _substituted(value, remap: dict[int, object]):
    """``value`` with merged references replaced; ``None`` if nothing changed."""
    if isinstance(value, ifcopenshell.entity_instance):
        return remap.get(value.id()) if value.id() else None
    if isinstance(value, tuple):
        changed = False
        out = []
        for v in value:
            s = _substituted(v, remap)
            changed |= s is not None
            out.append(v if s is None else s)
        return tuple(out) if changed else None
    return None


def _key_of(value):
    if isinstance(value, ifcopenshell.entity_instance):
        return ("#", value.id()) if value.id() else (value.is_a(), _key_of(value.wrappedValue))
    if isinstance(value, tuple):
        return tuple(_key_of(v) for v in value)
    if isinstance(value, float):
        return ("f", value)
    return value


def merge_identical(model: ifcopenshell.file, progress: Progress = no_progress,
                    span: tuple[float, float] = (0.0, 1.0), shared=None) -> dict[str, int]:
    """Merge identical non-rooted instances; returns how many of each entity were removed. ``shared``
    (``sharing.SharedPlacements``, ``sharing.SharedOperators``): what the sharing made once for several members, numbered here
    as the one this merge would keep; what it did not make is counted as removed."""
    pinned = _pinned(model)
    order, reached, copies = _topological(model, shared.watched() if shared is not None else frozenset())
    if shared is not None:
        order = shared.renumbered(model, order, reached)
    remap: dict[int, object] = {}
    canonical: dict[tuple, object] = {}
    mergeable_cache: dict[str, bool] = {}
    duplicates = []
    lo, hi = span
    for k, inst in enumerate(order):
        if k % 20000 == 0:
            progress(lo + (hi - lo) * k / max(len(order), 1), "post-pass")
        values = list(inst)
        if remap:
            for i, v in enumerate(values):
                if isinstance(v, (ifcopenshell.entity_instance, tuple)):  # only references can have been merged
                    s = _substituted(v, remap)
                    if s is not None:
                        inst[i] = s
                        values[i] = s
        name = inst.is_a()
        mergeable = mergeable_cache.get(name)
        if mergeable is None:
            mergeable = mergeable_cache[name] = not any(inst.is_a(t) for t in NEVER_MERGED)
        if not mergeable or inst.id() in pinned:
            continue
        key = (name, tuple(_key_of(v) for v in values))
        first = canonical.get(key)
        if first is None:
            canonical[key] = inst
        else:
            remap[inst.id()] = first
            duplicates.append((k, inst))
    unused = [(k, dup) for k, dup in duplicates if model.get_total_inverses(dup) == 0]
    # what was removed, each entity counted where the walk met it first: the copies never made are met, part
    # by part in the order the walk finishes them, where their referrers' entries came off the stack
    met = [(k, 0, dup.is_a()) for k, dup in unused]
    if shared is not None:
        met += [(k, -1, name) for k, _ in copies for name in shared.WALKED]
    removed: dict[str, int] = {}
    for _, _, name in sorted(met, key=lambda m: m[:2]):
        removed[name] = removed.get(name, 0) + 1
    remove_batch(model, [dup for _, dup in unused])
    return removed
