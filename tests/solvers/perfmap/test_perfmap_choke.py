"""Speed lines as real compressor maps have them: steep or vertical choke, repeated flows, lines the
paper's smooth families cannot follow. Every line ends within 1 % of the best decreasing concave
curve (its floor), or says why."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.families import curveset_from_fits
from plantsolve.solvers.perfmap.fitting import concave_floor, fit_concave


def speed_line(n: int, steep: float, pr0: float = 2.0, eta0: float = 0.86, flow0: float = 10.0):
    """A decreasing concave line whose pressure falls off a cliff at choke (power `steep`)."""
    t = np.linspace(0.0, 1.0, n)
    flow = flow0 * (1 + 0.6 * t)
    pressure = pr0 * (1.0 - 0.04 * t - 0.55 * t ** steep)
    efficiency = eta0 - 0.25 * (t - 0.45) ** 2 - 0.2 * t ** 8
    return flow, pressure, efficiency


def request(lines, **options) -> PerfmapRequest:
    positions = [{"theta": th, "phi": ph, "flow": f.tolist(), "pressure": p.tolist(), "efficiency": e.tolist()}
                 for (th, ph), (f, p, e) in lines]
    return PerfmapRequest.model_validate({"positions": positions, "options": {"map": False, **options}})


def cliff_map():
    return [((0.0, 0.6 + 0.1 * k), speed_line(24, 8 + 4 * k, pr0=1.6 + 0.2 * k, flow0=8 + 2 * k))
            for k in range(4)]


def test_lines_with_a_choke_cliff_reach_their_floor():
    res = solve(request(cliff_map())).result
    curves = curveset_from_fits(res.settings)
    t = np.linspace(0, 1, 1001)
    for k, s in enumerate(res.settings):
        assert s.floor == 0.0  # the data are exactly decreasing and concave
        assert s.pressure_max_rel_error <= 0.01 and s.pressure_excess <= 0.01
        y = curves.evaluate_xy(np.full(len(t), k), t)[1]
        assert np.diff(y).max() <= 1e-12 and np.diff(y, 2).max() <= 1e-12 * np.abs(y).max()
    # the paper's smooth families alone miss these lines by more than 1 %
    assert min(r.pressure_max_rel_error for r in res.error_table) > 0.01
    assert res.report.details["family_choice"]["settings_with_another_family"] >= 1
    assert not [w for w in res.report.warnings if w.code == "pressure_fit_poor"]


def test_a_forced_stiff_family_is_warned_about_with_the_numbers():
    res = solve(request(cliff_map(), model="parabola")).result
    poor = [w for w in res.report.warnings if w.code == "pressure_fit_poor"]
    assert len(poor) == 4
    for w in poor:
        d = w.details
        assert d["family"] == "parabola" and d["excess"] == pytest.approx(d["max_rel_error"] - d["floor"])
        assert d["excess"] > 0.01


def test_the_broken_line_reaches_the_floor_exactly_on_noisy_data():
    rng = np.random.default_rng(4)
    f, p, _ = speed_line(30, 6)
    noisy = p * (1 + 0.004 * rng.standard_normal(len(p)))
    t = (f - f[0]) / (f[-1] - f[0])
    floor = concave_floor(f, noisy)
    assert floor > 0
    fit = fit_concave(t, noisy, minimax=True)
    err = np.max(np.abs(fit(t) - noisy) / noisy)
    assert err == pytest.approx(floor, abs=2e-7)
    assert np.diff(fit.params).max() <= 1e-12 and np.diff(np.diff(fit.params) / np.diff(t)).max() <= 1e-9


def test_repeated_flows_and_a_vertical_choke_segment_are_accepted():
    f, p, e = speed_line(20, 6)
    # a vertical choke: three more readings at the last flow, lower pressure; a repeated mid reading
    f2 = np.concatenate([f, [f[-1]] * 3, [f[5]]])
    p2 = np.concatenate([p, p[-1] * np.array([0.95, 0.9, 0.85]), [p[5] * 1.002]])
    e2 = np.concatenate([e, e[-1] * np.array([0.97, 0.94, 0.9]), [e[5]]])
    lines = [((0.0, 1.0), (f2, p2, e2)), ((0.0, 2.0), speed_line(20, 7, pr0=2.3, flow0=12))]
    res = solve(request(lines)).result
    codes = {w.code: w for w in res.report.warnings}
    vertical = codes["vertical_choke_segment"].details
    assert vertical["flow"] == pytest.approx(f[-1]) and len(vertical["pressures"]) == 4
    assert vertical["pressures"][-1] == pytest.approx(p[-1])  # the characteristic ends at the top
    assert "repeated_flows_averaged" in codes
    s = res.settings[0]
    assert s.n_points == 20 and s.x_max == pytest.approx(f[-1])


def test_speed_lines_give_a_speed_map_and_the_query_finds_the_speed():
    from plantsolve.schemas.perfmap import PerfmapQueryRequest
    from plantsolve.solvers.perfmap.query import query
    from plantsolve.solvers.perfmap.synthetic import speed_lines

    res = solve(PerfmapRequest.model_validate(speed_lines(6, 12, options={"grid": [48, 48]}))).result
    assert res.map is not None and res.map.reachable_fraction > 0.3
    assert {w.code for w in res.report.warnings} >= {"one_parameter_map"}
    curves = curveset_from_fits(res.settings)
    k = 3
    x, y, e = curves.evaluate(np.array([k]), np.array([0.4]))
    ans = query(res, PerfmapQueryRequest.model_validate({"flow": float(x[0]), "pressure": float(y[0])})).points[0]
    assert ans.feasible and ans.setting == pytest.approx(res.settings[k].setting, abs=1e-6)
    assert ans.efficiency == pytest.approx(float(e[0]), abs=1e-6)
    # between two lines the speed is between theirs
    x2, y2, _ = curves.evaluate(np.array([k + 1]), np.array([0.4]))
    mid = query(res, PerfmapQueryRequest.model_validate({"flow": float((x[0] + x2[0]) / 2),
                                                         "pressure": float((y[0] + y2[0]) / 2)})).points[0]
    assert mid.feasible and res.settings[k].setting[0] < mid.setting[0] < res.settings[k + 1].setting[0]


def test_surge_choke_and_margin_lines_are_returned_and_drawn():
    from plantsolve.solvers.perfmap.artifacts import render_artifacts
    from plantsolve.solvers.perfmap.synthetic import speed_lines

    req = PerfmapRequest.model_validate(speed_lines(5, 10, options={"grid": [32, 32], "surge_margin": 0.1}))
    solved = solve(req)
    res = solved.result
    assert len(res.surge_line) == len(res.choke_line) == 5
    for s, surge, choke in zip(res.settings, res.surge_line, res.choke_line):
        assert surge.flow == pytest.approx(s.x_min) and choke.flow == pytest.approx(s.x_max)
        assert surge.pressure > choke.pressure and surge.setting == s.setting
    margin = res.surge_margin_line
    assert len(margin) == 5
    for m, surge in zip(margin, res.surge_line):
        assert surge.pressure / m.pressure - 1 == pytest.approx(0.1, abs=1e-9) and m.flow > surge.flow
    svg = next(a for a in render_artifacts(req, solved) if a.name == "map.svg").data.decode()
    for label in ("surge line", "choke line", "surge margin line"):
        assert label in svg


def test_a_vertical_choke_segment_is_part_of_the_choke_line():
    f, p, e = speed_line(20, 6)
    f2 = np.concatenate([f, [f[-1]] * 2])
    p2 = np.concatenate([p, p[-1] * np.array([0.9, 0.8])])
    e2 = np.concatenate([e, e[-1] * np.array([0.95, 0.9])])
    res = solve(request([((0.0, 1.0), (f2, p2, e2)), ((0.0, 2.0), speed_line(20, 7, pr0=2.3, flow0=12))])).result
    assert res.choke_line[0].vertical_to == pytest.approx(0.8 * p[-1])
    assert res.choke_line[1].vertical_to is None
