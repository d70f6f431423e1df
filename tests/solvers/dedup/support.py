"""Helpers of the dedup tests: run the solver on a generated model and check its output
independently (own tessellation of the written file, own semantic counts)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.unit

from plantsolve.solvers.base import no_progress
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.upload import parse_upload


def run(model: ifcopenshell.file, **options):
    request = parse_upload("model.ifc", model.to_string().encode(), options)
    return solve(request, no_progress)


def world(model: ifcopenshell.file) -> dict[str, np.ndarray]:
    """GlobalId → world points (file units) of every product with geometry."""
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    unit = ifcopenshell.util.unit.calculate_unit_scale(model)
    out = {}
    iterator = ifcopenshell.geom.iterator(settings, model, 1)
    if iterator.initialize():
        while True:
            shape = iterator.get()
            out[model.by_id(shape.id).GlobalId] = np.asarray(shape.geometry.verts, dtype=float).reshape(-1, 3) / unit
            if not iterator.next():
                break
    return out


def two_way(a: np.ndarray, b: np.ndarray) -> float:
    c = a.mean(axis=0)
    return max(float(cKDTree(b - c).query(a - c)[0].max()), float(cKDTree(a - c).query(b - c)[0].max()))


def reopen(result) -> ifcopenshell.file:
    assert result._optimized is not None, result.report
    return ifcopenshell.file.from_string(result._optimized.decode())


def assert_round_trip(original: ifcopenshell.file, result, tol: float = 1e-5, *, inherited: bool = False) -> ifcopenshell.file:
    """Every product's world geometry unchanged within ``tol``, the same rooted instances and
    GlobalIds, and the solver's own proof saying so."""
    out = reopen(result)
    before, after = world(original), world(out)
    assert set(before) == set(after)
    worst = max(two_way(before[g], after[g]) for g in before)
    assert worst <= tol, worst
    rooted = lambda m: sorted((r.is_a(), r.GlobalId) for r in m.by_type("IfcRoot"))  # noqa: E731
    assert rooted(original) == rooted(out)
    props = lambda m: sorted((p.Name, str(p.NominalValue)) for p in m.by_type("IfcPropertySingleValue"))  # noqa: E731
    assert props(original) == props(out)
    v = result.verification
    assert v.semantic_counts_equal, v
    if inherited:  # the input's own errors, and nothing else
        assert v.errors_inherited and not v.schema_valid and v.validation_errors, v
    else:
        assert v.schema_valid and not v.validation_errors and not v.errors_inherited, v
    assert v.products_checked == len(before) and v.max_deviation <= tol
    assert result.optimized_bytes == len(result._optimized) < result.original_bytes
    assert result.optimization_ratio == result.optimized_bytes / result.original_bytes
    assert abs(result.optimization_rate - (1 - result.optimization_ratio)) < 1e-15
    return out


def classes_by_name(result, model: ifcopenshell.file) -> set[frozenset[str]]:
    names = {p.GlobalId: p.Name for p in model.by_type("IfcProduct")}
    return {frozenset(names[g] for g in c.members) for c in result.classes}


def check_transforms(result, model: ifcopenshell.file, tol: float = 1e-5) -> None:
    """Each class transform takes the representative's original world points onto the member's."""
    points = world(model)
    for cls in result.classes:
        rep = points[cls.representative]
        for g, t in zip(cls.members, cls.transforms):
            m = np.array(t).reshape(4, 4)
            assert np.allclose(m[3], [0, 0, 0, 1])
            moved = rep @ m[:3, :3].T + m[:3, 3]
            assert two_way(moved, points[g]) <= tol
