"""Bend pruning and model selection helpers (beyond the paper) and the LM solver."""

import numpy as np

from plantsolve.solvers.tube import fit, prune
from plantsolve.solvers.tube.model import build_spine, sample_centreline, spine_distance
from plantsolve.solvers.tube.synthetic import make_model


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
    fun = lambda x: np.array([x[0] - 3.0, x[1] + 2.0])  # noqa: E731
    jac = lambda x: np.eye(2)  # noqa: E731
    x, info = fit.levenberg_marquardt(fun, jac, np.array([0.0, 1.0]), np.array([-np.inf, 0.0]),
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
