"""The segment geometry's derivative with respect to the LRA parameters, written out (each parameter moves the
tube from some segment on as one rigid body) instead of central differences of the forward kinematics: the
same derivative, to the differences' own error, in every radius layout and start-frame turn; exact where a
closed form is known."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.synthetic import make_model

ROWS = {
    "3 bends": [[30, 0, 40, 10], [12, 70, 200, 9], [20, -30, 15, 12], [25, 0, 0, 0]],
    "1 bend": [[30, 0, 40, 10], [25, 0, 0, 0]],
    "straight": [[30, 0, 0, 0]],
}


def _central_differences(x: np.ndarray, lay: fit.Layout, frame0: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """(S, 7, P) by Richardson's extrapolation of central differences at h and h/2 (error O(h⁴) + round-off)."""
    def diff(step):
        cols = []
        for p in range(len(x)):
            e = np.zeros(len(x))
            e[p] = step
            cols.append((fit.geometry_batch((x + e)[None], lay, frame0, 2.0)[0]
                         - fit.geometry_batch((x - e)[None], lay, frame0, 2.0)[0]) / (2 * step))
        return np.stack(cols, axis=-1)
    return (4 * diff(h / 2) - diff(h)) / 3


def _layouts(n: int) -> list[fit.Layout]:
    out = [fit.Layout(n, "free", None, True), fit.Layout(n, "common", None, False),
           fit.Layout(n, "fixed", 10.0, True), fit.Layout(n, "fixed", None, True, (), (9.0,) * n)]
    if n > 1:
        out.append(fit.Layout(n, "dies", None, True, (1, 0, 1)))
    return out


@pytest.mark.parametrize("name", list(ROWS))
def test_the_analytic_geometry_jacobian_is_the_derivative_in_every_layout(name):
    m = make_model(ROWS[name], 2.0, start=np.array([40.0, -25.0, 12.0]))
    rng = np.random.default_rng(7)
    for lay in _layouts(m.n_bends):
        x = fit.pack(m, lay)
        for turn in (0.0, 1e-4, 0.3, 2.5):  # the start frame's rotation vector: none, on the Taylor branch, beyond
            x = x + rng.normal(scale=1e-3, size=len(x))
            x[3:6] = turn * np.array([0.6, -0.8, 0.3]) / np.linalg.norm([0.6, -0.8, 0.3])
            g, bends = fit._kinematics(x[None], lay, m.frame)
            J = fit.geometry_jacobian(x, lay, g[0], bends)
            assert J.shape == (2 * m.n_bends + 1, 7, lay.size)
            np.testing.assert_allclose(J, _central_differences(x, lay, m.frame), rtol=0, atol=1e-8)


def test_the_analytic_jacobian_has_the_closed_forms_of_a_bend():
    # a 90-degree bend of radius 10 in the x-y plane from the origin along x: the arc's centre moves with the radius
    # along the normal (0, 1, 0), the straight after it (start (10, 10, 0), tangent (0, 1, 0)) with the arc end;
    # turning the bend by its angle swings that straight about the axis through the centre (0, 10, 0)
    m = make_model([[0.0, 0, 90, 10], [5.0, 0, 0, 0]], 2.0)
    lay = fit.Layout(1, "free", None, False)
    x = fit.pack(m, lay)
    g, bends = fit._kinematics(x[None], lay, m.frame)
    J = fit.geometry_jacobian(x, lay, g[0], bends)
    angle, radius = 6, 7
    axis = g[0][1, 3:6]
    assert abs(abs(axis[2]) - 1.0) < 1e-15
    centre, start = g[0][1, :3], g[0][2, :3]
    np.testing.assert_allclose(J[1, :3, radius], bends.normal[0], rtol=0, atol=1e-15)
    assert J[1, 6, radius] == 1.0 and J[2, 6, radius] == 0.0
    np.testing.assert_allclose(J[2, :3, radius], bends.tangent[0] + bends.normal[0],
                               rtol=0, atol=1e-15)  # (sin 90°, 1 - cos 90°) in the turned frame
    np.testing.assert_allclose(J[2, :3, angle], np.cross(axis, start - centre), rtol=0, atol=1e-14)
    np.testing.assert_allclose(J[2, 3:6, angle], np.cross(axis, g[0][2, 3:6]), rtol=0, atol=1e-15)
    assert not J[:2, :, angle].any()  # the arc, as an unbounded circle, does not move with its angle
