"""Every compressor map shipped with pyCycle (data/pycycle, Apache-2.0, see data/README.md): 'auto' ends
every speed line within 1 % of its floor (the best max relative error any decreasing concave curve
reaches), including the 20-line axial map axi3_2 whose mid-speed lines rise towards surge over few points
and end in a vertical choke segment; where no least-squares fit can, the line is fitted by minimax and
the report says so per line."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.families import FAMILIES, curveset_from_fits
from plantsolve.solvers.perfmap.fitting import concave_floor, fit_pressure_setting
from plantsolve.solvers.perfmap.validation import prepare

PYCYCLE = Path(__file__).parent / "data" / "pycycle"
MAPS = sorted(p.name for p in PYCYCLE.glob("*.py"))


def pycycle_request(name: str, **options) -> PerfmapRequest:
    return parse_upload(StoredInput.from_bytes(name, (PYCYCLE / name).read_bytes()), {"map": False, **options})


@lru_cache(maxsize=None)
def solved(name: str):
    """Each map solved once for the tests of this module (request, result)."""
    req = pycycle_request(name)
    return req, solve(req).result


@pytest.fixture(scope="module")
def axi3_2():
    return solved("axi3_2.py")


def test_all_nine_pycycle_compressor_maps_are_here():
    assert len(MAPS) == 9 and "axi3_2.py" in MAPS


@pytest.mark.parametrize("name", MAPS)
def test_auto_ends_every_line_of_a_pycycle_map_within_1_percent_of_its_floor(name):
    req, res = solved(name)
    settings = prepare(req)
    curves = curveset_from_fits(res.settings)
    assert len(res.settings) == len(settings) >= 18
    for k, (fit, s) in enumerate(zip(res.settings, settings)):
        # the reported error is the curve's, recomputed from the returned coefficients at the measured points
        y = curves.evaluate_xy(np.full(len(s.x), k), s.t)[1]
        err = float(np.max(np.abs(y - s.y) / s.y))
        assert fit.pressure_max_rel_error == pytest.approx(err, abs=2e-7)
        assert fit.floor == concave_floor(s.x, s.y)
        assert fit.floor - 1e-9 <= err <= fit.floor + 0.01, (name, fit.setting)
        dense = curves.evaluate_xy(np.full(501, k), np.linspace(0, 1, 501))[1]
        scale = np.abs(dense).max()
        assert np.diff(dense).max() <= 1e-12 * scale and np.diff(dense, 2).max() <= 1e-12 * scale
    assert not [w for w in res.report.warnings if w.code == "pressure_fit_poor"]


def test_the_axi3_2_lines_that_least_squares_cannot_bring_to_their_floor(axi3_2):
    req, res = axi3_2
    settings = {s.values: s for s in prepare(req)}
    by_setting = {tuple(f.setting): f for f in res.settings}
    worst = by_setting[(90.0, 0.9)]
    # 8 points (the 9th is the bottom of a vertical choke segment), rising 18 % towards surge
    s = settings[(90.0, 0.9)]
    assert len(s.x) == 8 and s.y[3] / s.y[0] > 1.17 and s.choke_pressures == [1.676, 2.1261]
    assert worst.floor == pytest.approx(0.0807, abs=5e-4)
    best_ls = min(fit_pressure_setting(f, s.t, s.y, False, with_loo=False).err for f in FAMILIES)
    assert best_ls > worst.floor + 0.03  # before: 'auto' kept the least-squares broken line, 11.6 %
    assert worst.pressure_fit == "minimax" and worst.pressure_excess <= 1e-6
    minimax = [tuple(w.details["values"]) for w in res.report.warnings if w.code == "pressure_fit_minimax"]
    assert sorted(minimax) == sorted(k for k, f in by_setting.items() if f.pressure_fit == "minimax")
    assert {(0.0, 0.9), (0.0, 0.95), (90.0, 0.8), (90.0, 0.9), (90.0, 0.95)} <= set(minimax)
    for w in res.report.warnings:
        if w.code == "pressure_fit_minimax":
            d = w.details
            assert d["least_squares_max_rel_error"] > d["floor"] + 0.01 >= d["max_rel_error"]
    assert res.report.details["family_choice"]["settings_fitted_by_minimax"] == len(minimax)
    # lines that least squares fits within 1 % keep it
    assert by_setting[(0.0, 0.5)].pressure_fit == "least_squares"


def test_a_forced_model_says_per_line_why_it_misses_the_floor(axi3_2):
    req, _ = axi3_2
    res = solve(req.model_copy(update={"options": req.options.model_copy(update={"model": "spline3"})})).result
    poor = {tuple(w.details["values"]): w.details for w in res.report.warnings if w.code == "pressure_fit_poor"}
    assert (90.0, 0.9) in poor
    for d in poor.values():
        assert d["reason"] == "model_forced" and d["fit"] == "least_squares" and d["excess"] > 0.01
    assert all(f.pressure_fit == "least_squares" for f in res.settings)


def test_minimax_requested_needs_no_switch(axi3_2):
    req, _ = axi3_2
    hard = [p for p in req.positions if p.setting[0] == 90.0 and p.setting[1] in (0.8, 0.9, 0.95)]
    req = req.model_copy(update={"positions": hard, "options": req.options.model_copy(update={"fit": "minimax"})})
    res = solve(req).result
    assert len(res.settings) == 3
    assert all(f.pressure_fit == "minimax" and f.pressure_excess <= 0.01 for f in res.settings)
    assert not [w for w in res.report.warnings if w.code in ("pressure_fit_minimax", "pressure_fit_poor")]


def test_a_line_within_reach_of_least_squares_keeps_it(n3_result):
    assert all(f.pressure_fit == "least_squares" for f in n3_result.settings)
    assert n3_result.report.details["family_choice"]["settings_fitted_by_minimax"] == 0


@pytest.mark.parametrize("n, rise, seed", [(4, 0.03, 0), (6, 0.10, 1), (8, 0.18, 2), (9, 0.12, 5), (12, 0.15, 3)])
def test_few_points_rising_to_surge_with_a_vertical_choke_reach_the_floor(n, rise, seed):
    """The axi3_2 pattern, generated: n points of a line that peaks at 40 % of its flow range (the surge
    end `rise` below the peak), falls by 40 % to choke, and ends in a vertical choke segment."""
    rng = np.random.default_rng(seed)
    t = np.concatenate([[0.0], np.sort(rng.uniform(0.05, 0.95, n - 2)), [1.0]])
    flow = 20.0 + 9.0 * t
    pressure = 3.0 * np.where(t < 0.4, 1.0 - rise * ((t - 0.4) / 0.4) ** 2, 1.0 - 0.4 * ((t - 0.4) / 0.6) ** 2)
    eta = 0.85 - 0.3 * (t - 0.5) ** 2
    line = {"setting": [0.9], "flow": flow.tolist() + [flow[-1]], "pressure": pressure.tolist() + [0.8 * pressure[-1]],
            "efficiency": eta.tolist() + [0.9 * eta[-1]]}
    regular = {"setting": [1.0], "flow": (flow + 2).tolist(), "pressure": (3.2 - 0.8 * t ** 2).tolist(),
               "efficiency": eta.tolist()}
    req = PerfmapRequest.model_validate({"positions": [line, regular], "setting_names": ["Nc"],
                                         "options": {"map": False}})
    res = solve(req).result
    s = prepare(req)[0]
    floor = concave_floor(s.x, s.y)
    assert 0.3 * rise < floor < rise  # the rise is a real violation of the physics
    if rise >= 0.1:  # least squares alone misses the floor by more than 1 % here
        assert min(fit_pressure_setting(f, s.t, s.y, False, with_loo=False).err for f in FAMILIES) > floor + 0.01
    fit = res.settings[0]
    assert fit.floor == floor and fit.pressure_excess <= 0.01
    assert "vertical_choke_segment" in {w.code for w in res.report.warnings}
    assert res.choke_line[0].vertical_to == pytest.approx(0.8 * pressure[-1])


def test_a_choke_segment_rounded_below_the_last_r_line_is_still_the_choke_segment():
    """N3_HPC_map (alpha 0, Nc 0.975) prints the choke flow 188.0271 three times after an R-line at 188.0273:
    read literally, the choke's low pressures come before 17.15 and the line 'rises' by 22 %."""
    req, res = solved("N3_HPC_map.py")
    literal = {s.values: s for s in prepare(req, choke_tolerance=0.0)}[(0.0, 0.975)]
    s = {s.values: s for s in prepare(req)}[(0.0, 0.975)]
    assert concave_floor(literal.x, literal.y) > 0.1  # the artefact the old reading made of it
    assert s.choke_pressures == [12.381, 14.0424, 15.6466, 17.1524] and s.x[-1] == 188.0273
    assert len(s.x) == 8 and np.all(np.diff(s.y) < 0) and concave_floor(s.x, s.y) == 0.0
    fit = next(f for f in res.settings if f.setting == [0.0, 0.975])
    assert fit.floor == 0.0 and fit.pressure_max_rel_error <= 0.01
    assert res.choke_line[res.settings.index(fit)].vertical_to == 12.381


def test_choke_tolerance_is_a_fraction_of_the_flow_range():
    """Flows within 1e-4 of the line's flow range below the largest join its choke segment; a point
    1e-3 below stays a point of the characteristic (unit-free: the same on flows x 1000)."""
    base = {"setting": [1.0], "efficiency": [0.7, 0.8, 0.82, 0.8, 0.7, 0.6]}
    for scale in (1.0, 1000.0):
        for gap, merged in ((0.5e-4, True), (1e-3, False)):
            flow = np.array([0.0, 0.3, 0.6, 0.8, 1.0, 1.0 - gap]) * scale + 7.0 * scale
            pos = {**base, "flow": flow.tolist(), "pressure": [2.0, 1.95, 1.85, 1.7, 1.5, 1.3]}
            other = {**pos, "setting": [2.0]}
            s = prepare(PerfmapRequest.model_validate({"positions": [pos, other], "setting_names": ["Nc"]}))[0]
            assert (s.choke_pressures == [1.3, 1.5]) is merged and len(s.x) == (5 if merged else 6)


def test_a_map_value_past_the_float_range_drops_its_point_and_classic_mac_line_ends_read():
    """Two damaged copies of pyCycle's LPC map: a 400-digit integer in WcMap overflowed the conversion (a 422
    calling the file malformed) and is now a non-finite value whose point is dropped; CR-only line ends hid
    every array but the first ('no compressor MAP_DATA here')."""
    text = (PYCYCLE / "LPC_map.py").read_text()
    whole = pycycle_request("LPC_map.py")
    poisoned = text.replace("17.907", "9" * 400, 1)
    req = parse_upload(StoredInput.from_bytes("LPC_map.py", poisoned.encode()), {"map": False})
    assert sum(len(p.flow) for p in req.positions) == sum(len(p.flow) for p in whole.positions) - 1
    dropped = [next(w for w in r.upload_warnings if w.code == "upload_points_dropped").details["points"]
               for r in (req, whole)]
    assert dropped[0] == dropped[1] + 1
    mac = parse_upload(StoredInput.from_bytes("LPC_map.py", text.replace("\n", "\r").encode()), {"map": False})
    assert mac.positions == whole.positions


# ---------------------------------------------------------------- the export run in pyCycle itself

A = np.array([1.6, 2.2, 3.0, 4.0])  # PR = A_k - B Wc^2 on line k (speeds 0.6 ... 0.9)
B = 0.02
C_SURGE, C_CHOKE = 0.05, 0.01  # surge and choke lines: PR - 1 = c Wc^2
SPEEDS = [0.6, 0.7, 0.8, 0.9]


def _closed_form_result():
    """Speed lines PR = A_k - B Wc^2 between the parabolas PR - 1 = 0.05 Wc^2 (surge) and 0.01 Wc^2 (choke), flow in
    kg/s, fitted exactly (parabola family); the 21-line beta grid's nodes (evenly spaced, R = 1, 1.1, ... 3) are the
    closed-form crossings."""
    positions = []
    for a, n in zip(A, SPEEDS):
        xs, xc = np.sqrt((a - 1) / (B + np.array([C_SURGE, C_CHOKE])))
        x = np.linspace(xs, xc, 7)
        eta = 0.9 - 0.2 * ((x - xs) / (xc - xs) - 0.4) ** 2
        positions.append({"setting": [n], "flow": x.tolist(), "pressure": (a - B * x * x).tolist(),
                          "efficiency": eta.tolist()})
    req = PerfmapRequest.model_validate({
        "setting_names": ["Nc"], "units": {"flow": "kg/s", "pressure": "1"}, "positions": positions,
        "options": {"map": False, "model": "parabola", "efficiency_model": "parabola",
                    "beta_grid": {"spacing": "even"}}})
    return solve(req).result


def _load(module_text: str):
    """The module as a user imports it: written to a file, imported, its ExportMap."""
    import importlib.util
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "map_pycycle.py"
        path.write_text(module_text)
        spec = importlib.util.spec_from_file_location("map_pycycle", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    return module.ExportMap


def _problem(map_data, design: bool):
    om = pytest.importorskip("openmdao.api")
    from pycycle.elements.compressor_map import CompressorMap

    p = om.Problem(reports=False)  # no report folders written into the working directory
    # off design with extrapolation, as pyCycle's example cycles run their compressors (map_extrap=True): Newton's
    # first steps on the stall-margin balance leave the table before they converge inside it
    p.model.add_subsystem("map", CompressorMap(map_data=map_data, design=design, extrap=not design), promotes=["*"])
    if not design:  # the operating point's balances (NcMap, RlineMap against Nc, Wc) need Newton
        p.model.nonlinear_solver = om.NewtonSolver(solve_subsystems=False, iprint=-1, maxiter=30, atol=1e-12,
                                                   rtol=1e-12)
        p.model.linear_solver = om.DirectSolver()
    p.setup()
    p.final_setup()  # where OpenMDAO checks the connected units
    return p


def _beta_lookup(result, speed, beta):
    from plantsolve.schemas.perfmap import PerfmapBetaQueryRequest
    from plantsolve.solvers.perfmap.query import answer_beta_query

    a = answer_beta_query(result, PerfmapBetaQueryRequest.model_validate({"speed": speed, "beta": beta})).points[0]
    return np.array([a.flow, a.pressure, a.efficiency])


def test_pycycle_reads_the_exported_module_as_shipped_at_three_nc_rline_points():
    """pyCycle's CompressorMap (design mode: the map read at NcMap, RlineMap) on the exported module: at a node
    exactly the fitted beta map; between two speed lines linear in Nc, as the beta query; between two R-lines
    pyCycle's linear interpolation of the nodes, within the tabulation error of the fitted (here closed-form) map."""
    from plantsolve.solvers.perfmap.cycle_exports import pycycle_module

    res = _closed_form_result()
    module = _load(pycycle_module(res).decode())
    assert [d["name"] for d in module.param_data] == ["alphaMap", "NcMap", "RlineMap"]
    assert [d["name"] for d in module.output_data] == ["WcMap", "effMap", "PRmap"]
    assert set(module.defaults) == {"alphaMap", "NcMap", "RlineMap", "WcMap", "PRmap", "effMap"}
    assert module.units == {"NcMap": "rpm", "WcMap": "kg/s"} and module.RlineStall == 1.0
    p = _problem(module, design=True)
    beta = np.array(res.beta_map.beta)

    def read(nc, rline):
        p.set_val("alphaMap", 0.0)
        p.set_val("NcMap", nc, units="rpm")
        p.set_val("RlineMap", rline)
        p.run_model()
        return np.array([p.get_val("WcMap", units="kg/s")[0], p.get_val("PRmap")[0], p.get_val("effMap")[0]])

    # 1. on the 0.7 line at R = 1.7 (beta 0.65, a node): the closed-form crossing with c = c_choke + beta (c_s - c_c)
    got = read(0.7, 1.7)
    j = int(np.argmin(np.abs(beta - 0.65)))
    line = res.beta_map.lines[1]
    assert got == pytest.approx([line.flow[j], line.pressure[j], line.efficiency[j]], rel=1e-9)
    x = np.sqrt((A[1] - 1) / (B + C_CHOKE + 0.65 * (C_SURGE - C_CHOKE)))
    assert got[:2] == pytest.approx([x, A[1] - B * x * x], rel=1e-9)
    # in pyCycle's own unit too: the declared kg/s is converted
    assert p.get_val("WcMap", units="lbm/s")[0] == pytest.approx(x / 0.45359237, rel=1e-9)
    # 2. between the 0.7 and 0.8 lines at R = 2.2 (beta 0.4): linear in speed, as the beta query
    assert read(0.75, 2.2) == pytest.approx(_beta_lookup(res, 0.75, 0.4), rel=1e-9)
    # 3. on the 0.8 line between R-lines 2.2 and 2.3: pyCycle interpolates the two nodes linearly ...
    k = int(np.argmin(np.abs(beta - 0.4)))
    lo, hi = (np.array([getattr(res.beta_map.lines[2], q)[i] for q in ("flow", "pressure", "efficiency")])
              for i in (k, k - 1))
    got = read(0.8, 2.25)
    assert got == pytest.approx((lo + hi) / 2, rel=1e-9)
    # ... which is the fitted map (exact on the line at beta 0.375) within the tabulation error of a 21-line grid
    exact = _beta_lookup(res, 0.8, 0.375)
    assert np.abs(got - exact) / exact == pytest.approx(0.0, abs=5e-4)


def test_pycycle_off_design_solve_lands_on_the_known_r_line():
    """Off design pyCycle balances NcMap and RlineMap against the corrected speed and flow: given the speed of the
    0.7 line and the flow of its beta 0.65 node (R = 1.7), Newton lands on R = 1.7 and reads that node's pressure
    ratio and efficiency (map scalars 1)."""
    from plantsolve.solvers.perfmap.cycle_exports import pycycle_module

    res = _closed_form_result()
    p = _problem(_load(pycycle_module(res).decode()), design=False)
    line = res.beta_map.lines[1]
    j = int(np.argmin(np.abs(np.array(res.beta_map.beta) - 0.65)))
    for name in ("s_Nc", "s_Wc", "s_PR", "s_eff"):
        p.set_val(name, 1.0)
    p.set_val("alphaMap", 0.0)
    p.set_val("Nc", 0.7, units="rpm")
    p.set_val("Wc", line.flow[j], units="kg/s")
    p.set_val("RlineMap", 2.0)
    p.set_val("NcMap", 0.75, units="rpm")
    p.run_model()
    assert p.get_val("RlineMap")[0] == pytest.approx(1.7, abs=1e-8)
    assert p.get_val("NcMap", units="rpm")[0] == pytest.approx(0.7, abs=1e-10)
    assert p.get_val("PR")[0] == pytest.approx(line.pressure[j], rel=1e-9)
    assert p.get_val("eff")[0] == pytest.approx(line.efficiency[j], rel=1e-9)
    x = np.sqrt((A[1] - 1) / (B + C_CHOKE + 0.65 * (C_SURGE - C_CHOKE)))
    assert p.get_val("PR")[0] == pytest.approx(A[1] - B * x * x, rel=1e-9)


def test_a_real_two_alpha_map_runs_in_pycycle_and_a_map_without_flow_unit_says_so():
    """N3_Fan_map (alpha 0 and 5): pyCycle reads the exported tables at a node of the alpha-5 plane exactly; with
    the line stating its flow unit removed (the upload reads it), WcMap has none (OpenMDAO warns and takes
    CompressorMap's lbm/s) and the module says so."""
    from plantsolve.solvers.perfmap.cycle_exports import pycycle_module

    text = (PYCYCLE / "N3_Fan_map.py").read_text()
    assert "FanMap.units['WcMap'] = 'lbm/s'\n" in text
    text = text.replace("FanMap.units['WcMap'] = 'lbm/s'\n", "")
    res = solve(parse_upload(StoredInput.from_bytes("N3_Fan_map.py", text.encode()), {"map": False})).result
    text = pycycle_module(res).decode()
    assert "the flow unit was not stated" in text
    module = _load(text)
    assert module.units["WcMap"] is None and module.output_data[0]["units"] is None
    with pytest.warns(Warning, match="no units"):
        p = _problem(module, design=True)
    line = next(line for line in res.beta_map.lines if line.setting == [5.0, 0.9])
    j = int(np.argmin(np.abs(np.array(res.beta_map.beta) - 0.5)))  # a node near the middle (adaptive spacing)
    p.set_val("alphaMap", 5.0)
    p.set_val("NcMap", 0.9, units="rpm")
    p.set_val("RlineMap", 1.0 + 2.0 * (1.0 - res.beta_map.beta[j]))
    p.run_model()
    got = [p.get_val("WcMap")[0], p.get_val("PRmap")[0], p.get_val("effMap")[0]]
    assert got == pytest.approx([line.flow[j], line.pressure[j], line.efficiency[j]], rel=1e-9)


@pytest.mark.parametrize("unit, declared, factor", [("lbm/s", "lbm/s", 1.0), ("kg/h", "kg/h", 1.0),
                                                    ("g/min", "kg/s", 1e-3 / 60)])
def test_the_flow_unit_is_declared_in_openmdaos_spelling_or_converted_to_kg_per_s(unit, declared, factor):
    from plantsolve.solvers.perfmap.cycle_exports import pycycle_module

    res = _closed_form_result()
    res = res.model_copy(update={"units": res.units.model_copy(update={"flow": unit})})
    module = _load(pycycle_module(res).decode())
    assert module.units["WcMap"] == declared
    assert module.WcMap[0, 1] == pytest.approx(np.array(res.beta_map.lines[1].flow[::-1]) * factor, rel=1e-9)
    assert module.WcSurge == pytest.approx([line.flow[-1] * factor for line in res.beta_map.lines], rel=1e-9)
