"""Helpers of the dedup tests: run the solver on a generated model and check its output
independently (own tessellation of the written file, own semantic counts)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.unit

import pytest

from plantsolve.solvers.base import InputRejected, Solved, StoredInput
from plantsolve.solvers.dedup import SPEC, compaction, postpass, sharing
from plantsolve.solvers.dedup.explicit import ExplicitReader
from plantsolve.solvers.dedup.grouping import build_classes, make_candidate, pool_transforms
from plantsolve.solvers.dedup.source import IfcSource
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.upload import parse_upload
from plantsolve.solvers.dedup.worldgeom import world_points


def intake_text(text: str, encoding: str = "utf-8") -> None:
    """The submission check of an IFC text uploaded as ``model.ifc`` (raises :class:`InputRejected` when refused)."""
    source = StoredInput.from_bytes("model.ifc", text.encode(encoding))
    SPEC.check_input(SPEC.input_of(parse_upload(source, {}), source))


def intake_refusal(text: str, encoding: str = "utf-8") -> str:
    """The one message the submission check refuses ``text`` with."""
    with pytest.raises(InputRejected) as refused:
        intake_text(text, encoding)
    (error,) = refused.value.errors
    return error.msg


def upload(model: ifcopenshell.file, name: str = "model.ifc", **options) -> IfcSource:
    """The model uploaded (in memory) as the intake takes it: parsed, loaded and checked."""
    source = StoredInput.from_bytes(name, model.to_string().encode())
    value = SPEC.input_of(parse_upload(source, options), source)
    SPEC.check_input(value)
    return value


def run(model: ifcopenshell.file, **options) -> Solved:
    return solve(upload(model, **options))


def classes_of(model: ifcopenshell.file, *, allow_mirror: bool = False) -> tuple[list, ExplicitReader]:
    """The model's classes of congruent products (tolerance 1e-5, no scaling) as the solve groups them, and the
    geometry reader whose walk of the old geometry found them (its closures recorded)."""
    products = [p for p in model.by_type("IfcProduct") if p.Representation is not None]
    reader = ExplicitReader(model, record_closures=True)
    points, faces = world_points(model, products, reader=reader)
    candidates = [make_candidate(p, sharing.body_representation(p), model, points[p.id()], faces[p.id()])
                  for p in products if p.id() in points and sharing.body_representation(p) is not None]
    return build_classes(candidates, 1e-5, allow_mirror=allow_mirror, allow_scale=False), reader


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


def reopen(solved: Solved) -> ifcopenshell.file:
    assert "optimized.ifc" in solved.files, solved.result.report
    return ifcopenshell.file.from_string(solved.files["optimized.ifc"].decode())


def assert_round_trip(original: ifcopenshell.file, solved: Solved, tol: float = 1e-5, *,
                      inherited: bool = False) -> ifcopenshell.file:
    """Every product's world geometry unchanged within ``tol``, the same rooted instances and
    GlobalIds, and the solver's own proof saying so."""
    result = solved.result
    out = reopen(solved)
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
    assert result.optimized_bytes == len(solved.files["optimized.ifc"]) < result.original_bytes
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


def zoo_expected(allow_mirror: bool = False, allow_scale: bool = False) -> set[frozenset[str]]:
    """The congruence classes (two or more members) of ``synthetic.zoo_spec``, by product name."""
    chiral = {"chiral_a", "chiral_b_shuffled", "chiral_nested_1", "chiral_nested_2"}
    if allow_mirror:
        chiral.add("chiral_mirrored")
    if allow_scale:
        chiral.add("chiral_scaled_1pct")
    return {frozenset(chiral), frozenset({"cube_a", "cube_b"}), frozenset({"mapped_a", "mapped_b"}),
            frozenset({"column_a", "column_b"})}


def shared_and_merged(model: ifcopenshell.file, mode: str, shared, *, allow_mirror: bool = False,
                      rebuild: bool = True) -> tuple[str, dict[str, int]]:
    """The model shared in ``mode`` (with ``shared``: a ``sharing.SharedPlacements`` or ``SharedOperators``, or
    None for one new instance per member), compacted and merged by the post-pass: its STEP text and the post-pass's
    removed counts."""
    classes, reader = classes_of(model, allow_mirror=allow_mirror)
    pool_transforms(classes, 1e-5)  # as the solve does: a ring's members then get the same transform
    before = compaction.instance_ids(model)
    detached = sharing.Detached(model)
    sharing.apply(model, classes, mode, detached=detached, shared=shared)
    everything = compaction.grown(model, before, shared.skipped if shared else ())
    assert sorted(everything.tolist()) == sorted(model.entity_names())
    model = compaction.compacted(model, detached.roots, detached.styled_by, known=reader.closures,
                                 everything=everything, rebuild=rebuild)
    removed = postpass.merge_identical(model, shared=shared)
    return model.to_string().split("DATA;", 1)[1], removed  # the header holds the time of writing
