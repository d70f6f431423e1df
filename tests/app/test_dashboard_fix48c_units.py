"""The dashboard's unit column for a perfmap result: a request without stated units showed the raw placeholder
``{units.flow}``, and a setting's unit (``{units.settings.0}``, the first of a list) was never filled."""

import json

import pytest

from plantsolve.app.dashboard_views import field_unit, result_summary
from plantsolve.schemas.perfmap import PerfmapRequest, PerfmapResult
from plantsolve.solvers.perfmap.solve import solve
from tests.conftest import REPO


def _result(units: bool) -> dict:
    body = json.loads((REPO / "examples" / "perfmap" / "n3_fan_map.json").read_text())
    if not units:
        body.pop("units", None)
    body["options"] = {**body.get("options", {}), "grid": [8, 6]}
    return json.loads(solve(PerfmapRequest.model_validate(body)).result.model_dump_json())


def test_a_result_without_stated_units_says_so_instead_of_a_placeholder():
    result = _result(units=False)
    assert result["units"]["flow"] is None and result["units"]["pressure"] is None
    units = {name: unit for name, _, unit in result_summary(result, PerfmapResult)}
    assert not any("{" in unit for unit in units.values())
    assert units["flow_range"] == units["pressure_range"] == units["map.flow"] == "not stated"
    assert units["map.reachable_fraction"] == "1"


def test_a_result_with_stated_units_shows_them():
    result = _result(units=True)
    units = {name: unit for name, _, unit in result_summary(result, PerfmapResult)}
    assert units["flow_range"] == result["units"]["flow"] and units["pressure_range"] == result["units"]["pressure"]


@pytest.mark.parametrize("path, expected", [(("map", "theta"), "deg"), (("map", "phi"), "rpm"),
                                            (("map", "settings"), "per column: deg, rpm"),
                                            (("map", "flow"), "not stated")])
def test_a_settings_unit_follows_the_list_index(path, expected):
    result = {"units": {"flow": None, "pressure": "Pa", "efficiency": "1", "settings": ["deg", "rpm"]}}
    assert field_unit(PerfmapResult, result, path) == expected


def test_an_index_beyond_the_list_is_not_stated():
    assert field_unit(PerfmapResult, {"units": {"settings": ["deg"]}}, ("map", "phi")) == "not stated"
