"""Shortcuts of the large-scan and hot paths give what the plain computations give."""

import numpy as np
import pytest

from plantsolve.solvers import geometry
from plantsolve.solvers.tube import fit, sample_order, vec3
from plantsolve.solvers.tube.synthetic import make_model, surface_samples


def test_canonical_order_is_lexsort_with_ties():
    rng = np.random.default_rng(2)
    pts = np.round(rng.normal(size=(5000, 3)), 1)  # many equal x, some equal rows
    pts[::7, 0] = -0.0  # -0.0 and 0.0 are equal keys
    np.testing.assert_array_equal(sample_order.lexicographic(pts), np.lexsort(pts.T[::-1]))
    pts = rng.normal(size=(2000, 3))  # no ties
    np.testing.assert_array_equal(sample_order.lexicographic(pts), np.lexsort(pts.T[::-1]))
    # x that differ only in their last bits share the sort key's high bits (its low bits hold the position):
    # those runs are sorted again by the full x
    pts = rng.normal(size=(5000, 3))
    pts[:, 0] = 1000.0 + rng.integers(0, 5, len(pts)) * 1e-12
    pts[::11, 0] = np.nextafter(pts[::11, 0], np.inf)
    np.testing.assert_array_equal(sample_order.lexicographic(pts), np.lexsort(pts.T[::-1]))
    pts[:, 0] = -pts[:, 0]  # the same among negative x, whose keys are their bits reversed
    np.testing.assert_array_equal(sample_order.lexicographic(pts), np.lexsort(pts.T[::-1]))


def test_cross_and_rotation_are_numpys_bit_for_bit():
    rng = np.random.default_rng(5)
    for _ in range(200):
        a, b = rng.normal(size=3) * 10.0 ** rng.uniform(-4, 4, 3), rng.normal(size=3)
        np.testing.assert_array_equal(vec3.cross(a, b), np.cross(a, b))
        axis, angle = b / np.linalg.norm(b), np.float64(rng.uniform(-7, 7))
        np.testing.assert_array_equal(vec3.rotate_about(a, axis, angle), geometry.rotate_about(a, axis, angle))
    A, B = rng.normal(size=(100, 3)), rng.normal(size=(100, 3))
    np.testing.assert_array_equal(vec3.cross(A, B), np.cross(A, B))


def test_end_lengths_from_the_samples_at_the_ends_match_all_samples():
    # a fit whose straights are too short: the ends found from the outer segments' samples alone are those
    # found from every sample
    rng = np.random.default_rng(8)
    truth = make_model([[40, 0, 60, 12], [20, 45, 80, 12], [15, -30, 30, 12], [35, 0, 0, 0]], 3.0)
    pts = surface_samples(truth, 20000, rng, noise=0.03)
    short = truth.copy()
    short.start = short.start + 9.0 * short.frame[:, 0]
    short.lengths = short.lengths.copy()
    short.lengths[[0, -1]] -= 9.0
    res, seg = fit.assign(short, pts, 6.0)
    full, _, _, settled = fit.end_lengths(short, pts, res, seg, 0.5, 6.0)
    ends = fit.near_ends(short, seg)
    part, _, _, settled_part = fit.end_lengths(short, pts[ends], res[ends], seg[ends], 0.5, 6.0)
    assert settled and settled_part and len(ends) < len(pts)
    np.testing.assert_allclose(part.lengths, full.lengths, rtol=0, atol=1e-12)
    np.testing.assert_allclose(part.start, full.start, rtol=0, atol=1e-12)
    np.testing.assert_allclose(full.lengths[[0, -1]], truth.lengths[[0, -1]], atol=0.3)


@pytest.mark.parametrize("by_reach", [False, True])
def test_sums_of_squares_of_held_radii_are_those_of_whole_assignments(by_reach, monkeypatch):
    # the secant test's models (a bend's radius held at half or twice, the control polygon kept) share the fitted
    # model's distances to the segments they do not move; the sums are those of assigning every sample to each
    # model, also where doubling the first or the second bend's radius clips the 3 mm straight between them to 0
    # and moves everything beyond; a large scan's way (the moved segments measured only on samples within their
    # reach) gives them too
    from plantsolve.solvers.tube.model import with_radii

    if by_reach:
        monkeypatch.setattr(fit, "SUMS_BY_REACH", 0)

    rng = np.random.default_rng(4)
    model = make_model([[40, 0, 60, 12], [3, 45, 80, 12], [25, -30, 30, 12], [35, 0, 0, 0]], 3.0)
    pts = surface_samples(model, 30000, rng, noise=0.03, outlier_fraction=0.01)
    keep = rng.random(len(pts)) < 0.9
    variants = []
    for k in range(3):
        for f in (0.5, 2.0):
            radii = model.radii.copy()
            radii[k] *= f
            variants.append(with_radii(model, radii))
    assert variants[1].lengths[1] == 0.0 and variants[3].lengths[1] == 0.0
    rss0, rss = fit.sums_of_squares(model, variants, pts, keep)
    for m, got in zip([model] + variants, [rss0] + rss):
        r = fit.assign(m, pts[keep], 0.0)[0]
        np.testing.assert_allclose(got, float(r @ r), rtol=1e-12)


def _scan_problem(n_samples: int):
    rng = np.random.default_rng(6)
    truth = make_model([[40, 0, 60, 12], [20, 45, 80, 12], [35, 0, 0, 0]], 3.0)
    pts = surface_samples(truth, n_samples, rng, noise=0.03, outlier_fraction=0.01)
    start = truth.copy()
    start.angles = start.angles + 0.02
    res, seg = fit.assign(start, pts, 6.0)
    return start, pts, res, seg, np.abs(res) <= 1.0, fit.Layout(2, "free", None, True)


def test_a_round_on_the_samples_a_mask_keeps_is_the_round_on_their_copy_bit_for_bit():
    # more samples than one block of the normal equations: the large-scan path
    m, pts, _, seg, keep, lay = _scan_problem(2 * fit.BLOCK)
    x0, _, _, fun, normal_equations, _, _, _ = fit._problem(m, pts, seg, lay, keep)
    y0, _, _, fun_c, normal_equations_c, _, _, _ = fit._problem(m, pts[keep], seg[keep], lay)
    np.testing.assert_array_equal(x0, y0)
    r, r_c = fun(x0), fun_c(x0)
    np.testing.assert_array_equal(r, r_c)
    w = 1.0 / np.sqrt(1.0 + r * r)
    for a, b in zip(normal_equations(x0, w, r), normal_equations_c(x0, w, r)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(fit.set_end_lengths(m, pts, seg, keep).lengths,
                                  fit.set_end_lengths(m, pts[keep], seg[keep]).lengths)
    # with the weights' scale given, the cost comes a block at a time with the normal equations summed on the way:
    # the same numbers as from every sample's residuals and weights
    f = 0.06
    _, _, _, _, normal_equations_f, _, _, cost_f = fit._problem(m, pts, seg, lay, keep, f_scale=f)
    x1 = x0 + 1e-4
    r1 = fun(x1)
    cost1, w1 = fit._soft_l1(r1, f)
    assert cost_f(x1) == cost1
    for a, b in zip(normal_equations_f(x1, None, None), normal_equations(x1, w1, r1)):
        np.testing.assert_array_equal(a, b)


def test_levenberg_marquardt_reusing_its_arrays_is_the_one_making_fresh_ones():
    # a trial's residuals and weights go into the arrays of the last rejected trial or the point left behind:
    # the iterates are those of fresh arrays each evaluation
    m, pts, _, seg, keep, lay = _scan_problem(20000)
    x0, lo, hi, fun, normal_equations, _, _, _ = fit._problem(m, pts, seg, lay, keep)
    fresh = lambda x, out=None: fun(x)  # noqa: E731
    xa, info_a = fit.levenberg_marquardt(fun, normal_equations, x0, lo, hi, 0.06, max_nfev=30)
    xb, info_b = fit.levenberg_marquardt(fresh, normal_equations, x0, lo, hi, 0.06, max_nfev=30)
    np.testing.assert_array_equal(xa, xb)
    assert info_a == info_b and info_a["nfev"] > 3


def test_reach_of_moved_segments_bounds_their_distance_from_the_replaced_ones():
    # a quarter arc of radius 10 against one of radius 5 from the same start and tangent: the point of the larger
    # farthest from the smaller is its end, whose nearest point of the smaller arc is that one's end, 5 √2 away
    # (the reach may exceed it by its sampling step, a tenth of the pipe radius)
    from plantsolve.solvers.tube.model import build_spine

    big, small = (build_spine(make_model([[0, 0, 90, r], [0, 0, 0, 0]], 1.0)) for r in (10.0, 5.0))
    moved, replaced = fit._sub_spine(big, np.array([1])), fit._sub_spine(small, np.array([1]))
    reach = fit._reach(moved, replaced, 1.0)
    assert np.hypot(5.0, 5.0) <= reach <= np.hypot(5.0, 5.0) + 0.2


def test_a_large_scans_last_evaluation_sums_no_normal_equations(monkeypatch):
    # the LM forms no normal equations after its last allowed evaluation: a large scan's evaluations sum them,
    # all but that one, and the iterates are those of summing them when the normal equations are asked for
    m, pts, _, seg, keep, lay = _scan_problem(2 * fit.BLOCK)
    made = []
    gram_sums = fit._gram_sums
    monkeypatch.setattr(fit, "_gram_sums", lambda *a: made.append(a) or gram_sums(*a))
    x0, lo, hi, fun, normal_equations, _, _, cost = fit._problem(m, pts, seg, lay, keep, f_scale=0.06, max_nfev=4)
    x, info = fit.levenberg_marquardt(fun, normal_equations, x0, lo, hi, 0.06, max_nfev=4, cost=cost)
    assert info["nfev"] == 4 and len(made) == 3
    _, _, _, fun_p, normal_equations_p, _, _, _ = fit._problem(m, pts, seg, lay, keep)
    x_p, info_p = fit.levenberg_marquardt(fun_p, normal_equations_p, x0, lo, hi, 0.06, max_nfev=4)
    np.testing.assert_array_equal(x, x_p)
    assert info == info_p
