"""What the sharing detached, deleted: old product shapes, representations and placements with every
instance only they use (what ``ifcopenshell.util.element.remove_deep2`` deletes, for all of them at
once), and the styled items of their items (an item still used elsewhere keeps its style).

The cost follows the smaller side, never the whole model twice:

- what the detached roots hold (``closure``) comes from the ids the geometry reader already walked
  (``ExplicitReader.closures``); only what it did not walk is traversed;
- which of those instances something outside still references is asked either of the C++ core for
  the detached ids at once, or of the instances outside, whichever are fewer;
- when most of the model goes (the paper's tunnel: 2.5 M of 2.5 M instances), the model is rebuilt
  from the STEP text of what stays, ids unchanged (the way ``unbatch_remove_deep2`` rebuilds, without
  writing what goes first); otherwise what goes is removed in one batch.
"""

from __future__ import annotations

import numpy as np

import ifcopenshell

# CPU per instance, measured on the 530-ring tunnel (µs): what decides which side is walked
TRAVERSE_ONE_LEVEL_US = 5.0  # expanding one instance outside the detached part
REFERENCED_WITHIN_US = 0.7  # the core's check of one detached id
WRITE_KEPT_US = 20.0  # one kept instance as STEP text, read back
REMOVE_US = 3.5  # one removed instance, batched


def closure(model: ifcopenshell.file, roots, known: dict[int, np.ndarray] | None = None) -> np.ndarray:
    """Ids of ``roots`` and of everything they reference, directly or not; the instances in ``known``
    (id → the ids of its traversal) are not walked again."""
    known = known or {}
    parts: list[np.ndarray] = []
    seen: set[int] = set()
    stack = list(roots)
    traverse = model.traverse
    while stack:
        inst = stack.pop()
        i = inst.id()
        if not i or i in seen:
            continue
        seen.add(i)
        held = known.get(i)
        if held is not None:
            parts.append(held)
            continue
        stack.extend(traverse(inst, max_levels=1)[1:])
    parts.append(np.fromiter(seen, dtype=np.int64, count=len(seen)))
    return np.concatenate(parts)  # ids may repeat: they only mark a mask


def _spread(model: ifcopenshell.file, starts, live: np.ndarray) -> None:
    """Marks in ``live`` everything ``starts`` reference, directly or not (``starts`` already marked)."""
    stack = [int(i) for i in starts]
    by_id, traverse = model.by_id, model.traverse
    while stack:
        for child in traverse(by_id(stack.pop()), max_levels=1)[1:]:
            c = child.id()
            if c and not live[c]:
                live[c] = True
                stack.append(c)


def going(model: ifcopenshell.file, roots, styled_by: dict[int, list], *,
          known: dict[int, np.ndarray] | None = None, from_outside: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(ids that go, ids of the whole model): the detached ``roots`` with what only they use, and the
    styled items (``styled_by``: item id → its IfcStyledItems) of the items that go, with what only
    those use. ``from_outside`` forces how the referenced part is found (None: the cheaper way)."""
    everything = np.fromiter(model.entity_names(), dtype=np.int64)
    if not len(everything) or not roots:
        return np.zeros(0, dtype=np.int64), everything
    size = int(everything.max()) + 1
    detached = np.zeros(size, dtype=bool)
    held = closure(model, roots, known)
    detached[held[held < size]] = True
    styled = [st for item, sts in styled_by.items() if item < size and detached[item] for st in sts]
    if styled:
        detached[closure(model, styled)] = True
    inside = everything[detached[everything]]
    outside = everything[~detached[everything]]
    if from_outside is None:
        from_outside = len(outside) * TRAVERSE_ONE_LEVEL_US < len(inside) * REFERENCED_WITHIN_US
    live = ~detached
    if from_outside:  # every instance outside marks what it references inside
        _spread(model, outside, live)
    else:  # the core names the detached instances referenced only from inside; the others stay
        only_within = np.zeros(size, dtype=bool)
        only_within[np.asarray(model._ids_referenced_only_within(inside.tolist()), dtype=np.int64)] = True
        entries = inside[~only_within[inside]]
        live[entries] = True
        _spread(model, entries, live)
    kept_styles = [st.id() for st in styled if not live[st.id()] and st.Item is not None and live[st.Item.id()]]
    if kept_styles:  # an item that stays keeps its style
        live[kept_styles] = True
        _spread(model, kept_styles, live)
    return everything[~live[everything]], everything


def remove_batch(model: ifcopenshell.file, instances) -> None:
    """Delete ``instances`` (an iterable, or a dict id → instance) in one batch, highest id first.

    One batch, because removing instance by instance rewrites the inverse maps once per instance.
    Highest id first, because the core keeps its instances in id-sorted arrays and erases each one
    in place: erasing from the end moves only the few kept instances behind it, while the hash
    order of a set made the batch quadratic (530 rings: most of the sharing phase)."""
    by_id = instances if isinstance(instances, dict) else {e.id(): e for e in instances}
    remove = model.remove
    model.batch()
    try:
        for i in sorted(by_id, reverse=True):
            remove(by_id[i])
    finally:
        model.unbatch()


def rebuilt(model: ifcopenshell.file, keep: np.ndarray) -> ifcopenshell.file:
    """A new model of the instances ``keep`` (ids, ascending; closed under references), with the
    same header and the same ids: its STEP text is what ``model.to_string()`` would write of them."""
    empty = ifcopenshell.file(schema_identifier=model.schema_identifier)
    empty.assign_header_from(model)
    head, tail = empty.to_string().split("DATA;\n", 1)
    by_id = model.by_id
    body = "".join(by_id(int(i)).to_string() + ";\n" for i in keep)
    return ifcopenshell.file.from_string(head + "DATA;\n" + body + tail)


def compacted(model: ifcopenshell.file, roots, styled_by: dict[int, list], *,
              known: dict[int, np.ndarray] | None = None, rebuild: bool | None = None) -> ifcopenshell.file:
    """``model`` without what goes (see ``going``): the same model, or a rebuilt one when most of it
    goes (``rebuild`` forces the choice). Entity instances of ``model`` must not be used afterwards
    when a new model is returned."""
    gone, everything = going(model, roots, styled_by, known=known)
    if not len(gone):
        return model
    kept = len(everything) - len(gone)
    if rebuild is None:
        rebuild = kept * WRITE_KEPT_US < len(gone) * REMOVE_US
    if rebuild:
        keep = np.setdiff1d(everything, gone, assume_unique=True)
        return rebuilt(model, keep)
    by_id = model.by_id
    remove_batch(model, {int(i): by_id(int(i)) for i in gone})
    return model
