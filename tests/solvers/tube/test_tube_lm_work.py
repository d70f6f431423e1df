"""Work a least-squares round does once: the Jacobian's batch of 2P + 1 models only at the points whose normal
equations are formed (a rejected trial needs its residuals only), the batch rows of a layout computed once, the
arc samples of a block found once; the numbers are those of the work done every time."""

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


def test_the_jacobian_is_batched_only_where_normal_equations_are_formed(monkeypatch):
    batches, normal_equations, evaluations = [], [], []
    batch = fit.geometry_and_jacobian
    lm = fit.levenberg_marquardt

    def counted_batch(x, *args, **kwargs):
        batches.append(x.copy())
        return batch(x, *args, **kwargs)

    def counted_lm(fun, ne, *args, **kwargs):
        def fun_counted(x, out=None):
            evaluations.append(x.copy())
            return fun(x, out=out)

        def ne_counted(x, w, r):
            normal_equations.append(x.copy())
            return ne(x, w, r)

        return lm(fun_counted, ne_counted, *args, **kwargs)

    monkeypatch.setattr(fit, "geometry_and_jacobian", counted_batch)
    monkeypatch.setattr(fit, "levenberg_marquardt", counted_lm)
    start, pts, seg = _problem_inputs()
    lay = fit.Layout(start.n_bends, "free", None, True)
    _, info = fit.solve_lm(start, pts, seg, lay, f_scale=0.04, max_nfev=40)
    assert info["nfev"] == len(evaluations) > len(normal_equations) >= 2  # some trials were rejected
    # one batch per point the normal equations are formed at, and at that point
    assert len(batches) == len(normal_equations)
    assert all(np.array_equal(a, b) for a, b in zip(batches, normal_equations))


def test_a_rounds_geometry_alone_is_the_batchs_row_to_the_bit():
    # the residuals of a trial come from the geometry of its point alone, the normal equations from the batch:
    # both are the same numbers, in every radius layout
    start, _, _ = _problem_inputs()
    n = start.n_bends
    rng = np.random.default_rng(11)
    for lay in (fit.Layout(n, "free", None, True), fit.Layout(n, "common", None, False),
                fit.Layout(n, "dies", None, True, (1, 0, 1)), fit.Layout(n, "fixed", 10.0, True)):
        x = fit.pack(start, lay)
        for turn in (0.0, 1e-4, 0.3):
            x = x + rng.normal(scale=1e-3, size=len(x))
            x[3:6] = turn * np.array([0.6, -0.8, 0.3])
            plan = fit.jacobian_batch(lay, fit._steps(len(x), lay, 2.0))
            g, _ = fit.geometry_and_jacobian(x, lay, start.frame, 2.0, plan)
            assert np.array_equal(fit.geometry_batch(x[None], lay, start.frame, 2.0)[0], g)


def test_a_layouts_batch_rows_are_computed_once_and_shared_read_only():
    lay = fit.Layout(3, "dies", None, True, (1, 0, 1))
    steps = fit._steps(lay.size, lay, 2.0)
    a, b = fit.jacobian_batch(lay, steps), fit.jacobian_batch(lay, 2 * steps)
    assert a.active == b.active and np.array_equal(a.plus, b.plus) and np.array_equal(a.minus, b.minus)
    assert not np.array_equal(a.shift, b.shift)  # the steps are each round's own
    pos, _ = fit._batch_rows(lay.size, lay.n, lay.radius_mode, lay.dies)
    assert pos is fit._batch_rows(lay.size, lay.n, lay.radius_mode, lay.dies)[0] and not pos.flags.writeable
    # the rows of a plus and a minus step of every parameter, each row once
    assert sorted(np.concatenate([a.plus, a.minus]).tolist()) == list(range(1, 2 * lay.size + 1))


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
