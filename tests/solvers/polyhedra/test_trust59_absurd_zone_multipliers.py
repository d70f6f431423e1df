"""A Zone Multiplier no building has: EnergyPlus takes any whole number from 1 (its IDD sets no maximum), so a
multiplier of 1,000,000 typed for 10 gave two_offices.idf 6e7 m³ and 2e7 m² of floor with only
zone_multipliers_applied. It is named (``implausible_zone_multiplier``) with the copies' volume and floor area; a
tower's middle floor standing for 8, or a hotel room for 600, is not."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

DATA = Path(__file__).parent / "data"
OFFICES = (DATA / "openstudio_two_offices.idf").read_text()
MULTIPLIER_A = "  1,                                      !- Multiplier"  # Office A's (60 m³, 20 m² of floor)


def solved(text: str, name: str = "offices.idf", options: dict | None = None):
    return solve(parse_upload(StoredInput.from_bytes(name, text.encode()), options)).result


def with_multiplier(value: str) -> str:
    return OFFICES.replace(MULTIPLIER_A, f"  {value},  !- Multiplier", 1)


def multiplier_warnings(result) -> list:
    return [w for w in result.report.warnings if w.code == "implausible_zone_multiplier"]


@pytest.mark.parametrize("value", ["1000000", "20000"])
def test_a_multiplier_no_building_has_is_named_with_what_it_adds(value):
    result = solved(with_multiplier(value))
    assert result.total_volume == pytest.approx(60.0 * int(value) + 60.0)  # counted as EnergyPlus counts it
    (warning,) = multiplier_warnings(result)
    assert warning.details["zones"] == {"Office A Thermal Zone": int(value)}
    assert warning.details["volume_added"] == pytest.approx(60.0 * (int(value) - 1))
    line = OFFICES[:OFFICES.index("Office A Thermal Zone,")].count("\n")  # its "Zone," line, above the name
    assert warning.details["lines"] == [line] and f"line {line}" in warning.message
    assert "Multiplier field" in warning.message and "zone_multipliers_applied" in {
        w.code for w in result.report.warnings}


def box_request(side: float, height: float, multiplier: int, units: str) -> dict:
    """A JSON request of one closed box zone ``hall`` standing for ``multiplier`` copies."""
    c = [(x, y, z) for x in (0, side) for y in (0, side) for z in (0, height)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [{"id": f"f{k}", "zones": ["hall"], "loops": [[list(c[i]) for i in q]]} for k, q in enumerate(quads)]
    return {"units": units, "faces": faces, "zone_multipliers": {"hall": multiplier}}


def test_copies_larger_together_than_the_largest_buildings_are_named_in_the_request_units():
    # 2,000 copies of a 50 x 50 x 10 m hall: 5e7 m³ and 5e6 m² of floor, past the largest buildings'
    result = solved(json.dumps(box_request(50, 10, 2000, "m")), "request.json")
    (warning,) = multiplier_warnings(result)
    assert warning.details["zones"] == {"hall": 2000} and warning.details["copies_volume_maximum"] == 3e7
    # the same hall in feet (4.6 m high, 232 m² of floor): 2,000 copies are 4.7e5 m², a large building's
    feet = solved(json.dumps(box_request(50, 10, 2000, "ft")), "request.json")
    assert not multiplier_warnings(feet)
    assert multiplier_warnings(solved(json.dumps(box_request(164, 32.8, 2000, "ft")), "request.json"))[0].details[
        "copies_volume_maximum"] == pytest.approx(3e7 / 0.3048 ** 3)


def test_a_zone_too_large_alone_and_counted_once_is_no_multipliers_doing():
    # a 400 x 400 x 300 m 'room' (cm read as m): 4.8e7 m³, implausible_zone_volume's to name, not a multiplier's
    result = solved(json.dumps(box_request(400, 300, 1, "m")), "request.json")
    assert not multiplier_warnings(result) and "implausible_zone_volume" in {w.code for w in result.report.warnings}


def test_a_real_buildings_multipliers_say_nothing():
    # EnergyPlus' MultiStory pattern: a middle zone for 4, a middle floor's ZoneGroup for 8 (32 copies)
    for value in ("8", "32", "600"):
        assert not multiplier_warnings(solved(with_multiplier(value)))


def test_the_epjson_reader_names_it_too():
    epjson = json.loads((DATA / "openstudio_two_offices.epJSON").read_text())
    zone = next(iter(epjson["Zone"].values()))
    zone["multiplier"] = 1000000
    (warning,) = multiplier_warnings(solved(json.dumps(epjson), "offices.epJSON"))
    assert list(warning.details["zones"].values()) == [1000000] and "line" not in warning.message.split("×")[0]


@pytest.mark.parametrize("value", ["0", "-3", "2.5"])
def test_zero_negative_and_fractional_multipliers_stay_refused_naming_the_line(value):
    with pytest.raises(InputRejected) as refused:
        solved(with_multiplier(value))
    (error,) = refused.value.errors
    assert error.loc[:2] == ("file", "line") and "Multiplier" in error.msg


@pytest.mark.parametrize("lines", [[1, 2], "abc", {"default": [1]}, {"default": "12"}])
def test_a_json_bodys_own_multiplied_zone_lines_of_another_shape_are_ignored(lines):
    # 'source' is free in a JSON body: the IDF reader's {zone: line} is the only shape read, anything else is not
    body = {**json.loads((Path(__file__).parents[3] / "examples/polyhedra/gable_house.json").read_text()),
            "zone_multipliers": {"default": 100000}, "source": {"multiplied_zone_lines": lines}}
    result = solve(PolyhedraRequest.model_validate(body)).result
    (warning,) = multiplier_warnings(result)
    assert warning.details["zones"] == {"default": 100000} and "its Zone at line" not in warning.message
