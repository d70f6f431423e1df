"""The GasTurb export of a map whose speed is no relative speed (rpm, per cent): GasTurb and GSP read a map's speed
column as relative corrected speed, so the job says the export holds rpm or per cent
(``exports_speed_not_relative``), and the file's title states the unit, which this service's .map reader reads back
(before: the rpm were read back as relative speeds 5000 to 11000, unit lost, warned implausible)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables
from plantsolve.solvers.perfmap.plausibility import exports_speed_not_relative
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload

REPO = Path(__file__).resolve().parents[3]


def _speed_table(header: str, factor: float) -> bytes:
    """The N+3 fan's nine speed lines at theta 0 as a rig table: the relative speed phi times ``factor``."""
    rows = (REPO / "examples" / "perfmap" / "n3_fan_map.csv").read_text().splitlines()[1:]
    cells = [r.split(",") for r in rows if float(r.split(",")[0]) == 0.0]
    body = [f"{float(c[1]) * factor:g},{c[2]},{c[3]},{c[4]}" for c in cells]
    return ("\n".join([f"{header},flow [kg/s],PR [-],efficiency [-]"] + body) + "\n").encode()


@cache
def _fitted(header: str, factor: float):
    return solve(parse_upload(StoredInput.from_bytes("rig.csv", _speed_table(header, factor)), {"map": False})).result


def _codes(result) -> dict:
    return {w.code: w for w in result.report.warnings}


@pytest.mark.parametrize("header, factor, unit", [("speed [rpm]", 10000.0, "rpm"), ("Nc [%]", 100.0, "%"),
                                                  ("speed", 10000.0, None)])
def test_an_export_in_rpm_or_per_cent_says_gasturb_reads_relative_speeds(header, factor, unit):
    warning = _codes(_fitted(header, factor)).get("exports_speed_not_relative")
    assert warning is not None
    assert warning.details["unit"] == unit
    assert warning.details["values"] == pytest.approx([0.5 * factor, 1.1 * factor])


@pytest.mark.parametrize("header, factor", [("Nc [-]", 1.0), ("speed", 1.0)])
def test_relative_speeds_are_not_warned(header, factor):
    assert "exports_speed_not_relative" not in _codes(_fitted(header, factor))


@pytest.mark.parametrize("header, factor, unit", [("speed [rpm]", 10000.0, "rpm"), ("Nc [%]", 100.0, "%")])
def test_the_gasturb_export_states_the_speed_unit_and_reads_back_in_it(header, factor, unit):
    fitted = _fitted(header, factor)
    (data,) = gasturb_tables(fitted).values()
    text = data.decode()
    assert f", speed [{unit}];" in text.splitlines()[0]
    back = parse_upload(StoredInput.from_bytes("back.map", data), {"map": False})
    assert back.setting_units == [unit]
    assert [p.setting[0] for p in back.positions] == pytest.approx([s.setting[0] for s in fitted.settings])
    assert "implausible_speed" not in {w.code for w in back.upload_warnings}


def test_a_relative_speed_export_has_no_speed_unit_in_its_title():
    (data,) = gasturb_tables(_fitted("Nc [-]", 1.0)).values()
    text = data.decode()
    assert "speed [" not in text.splitlines()[0]
    back = parse_upload(StoredInput.from_bytes("back.map", data), {"map": False})
    assert back.setting_units == ["1"]


@pytest.mark.parametrize("names, units, speeds", [
    (["Nc"], ["1"], [0.5, 1.15]),  # an overspeed line
    (["Nc"], ["-"], [0.45, 1.0]),
    (["Nc"], ["fraction"], [0.5, 1.1]),
    (["Nc"], [None], [0.5, 1.15]),
    (["N/Nd"], [None], [0.2, 1.1]),
    (["igv", "Nc"], ["deg", "1"], [0.5, 1.1]),
    (["theta", "phi"], [None, None], [0.0, 2.0]),  # the paper's phi, no unit and not named as the speed
])
def test_relative_speeds_however_spelled_are_not_warned(names, units, speeds):
    assert exports_speed_not_relative(names, units, speeds) is None
