"""EnergyPlus' Zone field Part of Total Floor Area = No (a plenum, an attic): EnergyPlus leaves the zone's floor out
of the building's total floor area; before, total_floor_area counted it, no word."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

DATA = Path(__file__).parent / "data"
OFFICES = (DATA / "openstudio_two_offices.idf").read_text()
PART_A = "  Yes;                                    !- Part of Total Floor Area"  # Office A's, the first Zone's
MULTIPLIER_A = "  1,                                      !- Multiplier"


def _solved(name: str, text: str):
    request = parse_upload(StoredInput.from_bytes(name, text.encode()), None)
    check_input(request)
    return solve(request)


def _office_a_outside(text: str = OFFICES) -> str:
    return text.replace(PART_A, "  No;  !- Part of Total Floor Area", 1)


def test_a_zone_not_part_of_total_floor_area_is_left_out_of_the_total_and_said_so():
    plain = _solved("offices.idf", OFFICES).result
    assert plain.total_floor_area == 40.0 and all(z.part_of_total_floor_area for z in plain.zones)
    result = _solved("offices.idf", _office_a_outside()).result
    zones = {z.id: z for z in result.zones}
    # its own floor is still measured; the total is Office B's alone (was 40 m²), the volume still both
    assert zones["Office A Thermal Zone"].floor_area == 20.0
    assert not zones["Office A Thermal Zone"].part_of_total_floor_area
    assert zones["Office B Thermal Zone"].part_of_total_floor_area
    assert (result.total_floor_area, result.total_volume) == (20.0, 120.0)
    (warning,) = [w for w in result.report.warnings if w.code == "zones_outside_total_floor_area"]
    assert warning.details["zones"] == ["Office A Thermal Zone"] and warning.details["floor_area_left_out"] == 20.0


def test_a_zone_of_multiplier_three_outside_the_total_counts_nothing_and_the_epjson_twin_agrees():
    text = _office_a_outside(OFFICES.replace(MULTIPLIER_A, "  3,  !- Multiplier", 1))
    result = _solved("offices.idf", text).result
    assert (result.total_floor_area, result.total_volume) == (20.0, 240.0)
    document = json.loads((DATA / "openstudio_two_offices.epJSON").read_text())
    document["Zone"]["Office A Thermal Zone"].update(multiplier=3, part_of_total_floor_area="No")
    twin = _solved("offices.epJSON", json.dumps(document)).result
    assert (twin.total_floor_area, twin.total_volume) == (20.0, 240.0)


@pytest.mark.parametrize("value", ["N", "False", "0"])
def test_a_part_of_total_floor_area_energyplus_refuses_is_refused_naming_its_line(value):
    with pytest.raises(InputRejected) as refused:
        _solved("offices.idf", OFFICES.replace(PART_A, f"  {value};  !- Part of Total Floor Area", 1))
    (error,) = refused.value.errors
    assert error.loc == ("file", "line", OFFICES.splitlines().index(PART_A) + 1)
    assert "Office A Thermal Zone" in error.msg and repr(value) in error.msg


def test_a_json_body_naming_no_zone_is_refused_and_zones_csv_rows_sum_to_the_total():
    body = parse_upload(StoredInput.from_bytes("o.idf", OFFICES.encode()), None).model_dump()
    body["zones_outside_total_floor_area"] = ["Ofice A"]
    with pytest.raises(InputRejected) as refused:
        _solved("body.json", json.dumps(body))
    assert refused.value.errors[0].loc == ("zones_outside_total_floor_area", 0)
    from plantsolve.solvers.polyhedra.artifacts import render_artifacts
    request = parse_upload(StoredInput.from_bytes("offices.idf", _office_a_outside().encode()), None)
    check_input(request)
    solved = solve(request)
    (table,) = [a for a in render_artifacts(request, solved) if a.name == "zones.csv"]
    zones = [r for r in csv.DictReader(io.StringIO(table.data.decode())) if r["record"] == "zone"]
    assert sum(float(r["floor_area [m2]"]) * int(r["multiplier"]) for r in zones
               if r["part_of_total_floor_area"] == "True") == solved.result.total_floor_area == 20.0
