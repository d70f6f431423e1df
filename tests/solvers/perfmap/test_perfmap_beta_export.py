"""The fitted map on a beta grid for cycle codes: closed-form node positions, single crossings, the pyCycle /
GasTurb / CSV exports read back by the project's own reader, and the (speed, beta) query."""

from __future__ import annotations

import ast
import re
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from plantsolve.schemas.perfmap import (
    BetaGridOption,
    PerfmapBetaQueryRequest,
    PerfmapRequest,
)
from plantsolve.solvers.base import InputRejected, ResultNotUsable, StoredInput
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.artifacts import cycle_code_artifacts
from plantsolve.solvers.perfmap.beta_grid import (
    BetaFrame,
    BetaGridError,
    adaptive_beta,
    check_single_crossings,
)
from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables
from plantsolve.solvers.perfmap.families import curveset_from_fits
from plantsolve.solvers.perfmap.query import answer_beta_query
from tests.support.perfmap_fits import fits_agree

PYCYCLE = Path(__file__).parent / "data" / "pycycle"

# Round-trip tolerances (default grid: 21 adaptive beta lines, exported, read back, fitted again), at the same flow
# on each line. The pressure's is the tabulation error of the broken-line (concave) fits between nodes, largest at
# the steep choke ends, where a flow step is a big pressure step (evenly spaced: 2.0 % at most, axi3_2, 1.2 % on the
# first 90 %; adaptive: 1.05 %, N3_HPC, and 0.47 %; bench/perfmap.py --export).
EFF_ROUND_TRIP = 1e-5  # efficiency, absolute: the efficiency families reproduce their own samples
PRESSURE_ROUND_TRIP = 0.012  # pressure, relative, anywhere (these maps: 0.83 %, N3_Fan)
PRESSURE_ROUND_TRIP_BODY = 0.006  # pressure, relative, on the first 90 % of the flow range (0.33 %)


@cache
def fitted(name: str):
    req = parse_upload(StoredInput.from_bytes(name, (PYCYCLE / name).read_bytes()), {"map": False})
    return solve(req).result


def artifacts(result) -> dict[str, bytes]:
    return {a.name: a.data for a in cycle_code_artifacts(result)}


# ---------------------------------------------------------------- known answer

A = np.array([1.6, 2.2, 3.0, 4.0])  # PR = A_k - B Wc^2 on line k (speeds 0.6 ... 0.9)
B = 0.02
C_SURGE, C_CHOKE = 0.05, 0.01  # surge and choke lines: PR - 1 = c Wc^2
SPEEDS = [0.6, 0.7, 0.8, 0.9]


def closed_form_flow(a: float, c: np.ndarray, p: int) -> np.ndarray:
    """Crossing of PR = a - B x^2 with PR - 1 = c x^p."""
    if p == 2:
        return np.sqrt((a - 1) / (B + c))
    return (-c + np.sqrt(c * c + 4 * B * (a - 1))) / (2 * B)


def closed_form_request(shape: str, spacing: str = "even") -> PerfmapRequest:
    positions = []
    for a, n in zip(A, SPEEDS):
        xs, xc = closed_form_flow(a, np.array([C_SURGE, C_CHOKE]), 2)
        x = np.linspace(xs, xc, 7)
        eta = 0.9 - 0.2 * ((x - xs) / (xc - xs) - 0.4) ** 2
        positions.append({"setting": [n], "flow": x.tolist(), "pressure": (a - B * x * x).tolist(),
                          "efficiency": eta.tolist()})
    return PerfmapRequest.model_validate({
        "setting_names": ["Nc"], "units": {"flow": "kg/s", "pressure": "1"}, "positions": positions,
        "options": {"map": False, "model": "parabola", "efficiency_model": "parabola",
                    "beta_grid": {"lines": 11, "shape": shape, "spacing": spacing}}})


@pytest.mark.parametrize("spacing", ["even", "adaptive"])
@pytest.mark.parametrize("shape, p", [("parabola", 2), ("straight", 1)])
def test_beta_nodes_of_closed_form_speed_lines_match_the_closed_form(shape, p, spacing):
    """Speed lines PR = A_k - B Wc^2 from the parabola PR - 1 = 0.05 Wc^2 (surge) to PR - 1 = 0.01 Wc^2 (choke):
    the fit is exact (a parabola family), so every node is the closed-form crossing with the beta line
    c = c_choke + beta (c_surge - c_choke), and with parabolic beta lines c_surge/c_choke are 0.05/0.01 on
    every line: each beta line is one parabola through the vertex (0, 1). Evenly spaced or adaptive, the beta
    values differ, the nodes' rule does not."""
    res = solve(closed_form_request(shape, spacing)).result
    b = res.beta_map
    assert (b.shape, b.exponent, b.vertex_flow, b.vertex_pressure) == (shape, p, 0.0, 1.0)
    beta = np.array(b.beta)
    assert b.spacing == spacing and len(beta) == 11 and beta[0] == 0.0 and beta[-1] == 1.0
    if spacing == "even":
        assert np.allclose(beta, np.linspace(0, 1, 11))
    else:  # multiples of 0.001, ascending, not the even grid
        assert np.all(np.diff(beta) > 0) and beta * 1000 == pytest.approx(np.round(beta * 1000), abs=1e-9)
        assert not np.allclose(beta, np.linspace(0, 1, 11))
    for a, line in zip(A, b.lines):
        ends = closed_form_flow(a, np.array([C_CHOKE, C_SURGE]), 2)
        c_ends = (a - B * ends ** 2 - 1) / ends ** p
        assert [line.c_choke, line.c_surge] == pytest.approx(c_ends, rel=1e-9)
        if p == 2:
            assert [line.c_choke, line.c_surge] == pytest.approx([C_CHOKE, C_SURGE], rel=1e-9)
        c = c_ends[0] + beta * (c_ends[1] - c_ends[0])
        x = closed_form_flow(a, c, p)
        assert np.array(line.flow) == pytest.approx(x, rel=1e-9)
        assert np.array(line.pressure) == pytest.approx(a - B * x * x, rel=1e-9)
        xs, xc = ends[1], ends[0]
        assert np.array(line.efficiency) == pytest.approx(0.9 - 0.2 * ((x - xs) / (xc - xs) - 0.4) ** 2, abs=1e-9)
        assert line.flow[0] == pytest.approx(xc, rel=1e-12) and line.flow[-1] == pytest.approx(xs, rel=1e-12)


def test_adaptive_beta_puts_the_nodes_on_the_kinks_of_broken_lines():
    """Two broken lines over 1001 candidate betas (flow falling with beta): one with kinks at beta 0.3 and 0.7, one
    with a kink at 0.05 near its choke end. Five beta values: the ends and exactly the three kinks, so the chords
    are the lines; with three the sharper kinks win; nodes never closer than 2e-4 of a line's flow range."""
    candidates = np.round(np.linspace(0, 1, 1001), 12)
    x = np.vstack([10 - 5 * candidates, 20 - 8 * candidates])
    y1 = np.interp(candidates, [0, 0.3, 0.7, 1], [1.2, 1.6, 1.8, 1.85])
    y2 = np.interp(candidates, [0, 0.05, 1], [1.0, 2.0, 2.4])
    y = np.vstack([y1, y2])
    assert adaptive_beta(x, y, candidates, 5).tolist() == [0.0, 0.05, 0.3, 0.7, 1.0]
    assert adaptive_beta(x, y, candidates, 3).tolist() == [0.0, 0.05, 1.0]
    steep = np.vstack([10 - 5 * candidates ** 8, 20 - 8 * candidates])  # line 1 barely moves near beta 0
    beta = adaptive_beta(steep, y, candidates, 8)
    k = np.searchsorted(candidates, beta)
    gaps = np.abs(np.diff(steep[:, k], axis=1)) / np.ptp(steep, axis=1)[:, None]
    assert len(beta) == 8 and gaps.min() >= 2e-4


def test_gasturb_table_of_the_closed_form_map_holds_its_values_and_surge_line():
    res = solve(closed_form_request("parabola")).result
    text = artifacts(res)["map_gasturb.map"].decode()
    tables = read_gasturb(text)
    head = text.splitlines()[0]
    assert head.startswith("99 ") and text.splitlines()[1] == "Reynolds: RNI=1 f=1 RNI=1 f=1"
    # readers find blocks by scanning for their titles, in this order
    assert not re.search("MASS FLOW|EFFICIENCY|PRESSURE RATIO|SURGE LINE", head.upper())
    at = [text.index(f"\n{t}\n") for t in ("Mass Flow", "Efficiency", "Pressure Ratio", "Surge Line")]
    assert at == sorted(at)
    speeds, beta, wc = tables["Mass Flow"]
    assert speeds == pytest.approx(SPEEDS) and beta == pytest.approx(np.linspace(0, 1, 11))
    assert wc == pytest.approx(np.array([line.flow for line in res.beta_map.lines]), rel=1e-6)
    assert tables["Pressure Ratio"][2] == pytest.approx(np.array([line.pressure for line in res.beta_map.lines]),
                                                        rel=1e-6)
    assert tables["Efficiency"][2] == pytest.approx(np.array([line.efficiency for line in res.beta_map.lines]),
                                                    abs=1e-6)
    surge_w, surge_pr = tables["Surge Line"]
    xs = closed_form_flow(A, np.full(4, C_SURGE), 2)
    assert surge_w == pytest.approx(xs, rel=1e-6) and surge_pr == pytest.approx(1 + C_SURGE * xs ** 2, rel=1e-6)
    choke_w, choke_pr = tables["Choke Line"]
    xc = closed_form_flow(A, np.full(4, C_CHOKE), 2)
    assert choke_w == pytest.approx(xc, rel=1e-6) and choke_pr == pytest.approx(1 + C_CHOKE * xc ** 2, rel=1e-6)


def _record(lines: list[str], i: int, n: int) -> tuple[list[float], int]:
    """A record of the published layout at line i: a leading number (key or speed) and n values, four on the first
    line and five on each further line; (its numbers, the next line)."""
    out = []
    for k in range(1 + max(0, -(-(n - 4) // 5))):
        cells = lines[i + k].split()
        assert len(cells) == (5 if k == 0 else min(5, n - 4 - 5 * (k - 1))) or (k == 0 and n < 4 and len(cells) == n + 1)
        out += [float(c) for c in cells]
    return out, i + 1 + max(0, -(-(n - 4) // 5))


def read_gasturb(text: str) -> dict:
    """The GasTurb layout as map readers parse it: a block title, 'R.CCC' (R - 1 rows, CCC - 1 columns) and the
    column values, then one row per speed, each record four values after its first number and five a line after
    that; a limit line is 'R.CCC' + flows, then a label + pressure ratios; a blank line closes each table."""
    lines = text.splitlines()
    out = {}
    for i, title in enumerate(lines):
        if title in ("Mass Flow", "Efficiency", "Pressure Ratio", "Surge Line", "Choke Line"):
            rows, cols = divmod(float(lines[i + 1].split()[0]), 1)
            n_rows, n_cols = round(rows) - 1, round(cols * 1000) - 1
            head, j = _record(lines, i + 1, n_cols)
            body = []
            for _ in range(n_rows):
                row, j = _record(lines, j, n_cols)
                body.append(row)
            body = np.array(body)
            assert lines[j] == ""
            if title in ("Surge Line", "Choke Line"):
                assert n_rows == 1
                out[title] = (np.array(head[1:]), body[0, 1:])
            else:
                out[title] = (body[:, 0], np.array(head[1:]), body[:, 1:])
    return out


# ---------------------------------------------------------------- crossings and ends on the real maps

@pytest.mark.parametrize("name", ["N3_Fan_map.py", "HPC_map.py", "axi3_2.py"])
def test_every_beta_line_crosses_every_speed_line_once_between_its_surge_and_choke_ends(name):
    res = fitted(name)
    b = res.beta_map
    assert b.vertex_flow == 0.0 and b.vertex_pressure == 1.0 and len(b.beta) == 21
    assert "beta_grid_choke_nodes" not in {w.code for w in res.report.warnings}
    curves = curveset_from_fits(res.settings)
    for k, line in enumerate(b.lines):
        t = np.array(line.t)
        assert t[0] == 1.0 and t[-1] == 0.0 and np.all(np.diff(t) < 0)  # one node per beta, in order
        x, y, e = curves.evaluate(np.full(len(t), k), t)
        assert np.array(line.flow) == pytest.approx(x, rel=1e-12) and np.array(line.efficiency) == pytest.approx(e)
        c = (y - 1.0) / x ** 2
        assert c == pytest.approx(line.c_choke + np.array(b.beta) * (line.c_surge - line.c_choke), rel=1e-9)
        # beta = 1 is the surge point, beta = 0 the choke point of the fitted line
        assert (line.flow[-1], line.pressure[-1]) == pytest.approx((res.surge_line[k].flow, res.surge_line[k].pressure))
        assert (line.flow[0], line.pressure[0]) == pytest.approx((res.choke_line[k].flow, res.choke_line[k].pressure))


def test_a_vertex_a_speed_line_reaches_is_refused_naming_the_line():
    res = fitted("N3_Fan_map.py")
    curves = curveset_from_fits(res.settings)
    low = int(np.argmin([s.x_min for s in res.settings]))
    y_top = res.surge_line[low].pressure
    with pytest.raises(BetaGridError) as e:
        check_single_crossings(curves, BetaFrame(2, 0.0, y_top))
    assert "vertex" in e.value.reason


# ---------------------------------------------------------------- round trips through the project's reader

@pytest.mark.parametrize("name, export", [("N3_Fan_map.py", "map_pycycle.py"), ("HPC_map.py", "map_pycycle.py"),
                                          ("axi3_2.py", "map_pycycle.py"), ("axi3_2.py", "map_beta.csv")])
def test_an_export_read_back_and_fitted_again_gives_the_same_speed_lines(name, export):
    res = fitted(name)
    again = solve(parse_upload(StoredInput.from_bytes(export, artifacts(res)[export]), {"map": False})).result
    p_all, p_body, e_all = fits_agree(res, again, abs=1e-4)
    assert p_all <= PRESSURE_ROUND_TRIP and p_body <= PRESSURE_ROUND_TRIP_BODY and e_all <= EFF_ROUND_TRIP


def test_the_round_trip_error_is_the_grids_tabulation_error_it_falls_with_more_beta_lines():
    """axi3_2's high-alpha lines, whose minimax broken lines have the sharpest kinks: evenly spaced, the round trip
    halves from 11 to 40 beta lines; the stated table error falls with it and bounds it (with the refit's own
    error); the adaptive spacing of 11 lines does better than 40 evenly spaced ones."""
    req = parse_upload(StoredInput.from_bytes("axi3_2.py", (PYCYCLE / "axi3_2.py").read_bytes()), {"map": False})
    hard = [p for p in req.positions if p.setting[0] == 90.0 and p.setting[1] in (0.5, 0.8, 0.9, 0.95)]
    errors, stated = {}, {}
    for lines, spacing in ((11, "even"), (40, "even"), (11, "adaptive")):
        res = solve(req.model_copy(update={"positions": hard, "options": req.options.model_copy(
            update={"beta_grid": BetaGridOption(lines=lines, spacing=spacing)})})).result
        data = artifacts(res)["map_beta.csv"]
        again = solve(parse_upload(StoredInput.from_bytes("b.csv", data), {"map": False})).result
        errors[lines, spacing] = fits_agree(res, again, abs=1e-4)
        stated[lines, spacing] = res.beta_map.table_pressure_max_rel_error
        refit = max(s.pressure_max_rel_error for s in again.settings)
        assert errors[lines, spacing][0] <= stated[lines, spacing] + refit + 1e-6
    (all11, body11, _), (all40, body40, _) = errors[11, "even"], errors[40, "even"]
    assert body40 < 0.5 * body11 and all40 < 0.5 * all11 and body40 <= 0.006
    assert stated[40, "even"] < 0.5 * stated[11, "even"]
    assert stated[11, "adaptive"] < stated[40, "even"] and errors[11, "adaptive"][0] < all40


def test_a_grid_whose_choke_nodes_a_reader_would_merge_says_so_per_line():
    """N3_LPC's 1.2 speed lines fall so steeply at choke that with 40 evenly spaced beta lines their first two nodes
    lie within 1e-4 of the flow range, which the reader takes as a vertical choke segment (and its round trip then
    loses the steep end: 8 % in efficiency at choke). The adaptive spacing keeps every line's nodes apart."""
    body = (PYCYCLE / "N3_LPC_map.py").read_bytes()
    res = solve(parse_upload(StoredInput.from_bytes("N3_LPC_map.py", body),
                             {"map": False, "beta_grid": {"lines": 40, "spacing": "even"}})).result
    (w,) = [w for w in res.report.warnings if w.code == "beta_grid_choke_nodes"]
    assert w.details == {"values": [[0.0, 1.2], [1.0, 1.2]], "lines": 40}
    for values in w.details["values"]:
        line = next(line for line in res.beta_map.lines if line.setting == values)
        assert line.flow[0] - line.flow[1] <= 1e-4 * (line.flow[0] - line.flow[-1])
    adaptive = solve(parse_upload(StoredInput.from_bytes("N3_LPC_map.py", body),
                                  {"map": False, "beta_grid": {"lines": 40}})).result
    assert "beta_grid_choke_nodes" not in {w.code for w in adaptive.report.warnings}
    assert adaptive.beta_map.table_pressure_max_rel_error < res.beta_map.table_pressure_max_rel_error


def test_the_pycycle_module_has_pycycles_layout_r_lines_from_stall_to_choke():
    res = fitted("N3_Fan_map.py")
    text = artifacts(res)["map_pycycle.py"].decode()
    arrays = {m.group(1): np.array(ast.literal_eval(m.group(2)))
              for m in re.finditer(r"^ExportMap\.(\w+) = np\.array\((.*?)\)$", text, re.MULTILINE | re.DOTALL)}
    assert "ExportMap.RlineStall = 1.0" in text and "from pycycle.maps.map_data import MapData" in text
    assert arrays["alphaMap"].tolist() == [0, 5] and len(arrays["NcMap"]) == 9
    assert arrays["RlineMap"] == pytest.approx(1 + 2 * (1 - np.array(res.beta_map.beta[::-1])), abs=1e-12)
    assert arrays["RlineMap"][0] == 1.0 and arrays["RlineMap"][-1] == 3.0 and len(arrays["RlineMap"]) == 21
    assert arrays["WcMap"].shape == arrays["PRmap"].shape == arrays["effMap"].shape == (2, 9, 21)
    assert np.all(np.diff(arrays["WcMap"], axis=2) > 0)  # flow rises from stall to choke, as in pyCycle's maps
    assert np.all(np.diff(arrays["PRmap"], axis=2) <= 1e-12)
    for which, points in (("Surge", res.surge_line), ("Choke", res.choke_line)):
        exported = np.array(sorted(zip(arrays[f"Wc{which}"], arrays[f"PR{which}"])))
        assert exported == pytest.approx(np.array(sorted((p.flow, p.pressure) for p in points)), rel=1e-9)


def test_a_speed_only_map_is_written_for_pycycle_at_two_equal_alphas():
    """pyCycle interpolates in alpha as well; its maps without variable geometry repeat the table at two alphas."""
    res = solve(closed_form_request("parabola")).result
    req = parse_upload(StoredInput.from_bytes("m.py", artifacts(res)["map_pycycle.py"]), {"map": False})
    assert req.setting_names == ["alpha", "Nc"]
    by_alpha = {a: [p for p in req.positions if p.setting[0] == a] for a in (0.0, 90.0)}
    assert [p.setting[1] for p in by_alpha[0.0]] == SPEEDS
    assert [p.flow for p in by_alpha[0.0]] == [p.flow for p in by_alpha[90.0]]
    assert by_alpha[0.0][1].flow == pytest.approx(res.beta_map.lines[1].flow[::-1], rel=1e-9)


def test_gasturb_file_names_are_file_names_whatever_the_settings_are_called():
    res = fitted("N3_Fan_map.py")
    renamed = res.model_copy(update={"setting_names": ["IGV/VGV [deg]", "Nc"]})
    assert sorted(gasturb_tables(renamed)) == ["map_gasturb_IGV_VGV_deg_0.map", "map_gasturb_IGV_VGV_deg_5.map"]


def test_no_pycycle_module_when_the_settings_are_no_full_alpha_speed_grid():
    res = fitted("N3_Fan_map.py")
    cut = res.model_copy(update={"beta_map": res.beta_map.model_copy(update={"lines": res.beta_map.lines[:-1]})})
    names = set(artifacts(cut))
    assert "map_pycycle.py" not in names and {"map_beta.csv", "map_gasturb_alpha0.map"} <= names


# ---------------------------------------------------------------- (speed, beta) query

def test_query_by_speed_and_beta_is_exact_on_a_line_and_linear_in_speed_between_lines():
    res = solve(closed_form_request("parabola")).result
    q = PerfmapBetaQueryRequest.model_validate({"points": [{"speed": 0.7, "beta": 0.5}, {"speed": 0.75, "beta": 1.0},
                                                           {"speed": 0.9, "beta": 0.0}]})
    on, between, choke = answer_beta_query(res, q).points
    x = closed_form_flow(A[1], np.array([C_CHOKE + 0.5 * (C_SURGE - C_CHOKE)]), 2)[0]
    assert on.on_speed_line and (on.flow, on.pressure) == pytest.approx((x, A[1] - B * x * x), rel=1e-9)
    xs = closed_form_flow(A[1:3], np.full(2, C_SURGE), 2)
    assert not between.on_speed_line and between.flow == pytest.approx(xs.mean(), rel=1e-9)
    assert between.pressure == pytest.approx((1 + C_SURGE * xs ** 2).mean(), rel=1e-9)
    assert choke.flow == pytest.approx(closed_form_flow(A[3], np.array([C_CHOKE]), 2)[0], rel=1e-12)
    single = answer_beta_query(res, PerfmapBetaQueryRequest.model_validate({"speed": 0.7, "beta": 0.5})).points[0]
    assert single.flow == on.flow


def test_query_with_alpha_and_refusals_name_the_point():
    res = fitted("N3_Fan_map.py")
    line = next(line for line in res.beta_map.lines if line.setting == [5.0, 0.9])
    a = answer_beta_query(res, PerfmapBetaQueryRequest.model_validate(
        {"points": [{"setting": [5.0, 0.9], "beta": res.beta_map.beta[7]}]})).points[0]
    assert (a.flow, a.pressure, a.efficiency) == pytest.approx((line.flow[7], line.pressure[7], line.efficiency[7]))
    bad = {"points": [{"setting": [5.0, 1.3], "beta": 0.5}, {"setting": [2.0, 0.9], "beta": 0.5},
                      {"speed": 0.9, "beta": 0.5}]}
    with pytest.raises(InputRejected) as e:
        answer_beta_query(res, PerfmapBetaQueryRequest.model_validate(bad))
    locs = [err.loc for err in e.value.errors]
    assert locs == [("points", 0, "setting", 1), ("points", 1, "setting", 0), ("points", 2, "speed")]
    assert "outside the map's speed lines" in e.value.errors[0].msg
    with pytest.raises(ValueError):
        PerfmapBetaQueryRequest.model_validate({"speed": 0.9, "beta": 1.5})
    with pytest.raises(ResultNotUsable):
        answer_beta_query(res.model_copy(update={"beta_map": None}),
                          PerfmapBetaQueryRequest.model_validate({"speed": 0.9, "beta": 0.5}))


def test_the_example_beta_query_on_the_n3_job(n3_result):
    """examples/perfmap/beta_query.json on the example job (theta, speed): lines at 0.9 and 0.95 are fitted
    lines, 0.85 lies between 0.8 and 0.9."""
    body = (Path(__file__).parents[3] / "examples" / "perfmap" / "beta_query.json").read_text()
    on, surge, between = answer_beta_query(n3_result, PerfmapBetaQueryRequest.model_validate_json(body)).points
    assert on.on_speed_line and not between.on_speed_line
    k = {tuple(s.setting or (s.theta, s.phi)): i for i, s in enumerate(n3_result.settings)}[(5.0, 0.95)]
    assert (surge.flow, surge.pressure) == pytest.approx((n3_result.surge_line[k].flow, n3_result.surge_line[k].pressure))
    lo, hi = (answer_beta_query(n3_result, PerfmapBetaQueryRequest.model_validate(
        {"setting": [0.0, speed], "beta": 0.25})).points[0] for speed in (0.8, 0.9))
    assert lo.on_speed_line and hi.on_speed_line
    assert between.flow == pytest.approx((lo.flow + hi.flow) / 2, rel=1e-9)
    assert between.efficiency == pytest.approx((lo.efficiency + hi.efficiency) / 2, rel=1e-9)
