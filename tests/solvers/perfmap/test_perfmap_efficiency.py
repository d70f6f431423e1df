"""Efficiency curves: physical bounds 0 <= eta <= 1 exactly, the parabola_log family, the
independent (LOO) choice of the efficiency family, efficiency warnings, and per-point
determinism of the inverse query. Real data: the N+3 fan map (pyCycle, Apache-2.0; see
test_perfmap_real_data.py)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapRequest
from plantsolve.solvers.perfmap.query import query
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.efficiency import (
    EFFICIENCY_FAMILIES,
    N_EFF_COEFFICIENTS,
    curve_extrema,
    eta_leave_one_out,
    design,
    fit_eta,
    lsi,
)
from plantsolve.solvers.perfmap.families import basis, bernstein
from plantsolve.solvers.perfmap.families import curveset_from_fits
from plantsolve.solvers.perfmap.synthetic import request_body

T = np.array([0.0, 0.13, 0.31, 0.5, 0.64, 0.82, 0.93, 1.0])
DENSE = np.linspace(0.0, 1.0, 200_001)


def _eta_dense(family, params, t=DENSE):
    p = np.asarray(params, float)
    if family == "parabola_log":
        return design(family, t, p[4]) @ p[:4]
    return basis(family, t) @ p


def _all_eta_curves(result, t=DENSE):
    return curveset_from_fits(result.settings).sample(t)[2]


# ---------------------------------------------------------------- building blocks


def test_lsi_equals_bounded_least_squares():
    rng = np.random.default_rng(7)
    for _ in range(20):
        A, b = rng.normal(size=(9, 5)), rng.normal(size=9)
        G = np.vstack([np.eye(5), -np.eye(5)])  # -0.3 <= x <= 0.3
        x = lsi(A, b, G, -0.3 * np.ones(10))
        ref = lsq_linear(A, b, bounds=(-0.3, 0.3), method="bvls", tol=1e-15).x
        assert np.max(np.abs(x - ref)) < 1e-12


def test_lsi_general_constraints_satisfy_kkt():
    rng = np.random.default_rng(8)
    A, b = rng.normal(size=(12, 4)), rng.normal(size=12)
    G, h = rng.normal(size=(6, 4)), rng.normal(size=6) + 0.5
    x = lsi(A, b, G, h)
    slack = G @ x - h
    assert slack.min() > -1e-12
    # KKT: A^T (A x - b) = G^T lam with lam >= 0 on the active rows only
    act = slack < 1e-9
    lam = np.linalg.lstsq(G[act].T, A.T @ (A @ x - b), rcond=None)[0]
    assert act.any() and lam.min() > -1e-9
    assert np.max(np.abs(G[act].T @ lam - A.T @ (A @ x - b))) < 1e-9


@pytest.mark.parametrize("family", EFFICIENCY_FAMILIES)
def test_curve_extrema_are_exact(family):
    rng = np.random.default_rng(3)
    for _ in range(25):
        p = rng.uniform(-1, 2, N_EFF_COEFFICIENTS[family])
        if family == "parabola_log":
            p[3], p[4] = rng.uniform(0, 0.3), 1.0 + 10 ** rng.uniform(-4, 0.5)
        _, vmin, _, vmax = curve_extrema(family, p)
        v = _eta_dense(family, p)
        assert vmax >= v.max() - 1e-14 and vmin <= v.min() + 1e-14
        # attained (the dense grid is within its spacing of the extremum)
        assert vmax - v.max() < 1e-6 and v.min() - vmin < 1e-6


def test_parabola_log_recovered_to_round_off():
    for params in ([0.5, 1.0, 0.7, 0.05, 1.02], [0.6, 0.9, 0.8, 0.2, 1.3]):
        p = np.array(params)
        eta = design("parabola_log", T, p[4]) @ p[:4]
        fit = fit_eta("parabola_log", T, eta, False, False)
        assert np.max(np.abs(fit.params - p)) < 1e-12 and fit.active_bounds == 0
        mm = fit_eta("parabola_log", T, eta, True, False)  # 1-D search in beta: not round-off
        assert np.max(np.abs(mm(T) - eta) / eta) < 1e-7


@pytest.mark.parametrize("family", EFFICIENCY_FAMILIES)
@pytest.mark.parametrize("minimax", [False, True])
@pytest.mark.parametrize("concave", [False, True])
def test_bounds_hold_exactly_where_the_free_fit_overshoots(family, minimax, concave):
    # peak measured at 0.99 and a choke collapse: unconstrained fits go above 1
    eta = np.array([0.80, 0.93, 0.99, 0.985, 0.95, 0.80, 0.45, 0.05])
    free = np.linalg.lstsq(bernstein(3, T), eta, rcond=None)[0]
    assert _eta_dense("cubic", free).max() > 1.0  # the test case does overshoot
    fit = fit_eta(family, T, eta, minimax, concave)
    v = _eta_dense(family, fit.params)
    assert 0.0 <= v.min() and v.max() <= 1.0
    if concave:
        k = 3 if family == "parabola_log" else len(fit.params)
        assert np.diff(fit.params[:k], 2).max() <= 1e-12
        assert np.diff(v, 2).max() <= 1e-12


# ---------------------------------------------------------------- family choice


def _spline3_eta_request():
    """Pressure exactly a parabola; efficiency exactly a 3-segment quadratic spline with a
    real kink in curvature (no other efficiency family contains it)."""
    body = request_body(n_theta=3, n_phi=3, n_points=9, options={"model": "auto",
                                                                 "grid": [12, 12]})
    t = np.linspace(0.0, 1.0, 9)
    for k, pos in enumerate(body["positions"]):
        c = np.array([1.3, 1.25, 1.1]) + 0.02 * k
        pos["pressure"] = (bernstein(2, t) @ c).tolist()
        d = np.array([0.55, 0.80, 0.93, 0.70, 0.40]) + 0.01 * k
        pos["efficiency"] = (basis("spline3", t) @ d).tolist()
    return PerfmapRequest.model_validate(body)


def test_auto_chooses_efficiency_family_independently_by_loo():
    res = solve(_spline3_eta_request()).result
    assert res.family == "parabola"  # pressure: exact for every family, fewest coefficients
    assert all(s.efficiency_family == "spline3" for s in res.settings)
    for s in res.settings:
        assert s.efficiency_max_abs_error < 1e-12 and s.efficiency_loo_abs < 1e-12
    row = {r.family: r for r in res.efficiency_error_table}
    assert row["spline3"].chosen == 9 and row["spline3"].loo_abs < 1e-12
    assert min(row[f].loo_abs for f in EFFICIENCY_FAMILIES if f != "spline3") > 1e-3
    # 'same' forces the paper's pairing, a family name forces that family
    req = _spline3_eta_request()
    for choice, expected in (("same", "parabola"), ("cubic", "cubic")):
        opts = req.options.model_copy(update={"efficiency_model": choice})
        forced = solve(req.model_copy(update={"options": opts})).result
        assert {s.efficiency_family for s in forced.settings} == {expected}
        assert min(s.efficiency_max_abs_error for s in forced.settings) > 1e-3


# ---------------------------------------------------------------- real data


def test_n3_efficiency_physical_and_close_to_measured(n3_request, n3_result):
    measured_max = max(max(p.efficiency) for p in n3_request.positions)  # 0.9495
    eta_map = np.array(n3_result.map.efficiency, dtype=float)
    assert np.nanmax(eta_map) <= 1.0
    # no overshoot: the map stays within 1 efficiency point of the best measurement
    assert np.nanmax(eta_map) <= measured_max + 0.01
    E = _all_eta_curves(n3_result)
    assert E.min() >= 0.0 and E.max() <= 1.0
    for s, e in zip(n3_result.settings, E):
        assert abs(s.efficiency_peak - e.max()) < 1e-6  # peak reported exactly
        assert s.efficiency_max_rel_error < 0.05  # was 0.51 at (5, 0.6) with spline2
    assert not [w for w in n3_result.report.warnings if w.code.startswith("efficiency")]
    # envelopes carry the bounded curves too
    for env in n3_result.envelopes:
        v = np.array([x for x in env.efficiency if x is not None])
        assert v.max() <= 1.0


def test_n3_forced_paper_efficiency_is_bounded_and_flagged(n3_request):
    opts = n3_request.options.model_copy(update={
        "model": "spline2", "efficiency_model": "same", "grid": [32, 32], "t_samples": 65})
    res = solve(n3_request.model_copy(update={"options": opts})).result
    E = _all_eta_curves(res)
    assert E.min() >= 0.0 and E.max() <= 1.0
    assert np.nanmax(np.array(res.map.efficiency, dtype=float)) <= 1.0
    k = next(i for i, s in enumerate(res.settings) if (s.theta, s.phi) == (5.0, 0.6))
    s = res.settings[k]
    assert s.efficiency_family == "spline2" and s.efficiency_bounds_active > 0
    assert s.efficiency_peak == pytest.approx(1.0, abs=1e-9)  # the bound holds, and bites
    poor = {w.details["setting"]: w for w in res.report.warnings if w.code == "efficiency_fit_poor"}
    assert k in poor and poor[k].details["max_rel_error"] == pytest.approx(
        s.efficiency_max_rel_error) and "phi=0.6" in poor[k].message
    assert all(res.settings[i].efficiency_max_rel_error > 0.05 for i in poor)
    assert any(w.code == "efficiency_above_measured" and w.details["setting"] == k
               for w in res.report.warnings)


def test_query_answer_does_not_depend_on_the_batch(n3_result):
    rng = np.random.default_rng(11)
    pts = [{"flow": float(x), "pressure": float(y)}
           for x, y in zip(rng.uniform(1000, 2700, 120), rng.uniform(0.98, 1.25, 120))]
    batch = query(n3_result, PerfmapQueryRequest(points=pts)).points
    assert 10 < sum(a.feasible for a in batch) < 110  # both kinds of points are exercised
    rev = query(n3_result, PerfmapQueryRequest(points=pts[::-1])).points[::-1]
    for k, p in enumerate(pts):
        alone = query(n3_result, PerfmapQueryRequest(points=[p])).points[0]
        assert alone.model_dump() == batch[k].model_dump() == rev[k].model_dump()


@pytest.mark.parametrize("family", ["parabola", "cubic", "spline2", "spline3"])
@pytest.mark.parametrize("concave", [False, True])
def test_closed_form_loo_equals_explicit_bounded_refits(family, concave):
    rng = np.random.default_rng(21)
    t = np.linspace(0.0, 1.0, 9)
    for eta in (np.array([0.80, 0.90, 0.97, 0.99, 0.985, 0.95, 0.80, 0.45, 0.05]),  # bounds bite
                0.6 + 0.3 * np.sin(2.5 * t) + 0.01 * rng.standard_normal(9)):
        rel, ab = eta_leave_one_out(family, t, eta, concave, np.arange(9))
        errs = []
        for i in range(9):
            keep = np.arange(9) != i
            f = fit_eta(family, t[keep], eta[keep], False, concave)
            errs.append(abs(float(f(t[i : i + 1])[0]) - eta[i]))
        assert ab == pytest.approx(max(errs), abs=1e-10)
        assert rel == pytest.approx(max(np.array(errs) / eta), abs=1e-10)


def test_efficiency_in_percent_is_rejected_with_its_field():
    from plantsolve.solvers.base import InputRejected
    from plantsolve.solvers.perfmap.validation import check_input

    body = request_body(n_theta=3, n_phi=3)
    body["positions"][4]["efficiency"] = [100 * e for e in body["positions"][4]["efficiency"]]
    with pytest.raises(InputRejected) as exc:
        check_input(PerfmapRequest.model_validate(body))
    errs = exc.value.errors
    assert [tuple(e.loc) for e in errs] == [("positions", 4, "efficiency", 0)]
    assert "percent" in errs[0].msg
