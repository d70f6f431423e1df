"""Per-sample distances to lines and circles and their gradients (the least-squares residuals)."""

import numpy as np

from plantsolve.solvers.tube import residuals
from plantsolve.solvers.tube.vec3 import rotvec_matrices


def _rows(rng, n):
    """Random line and circle rows [point/centre, unit tangent/axis, radius (0 for lines)] and samples near them."""
    a = rng.normal(size=(n, 3))
    a /= np.linalg.norm(a, axis=1)[:, None]
    arc = rng.random(n) < 0.5
    gs = np.column_stack([rng.normal(size=(n, 3)), a, np.where(arc, rng.uniform(1, 5, n), 0.0)])
    return gs, arc, rng.normal(scale=4.0, size=(n, 3))


def test_distances_match_the_closed_forms():
    rng = np.random.default_rng(0)
    gs, arc, q = _rows(rng, 200)
    got = residuals.Distances(q, gs, arc).distance
    w = q - gs[:, :3]
    s = np.einsum("nk,nk->n", w, gs[:, 3:6])
    rho = np.linalg.norm(w - s[:, None] * gs[:, 3:6], axis=1)
    # a circle: the nearest point of the circle is at radius R in the plane through the sample's axial offset
    np.testing.assert_allclose(got, np.where(arc, np.sqrt((rho - gs[:, 6]) ** 2 + s ** 2), rho), rtol=1e-13)


def test_gradients_match_central_differences():
    rng = np.random.default_rng(1)
    gs, arc, q = _rows(rng, 100)
    grad = residuals.Distances(q, gs, arc).gradient()
    h = 1e-6
    for k in range(7):
        if k == 6:
            step = np.where(arc, h, 0.0)  # a line has no radius
        else:
            step = np.full(len(q), h)
        up, dn = gs.copy(), gs.copy()
        up[:, k] += step
        dn[:, k] -= step
        fd = (residuals.Distances(q, up, arc).distance - residuals.Distances(q, dn, arc).distance) / (2 * h)
        np.testing.assert_allclose(grad[:, k], np.where(step > 0, fd, 0.0), atol=1e-7)


def test_blocks_cover_the_samples_in_runs_of_one_segment():
    seg = np.sort(np.random.default_rng(2).integers(0, 5, 1000))
    parts = residuals.blocks(seg, block=256)
    assert [b.start for b, _ in parts] == [0, 256, 512, 768]
    for b, runs in parts:
        for k, m in runs:
            assert (seg[b][m] == k).all()
        assert sum(m.stop - m.start for _, m in runs) == b.stop - b.start


def test_rotvec_matrices_are_rotations_about_the_vector():
    rng = np.random.default_rng(3)
    for scale in (0.0, 1e-9, 1e-4, 1.0, 3.0):
        v = rng.normal(size=(20, 3)) * scale
        R = rotvec_matrices(v)
        np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape), atol=1e-15)
        np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
        np.testing.assert_allclose(np.einsum("bij,bj->bi", R, v), v, atol=1e-15)  # the axis stays
        th = np.linalg.norm(v, axis=1)
        np.testing.assert_allclose((np.trace(R, axis1=1, axis2=2) - 1) / 2, np.cos(th), atol=1e-15)
