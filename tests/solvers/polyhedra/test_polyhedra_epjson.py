"""epJSON: EnergyPlus' JSON form of the IDF objects gives the same zones as the IDF it was made from."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

DATA = Path(__file__).parent / "data"


def read(name: str):
    return parse_upload(StoredInput.from_path(DATA / name), None)


def upload(name: str, document) -> object:
    return parse_upload(StoredInput.from_bytes(name, json.dumps(document).encode()), None)


@pytest.mark.parametrize("model", ["1ZoneUncontrolled", "4ZoneWithShading_Simple_1", "openstudio_two_offices"])
def test_an_idf_and_its_epjson_twin_give_identical_results(model):
    """epJSON lists objects by type, the IDF in file order: the same faces, zones and measures, in another order."""
    idf, epjson = read(f"{model}.idf"), read(f"{model}.epJSON")
    assert epjson.source["format"] == "epjson" and idf.source["format"] == "idf"
    assert sorted(json.dumps(f.model_dump()) for f in epjson.faces) == sorted(json.dumps(f.model_dump()) for f in idf.faces)
    assert sorted(s["object"] for s in epjson.source["skipped"]) == sorted(s["object"] for s in idf.source["skipped"])
    a, b = solve(idf).result, solve(epjson).result
    zones = {z.id: z for z in b.zones}
    assert len(a.zones) == len(zones)
    for z in a.zones:
        assert (zones[z.id].closed, zones[z.id].orientation) == (z.closed, z.orientation)
        assert zones[z.id].volume == pytest.approx(z.volume, rel=1e-12)
        assert zones[z.id].net_surface_area == pytest.approx(z.net_surface_area, rel=1e-12)
    faces = {f.id: f for f in b.faces}
    for f in a.faces:
        assert faces[f.id].net_area == pytest.approx(f.net_area, rel=1e-12)
    assert sorted(tuple(x.faces) for x in a.adjacency) == sorted(tuple(x.faces) for x in b.adjacency)


def test_epjson_known_answers():
    (z,) = solve(read("1ZoneUncontrolled.epJSON")).result.zones
    assert z.closed and z.volume == pytest.approx(1061.88, abs=0.005)  # EnergyPlus' Zone Summary: 1061.88 m3
    result = solve(read("4ZoneWithShading_Simple_1.epJSON")).result
    assert [round(z.volume, 9) for z in result.zones] == [4000.0] * 4


def test_epjson_skips_bad_objects_by_type_and_name():
    request = read("openstudio_two_offices.epJSON")
    skipped = {s["object"]: s["reason"] for s in request.source["skipped"]}
    assert "vertex 2" in skipped["buildingsurface:detailed 'Office B Broken Shade'"]
    assert "'Office B Nowhere' is not a surface" in skipped["fenestrationsurface:detailed 'Office B Orphan Window'"]
    assert all(s["line"] is None for s in request.source["skipped"])


def test_epjson_triangle_window_and_omitted_defaults():
    box = {
        "GlobalGeometryRules": {"GlobalGeometryRules 1": {"starting_vertex_position": "UpperLeftCorner",
                                                          "vertex_entry_direction": "Counterclockwise",
                                                          "coordinate_system": "Relative"}},
        "Zone": {"Z": {"x_origin": 100.0}},
        "Wall:Exterior": {"S": {"zone_name": "Z", "azimuth_angle": 180, "starting_x_coordinate": 0,
                                "starting_y_coordinate": 0, "starting_z_coordinate": 0, "length": 4, "height": 2.5}},
        "FenestrationSurface:Detailed": {"T": {"building_surface_name": "S", "surface_type": "Window",
                                               "vertex_1_x_coordinate": 1, "vertex_1_y_coordinate": 0,
                                               "vertex_1_z_coordinate": 2, "vertex_2_x_coordinate": 1,
                                               "vertex_2_y_coordinate": 0, "vertex_2_z_coordinate": 1,
                                               "vertex_3_x_coordinate": 3, "vertex_3_y_coordinate": 0,
                                               "vertex_3_z_coordinate": 1}},
    }
    request = upload("box.epJSON", box)
    faces = {f.id: f for f in request.faces}
    assert faces["S"].loops[0][1] == pytest.approx([100, 0, 0])  # the omitted tilt is a wall's 90 degrees
    assert faces["T"].parent == "S" and faces["T"].loops[0] == [[101, 0, 2], [101, 0, 1], [103, 0, 1]]


def test_epjson_with_nothing_usable_is_refused_naming_the_object():
    with pytest.raises(InputRejected) as e:
        upload("bad.epJSON", {"Roof": {"R": {"zone_name": "Z", "starting_x_coordinate": [1]}}})
    (error,) = e.value.errors
    assert error.loc == ("file", "roof 'R'") and "starting_x_coordinate" in error.msg
    with pytest.raises(InputRejected, match="no EnergyPlus surface"):
        upload("empty.epJSON", {"Version": {"Version 1": {"version_identifier": "24.1"}}})
    with pytest.raises(InputRejected, match="the file was cut"):
        parse_upload(StoredInput.from_bytes("cut.epJSON", b'{"Zone": {'), None)
