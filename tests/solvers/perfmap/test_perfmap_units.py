"""Units end to end: header units read with pint as exporters spell them, refused when their dimensions do
not fit the column, stated in the result, and converted on request without changing the answer."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import check_input
from plantsolve.solvers.perfmap.synthetic import speed_lines
from plantsolve.solvers.perfmap.units import UnitError, check_quantity, parse_unit

LINES = speed_lines(4, 8, steep=6.0)["positions"]


def table(header: list[str], sep: str = ";", flow_scale: float = 1.0, eff_scale: float = 1.0,
          extra_rows: tuple[str, ...] = (), under_header: tuple[str, ...] = ()) -> bytes:
    out = list(extra_rows) + [sep.join(header)] + list(under_header)
    for p in LINES:
        for f, pr, e in zip(p["flow"], p["pressure"], p["efficiency"]):
            out.append(sep.join(str(v) for v in (p["setting"][0], f * flow_scale, pr, e * eff_scale)))
    return "\n".join(out).encode()


@pytest.mark.parametrize("text, canonical, dims", [
    ("m3/h", "m³/h", "[length] ** 3 / [time]"), ("m^3/s", "m³/s", "[length] ** 3 / [time]"),
    ("m³/s", "m³/s", "[length] ** 3 / [time]"), ("kg/s", "kg/s", "[mass] / [time]"),
    ("lbm/s", "lbm/s", "[mass] / [time]"), ("°C", "°C", "[temperature]"), ("degC", "°C", "[temperature]"),
    ("rpm", "rpm", "1 / [time]"), ("1/min", "1/min", "1 / [time]"), ("[bar]", "bar", "[mass] / [length] / [time] ** 2"),
    ("psi", "psi", "[mass] / [length] / [time] ** 2"), ("%", "%", "dimensionless"), ("-", "1", "dimensionless"),
])
def test_spellings_of_real_exporters(text, canonical, dims):
    u = parse_unit(text)
    assert u.text == canonical
    assert (str(u.unit.dimensionality) if not u.dimensionless else "dimensionless") == dims


def test_factors_are_pints():
    assert parse_unit("lbm/s").factor_to(parse_unit("kg/s")) == pytest.approx(0.45359237)
    assert parse_unit("m3/h").factor_to(parse_unit("m³/s")) == pytest.approx(1 / 3600)
    assert parse_unit("bar").factor_to(parse_unit("kPa")) == pytest.approx(100.0)
    assert parse_unit("psi").factor_to(parse_unit("Pa")) == pytest.approx(6894.757, rel=1e-6)
    with pytest.raises(UnitError, match="not a unit of flow"):
        check_quantity("flow", "kg")
    with pytest.raises(UnitError, match="not understood"):
        parse_unit("zorkmids")


def test_header_units_are_stated_in_the_result():
    body = table(["Speed [rpm]", "Flow [m3/h]", "Pressure rise [bar]", "Efficiency [%]"], eff_scale=100)
    req = parse_upload(StoredInput.from_bytes("rig.csv", body), {"map": False})
    assert req.units.flow == "m³/h" and req.units.pressure == "bar" and req.units.efficiency == "1"
    assert req.positions[0].efficiency == pytest.approx(LINES[0]["efficiency"])  # % divided out
    res = solve(req).result
    assert res.units.model_dump() == {"flow": "m³/h", "pressure": "bar", "efficiency": "1", "settings": ["rpm"]}


def test_a_pressure_ratio_without_unit_is_dimensionless_and_a_bare_flow_is_unstated():
    req = parse_upload(StoredInput.from_bytes("rig.csv", table(["Nc", "Wc", "PR", "eff"], sep=",")), {"map": False})
    assert req.units.flow is None and req.units.pressure == "1"
    assert solve(req).result.units.flow is None


@pytest.mark.parametrize("header, column", [
    (["Speed", "Flow [kg]", "PR", "Eff"], "Flow [kg]"),
    (["Speed", "Flow", "PR [m/s]", "Eff"], "PR [m/s]"),
    (["Speed", "Flow", "PR", "Efficiency [bar]"], "Efficiency [bar]"),
    (["Speed", "Flow [quarts of ale]", "PR", "Eff"], "Flow [quarts of ale]"),
])
def test_an_incompatible_unit_is_refused_naming_the_column(header, column):
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.csv", table(header)), None)
    err = e.value.errors[0]
    assert err.loc == ("file", "header") and repr(column) in err.msg and "line 1" in err.msg


def test_units_after_a_comma_in_a_units_row_and_below_title_lines():
    body = table(["Speed, rpm", "Flow, kg/s", "Pressure, kPa", "Efficiency, %"], eff_scale=100,
                 extra_rows=("Rig 7 acceptance test", "Inlet 288.15 K; 101.325 kPa"))
    req = parse_upload(StoredInput.from_bytes("rig.csv", body), {"map": False})
    assert req.units.flow == "kg/s" and req.units.pressure == "kPa" and req.setting_units == ["rpm"]
    assert req.setting_names == ["Speed"]
    codes = {w.code: w for w in req.upload_warnings}
    assert codes["upload_rows_above_header"].details["rows"] == [1, 2]
    assert req.positions[0].efficiency == pytest.approx(LINES[0]["efficiency"])

    body = table(["Speed", "Flow", "Pressure", "Efficiency"], eff_scale=100, under_header=("[rpm];[m3/h];[psi];[%]",))
    req = parse_upload(StoredInput.from_bytes("rig.csv", body), {"map": False})
    assert (req.units.flow, req.units.pressure, req.setting_units) == ("m³/h", "psi", ["rpm"])
    assert req.positions[0].efficiency == pytest.approx(LINES[0]["efficiency"])
    assert {w.code for w in req.upload_warnings} >= {"upload_units_row"}


def test_result_units_convert_without_changing_the_answer():
    body = table(["Nc", "Wc [lbm/s]", "PR", "eff"], sep=",")
    plain = solve(parse_upload(StoredInput.from_bytes("rig.csv", body), {"grid": [16, 16]})).result
    conv = solve(parse_upload(StoredInput.from_bytes("rig.csv", body), {"grid": [16, 16], "result_units": {"flow": "kg/s"}})).result
    assert plain.units.flow == "lbm/s" and conv.units.flow == "kg/s"
    assert conv.flow_range == pytest.approx(np.multiply(plain.flow_range, 0.45359237).tolist())
    assert conv.settings[0].x_max == pytest.approx(plain.settings[0].x_max * 0.45359237)
    # relative errors and the map (on its own grid over the converted range) are unit-free
    assert [s.pressure_max_rel_error for s in conv.settings] == pytest.approx(
        [s.pressure_max_rel_error for s in plain.settings], rel=1e-6, abs=1e-12)
    a, b = np.array(plain.map.efficiency, dtype=float), np.array(conv.map.efficiency, dtype=float)
    assert np.array_equal(np.isfinite(a), np.isfinite(b)) and np.nanmax(abs(a - b)) < 1e-9
    # a duty point in the map's units: the same answer in lbm/s and in kg/s, and the answer says its units
    from plantsolve.schemas.perfmap import PerfmapQueryRequest
    from plantsolve.solvers.perfmap.query import query
    x = 0.5 * sum(plain.flow_range)
    y = 0.5 * sum(plain.pressure_range)
    pa = query(plain, PerfmapQueryRequest.model_validate({"flow": x, "pressure": y}))
    pb = query(conv, PerfmapQueryRequest.model_validate({"flow": x * 0.45359237, "pressure": y}))
    assert pa.units.flow == "lbm/s" and pb.units.flow == "kg/s"
    assert pa.points[0].feasible == pb.points[0].feasible
    if pa.points[0].feasible:
        assert pb.points[0].efficiency == pytest.approx(pa.points[0].efficiency, rel=1e-9)


def test_json_requests_state_units_and_are_refused_field_by_field():
    base = {"setting_names": ["Nc"], "positions": LINES}
    req = PerfmapRequest.model_validate({**base, "units": {"flow": "kg/s", "pressure": "bar", "efficiency": "%"},
                                         "positions": [{**p, "efficiency": [100 * e for e in p["efficiency"]]}
                                                       for p in LINES], "options": {"map": False}})
    check_input(req)
    res = solve(req).result
    assert res.units.flow == "kg/s" and res.settings[0].efficiency_peak <= 1.0
    for units, loc in (({"flow": "kg"}, ("units", "flow")), ({"efficiency": "kg/s"}, ("units", "efficiency")),
                       ({"pressure": "zorkmids"}, ("units", "pressure"))):
        with pytest.raises(InputRejected) as e:
            check_input(PerfmapRequest.model_validate({**base, "units": units}))
        assert e.value.errors[0].loc == loc
    with pytest.raises(InputRejected) as e:  # a conversion needs a stated unit to start from
        check_input(PerfmapRequest.model_validate({**base, "options": {"result_units": {"flow": "kg/s"}}}))
    assert e.value.errors[0].loc == ("options", "result_units", "flow")
    with pytest.raises(InputRejected) as e:
        check_input(PerfmapRequest.model_validate({**base, "units": {"flow": "kg/s"},
                                                   "options": {"result_units": {"flow": "m3/h"}}}))
    assert e.value.errors[0].loc == ("options", "result_units", "flow") and "other dimensions" in e.value.errors[0].msg
