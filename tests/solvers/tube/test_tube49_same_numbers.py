"""The distance of a sample to its line or circle and its gradient, written in place into scratch rows: the numbers
of the plain expressions, to the last bit (the bench's accuracy columns are the contract of a speed-up)."""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.tube import fit


def _plain(q, gs, arc):
    """The distance and gradient as plain numpy expressions (one fresh array per operation)."""
    c, a, R = gs[:3], gs[3:6], gs[6]
    w = q - c
    s = (w[0] * a[0] + w[2] * a[2]) + w[1] * a[1]
    perp = w - s * a
    rho = np.sqrt((perp[0] * perp[0] + perp[2] * perp[2]) + perp[1] * perp[1])
    dd = rho.copy()
    dd[arc] = np.hypot(rho[arc] - R[arc], s[arc])
    e = perp / np.maximum(rho, 1e-300)
    inv = 1.0 / np.maximum(dd, 1e-300)
    u = np.where(arc, (rho - R) * inv, 1.0)
    v = np.where(arc, s * inv, 0.0)
    grad = np.empty((7, len(rho)))
    grad[:3] = -(u * e + v * a)
    grad[3:6] = v * w - (u * s) * e
    grad[6] = np.where(arc, -u, 0.0)
    return dd, grad


def test_the_in_place_distance_and_gradient_are_the_plain_expressions_to_the_bit():
    rng = np.random.default_rng(49)
    n = 2000
    q = rng.normal(scale=50.0, size=(3, n))
    gs = rng.normal(scale=20.0, size=(7, n))
    gs[3:6] /= np.linalg.norm(gs[3:6], axis=0)
    gs[6] = np.abs(gs[6]) + 1.0
    mixed = np.repeat([False, True, False, True, False], [300, 500, 200, 700, 300])
    for arc in (np.zeros(n, bool), np.ones(n, bool), mixed):
        gs_k = gs.copy()
        gs_k[6, ~arc] = 0.0  # a line's radius is 0
        d, terms = fit._sample_distance(q, gs_k, arc)
        grad = np.empty((7, n))
        fit._sample_gradient(terms, grad)
        d_ref, grad_ref = _plain(q, gs_k, arc)
        assert np.array_equal(d, d_ref)
        # (a line's gradient entries equal but for the sign of a zero: -(e + 0 a) against -e)
        assert np.array_equal(grad, grad_ref)
