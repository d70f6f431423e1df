"""The mistakes users make with zone files, each answered with the right number, a warning naming the quantity or a
refusal naming what is wrong: a unit the format fixes against the request's, a room in millimetres read as metres, a
header unit its numbers contradict, absurd options, a file of another kind, a cut file. And the floor area of a
zone, against known answers."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import trimesh

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra import synthetic
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input
from tests.conftest import REPO

EXAMPLES = REPO / "examples" / "polyhedra"
DATA = Path(__file__).parent / "data"
FT = 0.3048


def upload(name: str, content: bytes, options: dict | None = None):
    request = parse_upload(StoredInput.from_bytes(name, content), options)
    check_input(request)
    return request, solve(request).result


def codes(result) -> dict:
    return {w.code: w for w in result.report.warnings}


def box_obj(a: float, b: float, c: float, group: str = "room") -> bytes:
    corners = [(0, 0, 0), (a, 0, 0), (a, b, 0), (0, b, 0), (0, 0, c), (a, 0, c), (a, b, c), (0, b, c)]
    faces = [(1, 4, 3, 2), (5, 6, 7, 8), (1, 2, 6, 5), (2, 3, 7, 6), (3, 4, 8, 7), (4, 1, 5, 8)]
    return (f"g {group}\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in corners) +
            "".join("f " + " ".join(map(str, f)) + "\n" for f in faces)).encode()


# --- a format's unit against the request's ---------------------------------------------------------------------

def test_an_idf_is_metres_whatever_the_request_says_and_is_converted_to_feet():
    content = (EXAMPLES / "two_offices.idf").read_bytes()
    _, result = upload("two_offices.idf", content, {"units": "ft"})
    assert result.units == "ft" and result.total_volume == pytest.approx(120 / FT ** 3, rel=1e-12)  # 4,237.8 ft³
    assert result.total_volume == pytest.approx(4237.76, abs=0.01)
    assert [z.floor_area for z in result.zones] == pytest.approx([20 / FT ** 2] * 2, rel=1e-12)
    units = result.report.details["source"]["units"]
    assert units["file_unit"] == "m" and units["request_unit"] == "ft" and units["basis"] == "format"
    assert units["factor"] == pytest.approx(1 / FT, rel=1e-15)
    assert codes(result)["units_converted"].details["factor"] == pytest.approx(1 / FT)
    # the same file in metres: no conversion, no warning
    _, metres = upload("two_offices.idf", content)
    assert metres.total_volume == pytest.approx(120.0) and "units_converted" not in codes(metres)
    assert metres.report.details["source"]["units"]["factor"] == 1.0


def test_an_epjson_in_millimetres_and_its_declared_measures_scale_with_it():
    content = (DATA / "openstudio_two_offices.epJSON").read_bytes()
    _, metres = upload("m.epJSON", content)
    _, mm = upload("m.epJSON", content, {"units": "mm"})
    assert mm.total_volume == pytest.approx(metres.total_volume * 1e9, rel=1e-12)
    assert mm.edge_length_total == pytest.approx(metres.edge_length_total * 1e3, rel=1e-12)
    assert mm.report.details["source"]["units"]["basis"] == "format"
    assert [w.code for w in mm.report.warnings if w.code.startswith("implausible")] == []


def test_gbxml_in_feet_asked_in_feet_is_not_converted_twice():
    content = (DATA / "revit_room_feet.xml").read_bytes()
    _, result = upload("room.xml", content, {"units": "ft"})
    (zone,) = result.zones
    assert zone.volume == pytest.approx(2000.0, rel=1e-12) and zone.floor_area == pytest.approx(200.0, rel=1e-12)
    units = result.report.details["source"]["units"]
    assert units["file_unit"] == "ft" and units["factor"] == pytest.approx(1.0) and units["basis"] == "lengthUnit"
    (row,) = result.report.details["declared_comparison"]  # declared in ft³ and ft², compared in ft³ and ft²
    assert row["declared_volume"] == pytest.approx(2000.0) and row["volume_difference"] == pytest.approx(0, abs=1e-9)


def test_ifc_project_units_are_named_and_converted_to_the_request():
    content = (DATA / "ifcopenshell_spaces.ifc").read_bytes()
    _, metres = upload("s.ifc", content)
    _, mm = upload("s.ifc", content, {"units": "mm"})
    units = mm.report.details["source"]["units"]
    assert units["file_unit"] == "mm" and units["basis"] == "IfcUnitAssignment" and units["factor"] == 1.0
    assert "MILLIMETRE" in units["evidence"]
    assert mm.total_volume == pytest.approx(metres.total_volume * 1e9, rel=1e-9)
    assert metres.report.details["source"]["units"]["factor"] == pytest.approx(1e-3)


def test_a_json_request_in_millimetres_given_units_m_on_the_form_is_converted_not_relabelled():
    body = {"units": "mm", "faces": synthetic.box_faces([0, 0, 0], [5000, 4000, 3000])}
    _, result = upload("room.json", json.dumps(body).encode(), {"units": "m"})
    (zone,) = result.zones
    assert result.units == "m" and zone.volume == pytest.approx(60.0) and zone.floor_area == pytest.approx(20.0)
    assert result.report.details["source"]["units"]["basis"] == "units"


# --- plausibility: a room in mm read as m, metres read as mm ----------------------------------------------------

def test_an_obj_room_in_millimetres_read_as_metres_is_warned_naming_the_mix_up():
    _, result = upload("room.obj", box_obj(5000, 4000, 3000))
    (zone,) = result.zones
    assert zone.volume == pytest.approx(6e10)  # the numbers as given, but not silently
    found = codes(result)
    for code, quantity in (("implausible_zone_volume", "volume"), ("implausible_floor_area", "floor area"),
                           ("implausible_zone_height", "height"), ("implausible_zone_extent", "horizontal extent")):
        warning = found[code]
        assert warning.details["likely_file_unit"] == "mm" and warning.details["zones"] == {"room": pytest.approx(
            {"volume": 6e10, "floor area": 2e7, "height": 3000, "horizontal extent": 5000}[quantity])}
        assert quantity in warning.message and "mm read as m" in warning.message
    assert "6e+10 m³" in found["implausible_zone_volume"].message and "60 m³" in found["implausible_zone_volume"].message
    assert "options.file_units" in found["implausible_zone_volume"].message
    # the way out the warning names: the file's unit given, the room measured in metres
    _, fixed = upload("room.obj", box_obj(5000, 4000, 3000), {"options": {"file_units": "mm"}})
    assert fixed.zones[0].volume == pytest.approx(60.0) and fixed.zones[0].floor_area == pytest.approx(20.0)
    assert not [c for c in codes(fixed) if c.startswith("implausible")]
    assert fixed.report.details["source"]["units"] == {
        "file_unit": "mm", "request_unit": "m", "factor": pytest.approx(1e-3), "basis": "options.file_units",
        "evidence": "OBJ states no unit; options.file_units says mm"}


def test_a_room_in_metres_sent_as_millimetres_is_warned_the_other_way():
    body = {"units": "mm", "faces": synthetic.box_faces([0, 0, 0], [5, 4, 3])}
    result = solve(PolyhedraRequest.model_validate(body)).result
    warning = codes(result)["implausible_zone_volume"]
    assert warning.details["likely_file_unit"] == "m" and "m read as mm" in warning.message
    assert "units 'm'" in warning.message


def test_a_plausible_building_in_any_unit_is_not_warned():
    for units, k in (("m", 1.0), ("mm", 1000.0), ("ft", 1 / FT), ("in", 1 / 0.0254)):
        body = synthetic.building(2, 2, 1, room=(5.0 * k, 4.0 * k, 3.0 * k))
        result = solve(PolyhedraRequest.model_validate({**body, "units": units})).result
        assert not [w.code for w in result.report.warnings if w.code.startswith("implausible")], units
    shaft = {"faces": synthetic.box_faces([0, 0, 0], [0.2, 0.2, 3.0])}  # a riser shaft: small, yet a zone
    result = solve(PolyhedraRequest.model_validate(shaft)).result
    assert not [w.code for w in result.report.warnings if w.code.startswith("implausible")]


def test_a_gbxml_whose_length_unit_contradicts_its_numbers_is_warned_naming_the_header():
    text = (DATA / "revit_room_feet.xml").read_bytes().decode("utf-16")
    metres_header = text.replace('lengthUnit="Feet"', 'lengthUnit="Millimeters"')
    assert metres_header != text
    _, result = upload("room.xml", metres_header.encode("utf-16"))
    warning = codes(result)["implausible_zone_volume"]
    assert "lengthUnit" in warning.message and warning.details["likely_file_unit"] in ("ft", "m")


def test_implausible_codes_are_documented_in_the_readme():
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("### polyhedra"):readme.index("### dedup")]
    for code in ("implausible_zone_volume", "implausible_floor_area", "implausible_zone_height",
                 "implausible_zone_extent"):
        assert f"`{code}`" in section


# --- floor area: known answers --------------------------------------------------------------------------------

def test_floor_area_of_a_box_room_a_gable_house_and_an_inside_out_box():
    body = {"faces": synthetic.box_faces([1, 2, 0], [6, 6, 3])}
    (room,) = solve(PolyhedraRequest.model_validate(body)).result.zones
    assert room.floor_area == pytest.approx(20.0) and room.volume == pytest.approx(60.0)
    house = solve(PolyhedraRequest.model_validate(synthetic.gable_house(8.0, 10.0))).result
    assert house.zones[0].floor_area == pytest.approx(80.0)  # the roof slopes face up: not floor
    inside_out = solve(PolyhedraRequest.model_validate(synthetic.inside_out_cube())).result
    assert inside_out.zones[0].floor_area == pytest.approx(1.0)  # the corrected orientation, not the faces' own


def test_floor_area_of_stacked_rooms_counts_the_slab_for_the_room_above_only():
    result = solve(PolyhedraRequest.model_validate(synthetic.building(3, 2, 1))).result
    assert [z.floor_area for z in result.zones] == pytest.approx([20.0] * 6)
    assert result.total_floor_area == pytest.approx(120.0)


# --- absurd options --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("options, units, field", [
    ({"merge_tolerance": 0.5}, "m", "merge_tolerance"),
    ({"merge_tolerance": 1.0}, "ft", "merge_tolerance"),
    ({"planarity_tolerance": 2.0}, "m", "planarity_tolerance"),
    ({"planarity_tolerance": 900.0}, "mm", "planarity_tolerance"),
])
def test_options_beyond_their_physical_bounds_are_refused_naming_the_field(options, units, field):
    body = {"units": units, "faces": synthetic.box_faces([0, 0, 0], [5, 4, 3]), "options": options}
    with pytest.raises(InputRejected) as refused:
        check_input(PolyhedraRequest.model_validate(body))
    (error,) = refused.value.errors
    assert error.loc == ("options", field) and units in error.msg


def test_a_millimetre_merge_tolerance_is_fine_in_millimetres():
    body = {"units": "mm", "faces": synthetic.box_faces([0, 0, 0], [5000, 4000, 3000]),
            "options": {"merge_tolerance": 2.0}}
    check_input(PolyhedraRequest.model_validate(body))


# --- a file of another kind ------------------------------------------------------------------------------------

@pytest.mark.parametrize("kind, says", [("tube", "a tube request"), ("alignment", "an alignment request"),
                                        ("flowmeter", "a flowmeter request"), ("rigidity", "a rigidity request")])
def test_another_kinds_request_is_refused_naming_it(kind, says):
    content = (REPO / "plantsolve" / "solvers" / kind / "example.json").read_bytes()
    with pytest.raises(InputRejected) as refused:
        upload("request.json", content)
    assert says in refused.value.errors[0].msg and f"/v1/{kind}/jobs" in refused.value.errors[0].msg


def test_a_result_uploaded_as_a_request_is_refused_naming_it():
    _, result = upload("two_offices.idf", (EXAMPLES / "two_offices.idf").read_bytes())
    with pytest.raises(InputRejected) as refused:
        upload("result.json", result.model_dump_json().encode())
    assert "a polyhedra result" in refused.value.errors[0].msg


def test_an_ifc_without_spaces_is_refused_naming_what_it_holds():
    with pytest.raises(InputRejected) as refused:
        upload("model.ifc", (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_bytes())
    message = refused.value.errors[0].msg
    assert "no IfcSpace" in message and "IfcBuildingElementProxy" in message and "IfcColumn" in message


def test_a_point_cloud_obj_and_a_csv_named_idf_are_refused_naming_what_they_hold():
    cloud = "".join(f"v {k * 0.1} {k % 7 * 0.2} {k % 5 * 0.3}\n" for k in range(200)).encode()
    with pytest.raises(InputRejected) as refused:
        upload("scan.obj", cloud)
    assert "point cloud" in refused.value.errors[0].msg
    with pytest.raises(InputRejected) as refused:
        upload("rig.idf", b"flow [kg/s],pressure_ratio,efficiency\n1.0,2.0,0.8\n1.2,2.2,0.82\n")
    assert "CSV table" in refused.value.errors[0].msg


def test_a_step_cad_model_named_ifc_is_refused_naming_its_schema():
    step = (b"ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('a','',(''),(''),'','','');\n"
            b"FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\nENDSEC;\nDATA;\n"
            b"#1=CARTESIAN_POINT('',(0.,0.,0.));\nENDSEC;\nEND-ISO-10303-21;\n")
    with pytest.raises(InputRejected) as refused:
        upload("part.ifc", step)
    assert "STEP CAD model (AP214)" in refused.value.errors[0].msg


# --- a cut file ------------------------------------------------------------------------------------------------

def test_a_cut_gbxml_is_refused_naming_the_line_and_the_cut():
    content = (EXAMPLES / "offices.xml").read_bytes()
    cut = content[:len(content) * 2 // 3]
    with pytest.raises(InputRejected) as refused:
        upload("offices.xml", cut)
    (error,) = refused.value.errors
    assert error.loc == ("file", "line", cut.count(b"\n") + 1) and "cut" in error.msg


def test_a_cut_epjson_is_refused_as_cut():
    content = (DATA / "openstudio_two_offices.epJSON").read_bytes()
    with pytest.raises(InputRejected) as refused:
        upload("offices.epJSON", content[:len(content) // 2])
    assert "cut" in refused.value.errors[0].msg


def test_a_cut_idf_is_a_truncated_file_warning_naming_the_line():
    content = (EXAMPLES / "two_offices.idf").read_bytes()
    cut = content[:len(content) * 2 // 3]
    _, result = upload("two_offices.idf", cut)
    warning = codes(result)["truncated_file"]
    assert warning.details["line"] <= cut.count(b"\n") + 1 and "Office B" in warning.message


def test_a_declared_volume_written_in_cubic_feet_is_named_as_such():
    text = (EXAMPLES / "two_offices.idf").read_text()
    field = ",                                       !- Volume {m3}"
    assert field in text
    declared = text.replace(field, f"{60 / FT ** 3:.2f},                                       !- Volume {{m3}}", 1)
    _, result = upload("two_offices.idf", declared.encode())
    warning = codes(result)["declared_measures_differ"]
    assert "ft³ taken as m³" in warning.message and warning.details["zones"] == ["Office A Thermal Zone"]
    (row,) = result.report.details["declared_comparison"]
    assert row["volume"] == pytest.approx(60.0) and row["declared_volume"] == pytest.approx(2118.88)


def test_a_json_file_with_an_unknown_unit_is_refused_naming_units_not_read_as_metres():
    body = {"units": "km", "faces": synthetic.box_faces([0, 0, 0], [5, 4, 3])}
    with pytest.raises(InputRejected) as refused:
        upload("room.json", json.dumps(body).encode())
    assert refused.value.errors[0].loc[:2] == ("file", "units")
    with pytest.raises(InputRejected) as refused:
        upload("room.json", json.dumps({**body, "units": "m", "source": [1]}).encode())
    assert refused.value.errors[0].loc[:2] == ("file", "source")


def test_a_binary_stl_room_in_millimetres_is_warned_and_read_right_with_its_unit():
    room = trimesh.creation.box(extents=(5000.0, 4000.0, 3000.0)).export(file_type="stl")
    _, result = upload("room.stl", room)
    warning = codes(result)["implausible_zone_volume"]
    assert warning.details["likely_file_unit"] == "mm" and result.zones[0].volume == pytest.approx(6e10)
    _, fixed = upload("room.stl", room, {"options": {"file_units": "mm"}})
    (zone,) = fixed.zones
    assert zone.volume == pytest.approx(60.0) and zone.floor_area == pytest.approx(20.0)
    assert fixed.report.details["source"]["units"]["factor"] == pytest.approx(1e-3)
    _, in_mm = upload("room.stl", room, {"units": "mm"})
    assert in_mm.zones[0].volume == pytest.approx(6e10) and "implausible_zone_volume" not in codes(in_mm)


def test_a_polyhedra_request_with_a_stray_key_is_refused_by_the_schema_not_called_another_kind():
    body = {"faces": synthetic.box_faces([0, 0, 0], [5, 4, 3]), "points": []}
    with pytest.raises(InputRejected) as refused:
        upload("room.json", json.dumps(body).encode())
    assert refused.value.errors[0].loc == ("file", "points") and "tube" not in refused.value.errors[0].msg


def test_default_tolerances_are_metres_so_a_file_asked_in_mm_is_judged_as_in_metres():
    content = (DATA / "1ZoneUncontrolled.idf").read_bytes()
    _, metres = upload("one.idf", content)
    _, mm = upload("one.idf", content, {"units": "mm"})
    assert set(codes(mm)) == set(codes(metres)) | {"units_converted"}
    assert mm.zones[0].volume == pytest.approx(metres.zones[0].volume * 1e9, rel=1e-12)
    tilted = {"units": "mm", "faces": synthetic.box_faces([0, 0, 0], [5000, 4000, 3000])}
    tilted["faces"][1]["loops"][0][0][2] += 0.05  # a roof corner 0.05 mm off its plane: within 1e-4 m
    result = solve(PolyhedraRequest.model_validate(tilted)).result
    assert "non_planar_faces" not in codes(result)
    tilted["options"] = {"planarity_tolerance": 0.01}  # given: taken in the request's unit
    assert "non_planar_faces" in codes(solve(PolyhedraRequest.model_validate(tilted)).result)


def test_world_coordinates_over_zone_origins_warn_that_the_origins_are_ignored():
    """two_offices.idf with its Coordinate System switched to World: EnergyPlus ignores Office B's origin (5, 0, 0),
    so B's zone-relative walls land on A and the 12 m² adjacency is gone; the warning names the zone and its line."""
    text = (EXAMPLES / "two_offices.idf").read_text()
    relative = "  Relative,                               !- Coordinate System"
    assert text.count(relative) == 1
    _, world = upload("two_offices.idf", text.replace(relative, relative.replace("Relative,", "World,   ")).encode())
    assert world.adjacency == []  # what the file now says, as EnergyPlus reads it
    warning = codes(world)["zone_origins_ignored"]
    assert warning.details["zones"] == ["Office B Thermal Zone"] and "World" in warning.message
    name = next(k for k, t in enumerate(text.splitlines()) if t.startswith("  Office B Thermal Zone,") and "!- Name" in t)
    assert warning.details["lines"] == [name] and f"(line {name})" in warning.message  # the line of 'Zone,' above it
    _, as_written = upload("two_offices.idf", text.encode())
    assert "zone_origins_ignored" not in codes(as_written) and as_written.adjacency[0].area == pytest.approx(12.0)


def test_an_epjson_saved_as_json_is_read_as_the_epjson_it_is():
    """The epJSON twin of the two offices uploaded as .json: its object types were refused as unknown request fields;
    it gives the zones and the adjacency of the .epJSON upload."""
    content = (DATA / "openstudio_two_offices.epJSON").read_bytes()
    _, as_json = upload("two_offices.json", content)
    _, as_epjson = upload("two_offices.epJSON", content)
    assert [(z.id, z.volume) for z in as_json.zones] == [(z.id, z.volume) for z in as_epjson.zones]
    assert [z.volume for z in as_json.zones] == pytest.approx([60.0, 60.0])
    assert [a.area for a in as_json.adjacency] == pytest.approx([12.0])
    assert as_json.report.details["source"]["format"] == "epjson"
