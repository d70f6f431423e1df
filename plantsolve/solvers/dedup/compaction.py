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


def instance_ids(model: ifcopenshell.file) -> np.ndarray:
    """The ids of every instance of ``model`` (the core lists them as Python ints: 0.3 s and 100 MB for the
    paper's tunnel, so they are listed once and grown, see :func:`grown`)."""
    return np.fromiter(model.entity_names(), dtype=np.int64)


def grown(model: ifcopenshell.file, before: np.ndarray, skipped=()) -> np.ndarray:
    """The ids of ``model``, which held ``before`` and has only gained instances since (the sharing adds and
    deletes nothing itself): the core numbers each new instance after the largest, so they are the numbers
    past ``before``'s largest but ``skipped`` (numbers the sharing left out: ``sharing.SharedPlacements``);
    listed again when one of those numbers is not an instance after all."""
    start = int(before.max(initial=0)) + 1
    added = np.arange(start, max(model.get_max_id() + 1, start), dtype=np.int64)
    if len(skipped):
        added = np.setdiff1d(added, np.asarray(skipped, dtype=np.int64), assume_unique=True)
    try:
        for i in added.tolist():
            model.by_id(i)
    except RuntimeError:  # a gap: not numbered as assumed
        return instance_ids(model)
    return np.concatenate([before, added])


def going(model: ifcopenshell.file, roots, styled_by: dict[int, list], *,
          known: dict[int, np.ndarray] | None = None, from_outside: bool | None = None,
          everything: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(ids that go, ids of the whole model): the detached ``roots`` with what only they use, and the
    styled items (``styled_by``: item id → its IfcStyledItems) of the items that go, with what only
    those use. ``from_outside`` forces how the referenced part is found (None: the cheaper way);
    ``everything``: the ids of the model's instances, when the caller has them."""
    everything = instance_ids(model) if everything is None else everything
    if not len(everything) or not roots:
        return np.zeros(0, dtype=np.int64), everything
    size = int(everything.max()) + 1
    if sparse_ids(size, len(everything)):
        return _going_sparse(model, roots, styled_by, known, everything)
    detached = np.zeros(size, dtype=bool)
    held = closure(model, roots, known)
    detached[held[held < size]] = True
    del held  # the mask says it (the ids of the old geometry are as many as the model's instances)
    styled = [st for item, sts in styled_by.items() if item < size and detached[item] for st in sts]
    if styled:
        detached[closure(model, styled)] = True
    within = detached[everything]
    if from_outside is None:
        n_inside = int(np.count_nonzero(within))
        from_outside = (len(everything) - n_inside) * TRAVERSE_ONE_LEVEL_US < n_inside * REFERENCED_WITHIN_US
    live = ~detached
    if from_outside:  # every instance outside marks what it references inside
        _spread(model, everything[~within], live)
    else:  # the core names the detached instances referenced only from inside; the others stay
        inside = everything[within]
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


def sparse_ids(size: int, count: int) -> bool:
    """Whether masks as long as the largest instance number (``size``) would be mostly empty: a model of
    ``count`` instances numbered up into the billions (a hostile file, or an exporter's odd numbering) would
    otherwise take a gigabyte per mask."""
    return size > 8 * count + (1 << 24)


def _going_sparse(model: ifcopenshell.file, roots, styled_by: dict[int, list], known: dict[int, np.ndarray] | None,
                  everything: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`going` for sparse instance numbers (:func:`sparse_ids`): the same sets, held as Python sets of
    the numbers instead of masks indexed by them; what stays is found from the detached side."""
    numbers = set(everything.tolist())
    detached = {i for i in closure(model, roots, known).tolist() if i in numbers}
    styled = [st for item, sts in styled_by.items() if item in detached for st in sts]
    if styled:
        detached.update(closure(model, styled).tolist())
    inside = [i for i in everything.tolist() if i in detached]
    only_within = set(model._ids_referenced_only_within(inside))
    dead = set(detached)
    entries = [i for i in inside if i not in only_within]
    dead.difference_update(entries)
    _spread_sparse(model, entries, dead)
    kept_styles = [st.id() for st in styled if st.id() in dead and st.Item is not None and st.Item.id() not in dead]
    if kept_styles:  # an item that stays keeps its style
        dead.difference_update(kept_styles)
        _spread_sparse(model, kept_styles, dead)
    return everything[np.isin(everything, np.fromiter(dead, dtype=np.int64, count=len(dead)))], everything


def _spread_sparse(model: ifcopenshell.file, starts, dead: set[int]) -> None:
    """:func:`_spread` on the set of what is not live: everything ``starts`` reference leaves ``dead``."""
    stack = [int(i) for i in starts]
    by_id, traverse = model.by_id, model.traverse
    while stack:
        for child in traverse(by_id(stack.pop()), max_levels=1)[1:]:
            c = child.id()
            if c in dead:
                dead.discard(c)
                stack.append(c)


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


def frame(model: ifcopenshell.file) -> tuple[str, str]:
    """The STEP text of ``model`` before its instances (header and 'DATA;' line excluded) and after them."""
    empty = ifcopenshell.file(schema_identifier=model.schema_identifier)
    empty.assign_header_from(model)
    head, tail = empty.to_string().split("DATA;\n", 1)
    return head, tail


def rebuilt(model: ifcopenshell.file, keep: np.ndarray, texts: dict[int, str] | None = None) -> ifcopenshell.file:
    """A new model of the instances ``keep`` (ids, ascending; closed under references), with the
    same header and the same ids: its STEP text is what ``model.to_string()`` would write of them.
    ``texts``: the STEP text of instances ``model`` holds only as stand-ins (``skeleton``)."""
    head, tail = frame(model)
    by_id = model.by_id
    if texts:
        body = "".join((texts[i] if i in texts else by_id(i).to_string()) + ";\n" for i in keep.tolist())
    else:
        body = "".join(by_id(int(i)).to_string() + ";\n" for i in keep)
    return ifcopenshell.file.from_string(head + "DATA;\n" + body + tail)


def compacted(model: ifcopenshell.file, roots, styled_by: dict[int, list], *,
              known: dict[int, np.ndarray] | None = None, rebuild: bool | None = None,
              everything: np.ndarray | None = None) -> ifcopenshell.file:
    """``model`` without what goes (see ``going``): the same model, or a rebuilt one when most of it
    goes (``rebuild`` forces the choice). Entity instances of ``model`` must not be used afterwards
    when a new model is returned."""
    gone, everything = going(model, roots, styled_by, known=known, everything=everything)
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
