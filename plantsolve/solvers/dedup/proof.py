"""Proof instead of the paper's "visual perception": per-product world geometry before vs after (the
written file read back and tessellated again), semantic counts, and ``ifcopenshell.validate``."""

from __future__ import annotations

import re
from collections import Counter

import numpy as np
from scipy.spatial import cKDTree

import ifcopenshell
import ifcopenshell.validate

from plantsolve.solvers.dedup.grouping import canonical

MAX_ERRORS_LISTED = 50
SEMANTIC_ROOTS = ("IfcProduct", "IfcPropertyDefinition", "IfcRelationship", "IfcObject", "IfcTypeObject")


def entity_counts(model: ifcopenshell.file) -> dict[str, int]:
    return dict(sorted(Counter(inst.is_a() for inst in model).items()))


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
    restyled = [g for g in before["styles"] if after["styles"].get(g) != before["styles"][g]]
    if restyled:
        out.append(f"{len(restyled)} product(s) with other styles, e.g. {restyled[0]}")
    return out[:limit]


def deviation(before: np.ndarray, after: np.ndarray) -> float:
    """Two-way Hausdorff distance of two point sets, centred on the first for accuracy."""
    c = before.mean(axis=0)
    a, b = before - c, after - c
    return max(float(np.max(cKDTree(b).query(a)[0])), float(np.max(cKDTree(a).query(b)[0])))


def normalised(message: str) -> str:
    """An error message without instance ids, to compare errors of the input and the output."""
    return re.sub(r"0x[0-9a-fA-F]+", "0x", re.sub(r"#\d+", "#", message))


def inherited(output_errors: list[str], input_errors: list[str]) -> bool:
    """Whether every error of the output is one the input already had (as many times or more)."""
    have = Counter(normalised(e) for e in input_errors)
    need = Counter(normalised(e) for e in output_errors)
    return all(have[k] >= n for k, n in need.items())


def validate(model: ifcopenshell.file, express_rules: bool) -> list[str]:
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(model, logger, express_rules=express_rules)
    errors = []
    for statement in logger.statements:
        if str(statement.get("level", "error")).lower() not in ("error", "critical"):
            continue
        inst = statement.get("instance")
        where = f"{inst}: " if inst is not None else ""
        errors.append(f"{where}{statement.get('message', statement)}"[:500])
    return errors
