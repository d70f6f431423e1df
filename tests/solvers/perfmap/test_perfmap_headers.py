"""Tables as rig software and cycle codes write them: their header names and units, one or two
setting parameters, an explicit ``columns`` mapping, unknown columns reported (not fatal), and
pyCycle/NPSS MAP_DATA map files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.synthetic import speed_lines

DATA = Path(__file__).parent / "data"
LINES = speed_lines(4, 8, steep=6.0)["positions"]


def k(speed: float) -> float:
    """An IGV schedule that is not linear in speed, so the two settings span a plane."""
    return 3.0 * (speed - 0.5) ** 2


def table(header: list[str], row, sep: str = ",", decimal: str = ".") -> bytes:
    out = [sep.join(header)]
    for p in LINES:
        for f, pr, e in zip(p["flow"], p["pressure"], p["efficiency"]):
            out.append(sep.join(str(v).replace(".", decimal) for v in row(p["setting"][0], f, pr, e)))
    return "\n".join(out).encode()


@pytest.mark.parametrize("header, row, sep, decimal", [
    (["Nc", "Wc [lbm/s]", "PR", "eff"], lambda n, f, p, e: (n, f, p, e), ",", "."),
    (["speed [rpm]", "corrected mass flow [kg/s]", "pressure ratio", "isentropic efficiency [%]"],
     lambda n, f, p, e: (n * 10000, f, p, 100 * e), ";", ","),
    (["N/sqrt(theta)", "R-line", "Wc", "PR", "eta"], lambda n, f, p, e: (n, 2.0, f, p, e), "\t", "."),
    (["Corrected Speed", "Corrected Mass Flow", "Total Pressure Ratio", "Polytropic Efficiency", "T_in [K]"],
     lambda n, f, p, e: (n, f, p, e, 288.15), ",", "."),
])
def test_header_families_of_real_tables(header, row, sep, decimal):
    req = parse_upload(StoredInput.from_bytes("map.csv", table(header, row, sep, decimal)), {"map": False})
    assert len(req.positions) == 4
    assert len(req.setting_names) == 1 and req.setting_names[0] == header[0].split(" [")[0]
    assert req.setting_units == ["rpm" if "[rpm]" in header[0] else ""]
    first = req.positions[0]
    assert first.flow == pytest.approx(LINES[0]["flow"]) and first.efficiency == pytest.approx(LINES[0]["efficiency"])
    codes = {w.code: w for w in req.upload_warnings}
    assert "one setting parameter" in codes["upload_settings"].message.lower()
    assert [p.setting[0] for p in req.positions] == pytest.approx(
        [x["setting"][0] * (10000 if "[rpm]" in header[0] else 1) for x in LINES])
    if "R-line" in header:
        assert codes["upload_rline_not_needed"].details["columns"] == ["R-line"]
    if "T_in [K]" in header:
        assert codes["upload_columns_ignored"].details["columns"] == ["T_in [K]"]
    res = solve(req).result
    assert len(res.settings) == 4 and all(s.pressure_excess <= 0.01 for s in res.settings)


def test_two_setting_parameters_keep_their_names_and_units_in_role_order():
    body = table(["Speed [%]", "IGV [deg]", "Flow", "PR", "Eff"], lambda n, f, p, e: (100 * n, 10 * n + k(n), f, p, e))
    req = parse_upload(StoredInput.from_bytes("rig.csv", body), {"grid": [24, 24]})
    assert req.setting_names == ["IGV", "Speed"] and req.setting_units == ["deg", "%"]
    assert req.positions[0].setting == pytest.approx([5.0 + k(0.5), 50.0])
    res = solve(req).result
    assert res.setting_names == ["IGV", "Speed"] and res.map is not None
    assert len(res.map.settings) == 2 and res.map.theta is not None  # two parameters: also as theta, phi


def test_the_columns_option_maps_any_header_to_a_role():
    body = table(["N1 [%]", "Q [m3/h]", "Pi_tt", "Wirkungsgrad"], lambda n, f, p, e: (n, f, p, e))
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.csv", body), None)
    assert e.value.errors[0].loc == ("file", "header") and "columns" in e.value.errors[0].msg
    options = {"columns": {"N1 [%]": "speed", "Q [m3/h]": "flow", "pi_tt": "pressure", "Wirkungsgrad": "efficiency"},
               "map": False}
    req = parse_upload(StoredInput.from_bytes("rig.csv", body), options)
    assert len(req.positions) == 4 and req.positions[1].setting == pytest.approx(LINES[1]["setting"])
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.csv", body), {"columns": {"N1 [%]": "rpm"}})
    assert e.value.errors[0].loc == ("options", "columns")


def test_four_setting_parameters_name_the_columns_to_drop():
    body = table(["Speed", "IGV", "VGV", "Diffuser", "Flow", "PR", "Eff"], lambda n, f, p, e: (n, 1, 2, 3, f, p, e))
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.csv", body), None)
    assert "IGV" in e.value.errors[0].msg and "'columns'" in e.value.errors[0].msg
    req = parse_upload(StoredInput.from_bytes("rig.csv", body), {"columns": {"VGV": "ignore"}, "map": False})
    assert req.setting_names == ["IGV", "Speed", "Diffuser"]


def test_pycycle_map_data_file():
    text = (DATA / "pycycle_fan_map.py").read_bytes()
    req = parse_upload(StoredInput.from_bytes("fan_map.py", text), None)
    assert len(req.positions) == 18  # 2 alpha x 9 Nc speed lines
    assert req.setting_names == ["alpha", "Nc"]
    assert sorted({p.setting[0] for p in req.positions}) == [0.0, 5.0]
    assert req.positions[0].setting[1] == 0.5 and len(req.positions[0].flow) == 12
    res = solve(req).result
    assert res.map is not None and res.map.reachable_fraction > 0.2
    assert all(s.pressure_excess <= 0.01 for s in res.settings)
    assert any(w.code == "vertical_choke_segment" for w in res.report.warnings)  # Wc repeated at choke


def test_a_pycycle_map_cut_inside_its_last_table_says_where():
    text = (DATA / "pycycle_fan_map.py").read_bytes()
    cut = text[: text.index(b"effMap") + 400]
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("fan_map.py", cut), None)
    (error,) = refused.value.errors
    line = cut[: cut.index(b"effMap")].count(b"\n") + 1
    assert error.loc == ("file", "effMap") and error.type == "truncated_file"
    assert f"line {line}" in error.msg and "cut" in error.msg


@pytest.mark.parametrize("text, needle", [
    (b"import numpy as np\nX = np.array([1, 2])\n", "missing NcMap"),
    (b"M.NcMap = np.array([0.5, 1.0])\nM.WcMap = np.array([[1, 2, 3]])\nM.PRmap = np.array([[1, 2, 3]])\n"
     b"M.effMap = np.array([[0.5, 0.5, 0.5]])\n", "shape"),
    (b"M.NcMap = np.array([0.5])\nM.WcMap = np.array([[1, 2, __import__('os')]])\n",
     "WcMap, line 2: \"__import__('os')\" is not a number"),
])
def test_map_data_that_cannot_be_read_says_why(text, needle):
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("bad.py", text), None)
    assert needle in e.value.errors[0].msg


def test_three_setting_parameters_give_the_maximum_efficiency_map_over_them():
    """Speed, IGV and VGV each varied: the map is the max over the faces of the settings' tetrahedra;
    a duty point on a measured line is matched by a setting whose efficiency is at least that line's."""
    from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapRequest
    from plantsolve.solvers.perfmap.query import query
    from plantsolve.solvers.perfmap.families import curveset_from_fits

    positions = []
    for igv in (0.0, 10.0):
        for vgv in (0.0, 5.0):
            for j, p in enumerate(speed_lines(3, 8, steep=5.0)["positions"]):
                shift = 1 + 0.01 * igv - 0.004 * vgv
                positions.append({"setting": [p["setting"][0], igv, vgv], "flow": [f * shift for f in p["flow"]],
                                  "pressure": p["pressure"],
                                  "efficiency": [e * (1 - 0.002 * igv + 0.001 * vgv) for e in p["efficiency"]]})
    req = PerfmapRequest.model_validate({"setting_names": ["speed", "IGV", "VGV"], "setting_units": ["-", "deg", "deg"],
                                         "positions": positions, "options": {"grid": [20, 20]}})
    res = solve(req).result
    assert res.map is not None and len(res.map.settings) == 3 and res.map.theta is None
    assert any(w.code == "three_parameter_map" for w in res.report.warnings)
    curves = curveset_from_fits(res.settings)
    k0 = 4
    x, y, e = curves.evaluate(np.array([k0]), np.array([0.5]))
    ans = query(res, PerfmapQueryRequest.model_validate({"flow": float(x[0]), "pressure": float(y[0])})).points[0]
    assert ans.feasible and len(ans.setting) == 3 and ans.efficiency >= float(e[0]) - 1e-9
