"""Shortcuts of the large-scan and hot paths give what the plain computations give."""

import numpy as np

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
