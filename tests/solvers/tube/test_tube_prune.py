"""Bend pruning and model selection helpers (beyond the paper) and the LM solver."""

import numpy as np
import pytest

from plantsolve.solvers.tube import fit, prune
from plantsolve.solvers.tube.model import build_spine, sample_centreline, spine_distance
from plantsolve.solvers.tube.synthetic import make_model, surface_samples


def test_merge_of_coplanar_touching_arcs_is_the_same_curve():
    split = make_model([[30, 0, 40, 10], [0, 0, 50, 10], [20, 0, 0, 0]], 2.0)
    whole = make_model([[30, 0, 90, 10], [20, 0, 0, 0]], 2.0)
    merged = prune.merged(split, 0)
    assert merged.n_bends == 1
    np.testing.assert_allclose(np.degrees(merged.angles), [90.0])
    c, _ = sample_centreline(merged, 0.5)
    d, _ = spine_distance(c, build_spine(whole))
    assert d.max() < 1e-9


def test_removing_a_zero_bend_keeps_the_curve():
    m = make_model([[30, 0, 1e-9, 10], [20, 35, 60, 8], [25, 0, 0, 0]], 2.0)
    r = prune.without_bend(m, 0)
    assert r.n_bends == 1 and abs(r.lengths[0] - 50) < 1e-6
    c, _ = sample_centreline(r, 0.5)
    d, _ = spine_distance(c, build_spine(m))
    assert d.max() < 1e-6


def test_candidates_and_selection_prefer_fewer_bends():
    m = make_model([[30, 0, 40, 10], [0, 10, 50, 10], [20, 0, 0, 0]], 2.0)
    kinds = [(k, i) for k, i, _ in prune.candidates(m, 0.1)]
    assert ("merge", 0) in kinds
    res_good = np.random.default_rng(0).normal(0, 0.01, 1000)
    fitted = [(0.1, m, res_good * 1.01), (0.2, prune.merged(m, 0), res_good), (0.3, m, res_good * 3)]
    assert prune.select(fitted, 2.0) == 1


def test_levenberg_marquardt_with_active_bound():
    # minimise (x0 − 3)² + (x1 + 2)² with x1 ≥ 0: the solution sits on the bound
    fun = lambda x, out=None: np.array([x[0] - 3.0, x[1] + 2.0])  # noqa: E731
    normal_equations = lambda x, w, r: (np.diag(w), w * r)  # noqa: E731  (J = identity)
    x, info = fit.levenberg_marquardt(fun, normal_equations, np.array([0.0, 1.0]), np.array([-np.inf, 0.0]),
                                      np.array([np.inf, np.inf]), f_scale=10.0)
    np.testing.assert_allclose(x, [3.0, 0.0], atol=1e-8)
    assert info["success"]


def test_geometry_batch_matches_forward_kinematics():
    m = make_model([[30, 0, 40, 10], [12, 70, 200, 9], [20, -30, 15, 12], [25, 0, 0, 0]], 2.0)
    for mode in ("free", "common", "fixed"):
        lay = fit.Layout(m.n_bends, mode, 10.0, True)
        x = fit.pack(m, lay)
        g1 = fit._geometry(fit.unpack(x, lay, m.frame, 2.0))
        g2 = fit.geometry_batch(x[None], lay, m.frame, 2.0)[0]
        np.testing.assert_allclose(g1, g2, atol=1e-12)


@pytest.mark.parametrize("rows", [
    [[30, 0, 40, 10], [12, 70, 200, 9], [20, -30, 15, 12], [25, 0, 0, 0]],
    [[30, 0, 40, 10], [25, 0, 0, 0]],
    [[30, 0, 0, 0]],
], ids=["3 bends", "1 bend", "straight"])
def test_jacobian_batch_gives_the_central_differences_of_the_whole_batch_to_the_bit(rows):
    # the plan's batch takes a row's start frame and its products before the first bend its parameter moves from
    # row 0 (they are row 0's numbers): the geometry and central differences are those of the plain batch x,
    # x + diag(steps), x - diag(steps), computed for every row, to the last bit, in every radius layout
    m = make_model(rows, 2.0)
    rng = np.random.default_rng(7)
    n = m.n_bends
    layouts = [fit.Layout(n, "free", None, True), fit.Layout(n, "common", None, False),
               fit.Layout(n, "fixed", 10.0, True), fit.Layout(n, "fixed", None, True, (), (9.0,) * n)]
    if n > 1:
        layouts.append(fit.Layout(n, "dies", None, True, (1, 0, 1)))
    for lay in layouts:
        x = fit.pack(m, lay)
        for turn in (0.0, 1e-4, 0.3):  # the start frame's rotation vector: none, on the Taylor branch, beyond
            x = x + rng.normal(scale=1e-3, size=len(x))
            x[3:6] = turn * np.array([0.6, -0.8, 0.3])
            steps = fit._steps(len(x), lay, 2.0)
            P = len(x)
            G = fit.geometry_batch(np.concatenate([x[None], x + np.diag(steps), x - np.diag(steps)]), lay, m.frame,
                                   2.0)
            dG = ((G[1:P + 1] - G[P + 1:]) / (2 * steps[:, None, None])).transpose(1, 2, 0)
            g2, dG2 = fit.geometry_and_jacobian(x, lay, m.frame, 2.0, fit.jacobian_batch(lay, steps))
            assert np.array_equal(g2, G[0]) and np.array_equal(dG2, dG)
            assert np.array_equal(np.signbit(dG2), np.signbit(dG))


def test_rotation_matrices_of_rotation_vectors_are_scipys_small_and_large_angles_in_one_batch():
    """Rodrigues' formula with the Taylor coefficients below 1e-3 rad (a Jacobian step's 1e-6 rad) and the closed
    form above, in one batch and in batches of small angles only, against scipy's rotation vectors."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(4)
    directions = rng.normal(size=(40, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    angles = np.concatenate([[0.0, 1e-9, 1e-6, 9.9e-4, 1.01e-3], rng.uniform(0.01, 3.1, 35)])
    V = directions * angles[:, None]
    for batch in (V, V[:5], V[5:]):
        np.testing.assert_allclose(fit.rotvec_matrices(batch), Rotation.from_rotvec(batch).as_matrix(), rtol=0,
                                   atol=1e-15)


def test_merge_folds_the_dropped_rotation_into_the_next_bend():
    m = make_model([[30, 0, 40, 10], [0, 10, 50, 10], [20, 25, 30, 8], [20, 0, 0, 0]], 2.0)
    mm = prune.merged(m, 0)
    assert mm.n_bends == 2
    np.testing.assert_allclose(np.degrees(mm.rotations), [0, 35, 0], atol=1e-12)


def test_off_die_bends_are_the_ones_far_from_the_others_radius():
    m = make_model([[30, 0, 40, 12], [20, 10, 0.2, 4000], [0.5, 0, 3, 1.5], [20, 30, 60, 13], [25, 0, 0, 0]], 2.0)
    assert prune.off_die(m) == [1, 2]
    kinds = {(kind, k) for kind, k, _ in prune.recheck_candidates(m, 0.1)}
    # both slivers can go, and they touch each other (0.25 r of straight between): merged once
    assert kinds == {("remove", 1), ("remove", 2), ("merge", 1)}


def test_recheck_keeps_a_removal_only_when_bic_is_no_worse():
    m = make_model([[30, 0, 40, 12], [20, 10, 0.2, 4000], [25, 0, 0, 0]], 2.0)
    def refit(cand):
        return cand, "info"

    kept, changes = prune.recheck_by_bic((m, "info"), refit, lambda x: -100.0 * x.n_bends, 0.1)
    assert kept[0].n_bends == 2 and changes == []
    kept, changes = prune.recheck_by_bic((m, "info"), refit, lambda x: 10.0 * x.n_bends, 0.1)
    assert kept[0].n_bends == 1 and changes[0]["change"] == "remove" and changes[0]["bend"] == 2


def test_new_radii_keep_the_control_polygon():
    from plantsolve.solvers.tube.model import control_polygon, with_radii

    m = make_model([[30, 0, 40, 12], [20, 70, 25, 12], [25, -40, 90, 9], [25, 0, 0, 0]], 2.0)
    m2 = with_radii(m, [5.0, 30.0, 11.0])
    np.testing.assert_allclose(m2.radii, [5.0, 30.0, 11.0])
    np.testing.assert_allclose(control_polygon(m2)[0], control_polygon(m)[0], atol=1e-9)


def test_merge_at_the_corner_keeps_the_lines_before_and_after():
    """Two coplanar arcs with a straight between become one arc tangent to the outer straights: the tube
    after them stays where it was (the corner where those straights meet is the merged bend's)."""
    from plantsolve.solvers.tube.model import control_polygon

    pair = make_model([[30, 0, 2.5, 10], [6, 0, 2.3, 100], [20, 40, 60, 12], [25, 0, 0, 0]], 2.0)
    one = prune.merged_at_corner(pair, 0)
    assert one.n_bends == 2
    np.testing.assert_allclose(np.degrees(one.angles), [4.8, 60.0], atol=1e-9)
    np.testing.assert_allclose(control_polygon(one)[0][[0, 2, 3]], control_polygon(pair)[0][[0, 3, 4]], atol=1e-9)


def _seven_on_one_die(gap_rp: float):
    """A 4.8 degree bend of the die cut in two (2.7 + 2.1 degrees, the die's radius, ``gap_rp`` pipe radii of
    straight between, 20 degrees of rotation), between large bends on the same die (pipe radius 20, die 60)."""
    return make_model([[120, 0, 2.7, 60], [gap_rp * 20, 20, 2.1, 60], [130, 50, 72, 60], [170, -85, 64, 60],
                       [120, 0, 0, 0]], 20.0)


def test_adjacent_small_bends_on_one_die_are_merge_candidates():
    """Both halves near the die, so neither is off-die: only the pair rule makes them a candidate."""
    m = _seven_on_one_die(0.3)
    assert prune.off_die(m) == []
    assert prune.adjacent_small_pairs(m, 0.1) == [0]
    assert [(kind, k) for kind, k, _ in prune.pair_merge_candidates(m, 0.1)] == [("merge", 0)]
    assert ("merge", 0) in {(kind, k) for kind, k, _ in prune.recheck_candidates(m, 0.1)}
    # a straight of 3 pipe radii between them: two bends (the family's smallest straight), not a split
    assert prune.adjacent_small_pairs(_seven_on_one_die(3.0), 0.1) == []
    # a large bend next to a small one is no pair, nor are two small bends far off each other's radius
    big = make_model([[120, 0, 2.7, 60], [6, 20, 30, 60], [130, 50, 72, 60], [120, 0, 0, 0]], 20.0)
    assert prune.adjacent_small_pairs(big, 0.1) == []
    apart = make_model([[120, 0, 2.7, 60], [6, 20, 2.1, 400], [130, 50, 72, 60], [170, -85, 64, 60],
                        [120, 0, 0, 0]], 20.0)
    assert prune.adjacent_small_pairs(apart, 0.1) == []


def test_merging_the_halves_of_a_split_bend_gives_the_bend_back():
    """A bend split in its plane with no straight between the halves (``prune.split``), merged at the corner:
    the same angle, radius and centreline, the tube after it unmoved."""
    one = make_model([[120, 0, 4.8, 60], [130, 50, 72, 60], [170, -85, 64, 60], [120, 0, 0, 0]], 20.0)
    two = prune.split(one, 0, 0.57, 60.0, 0.0)
    assert two.n_bends == 4 and prune.adjacent_small_pairs(two, 0.1) == [0]
    (_, _, back), = prune.pair_merge_candidates(two, 0.1)
    np.testing.assert_allclose(np.degrees(back.angles), np.degrees(one.angles), atol=1e-9)
    np.testing.assert_allclose(back.radii, one.radii, atol=1e-9)
    d, _ = spine_distance(sample_centreline(one, 1.0)[0], build_spine(back))
    assert d.max() < 1e-6


def test_recheck_runs_on_the_given_candidates_and_keeps_a_merge_only_when_bic_is_no_worse():
    m = _seven_on_one_die(0.3)

    def refit(cand):
        return cand, "info"

    kept, changes = prune.recheck_by_bic((m, "info"), refit, lambda x: 10.0 * x.n_bends, 0.1,
                                         candidates=prune.pair_merge_candidates)
    assert kept[0].n_bends == 3 and changes[0]["change"] == "merge" and changes[0]["bend"] == 1
    # one arc turning the tube from the straight before the pair to the one after it
    sp = build_spine(m)
    turn = np.degrees(np.arccos(sp.tangent[0] @ sp.tangent[4]))
    assert 4.7 < turn < 4.8
    np.testing.assert_allclose(np.degrees(kept[0].angles[0]), turn, atol=1e-4)  # the outer lines are skew
    kept, changes = prune.recheck_by_bic((m, "info"), refit, lambda x: -10.0 * x.n_bends, 0.1,
                                         candidates=prune.pair_merge_candidates)
    assert kept[0].n_bends == 4 and changes == []


def test_nearest_die_in_log_radius():
    assert prune.nearest_die([58.0, 61.0, 150.0, 95.0], [60.0, 180.0]) == (0, 0, 1, 0)


def test_recheck_with_held_radii_refits_the_merge_on_the_dies_of_its_bends():
    """Two dies (60 and 200): the halves of a 4.8 degree bend of the 60 die are merged, the candidate refitted
    in the 'dies' model with one die per remaining bend (the merged one on the 60 die) and its radii held
    there; kept because the merged arc is the same curve with four parameters fewer."""
    from plantsolve.solvers.tube.synthetic import surface_samples

    one = make_model([[120, 0, 4.8, 60], [130, 50, 72, 200], [170, -85, 64, 60], [120, 0, 0, 0]], 20.0)
    two = prune.split(one, 0, 0.57, 60.0, 0.0)
    pts = surface_samples(one, 3000, np.random.default_rng(4), noise=0.2)
    calls = []

    def rounds(m, P, thr, n_rounds, max_nfev, radius_mode=None, dies=(), fixed_radii=()):
        calls.append((radius_mode, dies, m.radii.copy()))
        return m, {"refit": True}, thr, 0.2

    (kept, info, _, mode), changes = prune.recheck_on_fit(
        (two, {}, 2.0, {"radius_mode": "dies", "dies": (0, 0, 1, 0)}), pts, 2.0, 40.0, True, rounds, 0.1, "dies")
    assert [c["change"] for c in changes] == ["merge"] and kept.n_bends == 3 and info == {"refit": True}
    assert calls[0][:2] == ("dies", (0, 1, 0)) and mode == {"radius_mode": "dies", "dies": (0, 1, 0)}
    np.testing.assert_allclose(calls[0][2], [60.0, 200.0, 60.0])
    d, _ = spine_distance(sample_centreline(one, 1.0)[0], build_spine(kept))
    assert d.max() < 1e-6


@pytest.mark.parametrize("block", [None, 700], ids=["one block", "blocks of 700"])
def test_normal_equations_match_the_dense_jacobian(block, monkeypatch):
    # Jᵀ W J and Jᵀ W r from the per-segment 7 × 7 products equal those of the (N, P) Jacobian built row by row;
    # a scan of more samples than one block (fit.BLOCK) sums them block by block
    if block is not None:
        monkeypatch.setattr(fit, "BLOCK", block)
    rng = np.random.default_rng(4)
    m = make_model([[30, 0, 40, 10], [12, 70, 100, 9], [20, -30, 15, 12], [25, 0, 0, 0]], 2.0)
    pts = surface_samples(m, 3000, rng, noise=0.02)
    _, seg = fit.assign(m, pts, 4.0)
    for mode, fit_rp in (("free", True), ("common", False)):
        lay = fit.Layout(m.n_bends, mode, None, fit_rp)
        x0, _, _, fun, normal_equations, frame0, rp, _ = fit._problem(m, pts, seg, lay)
        r = fun(x0)
        w = rng.uniform(0.2, 1.0, len(r))
        A, b = normal_equations(x0, w, r)
        order = np.argsort(seg, kind="stable")
        groups = fit._groups(seg[order])
        g = fit.geometry_batch(x0[None], lay, frame0, rp)[0]
        kind = fit.build_spine(fit.unpack(x0, lay, frame0, rp)).kind
        _, gr = fit._dist_and_grad(pts[order], groups, g, kind, True)
        dG = fit._geometry_jacobian(x0, lay, frame0, rp, rp)
        J = np.concatenate([gr[sl] @ dG[k] for k, sl in groups])
        if fit_rp:
            J[:, -1] -= 1.0
        np.testing.assert_allclose(A, J.T @ (w[:, None] * J), rtol=1e-10, atol=1e-10 * np.abs(A).max())
        np.testing.assert_allclose(b, J.T @ (w * r), rtol=1e-10, atol=1e-10 * np.abs(b).max())


def test_normal_equations_after_fun_are_those_computed_afresh():
    # the normal equations at the point fun has just evaluated reuse its geometry and distance terms: the same
    # numbers as computed from nothing
    rng = np.random.default_rng(5)
    m = make_model([[30, 0, 40, 10], [12, 70, 100, 9], [20, -30, 15, 12], [25, 0, 0, 0]], 2.0)
    pts = surface_samples(m, 2000, rng, noise=0.02)
    _, seg = fit.assign(m, pts, 4.0)
    lay = fit.Layout(m.n_bends, "free", None, True)
    x0, _, _, fun, normal_equations, _, _, _ = fit._problem(m, pts, seg, lay)
    x1 = x0 + rng.normal(size=len(x0)) * 1e-4
    r = fun(x1)
    w = rng.uniform(0.2, 1.0, len(r))
    A1, b1 = normal_equations(x1, w, r)
    fun(x0)  # the latest evaluation is now another point
    A2, b2 = normal_equations(x1, w, r)
    assert np.array_equal(A1, A2) and np.array_equal(b1, b2)


def _split_trial(gain_of_even_split: float):
    """split_by_evidence on a tube with one 200 degree bend, with a refit that returns the same residuals for
    the model and every candidate except the even split, whose residuals shrink by ``gain_of_even_split``
    times the evidence tolerance; returns the bend fractions of the candidates refitted."""
    m = make_model([[30, 0, 200, 10], [30, 0, 0, 0]], 2.0)
    res = np.random.default_rng(3).normal(0.0, 0.02, 3000)
    tol = prune.evidence_tolerance(len(res))
    tried = []

    def refit(model):
        if model.n_bends == 1:
            return model, res
        frac = round(float(model.angles[0] / (model.angles[0] + model.angles[1])), 2)
        tried.append(frac)
        return model, res / (1 + gain_of_even_split * tol) if frac == 0.5 else res

    model, changes = prune.split_by_evidence(m, refit, 2.0)
    assert model.n_bends == 1 and not changes
    return tried


def test_off_centre_splits_are_tried_only_after_an_even_split_showed_some_gain():
    # the even split of one arc gains nothing: its off-centre splits start no nearer two bends
    assert _split_trial(0.0) == [0.5]
    # a gain short of the evidence but over a quarter of it: 0.4 and 0.6 tried too
    assert _split_trial(0.3) == [0.5, 0.4, 0.6]
    # over half of it: the even split refitted once more first
    assert _split_trial(0.7) == [0.5, 0.5, 0.4, 0.6]
