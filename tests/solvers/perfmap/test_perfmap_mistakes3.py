"""Mistakes of the third probe: a gauge pressure converted to an absolute unit by a factor alone, a temperature
column taken for the speed, a pyCycle map whose stated flow unit was not read."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

LINES = (DATA / "n3_fan_map.csv").read_text().replace("\r\n", "\n").splitlines()  # theta,phi,flow,pressure,efficiency


def _load(content: str, name: str = "rig.csv", options=None):
    source = StoredInput.from_bytes(name, content.encode())
    return load(parse_upload(source, options), source)


def _header(header: str) -> str:
    return "\n".join([header] + LINES[1:]) + "\n"


@pytest.mark.parametrize("given, wanted", [("barg", "bar"), ("barg", "kPa"), ("psig", "psi"), ("psia", "psig")])
def test_a_gauge_pressure_is_not_converted_to_an_absolute_unit_by_a_factor(given, wanted):
    with pytest.raises(InputRejected) as refused:
        _load(_header(f"theta,phi,flow,pressure [{given}],efficiency"), options={"result_units": {"pressure": wanted}})
    (error,) = refused.value.errors
    assert error.loc == ("options", "result_units", "pressure") and "gauge" in error.msg


def test_gauge_to_gauge_and_absolute_to_absolute_still_convert():
    plain = _load(_header("theta,phi,flow,pressure [bara],efficiency"), options={"result_units": {"pressure": "kPa"}})
    assert plain.units.pressure == "kPa"
    gauge = _load(_header("theta,phi,flow,pressure [barg],efficiency"), options={"result_units": {"pressure": "psig"}})
    (conversion,) = [c for c in gauge.source["conversions"] if c["quantity"] == "pressure"]
    assert conversion["factor"] == pytest.approx(100_000 / 6894.757293168361, rel=1e-12)


@pytest.mark.parametrize("unit", ["K", "degC", "kg", "bar", "kg/s"])
def test_a_speed_column_in_a_unit_no_speed_has_is_refused_naming_the_header(unit):
    with pytest.raises(InputRejected) as refused:
        _load(_header(f"theta,speed [{unit}],flow,pressure,efficiency"))
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and "'speed'" in error.msg and "named as a speed" in error.msg


@pytest.mark.parametrize("unit", ["rpm", "%", "-", "rad/s", "rpm/K^0.5", "rpm/R^0.5", "rpm/sqrt(degR)"])
def test_speed_units_are_accepted(unit):
    _load(_header(f"theta,speed [{unit}],flow,pressure,efficiency"))


def test_a_json_request_names_the_setting_unit():
    from plantsolve.schemas.perfmap import PerfmapRequest
    from plantsolve.solvers.perfmap.synthetic import request_body
    body = request_body()
    positions = [{"setting": [p.pop("theta"), p.pop("phi")], **p} for p in body["positions"]]
    body = {**body, "positions": positions, "setting_names": ["IGV", "Nc"], "setting_units": ["deg", "degF"]}
    with pytest.raises(InputRejected) as refused:
        load(PerfmapRequest.model_validate(body))
    assert refused.value.errors[0].loc == ("setting_units", 1)


def test_a_pycycle_map_states_its_flow_unit_and_converts_with_it():
    text = (DATA / "pycycle_fan_map.py").read_text()
    assert "units['WcMap'] = 'lbm/s'" in text
    as_read = _load(text, "fan.py")
    assert as_read.units.flow == "lbm/s"  # was None: a flow without its unit
    in_kg = _load(text, "fan.py", {"result_units": {"flow": "kg/s"}})
    flows = np.concatenate([p.flow for p in as_read.internal.positions])
    np.testing.assert_allclose(np.concatenate([p.flow for p in in_kg.internal.positions]), flows * 0.45359237,
                               rtol=1e-12)


# ---------------------------------------------------------------- GasTurb maps: units the file contradicts

COMPMAP = (DATA / "gasturb" / "compmap.map").read_text()


@pytest.mark.parametrize("unit", ["psi", "kPa", "bar"])
def test_a_pressure_unit_over_a_gasturb_pressure_ratio_table_is_refused(unit):
    """The Pressure Ratio table holds p2/p1; the option labelled the ratios 0.94..7.9 as psi without a word."""
    with pytest.raises(InputRejected) as refused:
        _load(COMPMAP, "compmap.map", {"units": {"pressure": unit}})
    (error,) = refused.value.errors
    assert error.loc == ("options", "units", "pressure") and "ratios" in error.msg


def test_a_flow_unit_option_contradicting_the_maps_own_is_refused_and_an_agreeing_one_is_read():
    stated = COMPMAP.replace("Mass Flow\n", "Mass Flow [lb/s]\n", 1)
    with pytest.raises(InputRejected) as refused:
        _load(stated, "compmap.map", {"units": {"flow": "kg/s"}})
    (error,) = refused.value.errors
    assert error.loc == ("options", "units", "flow") and "'lb/s'" in error.msg and "'kg/s'" in error.msg
    agreeing = _load(stated, "compmap.map", {"units": {"flow": "lbm/s"}, "result_units": {"flow": "kg/s"}})
    as_stated = _load(stated, "compmap.map")
    np.testing.assert_allclose(np.concatenate([p.flow for p in agreeing.internal.positions]),
                               np.concatenate([p.flow for p in as_stated.internal.positions]) * 0.45359237, rtol=1e-12)
    assert _load(COMPMAP, "compmap.map", {"units": {"flow": "kg/s", "pressure": "-"}}).units.flow == "kg/s"


def test_a_table_whose_every_flow_is_negative_is_warned_naming_the_flow():
    """A rig counting flow against its axis: before, 43 fit warnings ('not decreasing and concave' on every line)
    and none naming the flow's sign."""
    rows = [",".join(c if k != 2 else f"-{c}" for k, c in enumerate(line.split(","))) for line in LINES[1:]]
    value = _load("\n".join(["theta,phi,flow [kg/s],pressure,efficiency"] + rows) + "\n")
    (warning,) = [w for w in value.warnings if w.code == "implausible_flow"]
    flows = [float(line.split(",")[2]) for line in LINES[1:]]
    assert "every flow is negative" in warning.message and warning.details["values"] == [-max(flows), -min(flows)]
    plain = _load("\n".join(["theta,phi,flow [kg/s],pressure,efficiency"] + LINES[1:]) + "\n")
    assert not [w for w in plain.warnings if w.code == "implausible_flow"]


@pytest.mark.parametrize("header", ["PR [bar]", "pressure ratio [psi]", "p2/p1 [kPa]"])
def test_a_ratio_named_column_with_a_pressure_unit_is_warned_naming_the_column(header):
    value = _load(_header(f"theta,phi,flow,{header},efficiency"))
    (warning,) = [w for w in value.internal.upload_warnings if w.code == "unit_contradicted_by_name"]
    assert warning.details["column"] == header and f"'{header}'" in warning.message
    assert value.units.pressure == warning.details["unit"]
    plain = _load(_header("theta,phi,flow,pressure [bar],efficiency"))
    assert not [w for w in plain.internal.upload_warnings if w.code == "unit_contradicted_by_name"]


def _in_percent(lines: list[str]) -> str:
    rows = [line.split(",") for line in lines[1:]]
    return "\n".join(["theta,phi,flow,PR [%],efficiency"]
                     + [",".join([*r[:3], f"{100 * float(r[3]):.6g}", r[4]]) for r in rows]) + "\n"


def test_a_pressure_ratio_in_percent_is_the_ratio_it_states():
    """PR [%] of 107.6 is a ratio of 1.076: before, the map, its plots and the cycle codes' PR tables kept 107.6."""
    from plantsolve.solvers.perfmap.solve import solve
    plain = _load(_header("theta,phi,flow,PR,efficiency"))
    percent = _load(_in_percent(LINES))
    assert percent.units.pressure == "1"
    got = [v for p in percent.internal.positions for v in p.pressure]
    want = [v for p in plain.internal.positions for v in p.pressure]
    np.testing.assert_allclose(got, want, rtol=1e-12)
    (conversion,) = [c for c in percent.source["conversions"] if c["quantity"] == "pressure"]
    assert (conversion["from_unit"], conversion["to_unit"], conversion["factor"]) == ("%", "1", pytest.approx(0.01))
    result = solve(percent).result
    assert result.units.pressure == "1"
    assert max(max(line.pressure) for line in result.beta_map.lines) < 60
