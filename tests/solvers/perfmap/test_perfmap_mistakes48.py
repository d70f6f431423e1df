"""Mistakes of the 48th probe (request options, queries, exports): pressures marked absolute or gauge as process
sheets write them ('kPa(a)', 'bar(g)'), refused as not understood while 'psia' and 'bara' passed; a one-point query
whose error named '/0' instead of its field; a map of one speed line exported as a pyCycle module pyCycle refuses;
the paper's (theta, phi) map and a table whose diffuser column follows the speed exported with the vane angle as the
speed, without a word."""

from __future__ import annotations

import pytest

from pydantic import ValidationError

from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapRequest
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables, pycycle_module
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.validation import load

FLOWS = [[10.0, 11.0, 12.0, 13.0], [12.0, 13.0, 14.0, 15.0], [14.0, 15.0, 16.0, 17.0]]


def speed_lines(pressure_unit: str = "1", result_pressure: str | None = None, speeds=(0.6, 0.7, 0.8),
                names=("Nc",), lead=()) -> PerfmapRequest:
    positions = [{"setting": [*lead, s], "flow": flows, "pressure": [p + 0.5 * s for p in (0.80, 0.78, 0.74, 0.68)],
                  "efficiency": [0.80, 0.86, 0.88, 0.84]} for s, flows in zip(speeds, FLOWS)]
    options = {"result_units": {"pressure": result_pressure}} if result_pressure else {}
    return PerfmapRequest.model_validate({"setting_names": list(names), "positions": positions, "options": options,
                                          "units": {"flow": "kg/s", "pressure": pressure_unit}})


@pytest.mark.parametrize("given, wanted, factor, stated", [
    ("bar", "kPa(a)", 100.0, "kPa"), ("bar", "bar (abs)", 1.0, "bar"), ("kPa(a)", "psia", 1 / 6.894757, "psia"),
    ("MPa(a)", "kPa", 1000.0, "kPa"), ("bar(g)", "kPa(g)", 100.0, "kPag"), ("kPa gauge", "barg", 0.01, "barg"),
])
def test_a_pressure_marked_absolute_or_gauge_is_read(given, wanted, factor, stated):
    loaded = load(speed_lines(given, wanted))
    assert loaded.units.pressure == stated
    assert loaded.internal.positions[0].pressure[0] == pytest.approx(1.10 * factor, rel=1e-6)


@pytest.mark.parametrize("given, wanted, loc, why", [
    ("bar", "kPa(g)", ("options", "result_units", "pressure"), "gauge"),  # absolute to gauge needs the ambient
    ("Pa(g)", None, ("units", "pressure"), "gauge pressure is read in"),  # no gauge pascals: not read as absolute
    ("kg(a)", None, ("units", "pressure"), "no pressure unit"),
])
def test_a_marked_unit_that_cannot_be_used_is_refused_saying_why(given, wanted, loc, why):
    """Refused before too, as 'not understood' (which told nothing of the mark)."""
    with pytest.raises(InputRejected) as refused:
        load(speed_lines(given, wanted))
    (error,) = refused.value.errors
    assert error.loc == loc and why in error.msg and "not understood" not in error.msg


@pytest.mark.parametrize("body, loc", [
    ({"flow": 1.0, "pressure": 2.0, "units": {"flow": "lbm/s"}}, ("units",)),  # duty points are in the map's units
    ({"flow": float("inf"), "pressure": 2.0}, ("flow",)),
    ({"flow": 1.0}, ("pressure",)),  # was 'points' missing and 'flow' not permitted
])
def test_a_one_point_query_names_its_own_field(body, loc):
    """The one-point form's errors were at points.0.<field>, which the body has not: the problem named '/0'."""
    with pytest.raises(ValidationError) as refused:
        PerfmapQueryRequest.model_validate(body)
    assert [e["loc"] for e in refused.value.errors()] == [loc]


def test_one_speed_line_writes_no_pycycle_module_and_says_why():
    """pyCycle's CompressorMap refused the module ('There are 1 points in a data dimension'): it interpolates over
    the speed. The GasTurb table is still written."""
    result = solve(speed_lines(speeds=(0.7,))).result
    assert pycycle_module(result) is None and list(gasturb_tables(result)) == ["map_gasturb.map"]
    (warning,) = [w for w in result.report.warnings if w.code == "pycycle_export_not_possible"]
    assert warning.details == {"speed_lines": 1, "minimum": 2}
    two = solve(speed_lines(speeds=(0.7, 0.8))).result
    assert pycycle_module(two) is not None
    assert not [w for w in two.report.warnings if w.code == "pycycle_export_not_possible"]


@pytest.mark.parametrize("names, units, setting", [
    (("theta", "phi"), ["deg", "deg"], "phi"),  # the paper's IGV and diffuser angles: phi was written as NcMap
    (("speed", "diffuser"), None, "diffuser"),  # a table's columns in the reader's order: speed, then diffuser
])
def test_exports_whose_last_setting_is_no_speed_are_warned_naming_it(names, units, setting):
    body = speed_lines(speeds=(0.0, 15.0, 30.0), names=names, lead=(10.0,)).model_dump(exclude_unset=True)
    result = solve(PerfmapRequest.model_validate({**body, "setting_units": units})).result
    assert b"NcMap = np.array([0, 15, 30])" in pycycle_module(result)  # still written: the warning says what it is
    (warning,) = [w for w in result.report.warnings if w.code == "exports_last_setting_not_speed"]
    assert warning.details["setting"] == setting and warning.details["quantity"] == "settings"


def test_a_last_setting_that_may_be_the_speed_is_not_warned():
    """Beside the warned map (which fails on the old code), the ones that must stay quiet."""
    def codes(names, units):
        body = speed_lines(names=names, lead=(10.0,)).model_dump(exclude_unset=True)
        return [w.code for w in solve(PerfmapRequest.model_validate({**body, "setting_units": units})).result.report.warnings]

    assert "exports_last_setting_not_speed" in codes(("alpha", "diffuser"), None)
    assert "exports_last_setting_not_speed" not in codes(("IGV [deg]", "Nc"), None)
    assert "exports_last_setting_not_speed" not in codes(("theta", "phi"), ["deg", "-"])  # examples/perfmap/n3_fan_map
    assert "exports_last_setting_not_speed" not in codes(("theta", "phi"), None)  # no unit: either may be meant


def test_a_faster_speed_line_at_smaller_flows_is_warned_naming_both():
    """Two speed values swapped (0.8 typed for 0.7 and back): the exports and the (speed, beta) query interpolated
    between crossing lines without a word."""
    swapped = solve(speed_lines(speeds=(0.6, 0.8, 0.7))).result
    (warning,) = [w for w in swapped.report.warnings if w.code == "speed_lines_out_of_order"]
    assert warning.details["slower"] == [0.7] and warning.details["faster"] == [0.8]
    slow, fast = warning.details["flows"]
    assert slow - fast == pytest.approx(2.0, abs=0.2)  # FLOWS[2] lies 2 kg/s beyond FLOWS[1]
    in_order = solve(speed_lines()).result
    assert not [w for w in in_order.report.warnings if w.code == "speed_lines_out_of_order"]
