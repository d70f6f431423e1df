"""Deleting what the sharing detached (``compaction``), and the shortcuts the speed work took: each
way of finding what stays and each way of deleting it give the same model; styled duplicates lose
their old geometry and its style; entity counts from the geometry reader's walk, the lexsort unique
and the one-directional verification equal the plain computations; what the phases hand each other (the
input's ids, the reader's placements, the matching's k-d trees) gives what each computing its own gave."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import ifcopenshell
import ifcopenshell.util.element

from plantsolve.solvers.dedup import compaction, proof, sharing
from plantsolve.solvers.dedup.explicit import ExplicitReader, unique_rows, unique_rows_each
from plantsolve.solvers.dedup.grouping import build_classes, make_candidate
from plantsolve.solvers.dedup.matching import Match, det3, hausdorff, make_shape, one_to_one, verify
from plantsolve.solvers.dedup.synthetic import (WORLD_ORIGIN, ModelSpec, Product, apply, build_model, pose,
                                                 segment_mesh, tunnel_file, zoo_spec)
from plantsolve.solvers.dedup.worldgeom import world_points
from tests.solvers.dedup.support import assert_round_trip, classes_of, run


def _shared(model: ifcopenshell.file, mode: str):
    """The model with its classes shared, what was detached, and the reader's walk of the old geometry."""
    classes, reader = classes_of(model)
    detached = sharing.Detached(model)
    sharing.apply(model, classes, mode, detached=detached)
    return detached, reader


def _styled_duplicates() -> ModelSpec:
    """Three red columns and three green meshes, each three congruent copies."""
    o = WORLD_ORIGIN
    mesh, faces = segment_mesh(15.0, taper_deg=4.0)
    products = [Product("column", entity="IfcColumn", extrusion=(0.4, 0.6, 3.0), style_rgb=(1.0, 0.0, 0.0),
                        name=f"column_{k}", placement=pose(0, 0, 25 * k, o + [k * 3.0, 20.0, 0.0])) for k in range(3)]
    products += [Product("mesh", verts=apply(pose(10 * k, 20, 30, o + [10.0 * k, 5.0, 0.0]), mesh), faces=faces,
                         style_rgb=(0.0, 1.0, 0.0), name=f"mesh_{k}") for k in range(3)]
    return ModelSpec(schema="IFC4", products=products)


@pytest.mark.parametrize("make", [lambda: tunnel_file(3, "IFC4", face_set="surface_model"),
                                  lambda: build_model(zoo_spec("IFC4")), lambda: build_model(_styled_duplicates())],
                         ids=["tunnel", "zoo", "styled"])
@pytest.mark.parametrize("mode", ["product_shape", "mapped_item"])
def test_every_way_of_deleting_gives_the_same_model(make, mode):
    texts = set()
    gone_sets = set()
    for from_outside in (True, False):
        for rebuild in (True, False):
            model = make()
            detached, reader = _shared(model, mode)
            gone, _ = compaction.going(model, detached.roots, detached.styled_by, known=reader.closures,
                                       from_outside=from_outside)
            gone_sets.add(tuple(sorted(gone.tolist())))
            out = compaction.compacted(model, detached.roots, detached.styled_by, known=reader.closures,
                                       rebuild=rebuild)
            texts.add(out.to_string().split("DATA;", 1)[1])  # the header's time stamp is the generator's
            assert len(out.by_type("IfcProduct")) == len(make().by_type("IfcProduct"))
    assert len(gone_sets) == 1 and len(texts) == 1 and gone_sets.pop()


@pytest.mark.parametrize("mode", ["product_shape", "mapped_item"])
def test_what_goes_is_what_remove_deep2_would_delete(mode):
    """On the tunnel the reference is the library's own: each detached root removed with
    ``remove_deep2``, one by one, leaves the same instances."""
    model = tunnel_file(2, "IFC4", face_set="surface_model")
    detached, reader = _shared(model, mode)
    gone, everything = compaction.going(model, detached.roots, detached.styled_by, known=reader.closures)
    expected = tunnel_file(2, "IFC4", face_set="surface_model")
    detached2, _ = _shared(expected, mode)
    for root_id in [root.id() for root in detached2.roots]:
        try:
            root = expected.by_id(root_id)
        except RuntimeError:  # went with an earlier root
            continue
        if expected.get_total_inverses(root) == 0:
            ifcopenshell.util.element.remove_deep2(expected, root)
    assert sorted(set(everything.tolist()) - set(gone.tolist())) == sorted(expected.entity_names())


@pytest.mark.parametrize("make", [lambda: tunnel_file(2, "IFC4", face_set="surface_model"),
                                  lambda: build_model(zoo_spec("IFC2X3"))], ids=["tunnel", "zoo"])
@pytest.mark.parametrize("mode", ["product_shape", "mapped_item"])
def test_the_ids_grown_by_the_sharing_are_the_models_ids(make, mode):
    """The input's ids listed once and grown by what the sharing added are the ids the core lists after it;
    a number past the input's largest that is no instance (a deleted one) makes them listed again."""
    model = make()
    before = compaction.instance_ids(model)
    _shared(model, mode)
    assert sorted(compaction.grown(model, before).tolist()) == sorted(model.entity_names())
    assert len(compaction.grown(model, before)) > len(before)
    model.remove(model.by_id(int(model.get_max_id()) - 1))  # a gap among the added numbers
    assert sorted(compaction.grown(model, before).tolist()) == sorted(model.entity_names())


def test_the_sharing_places_members_alike_with_the_readers_matrices_or_its_own():
    """The placements the geometry reader evaluated, handed to the sharing, write the file a sharing
    evaluating its own would: byte for byte, in both modes."""
    for mode in ("product_shape", "mapped_item"):
        texts = set()
        for reuse in (True, False):
            model = tunnel_file(3, "IFC4", face_set="surface_model")
            products = [p for p in model.by_type("IfcProduct") if p.Representation is not None]
            reader = ExplicitReader(model)
            points, faces = world_points(model, products, reader=reader)
            candidates = [make_candidate(p, sharing.body_representation(p), model, points[p.id()], faces[p.id()])
                          for p in products]
            classes = build_classes(candidates, 1e-5, allow_mirror=False, allow_scale=False)
            sharing.apply(model, classes, mode, placements=reader.placements if reuse else None)
            texts.add(model.to_string().split("DATA;", 1)[1])
        assert len(texts) == 1


def test_styled_duplicates_lose_their_old_geometry_and_its_style():
    model = build_model(_styled_duplicates())
    for mode in ("product_shape", "mapped_item"):
        solved = run(model, sharing=mode)
        result = solved.result
        assert len(result.classes) == 2 and result.products_shared == 4
        out = assert_round_trip(model, solved)  # every product looks as it did, styles included
        assert result.entity_counts_before["IfcStyledItem"] == 6
        assert len(out.by_type("IfcStyledItem")) == 2 and len(out.by_type("IfcExtrudedAreaSolid")) == 1
        assert len(out.by_type("IfcFaceBasedSurfaceModel")) + len(out.by_type("IfcPolygonalFaceSet")) \
            + len(out.by_type("IfcFacetedBrep")) == 1


@pytest.mark.parametrize("make", [lambda: tunnel_file(2, "IFC4", face_set="surface_model"),
                                  lambda: build_model(zoo_spec("IFC2X3"))], ids=["tunnel", "zoo"])
def test_entity_counts_from_the_readers_walk_equal_the_plain_count(make):
    model = make()
    reader = ExplicitReader(model, record_closures=True)
    world_points(model, [p for p in model.by_type("IfcProduct") if p.Representation is not None], reader=reader)
    assert reader.closures
    assert proof.entity_counts(model, reader.closures, reader.closure_entities) == proof.entity_counts(model)
    # overlapping walks are not trusted: the plain count
    first = next(iter(reader.closures))
    overlapping = {**reader.closures, -1: reader.closures[first]}
    entities = {**reader.closure_entities, -1: reader.closure_entities[first]}
    assert proof.entity_counts(model, overlapping, entities) == proof.entity_counts(model)


def test_unique_rows_is_numpys_unique():
    rng = np.random.default_rng(3)
    points = np.round(rng.normal(size=(400, 3)), 1)
    points = np.concatenate([points, points[::3], [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]])
    assert np.array_equal(unique_rows(points), np.unique(points, axis=0))
    assert unique_rows(np.zeros((0, 3))).shape == (0, 3)


def test_unique_rows_of_many_at_once_are_each_one_s():
    rng = np.random.default_rng(4)
    parts = [np.round(rng.normal(size=(int(n), 3)), 1) for n in rng.integers(5, 60, 100)]
    parts.insert(7, np.zeros((0, 3)))
    parts[3][:2] = [[-0.0, 0.0, 0.0], [0.0, -0.0, 0.0]]  # equal rows that differ in their zeros' signs
    parts[5][2:4] = [[np.nan, 1.0, 2.0], [np.nan, 1.0, 2.0]]
    for one, each in zip(map(unique_rows, parts), unique_rows_each(parts), strict=True):
        assert one.shape == each.shape and np.array_equal(one, each, equal_nan=True)
        assert np.array_equal(np.signbit(one), np.signbit(each))


def _both_ways(rep, member, m: Match) -> float:
    """The two-way Hausdorff distance as ``verify`` computed it before (a tree of each side)."""
    a = m.rotation * m.scale
    moved = (rep.points - rep.centre) @ a.T + a @ rep.centre + m.translation - member.centre
    return hausdorff(moved, member.local)


def test_a_groups_signatures_are_each_shapes_own():
    """The group's signatures in one quantile call are, row by row and bit for bit, each shape's computed alone."""
    from plantsolve.solvers.dedup.grouping import QUANTILES, signatures

    rng = np.random.default_rng(3)
    base = rng.normal(size=(40, 3)) * [3.0, 2.0, 1.0]
    shapes = [make_shape(base @ pose(10 * k, 20, 30 * k, WORLD_ORIGIN)[:3, :3].T + k
                         + rng.normal(scale=1e-3, size=(40, 3))) for k in range(6)]
    for row, shape in zip(signatures(shapes), shapes):
        d = np.sqrt(np.sum(shape.local * shape.local, axis=1))
        alone = np.concatenate([np.sqrt(np.maximum(shape.eigenvalues, 0.0)), [shape.radius], np.quantile(d, QUANTILES)])
        assert np.array_equal(row, alone)


def test_verify_in_one_direction_is_the_two_way_hausdorff_distance():
    rng = np.random.default_rng(5)
    rep_points = rng.normal(size=(60, 3)) + 1e6
    rep = make_shape(rep_points)
    angle = 0.3
    r = np.array([[np.cos(angle), -np.sin(angle), 0.0], [np.sin(angle), np.cos(angle), 0.0], [0.0, 0.0, 1.0]])
    t = np.array([5.0, -2.0, 1.0])
    exact = Match(r, 1.0, t, 0.0, False)
    for noise in (0.0, 1e-7, 1e-6):
        moved = rep_points @ r.T + t + rng.normal(scale=noise, size=rep_points.shape)
        member = make_shape(moved[rng.permutation(len(moved))])
        assert verify(rep, member, exact, 1e-5) == _both_ways(rep, member, exact) <= 1e-5
    # a collapsed member (two points onto one): the way back is searched, and finds the gap
    member = make_shape(np.concatenate([rep_points[:-1] @ r.T + t, (rep_points[:1] @ r.T + t)]))
    full = _both_ways(rep, member, exact)
    assert verify(rep, member, exact, 10.0) == full and full > 1e-3
    assert verify(rep, member, exact, 1e-5) > 1e-5


def test_the_proofs_deviation_in_one_direction_is_the_two_way_distance():
    def both_ways(before, after):
        c = before.mean(axis=0)
        a, b = before - c, after - c
        return max(float(np.max(cKDTree(b).query(a)[0])), float(np.max(cKDTree(a).query(b)[0])))

    rng = np.random.default_rng(1)
    for k in range(200):
        a = rng.normal(size=(int(rng.integers(2, 50)), 3)) + 1e6
        b = a[rng.permutation(len(a))] + rng.normal(scale=10 ** rng.uniform(-9, 0), size=a.shape)
        if k % 3 == 0:  # two points onto one
            b = np.concatenate([b[:-1], b[:1]])
        if k % 5 == 0:  # one fewer
            b = b[:-1]
        assert proof.deviation(a, b) == both_ways(a, b)
        # the matching's shape of the points before: the written points looked up in its tree
        assert proof.deviation(a, b, make_shape(a)) == both_ways(a, b)


def test_det3_and_one_to_one_are_numpys():
    rng = np.random.default_rng(2)
    for _ in range(50):
        m = rng.normal(size=(3, 3))
        assert det3(m) == pytest.approx(np.linalg.det(m), rel=1e-12, abs=1e-12)
        idx = rng.integers(0, 6, size=6)
        assert one_to_one(idx, 6) == (len(np.unique(idx)) == 6)
    assert one_to_one(np.array([2, 0, 1]), 3) and not one_to_one(np.array([0, 1]), 3)
