"""Correspondence-free matching on point sets alone: known rotations recovered, mirror and 1 % scale
refused unless allowed, a symmetric shape matched with a valid proper rotation, far from the origin."""

from __future__ import annotations

import ifcopenshell.util.placement
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantsolve.solvers.dedup.matching import (
    TRIES_AT_ONCE,
    Match,
    first_steps,
    first_verified,
    make_shape,
    match,
    verify,
)
from plantsolve.solvers.dedup.sharing import Placements
from plantsolve.solvers.dedup.synthetic import box_mesh, segment_mesh, tunnel_file

FAR = np.array([1.0e6, 1.0e6, 30.0])


@pytest.mark.parametrize("seed", range(6))
def test_a_random_rigid_copy_with_shuffled_points_gives_the_known_transform(seed):
    verts, _ = segment_mesh(15.0, taper_deg=4.0)  # the chiral keystone
    rng = np.random.default_rng(seed)
    rotation = Rotation.random(random_state=seed).as_matrix()
    shift = FAR + rng.normal(size=3) * 300.0
    rep = make_shape(verts + FAR)
    member = make_shape((verts @ rotation.T + shift)[rng.permutation(len(verts))])
    m = match(rep, member, 1e-6)
    assert m is not None and not m.mirror and m.scale == 1.0
    # member = R (x + FAR) + t  ⇒  t = shift − R·FAR
    assert np.allclose(m.rotation, rotation, atol=1e-9)
    assert np.allclose(m.translation, shift - rotation @ FAR, atol=1e-6)
    assert m.deviation < 1e-8


def test_mirror_and_one_percent_scale_join_only_when_allowed():
    verts, _ = segment_mesh(15.0, taper_deg=4.0)
    rotation = Rotation.from_euler("xyz", [10, 70, -30], degrees=True).as_matrix()
    rep = make_shape(verts + FAR)
    mirrored = make_shape((verts * [1.0, -1.0, 1.0]) @ rotation.T + FAR)
    scaled = make_shape((verts * 1.01) @ rotation.T + FAR)
    assert match(rep, mirrored, 1e-5) is None
    assert match(rep, scaled, 1e-5) is None
    m = match(rep, mirrored, 1e-5, allow_mirror=True)
    assert m is not None and m.mirror and np.linalg.det(m.rotation) == pytest.approx(-1.0)
    s = match(rep, scaled, 1e-5, allow_scale=True)
    assert s is not None and s.scale == pytest.approx(1.01, abs=1e-9) and not s.mirror


def test_a_symmetric_cube_matches_with_a_proper_rotation_and_the_identity_for_itself():
    verts, _ = box_mesh(0.8)
    rotation = Rotation.from_euler("xyz", [33, -12, 71], degrees=True).as_matrix()
    rep = make_shape(verts + FAR)
    member = make_shape(verts @ rotation.T + FAR + 5.0)
    m = match(rep, member, 1e-6)
    assert m is not None and np.linalg.det(m.rotation) == pytest.approx(1.0)
    moved = (verts + FAR) @ m.rotation.T + m.translation
    assert np.abs(np.sort(moved, axis=0) - np.sort(member.points, axis=0)).max() < 1e-6
    same = match(rep, make_shape(verts + FAR), 1e-6)
    assert np.allclose(same.rotation, np.eye(3)) and np.allclose(same.translation, 0.0, atol=1e-6)


def test_different_shapes_with_equal_point_counts_do_not_match():
    a, _ = segment_mesh(50.0)
    b, _ = segment_mesh(47.5)
    assert len(a) == len(b)
    assert match(make_shape(a + FAR), make_shape(b + FAR), 1e-5) is None


@pytest.mark.parametrize("seed", range(4))
def test_the_first_verified_of_many_tries_is_the_one_verify_finds_in_turn_with_the_same_bits(seed):
    # the pool's batched tries: every try's deviation as verify() gives it, bit for bit, and the first
    # within the tolerance chosen (wrong rotations, a near miss, right ones in a shuffled order)
    verts, _ = segment_mesh(15.0, taper_deg=4.0)
    rng = np.random.default_rng(seed)
    rotation = Rotation.random(random_state=seed).as_matrix()
    rep = make_shape(verts + FAR)
    member = make_shape((verts @ rotation.T + FAR + 5.0)[rng.permutation(len(verts))])
    right = match(rep, member, 1e-6)
    wrong = [Match(Rotation.random(random_state=seed + 10 + k).as_matrix(), 1.0, right.translation, 0.0, False)
             for k in range(5)]
    near_miss = Match(right.rotation, 1.0, right.translation + [2e-6, 0.0, 0.0], 0.0, False)
    tries = wrong[:2] + [near_miss] + wrong[2:] + [right] + wrong[:1]
    order = rng.permutation(len(tries)).tolist()
    tries = [tries[i] for i in order]
    one_by_one = [verify(rep, member, m, 1e-6) for m in tries]
    expected = next(i for i, d in enumerate(one_by_one) if d <= 1e-6)
    assert first_verified(rep, member, tries, 1e-6) == (expected, one_by_one[expected])
    assert tries[expected] is right
    assert first_verified(rep, member, [m for m in tries if m is not right], 1e-6) is None


@pytest.mark.parametrize("position", range(2 * TRIES_AT_ONCE + 3))
def test_the_first_verified_try_is_found_wherever_the_tries_are_cut_into_batches(position):
    # the tries go a few at a time: the valid one at every place, before, on and after a batch's edge, a second
    # valid one (another of the shape's rotations would do as well) after it and a near miss before it; the
    # answer is the index and the bits of verify() one try after another
    verts, _ = segment_mesh(15.0, taper_deg=4.0)
    rotation = Rotation.random(random_state=7).as_matrix()
    rep = make_shape(verts + FAR)
    member = make_shape(verts @ rotation.T + FAR + 5.0)
    right = match(rep, member, 1e-6)
    near_miss = Match(right.rotation, 1.0, right.translation + [2e-6, 0.0, 0.0], 0.0, False)
    tries = [Match(Rotation.random(random_state=20 + k).as_matrix(), 1.0, right.translation, 0.0, False)
             for k in range(2 * TRIES_AT_ONCE + 3)]
    tries[position] = right
    if position > 0:
        tries[position - 1] = near_miss
    later = Match(right.rotation.copy(), 1.0, right.translation.copy(), 0.0, False)  # the same fit, other arrays
    tries.append(later)
    one_by_one = [verify(rep, member, m, 1e-6) for m in tries]
    assert next(i for i, d in enumerate(one_by_one) if d <= 1e-6) == position
    assert first_verified(rep, member, tries, 1e-6) == (position, one_by_one[position])
    assert first_verified(rep, member, tries[position + 1:], 1e-6) == (len(tries) - position - 2, one_by_one[-1])


def test_stacked_matmul_gives_each_matrix_the_bits_of_its_own_product():
    # what first_verified relies on: np.matmul over a stack calls the same kernel per matrix as '@'
    rng = np.random.default_rng(3)
    local = rng.normal(size=(148, 3)) * 7.0
    centre = FAR + rng.normal(size=3)
    scaled = np.stack([Rotation.random(random_state=k).as_matrix() * 1.001 for k in range(40)])
    stacked, offsets = np.matmul(local, scaled.transpose(0, 2, 1)), np.matmul(scaled, centre)
    for k, x in enumerate(scaled):
        assert np.array_equal(stacked[k], local @ x.T) and np.array_equal(offsets[k], x @ centre)


def test_the_refinements_first_steps_found_together_are_each_rotations_own():
    verts, _ = segment_mesh(15.0, taper_deg=4.0)
    rep, member = make_shape(verts + FAR), make_shape(verts @ Rotation.random(random_state=5).as_matrix().T + FAR)
    rotations = [Rotation.random(random_state=k).as_matrix() for k in range(6)]
    for r, (dist, idx) in zip(rotations, first_steps(rep.local, member, rotations), strict=True):
        own_dist, own_idx = member.tree.query(rep.local @ r.T + np.zeros(3), k=1)
        assert np.array_equal(dist, own_dist) and np.array_equal(idx, own_idx)
    assert first_steps(rep.local, member, []) == []


def test_placements_evaluated_once_per_set_of_values_are_the_librarys_bit_for_bit():
    """``sharing.Placements`` works an IfcAxis2Placement3D out once per set of values (the tunnel's products each
    have a placement of their own, with the same values): every product's matrix is still the one
    ``ifcopenshell.util.placement`` computes, bit for bit, a -0.0 told from a 0.0."""
    model = tunnel_file(3, "IFC4")
    products = [p for p in model.by_type("IfcProduct") if p.ObjectPlacement is not None]
    twin, other = products[0].ObjectPlacement.RelativePlacement, products[1].ObjectPlacement.RelativePlacement
    other.Location = model.create_entity("IfcCartesianPoint", [-0.0 if v == 0 else v for v in twin.Location.Coordinates])
    other.Axis = model.create_entity("IfcDirection", twin.Axis.DirectionRatios if twin.Axis else (0.0, 0.0, 1.0))
    other.RefDirection = model.create_entity("IfcDirection", [0.0, -1.0, 0.0])
    placements = Placements()
    for product in products:
        ours = placements.of(product)
        library = np.asarray(ifcopenshell.util.placement.get_local_placement(product.ObjectPlacement), dtype=float)
        assert ours.tobytes() == library.tobytes(), product
    assert len(placements._axes) < len(products)  # most placements hold values seen before
