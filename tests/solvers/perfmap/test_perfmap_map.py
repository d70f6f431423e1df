"""Envelopes, triangulation, exact map (vs dense search), binning baseline, inverse query."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapRequest
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.perfmap.query import query
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.performance_map import binned_map, curve_ranges
from plantsolve.solvers.perfmap.query import characteristic_at
from plantsolve.solvers.perfmap.families import curveset_from_fits
from plantsolve.solvers.perfmap.synthetic import request_body, true_map
from plantsolve.solvers.perfmap.triangulation import triangulate


def _arr(v):
    return np.array(v, dtype=float)


def test_synthetic_fits_are_exact(synthetic_result):
    assert synthetic_result.family == "cubic"
    row = next(r for r in synthetic_result.error_table if r.family == "cubic")
    assert row.pressure_max_rel_error < 1e-12 and row.efficiency_max_rel_error < 1e-12
    assert row.floor == 0.0
    assert synthetic_result.report.status == "ok"


def test_exact_map_agrees_with_dense_search(synthetic_result):
    m = synthetic_result.map
    gx, gy = _arr(m.flow), _arr(m.pressure)
    te, tt, tp = true_map(gx, gy, n_t=40001)
    eta = _arr(m.efficiency)
    assert np.array_equal(np.isnan(eta), np.isnan(te))  # same reachable region, NaN not 0
    assert 0.2 < np.mean(np.isfinite(eta)) < 0.9
    ok = np.isfinite(te)
    # the dense search itself is low by up to ~|d eta/dt| * 2.5e-5
    assert np.max(np.abs(eta - te)[ok]) < 5e-5
    # optimal settings agree except where the optimum is flat (tiny mean error)
    assert np.mean(np.abs(_arr(m.theta) - tt)[ok]) < 0.01
    assert np.mean(np.abs(_arr(m.phi) - tp)[ok]) < 0.02


def test_binning_baseline_is_biased_high(synthetic_result):
    m = synthetic_result.map
    gx, gy = _arr(m.flow), _arr(m.pressure)
    curves = curveset_from_fits(synthetic_result.settings)
    th = _arr([s.theta for s in synthetic_result.settings])
    ph = _arr([s.phi for s in synthetic_result.settings])
    be, _ = binned_map(curves, np.array(synthetic_result.triangles), np.column_stack([th, ph]), gx, gy,
                       curve_ranges(curves))
    te, _, _ = true_map(gx, gy, n_t=8001)
    ok = np.isfinite(be) & np.isfinite(te)
    # the paper's method, for the record: the max over a cell is biased high, and cells
    # whose centre is unreachable are marked reachable; the exact map has neither defect
    assert np.mean(be[ok] - te[ok]) > 1e-4
    assert np.sum(np.isfinite(be) & ~np.isfinite(te)) > 0
    eta = _arr(m.efficiency)
    assert np.sum(np.isfinite(eta) & ~np.isfinite(te)) == 0


def test_interpolated_characteristics_keep_side_conditions(synthetic_result, n3_result):
    rng = np.random.default_rng(0)
    for res in (synthetic_result, n3_result):
        th = _arr([s.theta for s in res.settings])
        ph = _arr([s.phi for s in res.settings])
        t = np.linspace(0, 1, 3001)
        for tri in res.triangles:
            w = rng.dirichlet([1, 1, 1])
            curve = characteristic_at(res, float(w @ th[tri]), float(w @ ph[tri]))
            x, y, _ = curve(t)
            assert np.all(np.diff(x) > 0)
            slope = np.diff(y) / np.diff(x)
            assert slope.max() <= 1e-10
            assert np.diff(slope).max() <= 1e-8


def test_triangulation_is_unit_free_and_deterministic():
    rng = np.random.default_rng(2)
    th = rng.uniform(0, 10, 15)
    ph = rng.uniform(0.5, 1.1, 15)
    a = triangulate(th, ph)
    assert np.array_equal(a, triangulate(th * 1000.0 + 7.0, ph * 0.001))
    assert np.array_equal(a, triangulate(th.copy(), ph.copy()))
    # covers the convex hull: areas add up (normalised coordinates)
    from scipy.spatial import ConvexHull
    P = np.column_stack([(th - th.min()) / np.ptp(th), (ph - ph.min()) / np.ptp(ph)])
    A = P[a]
    u, v = A[:, 1] - A[:, 0], A[:, 2] - A[:, 0]
    area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).sum()
    assert abs(area - ConvexHull(P).volume) < 1e-12


def test_query_returns_setting_whose_characteristic_passes_through(synthetic_result):
    m = synthetic_result.map
    eta = _arr(m.efficiency)
    iy, ix = np.nonzero(np.isfinite(eta))
    pick = np.linspace(0, len(iy) - 1, 12).astype(int)
    pts = [{"flow": m.flow[ix[k]], "pressure": m.pressure[iy[k]]} for k in pick]
    ans = query(synthetic_result, PerfmapQueryRequest(points=pts)).points
    for p, a in zip(pts, ans):
        assert a.feasible and a.distance_to_map == 0.0
        curve = characteristic_at(synthetic_result, a.theta, a.phi)
        t = np.linspace(0, 1, 200001)
        x, y, e = curve(t)
        k = np.searchsorted(x, p["flow"])
        s = (p["flow"] - x[k - 1]) / (x[k] - x[k - 1])
        y_at = (1 - s) * y[k - 1] + s * y[k]
        assert abs(y_at - p["pressure"]) < 1e-6 * (1 + abs(p["pressure"]))
        e_at = (1 - s) * e[k - 1] + s * e[k]
        assert abs(e_at - a.efficiency) < 1e-6
    # the query and the map are the same computation
    for k, a in zip(pick, ans):
        assert abs(a.efficiency - eta[iy[k], ix[k]]) < 1e-12


def test_query_infeasible_point_says_so(synthetic_result):
    lo, hi = synthetic_result.flow_range
    q = PerfmapQueryRequest.model_validate({"flow": hi + (hi - lo), "pressure": 1.0})
    a = query(synthetic_result, q).points[0]
    assert not a.feasible and a.theta is None and a.efficiency is None
    assert 0.9 < a.distance_to_map < 1.5  # one flow span to the right, in normalised units


def test_query_without_map_is_rejected():
    req = PerfmapRequest.model_validate(request_body(n_theta=1, n_phi=3, options={"map": False}))
    res = solve(req).result
    assert res.map is None and len(res.envelopes) == 1
    with pytest.raises(InputRejected):
        query(res, PerfmapQueryRequest(points=[{"flow": 0.5, "pressure": 1.0}]))


def test_envelope_is_the_max_over_interpolated_curves(synthetic_result):
    res = synthetic_result
    env = res.envelopes[0]
    members = [s for s in res.settings if s.theta == env.theta]
    curves = curveset_from_fits(res.settings)
    idx = [i for i, s in enumerate(res.settings) if s.theta == env.theta]
    # every measured setting's curve lies below the envelope, which touches some curve
    xe, ye = np.array(env.flow), np.array(env.pressure)
    touched = np.zeros(len(xe), bool)
    for i in idx:
        s = res.settings[i]
        inside = (xe >= s.x_min) & (xe <= s.x_max)
        t = (xe[inside] - s.x_min) / (s.x_max - s.x_min)
        _, y, _ = curves.evaluate(np.full(len(t), i), t)
        assert np.all(y <= ye[inside] + 1e-12)
        touched[np.flatnonzero(inside)[np.abs(y - ye[inside]) < 1e-12]] = True
    assert touched.any()
    assert env.flow[0] == pytest.approx(min(s.x_min for s in members))
    assert env.flow[-1] == pytest.approx(max(s.x_max for s in members))
    phis = [s.phi for s in members]
    assert min(phis) - 1e-12 <= min(env.phi) and max(env.phi) <= max(phis) + 1e-12
    assert all(np.isfinite(env.efficiency))


def test_map_nodes_are_nan_outside_not_zero(n3_result):
    eta = _arr(n3_result.map.efficiency)
    assert np.isnan(eta).any() and not (eta == 0).any()
    assert 0.1 < n3_result.map.reachable_fraction < 0.9


def test_query_on_stored_json_result(synthetic_result):
    from plantsolve.schemas.perfmap import PerfmapResult

    stored = PerfmapResult.model_validate_json(synthetic_result.model_dump_json())
    q = PerfmapQueryRequest(points=[{"flow": f, "pressure": p}
                                    for f, p in zip(synthetic_result.map.flow[5:30:5],
                                                    synthetic_result.map.pressure[10:35:5])])
    assert query(stored, q) == query(synthetic_result, q)
