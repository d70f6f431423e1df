"""Plausible mistakes in EnergyPlus files that read with a wrong number and no word before: field notes in feet, a zone
defined twice, a Space's declared floor area."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

OFFICES = (Path(__file__).parents[3] / "examples" / "polyhedra" / "two_offices.idf").read_text()


def _solved(text: str, options: dict | None = None):
    request = parse_upload(StoredInput.from_bytes("offices.idf", text.encode()), options)
    check_input(request)
    return solve(request).result


def test_field_notes_in_feet_are_named_and_file_units_reads_the_numbers_as_feet():
    """An IDF written in feet with '{ft}' notes (an IP export) read as metres gave 60 m³ offices, no word; EnergyPlus
    reads metres too, so the numbers stand, but the notes are named with the option that reads them as feet."""
    feet = OFFICES.replace("{m}", "{ft}")
    result = _solved(feet)
    (warning,) = [w for w in result.report.warnings if w.code == "idf_notes_other_units"]
    first = next(k for k, line in enumerate(feet.splitlines(), 1) if "{ft}" in line and "Origin" in line)
    assert warning.details["units"] == ["ft"] and warning.details["lines"][0] == first
    assert "file_units" in warning.message
    assert [z.volume for z in result.zones] == pytest.approx([60.0, 60.0])
    as_feet = _solved(feet, {"file_units": "ft"})
    assert [z.volume for z in as_feet.zones] == pytest.approx([60.0 * 0.3048 ** 3] * 2)
    (said,) = [w for w in as_feet.report.warnings if w.code == "idf_notes_other_units"]
    assert said.details["read_as"] == "ft" and "as options.file_units says" in said.message
    plain = _solved(OFFICES)  # metre notes, and notes of other fields ({deg}): nothing said
    assert not [w for w in plain.report.warnings if w.code == "idf_notes_other_units"]


@pytest.mark.parametrize("second", ["Office B Thermal Zone", "OFFICE B THERMAL ZONE"])
def test_a_zone_defined_twice_is_refused_naming_both_lines(second):
    """A second Zone object of one name (a pasted block, case aside) silently replaced the first's origin, multiplier
    and floor-area rule; EnergyPlus refuses it, so does the reader, naming both lines."""
    at = OFFICES.index("Zone,\n  Office B Thermal Zone")
    text = OFFICES[:at] + f"Zone,\n  {second},\n  0,\n  99;\n\n" + OFFICES[at:]
    first = text[:at].count("\n") + 1
    with pytest.raises(InputRejected) as refused:
        _solved(text)
    (error,) = refused.value.errors
    later = text.index("Zone,\n  Office B Thermal Zone", at + 1)
    assert error.loc == ("file", "line", text[:later].count("\n") + 1)
    assert f"line {first}" in error.msg and "two zones of one name" in error.msg


def _spaces(*areas: str) -> str:
    return "".join(f"\nSpace,\n  Office A part {k},  !- Name\n  Office A Thermal Zone,  !- Zone Name\n  ,  !- Ceiling "
                   f"Height {{m}}\n  ,  !- Volume {{m3}}\n  {area},  !- Floor Area {{m2}}\n  General;  !- Space Type\n"
                   for k, area in enumerate(areas, 1))


def test_the_floor_area_a_zones_spaces_state_is_set_against_the_measured_one():
    """EnergyPlus takes a Space's stated Floor Area over its floor surfaces'; the reader ignored Space objects, so a
    zone whose spaces state 99 m² (EnergyPlus' report) measured 20 m², no word. Now the spaces' sum is the zone's
    declared floor area, compared like a Zone's own."""
    wrong = _solved(OFFICES + _spaces("99"))
    (warning,) = [w for w in wrong.report.warnings if w.code == "declared_measures_differ"]
    assert warning.details["zones"] == ["Office A Thermal Zone"]
    (row,) = wrong.report.details["declared_comparison"]
    assert row["declared_floor_area"] == pytest.approx(99.0) and row["floor_area"] == pytest.approx(20.0)
    right = _solved(OFFICES + _spaces("12", "8"))  # two rooms of one zone: their sum
    assert not [w for w in right.report.warnings if w.code == "declared_measures_differ"]
    assert right.report.details["declared_comparison"][0]["declared_floor_area"] == pytest.approx(20.0)
    partial = _solved(OFFICES + _spaces("99", "autocalculate"))  # one space measured by EnergyPlus: no sum to compare
    assert "declared_comparison" not in partial.report.details


def test_a_spaces_floor_area_in_epjson_is_compared_as_in_the_idf():
    import json

    document = json.loads((Path(__file__).parent / "data" / "openstudio_two_offices.epJSON").read_text())
    zone = next(iter(document["Zone"]))
    document["Space"] = {"Room": {"zone_name": zone, "floor_area": 99.0, "volume": "Autocalculate"}}
    request = parse_upload(StoredInput.from_bytes("offices.epJSON", json.dumps(document).encode()), None)
    assert request.source["declared"] == {zone: {"floor_area": 99.0}}


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le"])
def test_an_ascii_stl_saved_as_utf16_is_read_as_the_box_it_is(encoding):
    """Read as bytes, a UTF-16 ASCII STL passed for a binary STL cut short whose denormal floats collapsed: a 422 on
    face 't1' that named nothing of the file. Now it is decoded and read."""
    text = (Path(__file__).parent / "data" / "ascii_box.stl").read_text()
    request = parse_upload(StoredInput.from_bytes("box.stl", text.encode(encoding)), None)
    check_input(request)
    (zone,) = solve(request).result.zones
    assert zone.volume == pytest.approx(1.0) and not request.source["warnings"]


def test_an_idf_without_global_geometry_rules_says_world_was_assumed_not_stated():
    """Without GlobalGeometryRules (an excerpt of a model), the zone-origin warning said 'GlobalGeometryRules says
    World coordinates', a statement the file does not make. Now it names the missing object and the assumption."""
    import re

    text = re.sub(r"GlobalGeometryRules,.*?;[^\n]*\n", "", OFFICES, flags=re.DOTALL)
    (warning,) = [w for w in _solved(text).report.warnings if w.code == "zone_origins_ignored"]
    assert "has no GlobalGeometryRules" in warning.message and "says World" not in warning.message
    assert warning.details["global_geometry_rules"] is False and warning.details["zones"] == ["Office B Thermal Zone"]


def test_an_ifc_quantity_stating_its_own_unit_is_read_in_it():
    """An IfcQuantityArea may state its own Unit (square feet in a metre project); the reader applied the project's
    area unit to every quantity, so 215.28 ft² was declared as 215.28 m² against the 20 m² measured. Now the
    quantity's own unit is used (and the project's when it states none)."""
    text = (Path(__file__).parent / "data" / "ifcopenshell_spaces.ifc").read_text()
    assert "#34=IFCQUANTITYAREA('NetFloorArea',$,$,20.,$);" in text
    text = text.replace("#34=IFCQUANTITYAREA('NetFloorArea',$,$,20.,$);",
                        "#34=IFCQUANTITYAREA('NetFloorArea',$,#9003,215.2782,$);\n"
                        "#9001=IFCDIMENSIONALEXPONENTS(2,0,0,0,0,0,0);\n"
                        "#9002=IFCMEASUREWITHUNIT(IFCAREAMEASURE(0.09290304),#3);\n"
                        "#9003=IFCCONVERSIONBASEDUNIT(#9001,.AREAUNIT.,'square foot',#9002);")
    plain = parse_upload(StoredInput.from_bytes("spaces.ifc", (Path(__file__).parent / "data" /
                                                               "ifcopenshell_spaces.ifc").read_bytes()), None)
    feet = parse_upload(StoredInput.from_bytes("spaces.ifc", text.encode()), None)
    changed = [z for z, claim in feet.source["declared"].items() if claim != plain.source["declared"][z]]
    (zone,) = changed
    assert feet.source["declared"][zone]["floor_area"] == pytest.approx(20.0, rel=1e-6)
    assert feet.source["declared"][zone]["volume"] == plain.source["declared"][zone]["volume"]
