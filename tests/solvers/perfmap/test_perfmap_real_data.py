"""End to end on a real published compressor map.

Data: the N+3 reference turbofan fan map shipped with pyCycle (OpenMDAO),
example_cycles/N+3ref/N3_Fan_map.py at commit 65faca6, licence Apache-2.0 ("Python version
of HBTF Fan map from NPSS"), converted to theta,phi,flow,pressure,efficiency (see
data/README.md). Near surge several speed lines are not monotone: they must give a floor
diagnostic, not a failure.
"""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.perfmap.families import curveset_from_fits

from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapResult
from plantsolve.solvers.base import Solved
from plantsolve.solvers.perfmap.artifacts import render_artifacts
from plantsolve.solvers.perfmap.query import query
from plantsolve.solvers.perfmap.families import log_eval, log_params_from_public


def test_n3_end_to_end(n3_request, n3_result: PerfmapResult):
    res = n3_result
    assert len(res.settings) == 18 and res.report.status == "warning"
    floors = {w.details["setting"]: w.details["floor"] for w in res.report.warnings
              if w.code == "data_not_decreasing_concave"}
    assert floors and all(f > 0 for f in floors.values())
    # the non-monotone lines near surge are the low-speed ones
    assert any(res.settings[k].phi <= 0.6 for k in floors)
    for k, s in enumerate(res.settings):
        assert s.floor == floors.get(k, 0.0)
        assert s.pressure_max_rel_error >= s.floor - 1e-9
    assert [r.family for r in res.error_table] == ["parabola", "log", "cubic", "spline2", "spline3"]
    assert res.error_table[1].efficiency_max_rel_error is None
    # every fitted characteristic is decreasing and concave, on dense samples
    t = np.linspace(0, 1, 2001)
    curves = curveset_from_fits(res.settings)
    for k, s in enumerate(res.settings):
        if s.family == "log":
            y = log_eval(log_params_from_public(s.pressure_coefficients, s.x_min, s.x_max), t)
            assert np.allclose(y, curves.evaluate_xy(np.full(len(t), k), t)[1])
        y = curves.evaluate_xy(np.full(len(t), k), t)[1]
        scale = np.abs(y).max()
        assert np.diff(y).max() <= 1e-12 * scale and np.diff(y, 2).max() <= 1e-12 * scale
        # every line within 1 % of the best decreasing concave curve, or warned about
        assert s.pressure_excess <= 0.01 + 1e-12
    assert not [w for w in res.report.warnings if w.code == "pressure_fit_poor"]
    assert len(res.envelopes) == 2 and {e.theta for e in res.envelopes} == {0.0, 5.0}
    assert res.map is not None and res.map.reachable_fraction > 0.3
    eta = np.array(res.map.efficiency, dtype=float)
    assert 0.8 < np.nanmax(eta) < 1.1


def test_n3_query_and_plots(n3_request, n3_result):
    q = PerfmapQueryRequest(points=[{"flow": 2000.0, "pressure": 1.15},
                                    {"flow": 1000.0, "pressure": 1.6}])
    a, b = query(n3_result, q).points
    assert a.feasible and 0.0 <= a.theta <= 5.0 and 0.5 <= a.phi <= 1.1 and a.efficiency > 0.8
    assert not b.feasible and b.distance_to_map > 0.1
    arts = render_artifacts(n3_request, Solved(n3_result))
    # 3 plots as PNG and SVG, curves.csv, map.csv; the beta-grid exports: pyCycle, GasTurb per theta (0, 5), CSV
    assert len(arts) == 12 and all(len(x.data) > 1000 for x in arts)
    assert {"map_pycycle.py", "map_gasturb_theta0.map", "map_gasturb_theta5.map", "map_beta.csv"} <= {a.name for a in arts}


def test_n3_all_models_and_minimax(n3_request, monkeypatch):
    import copy

    from plantsolve.solvers.perfmap import solve as solve_module

    # Every family is fitted to every line whatever the model asked for (the error table is the paper's Table 1 of
    # all of them): the three solves of one fit share that work, each on a fresh copy (what follows may change it)
    fitted: dict = {}

    def fit_once(settings, minimax, concave_efficiency, progress):
        key = (minimax, concave_efficiency, tuple((s.x.tobytes(), s.y.tobytes(), s.eta.tobytes()) for s in settings))
        if key not in fitted:
            fitted[key] = fit_characteristics(settings, minimax, concave_efficiency, progress)
        return copy.deepcopy(fitted[key])

    fit_characteristics = solve_module.fit_characteristics
    monkeypatch.setattr(solve_module, "fit_characteristics", fit_once)
    solve = solve_module.solve
    for model in ("parabola", "log", "spline3"):
        for fit in ("least_squares", "minimax"):
            req = n3_request.model_copy(update={"options": n3_request.options.model_copy(
                update={"model": model, "fit": fit, "grid": [16, 16], "t_samples": 33})})
            res = solve(req).result
            assert res.family == model and res.fit == fit
            if fit == "minimax":
                for s in res.settings:  # minimax never loses to the floor, and is >= it
                    assert s.pressure_max_rel_error >= s.floor - 1e-9
