"""Proof instead of the paper's "visual perception": per-product world geometry before vs after (the
written file read back and tessellated again), semantic counts, and ``ifcopenshell.validate`` on what
the optimization wrote or changed (the rest of the file is the input's, instance for instance)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell
import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.dedup import changes as diffing
from plantsolve.solvers.dedup import compaction, ifcio, schemacheck
from plantsolve.solvers.dedup.changes import Changes
from plantsolve.solvers.dedup.grouping import canonical
from plantsolve.solvers.dedup.matching import Shape, one_to_one
from plantsolve.solvers.dedup.schemacheck import Finding, Rules
from plantsolve.solvers.dedup.skeleton import LineIndex

MAX_ERRORS_LISTED = 50
# under this many output bytes per input byte the whole output is validated: cheaper than reading the
# input to find what changed (about 1 µs per output byte to validate, 35 ns per input byte to compare)
WHOLE_OUTPUT_BELOW = 1 / 25
SEMANTIC_ROOTS = ("IfcProduct", "IfcPropertyDefinition", "IfcRelationship", "IfcObject", "IfcTypeObject")


def entity_counts(model: ifcopenshell.file, walked: dict[int, np.ndarray] | None = None,
                  walked_entities: dict[int, Counter] | None = None, everything: np.ndarray | None = None,
                  ) -> dict[str, int]:
    """Instances per entity. ``walked`` (id → the ids of an instance's traversal) and ``walked_entities``
    (the same id → its traversal's entity counts) are what a reader already counted: when those
    traversals are disjoint, only the instances outside them are looked at (a geometry-heavy model:
    millions fewer); ``everything``: the model's instance ids, when the caller has them."""
    counts: Counter = Counter()
    rest = None
    if walked and walked_entities is not None and walked.keys() == walked_entities.keys():
        everything = compaction.instance_ids(model) if everything is None else everything
        ids = np.concatenate(list(walked.values()))
        size = int(max(everything.max(initial=0), ids.max(initial=0))) + 1
        # instance numbers far sparser than the instances: a mask as long as the largest is not bounded
        if not compaction.sparse_ids(size, len(everything)):
            inside = np.zeros(size, dtype=bool)
            inside[ids] = True
            if int(inside.sum()) == len(ids) and inside[everything].sum() == len(ids):  # disjoint, all in the model
                for entities in walked_entities.values():
                    counts.update(entities)
                rest = everything[~inside[everything]].tolist()
    if rest is None:
        counts.update(inst.is_a() for inst in model)
    else:
        by_id = model.by_id
        counts.update(by_id(i).is_a() for i in rest)
    return dict(sorted(counts.items()))


def _item_styles(item, styled_by: dict[int, list], depth: int = 0) -> list[str]:
    keys = [repr(canonical(st.Styles)) for st in styled_by.get(item.id(), ())]
    if item.is_a("IfcMappedItem") and depth < 8:
        for inner in item.MappingSource.MappedRepresentation.Items or ():
            keys += _item_styles(inner, styled_by, depth + 1)
    return keys


def product_styles(model: ifcopenshell.file) -> dict[str, tuple]:
    """GlobalId → the styles (by content) on its representation items, through mapped items: a
    product must look the same afterwards."""
    styled_by: dict[int, list] = {}
    for styled in model.by_type("IfcStyledItem"):
        if styled.Item is not None:
            styled_by.setdefault(styled.Item.id(), []).append(styled)
    cache: dict[int, tuple] = {}
    out = {}
    for product in model.by_type("IfcProduct"):
        shape = product.Representation
        if shape is None:
            continue
        if shape.id() not in cache:
            keys = [k for rep in shape.Representations or () for item in rep.Items or ()
                    for k in _item_styles(item, styled_by)]
            cache[shape.id()] = tuple(sorted(keys))
        out[product.GlobalId] = cache[shape.id()]
    return out


def semantic_fingerprint(model: ifcopenshell.file) -> dict:
    """Rooted instances per entity, their GlobalIds, property values and each product's styles:
    what must not change."""
    counts = Counter()
    guids = set()
    for root in model.by_type("IfcRoot"):
        counts[root.is_a()] += 1
        guids.add(root.GlobalId)
    # what each property or quantity set holds, by content: the post-pass may let two sets share one
    # identical property instance (IFC4 allows it), which changes instance counts but no set's content
    props = Counter()
    for pset in model.by_type("IfcPropertySet"):
        for prop in pset.HasProperties or ():
            value = repr(prop.NominalValue) if prop.is_a("IfcPropertySingleValue") else prop.is_a()
            props[(prop.Name, value)] += 1
    for qset in model.by_type("IfcElementQuantity"):
        for quantity in qset.Quantities or ():
            props[(quantity.Name, repr(quantity[3]))] += 1
    return {"rooted": dict(counts), "guids": guids, "properties": dict(props), "styles": product_styles(model)}


def fingerprint_differences(before: dict, after: dict, limit: int = 20) -> list[str]:
    """What changed between two semantic fingerprints, one sentence per difference (at most
    ``limit``): the reason an output is refused, for the report."""
    out: list[str] = []
    for entity in sorted(set(before["rooted"]) | set(after["rooted"])):
        a, b = before["rooted"].get(entity, 0), after["rooted"].get(entity, 0)
        if a != b:
            out.append(f"{entity}: {a} rooted instance(s) before, {b} after")
    lost, new = before["guids"] - after["guids"], after["guids"] - before["guids"]
    if lost:
        out.append(f"{len(lost)} GlobalId(s) lost, e.g. {sorted(lost)[0]}")
    if new:
        out.append(f"{len(new)} GlobalId(s) new, e.g. {sorted(new)[0]}")
    for key in sorted(set(before["properties"]) | set(after["properties"]), key=repr):
        a, b = before["properties"].get(key, 0), after["properties"].get(key, 0)
        if a != b:
            out.append(f"property {key[0]!s} {key[1]!s}: {a} before, {b} after")
    restyled = sorted(g for g in set(before["styles"]) | set(after["styles"])
                      if after["styles"].get(g) != before["styles"].get(g))  # a style lost, changed or gained
    if restyled:
        out.append(f"{len(restyled)} product(s) with other styles, e.g. {restyled[0]}")
    return out[:limit]


def deviation(before: np.ndarray, after: np.ndarray, known: Shape | None = None, window: float = 0.0) -> float:
    """Two-way Hausdorff distance of two point sets, centred on the first for accuracy. When the sets
    are equally large and every point of one has another nearest point in the other, that map is
    one-to-one and the way back is no farther: one tree, one query. ``known``: the matching's shape of
    ``before`` (its centre, centred points and k-d tree, built while matching): the written points are
    then looked up in that tree, and only a map that is not one-to-one needs a tree of theirs; ``window``: how
    close a written point must land to one of ``known``'s alone to be answered without the tree's search."""
    if known is not None:
        a, b = known.local, after - known.centre
        dist, idx = known.nearest.query(b, window=window)
        first = float(np.max(dist))
        if len(a) == len(b) and one_to_one(idx, len(a)):
            return first
        return max(first, float(np.max(cKDTree(b).query(a)[0])))
    c = before.mean(axis=0)
    a, b = before - c, after - c
    dist, idx = cKDTree(b).query(a)
    first = float(np.max(dist))
    if len(a) == len(b) and one_to_one(idx, len(b)):
        return first
    return max(first, float(np.max(cKDTree(a).query(b)[0])))


def affected(model: ifcopenshell.file, changes: Changes, *, output: bool = True, depth: int = 2) -> list:
    """The instances of ``model`` (the output, or else the input) whose verdict the optimization can
    have changed: those it wrote, changed or removed and those referenced by other instances than
    before (the ones of them ``model`` holds), and what references those, ``depth`` levels up (a
    where-rule reads what its instance refers to, one or two levels deep). Every other instance has the
    same attribute values, the same inverse references and the same referenced instances as in the
    input: its verdict is the input's, and it is not checked again."""
    seeds = changes.changed | changes.rewired | (changes.new if output else changes.removed)
    seen: dict[int, object] = {}
    frontier = []
    for i in sorted(seeds):
        try:
            inst = model.by_id(i)
        except RuntimeError:  # a '#12' inside a string
            continue
        seen[i] = inst
        frontier.append(inst)
    for _ in range(depth):
        above = []
        for inst in frontier:
            for ref in model.get_inverse(inst):
                if ref.id() not in seen:
                    seen[ref.id()] = ref
                    above.append(ref)
        frontier = above
    return [seen[i] for i in sorted(seen)]


def findings(model: ifcopenshell.file, instances: list | None, rules: Rules | None) -> list[Finding]:
    """Errors of ``ifcopenshell.validate`` on ``instances`` (None: the whole model): schema checks and,
    with ``rules``, their where-rules and the schema's global rules (always over the whole model)."""
    out = schemacheck.schema_findings(model, instances)
    if rules is not None:
        out += schemacheck.rule_findings(model, model if instances is None else instances, rules)
        out += schemacheck.global_rule_findings(model, rules)
    return out


def validate(model: ifcopenshell.file, express_rules: bool) -> list[Finding]:
    """The whole model's errors."""
    return findings(model, None, Rules(model.schema_identifier) if express_rules else None)


def input_errors_like(original: ifcopenshell.file, changes: Changes, found: list[Finding],
                      rules: Rules | None) -> list[Finding]:
    """The input's errors on its counterpart of the changed part, among instances of the entities the
    output's errors were found on (an error of another entity cannot account for them)."""
    entities = {f.entity for f in found}
    part = [inst for inst in affected(original, changes, output=False) if inst.is_a() in entities]
    return findings(original, part, rules)


def inherited(output_errors: list[Finding], input_errors: list[Finding]) -> bool:
    """Whether every error of the output is one the input already had (as many times or more): the same
    rule or attribute on the same entity with the same message, wherever and on whichever instance id."""
    have = Counter(e.key for e in input_errors)
    need = Counter(e.key for e in output_errors)
    return all(have[k] >= n for k, n in need.items())


@dataclass
class Verdict:
    errors: list[Finding]
    inherited: bool
    validated: int
    changed: int | None  # None: the output was validated whole, the input never read


def verdict(check: ifcopenshell.file, written: bytes, input_path: Path, rules: Rules | None,
            index: LineIndex | None = None) -> Verdict:
    """The written file's validation errors and whether the input had them all. The part that changed
    is validated (see ``affected``), or the whole output when it is that much smaller than the input;
    the input's text is compared with the output only then, and its counterpart validated only
    when the output has errors. ``index``: the scan's index of the input's lines, which makes the
    comparison cost what the output holds, not what the input does: the changed part is then validated
    whatever the sizes."""

    def compared() -> Changes:
        if index is not None:
            return diffing.diff_indexed(index, written.decode("latin-1"))
        return diffing.diff(input_path.read_bytes().decode("latin-1"), written.decode("latin-1"))

    delta = None
    whole = index is None and len(written) < input_path.stat().st_size * WHOLE_OUTPUT_BELOW
    if whole:
        part = list(check)
    else:
        delta = compared()
        part = affected(check, delta)
    found = findings(check, part, rules)
    inherited_errors = False
    if found:  # are they ours? (real exports are often invalid already): the same part of the input
        delta = delta or compared()
        ours = {inst.id() for inst in affected(check, delta)} if whole else None
        # an error on an instance outside the changed part is on it exactly as the input has it
        new = [f for f in found if ours is None or not f.instance_id or f.instance_id in ours]
        original = ifcio.open_path(str(input_path))
        inherited_errors = inherited(new, input_errors_like(original, delta, new, rules))
        del original
    changed = None if delta is None else len(delta.changed | delta.new | delta.rewired)
    if delta is not None:
        delta.release()
    return Verdict(found, inherited_errors, len(part), changed)
