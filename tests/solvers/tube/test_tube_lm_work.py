"""Work a least-squares round does once: the Jacobian only at the points whose normal equations are formed (a
rejected trial needs its residuals only), the arc samples of a block found once; the numbers are those of the work
done every time."""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.synthetic import make_model, surface_samples


def _problem_inputs(seed: int = 4):
    rng = np.random.default_rng(seed)
    m = make_model([[30, 0, 40, 10], [12, 70, 100, 9], [20, -30, 15, 12], [25, 0, 0, 0]], 2.0)
    pts = surface_samples(m, 3000, rng, noise=0.02)
    _, seg = fit.assign(m, pts, 4.0)
    # a start off the fit, so that the solver rejects some trials (its damping grows until a step descends)
    start = m.copy()
    start.angles = m.angles * 1.08
    start.radii = m.radii * 0.9
    start.lengths = m.lengths.copy()
    start.lengths[1:-1] *= 1.1
    return start, pts, seg


def test_the_jacobian_is_formed_only_where_normal_equations_are_formed(monkeypatch):
    jacobians, normal_equations, evaluations = [], [], []
    jacobian = fit.geometry_jacobian
    lm = fit.levenberg_marquardt

    def counted_jacobian(x, *args, **kwargs):
        jacobians.append(x.copy())
        return jacobian(x, *args, **kwargs)

    def counted_lm(fun, ne, *args, **kwargs):
        def fun_counted(x, out=None):
            evaluations.append(x.copy())
            return fun(x, out=out)

        def ne_counted(x, w, r):
            normal_equations.append(x.copy())
            return ne(x, w, r)

        return lm(fun_counted, ne_counted, *args, **kwargs)

    monkeypatch.setattr(fit, "geometry_jacobian", counted_jacobian)
    monkeypatch.setattr(fit, "levenberg_marquardt", counted_lm)
    start, pts, seg = _problem_inputs()
    lay = fit.Layout(start.n_bends, "free", None, True)
    _, info = fit.solve_lm(start, pts, seg, lay, f_scale=0.04, max_nfev=40)
    assert info["nfev"] == len(evaluations) > len(normal_equations) >= 2  # some trials were rejected
    # one Jacobian per point the normal equations are formed at, and at that point
    assert len(jacobians) == len(normal_equations)
    assert all(np.array_equal(a, b) for a, b in zip(jacobians, normal_equations))


def test_the_arc_samples_of_a_block_given_or_found_give_the_same_distances_and_terms():
    rng = np.random.default_rng(3)
    n = 500
    q, gs = rng.normal(size=(3, n)), rng.normal(size=(7, n))
    gs[3:6] /= np.linalg.norm(gs[3:6], axis=0)  # unit directions (lines) and axes (circles)
    gs[6] = np.abs(gs[6]) + 1.0
    for arc in (np.zeros(n, bool), np.ones(n, bool), np.repeat([False, True, False, True], [100, 150, 50, 200])):
        on_arc = fit._arc_samples(arc)
        assert on_arc is (True if arc.all() else False if not arc.any() else on_arc)
        d1, t1 = fit._sample_distance(q, gs, arc)
        d2, t2 = fit._sample_distance(q, gs, arc, on_arc)
        assert np.array_equal(d1, d2)
        out1, out2 = np.empty((7, n)), np.empty((7, n))
        fit._sample_gradient(t1, out1)
        fit._sample_gradient(t2, out2)
        assert np.array_equal(out1, out2) and np.array_equal(np.signbit(out1), np.signbit(out2))
        # the distances themselves: to a line, the perpendicular one; to a circle (centre c, axis a, radius R),
        # the one to the nearest point of its rim, from the point's height s over the plane and its distance rho
        # from the axis
        c, a, R = gs[:3], gs[3:6], gs[6]
        s = np.einsum("kn,kn->n", q - c, a)
        rho = np.linalg.norm(q - c - s * a, axis=0)
        expected = np.where(arc, np.sqrt((rho - R) ** 2 + s ** 2), rho)
        np.testing.assert_allclose(d1, expected, rtol=1e-12, atol=1e-12)
