"""EnergyPlus' Zone Multiplier (and a ZoneGroup's Zone List Multiplier): a zone standing for several identical zones
is counted that many times in the totals, as EnergyPlus counts floor area; before, it was counted once, no word."""

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
MULTIPLIER_A = "  1,                                      !- Multiplier"  # Office A's, the first Zone's


def _solved(name: str, text: str):
    request = parse_upload(StoredInput.from_bytes(name, text.encode()), None)
    check_input(request)
    return solve(request).result


def _with_multiplier(value: str) -> str:
    return OFFICES.replace(MULTIPLIER_A, f"  {value},  !- Multiplier", 1)


def test_a_zone_multiplier_counts_the_zone_that_many_times_in_the_totals_and_says_so():
    plain = _solved("offices.idf", OFFICES)
    assert (plain.total_volume, plain.total_floor_area) == (120.0, 40.0)
    result = _solved("offices.idf", _with_multiplier("3"))
    zones = {z.id: z for z in result.zones}
    # each zone's own measures are one copy's; the totals count Office A three times (was 120 m³ and 40 m²)
    assert zones["Office A Thermal Zone"].volume == 60.0 and zones["Office A Thermal Zone"].multiplier == 3
    assert zones["Office B Thermal Zone"].multiplier == 1
    assert (result.total_volume, result.total_floor_area) == (240.0, 80.0)
    (warning,) = [w for w in result.report.warnings if w.code == "zone_multipliers_applied"]
    assert warning.details["zones"] == {"Office A Thermal Zone": 3} and "×3" in warning.message


def test_a_zone_group_multiplies_the_zones_of_its_list_and_the_epjson_twin_agrees():
    text = _with_multiplier("3") + ("\nZoneList, Offices, Office A Thermal Zone, Office B Thermal Zone;\n"
                                    "ZoneGroup, Floors 2-3, Offices, 2;\n")
    result = _solved("offices.idf", text)
    assert {z.id: z.multiplier for z in result.zones} == {"Office A Thermal Zone": 6, "Office B Thermal Zone": 2}
    assert (result.total_volume, result.total_floor_area) == (480.0, 160.0)
    document = json.loads((DATA / "openstudio_two_offices.epJSON").read_text())
    document["Zone"]["Office A Thermal Zone"]["multiplier"] = 3
    document["ZoneList"] = {"Offices": {"zones": [{"zone_name": "Office A Thermal Zone"},
                                                  {"zone_name": "Office B Thermal Zone"}]}}
    document["ZoneGroup"] = {"Floors 2-3": {"zone_list_name": "Offices", "zone_list_multiplier": 2}}
    twin = _solved("offices.epJSON", json.dumps(document))
    assert (twin.total_volume, twin.total_floor_area) == (480.0, 160.0)


@pytest.mark.parametrize("value", ["2.5", "0", "-1", "three", "inf", "1e400", "nan"])  # inf, 1e400: a 500 before
def test_a_multiplier_energyplus_refuses_is_refused_naming_its_line(value):
    with pytest.raises(InputRejected) as refused:
        _solved("offices.idf", _with_multiplier(value))
    (error,) = refused.value.errors
    assert error.loc == ("file", "line", OFFICES.splitlines().index(MULTIPLIER_A) + 1)
    assert "Office A Thermal Zone" in error.msg and repr(value) in error.msg


def test_a_zone_group_of_a_missing_list_and_a_multiplier_for_no_zone_are_refused():
    with pytest.raises(InputRejected) as refused:
        _solved("offices.idf", OFFICES + "\nZoneGroup, Floors, No Such List, 4;\n")
    assert "No Such List" in refused.value.errors[0].msg
    body = {"units": "m", "faces": [], "zone_multipliers": {"Ofice A": 2}}
    body["faces"] = parse_upload(StoredInput.from_bytes("o.idf", OFFICES.encode()), None).model_dump()["faces"]
    with pytest.raises(InputRejected) as refused:
        _solved("body.json", json.dumps(body))
    assert refused.value.errors[0].loc == ("zone_multipliers", "Ofice A")


def test_zones_csv_states_each_zones_multiplier_so_that_its_rows_sum_to_the_totals():
    from plantsolve.solvers.polyhedra.artifacts import render_artifacts
    text = _with_multiplier("3")
    request = parse_upload(StoredInput.from_bytes("offices.idf", text.encode()), None)
    check_input(request)
    solved = solve(request)
    (table,) = [a for a in render_artifacts(request, solved) if a.name == "zones.csv"]
    rows = list(csv.DictReader(io.StringIO(table.data.decode())))
    zones = [r for r in rows if r["record"] == "zone"]
    assert {r["id"]: r["multiplier"] for r in zones} == {"Office A Thermal Zone": "3", "Office B Thermal Zone": "1"}
    assert sum(float(r["volume [m3]"]) * int(r["multiplier"]) for r in zones) == solved.result.total_volume == 240.0
    assert sum(float(r["floor_area [m2]"]) * int(r["multiplier"]) for r in zones) == solved.result.total_floor_area
