"""Mistakes of the fifth probe: a pyCycle map's flow unit taken from a comment or a docstring (or from the first of
two assignments), a GasTurb map stating two flow units and one taken, a flow in per cent holding kilograms per second,
and a row of units whose '1' (a pressure ratio's unit) made it a data row and lost every unit in it."""

from __future__ import annotations

import json

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

FAN = (DATA / "pycycle" / "N3_Fan_map.py").read_text()
FAN_UNIT = "FanMap.units['WcMap'] = 'lbm/s'\n"
COMPMAP = (DATA / "gasturb" / "compmap.map").read_text()


def _load(content: str, name: str, options=None):
    source = StoredInput.from_bytes(name, content.encode())
    return load(parse_upload(source, options), source)


@pytest.mark.parametrize("edit, unit", [
    # an old rig's unit commented out above the one in force: was kg/s, 2.2 times off in every conversion
    (lambda t: t.replace(FAN_UNIT, "# FanMap.units['WcMap'] = 'kg/s'  (the old rig)\n" + FAN_UNIT), "lbm/s"),
    # pyCycle keeps the last assignment: was lbm/s, the first
    (lambda t: t.replace(FAN_UNIT, FAN_UNIT + "FanMap.units['WcMap'] = 'kg/s'\n"), "kg/s"),
    # only in a comment or a docstring: pyCycle sees no unit, and neither does the result (was kg/s)
    (lambda t: t.replace(FAN_UNIT, "# FanMap.units['WcMap'] = 'kg/s'\n"), None),
    (lambda t: t.replace(FAN_UNIT, "\"\"\"units['WcMap'] = 'kg/s' was the old setting\"\"\"\n"), None),
    # a units dict assigned after the unit replaces it, as in Python
    (lambda t: t.replace(FAN_UNIT, FAN_UNIT + "FanMap.units = {'NcMap': 'rpm'}\n"), None),
    (lambda t: t.replace(FAN_UNIT, "FanMap.units = dict(NcMap='rpm', WcMap='kg/s')\n"), "kg/s"),
])
def test_a_pycycle_maps_flow_unit_is_the_one_python_would_hold(edit, unit):
    text = edit(FAN)
    request = parse_upload(StoredInput.from_bytes("N3_Fan_map.py", text.encode()), {"map": False})
    assert request.units.flow == unit


def test_a_pycycle_map_that_is_no_python_still_reads_its_unit_outside_comments():
    text = FAN.replace(FAN_UNIT, "# FanMap.units['WcMap'] = 'kg/s'\n" + FAN_UNIT) + "\nthis line is no Python\n"
    request = parse_upload(StoredInput.from_bytes("N3_Fan_map.py", text.encode()), {"map": False})
    assert request.units.flow == "lbm/s"


def test_a_gasturb_map_stating_two_flow_units_is_refused_naming_both():
    """'Mass Flow [kg/s]' under a title saying 'flow [lb/s]': the table's line was taken without a word."""
    text = COMPMAP.replace("Sample Axial compressor map", "Sample map; flow [lb/s]", 1).replace(
        "Mass Flow\n", "Mass Flow [kg/s]\n", 1)
    with pytest.raises(InputRejected) as refused:
        _load(text, "compmap.map", {"map": False})
    (error,) = refused.value.errors
    assert error.loc == ("file", "Mass Flow") and "'kg/s'" in error.msg and "[lb/s]" in error.msg
    agreeing = text.replace("Mass Flow [kg/s]\n", "Mass Flow [lbm/s]\n", 1)
    assert _load(agreeing, "compmap.map", {"map": False}).units.flow == "lbm/s"


FLOWS = [[1104.3, 1247.2, 1384.7, 1514.8], [1369.1, 1519.4, 1661.8, 1793.9], [1644.5, 1791.9, 1929.5, 2054.9]]


def _speed_lines(flow_unit: str, scale: float = 1.0) -> str:
    positions = [{"setting": [s], "flow": [f * scale for f in flows], "pressure": [1.30, 1.28, 1.24, 1.18],
                  "efficiency": [0.80, 0.86, 0.88, 0.84]} for s, flows in zip((0.6, 0.7, 0.8), FLOWS)]
    return json.dumps({"setting_names": ["Nc"], "units": {"flow": flow_unit, "pressure": "1"}, "positions": positions})


@pytest.mark.parametrize("scale, hint", [(1.0, "labelled %"), (1 / 2500, "fractions of design")])
def test_a_flow_in_per_cent_far_from_per_cent_of_design_is_warned_naming_the_flow(scale, hint):
    """kg/s labelled % (1104..2055 % of design), or fractions labelled % (0.44..0.82 %): read without a word."""
    loaded = _load(_speed_lines("%", scale), "map.json")
    (warning,) = [w for w in loaded.warnings if w.code == "implausible_flow"]
    assert warning.details["quantity"] == "flow" and hint in warning.message
    assert not [w for w in _load(_speed_lines("%", 1 / 20), "map.json").warnings if w.code == "implausible_flow"]


ROWS = ["5000,500.9193,1.0760,65.85", "5000,565.7313,1.0811,77.56", "5000,628.1028,1.0799,85.52",
        "6000,621.0000,1.1171,71.45", "6000,689.1000,1.1100,82.00", "6000,753.8000,1.0980,86.30",
        "7000,745.9000,1.1620,74.00", "7000,812.6000,1.1540,84.00", "7000,876.3000,1.1380,87.50"]


def test_a_units_row_writing_a_ratio_as_1_gives_its_units():
    """'rpm,lbm/s,1,%' under 'speed,flow,PR,efficiency': the '1' made it a data row, skipped, its units lost, and
    the per-cent efficiencies refused as fractions above 1."""
    loaded = _load("\n".join(["speed,flow,PR,efficiency", "rpm,lbm/s,1,%", *ROWS]) + "\n", "rig.csv")
    assert loaded.units.flow == "lbm/s" and loaded.units.pressure == "1" and loaded.units.settings == ["rpm"]
    assert max(loaded.settings[0].eta) == pytest.approx(0.8552)
    # a row of numbers only is data, even when it holds ones
    with pytest.raises(InputRejected):
        _load("\n".join(["speed,flow,PR,efficiency", "1,1,1,1", *ROWS]) + "\n", "rig.csv")


def _rig(header: str) -> str:
    return "\n".join([header, *ROWS]) + "\n"


@pytest.mark.parametrize("pressure", ["PR (π)", "pressure ratio [pi]", "PR (π) [-]", "PR [-] (π)"])
def test_the_symbol_of_the_pressure_ratio_in_brackets_names_it_and_scales_nothing(pressure):
    """pint reads π as 3.14159: 'PR (π)' multiplied every ratio by it (1.08 read as 3.38) without a word."""
    loaded = _load(_rig(f"speed [rpm],flow [kg/s],{pressure},efficiency [%]"), "rig.csv")
    assert loaded.units.pressure == "1" and list(loaded.settings[0].y) == pytest.approx([1.0760, 1.0811, 1.0799])


@pytest.mark.parametrize("column, unit", [("PR [dB]", "dB"), ("PR [rad]", "rad"), ("efficiency [deg]", "deg"),
                                          ("flow [count]", "count"), ("efficiency [mB]", "mB"), ("flow [pi]", "pi")])
def test_a_dimensionless_unit_that_is_no_ratio_is_refused_naming_the_column(column, unit):
    """Decibels scaled the ratios by 1.26, degrees the efficiencies by 0.0175; radians and counts were labels."""
    names = {"PR": "PR [-]", "efficiency": "efficiency [%]", "flow": "flow [kg/s]"}
    names[column.split()[0]] = column
    with pytest.raises(InputRejected) as refused:
        _load(_rig(f"speed [rpm],{names['flow']},{names['PR']},{names['efficiency']}"), "rig.csv")
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and repr(column) in error.msg and "no unit of a ratio" in error.msg


@pytest.mark.parametrize("column", ["flow [kg/s] [lb/s]", "Wc (lbm/s) [kg/s]"])
def test_a_header_stating_two_units_is_refused_naming_both(column):
    """The one nearest the end was taken, the other dropped without a word (2.2 times off either way)."""
    with pytest.raises(InputRejected) as refused:
        _load(_rig(f"speed [rpm],{column},PR [-],efficiency [%]"), "rig.csv")
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and "which is meant" in error.msg and repr(column) in error.msg
    assert _load(_rig("speed [rpm],Wc (lbm/s) [lb/s],PR [-],efficiency [%]"), "rig.csv").units.flow == "lb/s"


def test_exports_of_a_map_in_pressures_not_ratios_are_said_to_hold_them():
    """A rig table of pressures rises in kPa: pyCycle's PRmap and GasTurb's Pressure Ratio table were written in
    kPa with no word in the report, and the cycle codes read them as ratios."""
    from plantsolve.solvers.perfmap.solve import solve

    def solved(pressure: str):
        source = StoredInput.from_bytes("rig.csv", _rig(f"speed [rpm],flow [kg/s],{pressure},efficiency [%]").encode())
        return solve(parse_upload(source, {"map": False})).result

    kpa = solved("pressure rise [kPa]")
    (warning,) = [w for w in kpa.report.warnings if w.code == "exports_pressure_not_ratio"]
    assert warning.details == {"quantity": "pressure", "unit": "kPa"} and "PRmap" in warning.message
    assert kpa.beta_map is not None  # the exports are still written, the unit stated beside their tables
    assert not [w for w in solved("PR [-]").report.warnings if w.code == "exports_pressure_not_ratio"]
