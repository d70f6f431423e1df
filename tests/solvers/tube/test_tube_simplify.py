"""§4.5 polygon simplification against a brute-force shortest path over every shortcut."""

import numpy as np
import pytest

from plantsolve.solvers.tube import curve
from plantsolve.solvers.tube.vec3 import cross


def _seg_dist(p, a, b):
    ab = b - a
    t = np.clip((p - a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - a - t[:, None] * ab, axis=1)


def _shortcuts(poly, eps):
    """Every shortcut i → j whose skipped vertices lie within eps of it, with its squared error."""
    n = len(poly)
    out = {}
    for i in range(n - 1):
        for j in range(i + 1, n):
            d = _seg_dist(poly[i + 1:j], poly[i], poly[j])
            if d.size == 0 or d.max() <= eps:
                out[i, j] = float(d @ d)
    return out


def _brute_force(poly, eps):
    """Fewest vertices, then least summed squared error, by dynamic programming over all shortcuts."""
    n = len(poly)
    cuts = _shortcuts(poly, eps)
    best = [(0, 0.0)] + [(np.inf, np.inf)] * (n - 1)
    for j in range(1, n):
        best[j] = min((best[i][0] + 1, best[i][1] + c) for (i, jj), c in cuts.items() if jj == j)
    return best[-1]


def _noisy_curve(rng, n):
    t = np.linspace(0.0, rng.uniform(2.0, 9.0), n)
    bend = np.column_stack([np.cos(t) * 10, np.sin(0.7 * t) * 10, np.where(t > 4, 3 * (t - 4), 0.0)])
    return bend + rng.normal(scale=rng.uniform(0.001, 0.1), size=(n, 3))


@pytest.mark.parametrize("seed", range(6))
def test_simplify_is_the_fewest_vertex_least_error_polygon(seed):
    rng = np.random.default_rng(seed)
    poly = _noisy_curve(rng, int(rng.integers(20, 70)))
    eps = float(rng.uniform(0.05, 1.0))
    got = curve.simplify(poly, eps)
    idx = [int(np.flatnonzero((poly == v).all(1))[0]) for v in got]
    assert idx[0] == 0 and idx[-1] == len(poly) - 1
    cuts = _shortcuts(poly, eps)
    assert all((a, b) in cuts for a, b in zip(idx, idx[1:]))  # every kept segment within ε
    count, sse = _brute_force(poly, eps)
    assert len(idx) - 1 == count
    assert sum(cuts[a, b] for a, b in zip(idx, idx[1:])) == pytest.approx(sse, rel=1e-12, abs=1e-300)


def _reach(poly, i, eps):
    """The reach of one vertex, written for it alone (the reference of curve._reaches): the last vertex j that a
    shortcut i → j may reach.

    A skipped vertex k at distance r_k > ε from p_i is within ε of the segment only if the segment's
    direction is within α_k = asin(ε / r_k) of the direction u_k to it (the segment lies on the ray from
    p_i, and the ray's distance is r_k sin θ, or r_k beyond 90°). Once the cone of a vertex K and that of
    the narrowest cone before it are disjoint (angle between the axes beyond the sum of the half-angles),
    no direction serves both, so no shortcut that skips both, i.e. none to a j > K, is within ε."""
    rel = poly[i + 1:] - poly[i]
    r = np.sqrt((rel * rel).sum(1))
    far = r > eps
    u = rel / np.where(far, r, 1.0)[:, None]
    alpha = np.where(far, np.arcsin(np.minimum(eps / np.where(far, r, 1.0), 1.0)), np.pi)
    k = np.arange(len(r))
    narrowest = np.maximum.accumulate(np.where(alpha <= np.minimum.accumulate(alpha), k, 0))
    ur = u[narrowest]
    between = np.arctan2(np.sqrt((cross(ur, u) ** 2).sum(1)), (ur * u).sum(1))
    apart = np.flatnonzero(between > alpha[narrowest] + alpha + curve.CONE_MARGIN)
    return i + 1 + int(apart[0]) if len(apart) else len(poly) - 1


@pytest.mark.parametrize("seed", range(4))
def test_reach_never_cuts_a_shortcut_within_eps(seed):
    rng = np.random.default_rng(100 + seed)
    poly = _noisy_curve(rng, 60)
    for eps in (0.02, 0.3, 2.0):
        cuts = _shortcuts(poly, eps)
        for i in range(len(poly) - 1):
            reach = _reach(poly, i, eps)
            assert max(j for a, j in cuts if a == i) <= reach
        # the bound prunes: on a curved stretch a vertex cannot see to the far end
        assert _reach(poly, 0, 0.02) < len(poly) - 1


@pytest.mark.parametrize("block", [1, 500, 200_000])
def test_reaches_of_all_vertices_are_each_vertex_reach(block):
    rng = np.random.default_rng(7)
    poly = _noisy_curve(rng, 70)
    for eps in (0.02, 0.3, 2.0):
        want = [_reach(poly, i, eps) for i in range(len(poly) - 1)]
        assert curve._reaches(poly, eps, block=block).tolist() == want


def test_shortcut_rows_in_blocks_match_one_block():
    rng = np.random.default_rng(8)
    poly = _noisy_curve(rng, 50)
    first = np.arange(1, 50)
    count = np.minimum(np.full(49, 12), 50 - first)
    m1, s1 = curve._shortcut_rows(poly, first, count)
    m2, s2 = curve._shortcut_rows(poly, first, count, block=1)
    cuts = _shortcuts(poly, np.inf)  # every shortcut, with its squared error
    for i in range(49):
        assert np.array_equal(m1[i], m2[i]) and np.array_equal(s1[i], s2[i])
        for a, j in enumerate(range(i + 1, i + 1 + count[i])):
            assert s1[i][a] == pytest.approx(cuts[i, j], rel=1e-12, abs=1e-300)
            assert m1[i][a] == pytest.approx(_seg_dist(poly[i + 1:j], poly[i], poly[j]).max(initial=0.0), rel=1e-12)


def test_simplify_with_several_tolerances_on_one_polygon_is_each_ones_answer():
    """The shortcut rows kept from one tolerance serve the next (smaller or larger) one."""
    rng = np.random.default_rng(9)
    poly = _noisy_curve(rng, 60)
    shared = curve.Shortcuts(poly)
    for eps in (0.1, 0.25, 0.05, 0.6, 0.1):
        got = curve.simplify(poly, eps, shared)
        assert np.array_equal(got, curve.simplify(poly, eps))  # the same as computed afresh
        idx = [int(np.flatnonzero((poly == v).all(1))[0]) for v in got]
        cuts = _shortcuts(poly, eps)
        count, sse = _brute_force(poly, eps)
        assert len(idx) - 1 == count
        assert sum(cuts[a, b] for a, b in zip(idx, idx[1:])) == pytest.approx(sse, rel=1e-12, abs=1e-300)
