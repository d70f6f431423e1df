"""A large scan's least-squares round sorts its samples by segment, so nearly every block of 65,536 holds one
segment's samples only: such a block takes that segment's geometry as one broadcast column, not a copy repeated
for every sample, and gets the numbers of the repeated copy to the bit (elementwise operations)."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.synthetic import make_model, surface_samples


@pytest.mark.parametrize("arc", [False, True])
def test_one_segments_geometry_broadcast_gives_the_repeated_copys_numbers(arc):
    rng = np.random.default_rng(11)
    n = 4000
    q = rng.normal(scale=30.0, size=(3, n))
    g = rng.normal(size=7)
    g[3:6] /= np.linalg.norm(g[3:6])
    g[6] = 12.5 if arc else 0.0
    column = g[:, None]
    d_b, t_b = fit._sample_distance(q, column, arc, arc)
    d_r, t_r = fit._sample_distance(q, np.repeat(column, n, axis=1), np.full(n, arc), arc)
    assert np.array_equal(d_b, d_r)
    out_b, out_r = np.empty((7, n)), np.empty((7, n))
    fit._sample_gradient(t_b, out_b)
    fit._sample_gradient(t_r, out_r)
    assert np.array_equal(out_b, out_r) and np.array_equal(np.signbit(out_b), np.signbit(out_r))
    # and the distance is the formula's: perpendicular to the line, or to the circle's rim
    s = (q - g[:3, None]).T @ g[3:6]
    rho = np.linalg.norm(q - g[:3, None] - s * g[3:6, None], axis=0)
    np.testing.assert_allclose(d_b, np.hypot(rho - g[6], s) if arc else rho, rtol=1e-12, atol=1e-12)


def test_a_streamed_rounds_blocks_of_one_segment_repeat_no_geometry(monkeypatch):
    rng = np.random.default_rng(7)
    m = make_model([[30, 0, 40, 10], [12, 70, 100, 9], [20, -30, 15, 12], [25, 0, 0, 0]], 2.0)
    pts = surface_samples(m, 8 * fit.BLOCK + 300, rng, noise=0.02, outlier_fraction=0.01)
    _, seg = fit.assign(m, pts, 4.0)
    lay = fit.Layout(m.n_bends, "free", None, True)
    x0, _, _, fun, normal_equations, _, _, cost = fit._problem(m, pts, seg, lay, None, 0.04, 6)
    assert cost is not None  # more than one block: streamed
    # blocks of 65,536 samples sorted by segment: how many of them hold more than one segment's samples
    bounds = np.r_[0, np.cumsum(np.bincount(seg, minlength=2 * m.n_bends + 1))]
    mixed = sum(bool(((bounds > a) & (bounds < min(a + fit.BLOCK, len(pts)))).any())
                for a in range(0, len(pts), fit.BLOCK))
    n_blocks = -(-len(pts) // fit.BLOCK)
    assert mixed < n_blocks
    repeats = []
    real_repeat = np.repeat

    def counting(a, *args, **kw):
        if np.ndim(a) == 2:  # a segment geometry's (7, S) columns repeated per sample
            repeats.append(np.shape(a))
        return real_repeat(a, *args, **kw)

    monkeypatch.setattr(fit.np, "repeat", counting)
    first = cost(x0)
    assert len(repeats) == mixed  # the mixed blocks only
    monkeypatch.setattr(fit.np, "repeat", real_repeat)
    # the cost is the soft-L1 cost of the residuals over all samples to the bit
    r = fun(x0)
    assert first == fit._soft_l1(r, 0.04)[0]


def test_a_lines_gradient_is_the_negated_products_to_the_bit_zeros_signs_too():
    rng = np.random.default_rng(5)
    n = 3000
    q = rng.normal(scale=10.0, size=(3, n))
    g = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0])  # the z axis
    q[:, :50] = 0.0  # samples on the axis: distance 0, gradient terms of zero, whose signs show
    q[2, 50:100] = 0.0  # at height 0: s = ±0
    d, terms = fit._sample_distance(q, g[:, None], False, False)
    out = np.empty((7, n))
    fit._sample_gradient(terms, out)
    _, s, perp, rho, _, _, _, _ = terms
    e = perp / np.maximum(rho, 1e-300)
    expected = np.vstack([-e, -(s * e), np.zeros((1, n))])
    assert np.array_equal(out, expected) and np.array_equal(np.signbit(out), np.signbit(expected))
    np.testing.assert_allclose(d, np.hypot(q[0], q[1]), rtol=1e-15)
