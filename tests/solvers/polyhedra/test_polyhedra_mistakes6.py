"""Plausible mistakes in EnergyPlus files, a sixth round: a zone whose Spaces leave surfaces over (EnergyPlus'
'-Remainder' space), an epJSON that writes a Yes/No choice as a JSON boolean."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

EXAMPLES = Path(__file__).parents[3] / "examples" / "polyhedra"
OFFICES = (EXAMPLES / "two_offices.idf").read_text()
EPJSON = json.loads((Path(__file__).parent / "data" / "openstudio_two_offices.epJSON").read_text())


def _solved(name: str, text: str):
    request = parse_upload(StoredInput.from_bytes(name, text.encode()), None)
    check_input(request)
    return solve(request).result


def _floor(name: str, space: str, corners: str) -> str:
    return (f"BuildingSurface:Detailed,\n  {name},\n  Floor,\n  ,\n  Office A Thermal Zone,\n  {space},\n"
            f"  Ground,\n  ,\n  NoSun,\n  NoWind,\n  ,\n  ,\n  {corners};\n\n")


def _split_office_a(first_space: str, second_space: str, walls_space: str) -> str:
    """Office A's 5 × 4 m floor as two floors, 3 × 4 m in ``first_space`` and 2 × 4 m in ``second_space``, its walls
    and roof in ``walls_space`` ('' : in no Space)."""
    start = OFFICES.index("BuildingSurface:Detailed,\n  Office A Floor")
    end = OFFICES.index("BuildingSurface:Detailed,", start + 10)
    floors = (_floor("Office A Floor 1", first_space, "3, 4, 0,\n  3, 0, 0,\n  0, 0, 0,\n  0, 4, 0")
              + _floor("Office A Floor 2", second_space, "5, 4, 0,\n  5, 0, 0,\n  3, 0, 0,\n  3, 4, 0"))
    text = OFFICES[:start] + floors + OFFICES[end:]
    return text.replace("  Office A,                               !- Space Name", f"  {walls_space},  !- Space Name")


def _space(name: str, volume: str, floor_area: str) -> str:
    return f"\nSpace,\n  {name},\n  Office A Thermal Zone,\n  ,\n  {volume},\n  {floor_area},\n  General;\n"


@pytest.mark.parametrize("volume, floor_area", [("", "12"), ("36", "")])
def test_a_zones_remainder_space_is_no_part_of_what_its_spaces_state(volume, floor_area):
    """Surfaces of a zone that name no Space go to EnergyPlus' '<zone>-Remainder' space, measured from its surfaces:
    the Space objects' sum (12 m² of the 20, 36 m³ of the 60) is no claim about the zone. It was compared as one: a
    false declared_measures_differ on a right model."""
    result = _solved("offices.idf", _split_office_a("A1", "", "") + _space("A1", volume, floor_area))
    assert not [w for w in result.report.warnings if w.code == "declared_measures_differ"]
    assert "declared_comparison" not in result.report.details
    assert [z.floor_area for z in result.zones] == pytest.approx([20.0, 20.0])
    # every surface in a Space: the Spaces' sum is the zone's, and a wrong one is still named
    whole = _split_office_a("A1", "A2", "A1") + _space("A1", "", "12") + _space("A2", "", "80")
    (warning,) = [w for w in _solved("offices.idf", whole).report.warnings if w.code == "declared_measures_differ"]
    assert warning.details["zones"] == ["Office A Thermal Zone"]
    right = _split_office_a("A1", "A2", "A1") + _space("A1", "", "12") + _space("A2", "", "8")
    assert _solved("offices.idf", right).report.details["declared_comparison"][0]["declared_floor_area"] == 20.0


@pytest.mark.parametrize("part, total", [(True, 40.0), (False, 20.0)])
def test_an_epjson_boolean_part_of_total_floor_area_is_the_choice_it_says(part, total):
    """A writer's epJSON with ``"part_of_total_floor_area": false`` (a boolean, not "No") dropped the whole Zone object:
    its origin, multiplier and floor-area rule lost, a plenum counted in total_floor_area. Now true/false are Yes/No."""
    document = json.loads(json.dumps(EPJSON))
    zone = "Office A Thermal Zone"
    document["Zone"][zone]["part_of_total_floor_area"] = part
    result = _solved("offices.epJSON", json.dumps(document))
    skipped = result.report.details["source"]["skipped"]
    assert not [s for s in skipped if s["object"].startswith("zone")]
    assert result.total_floor_area == pytest.approx(total)
    assert [z.volume for z in result.zones] == pytest.approx([60.0, 60.0])
