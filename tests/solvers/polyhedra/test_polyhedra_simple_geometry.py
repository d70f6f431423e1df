"""EnergyPlus' simple-geometry objects (Wall:Exterior … GlazedDoor:Interzone) as EnergyPlus builds them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.idf_rectangles import rectangle

DATA = Path(__file__).parent / "data"
FOUR_ZONES = "4ZoneWithShading_Simple_1.idf"


def upload(name: str, content: bytes):
    return parse_upload(StoredInput.from_bytes(name, content), None)


def loop(request, face_id):
    return np.array(next(f for f in request.faces if f.id == face_id).loops[0], dtype=float)


def test_four_zone_simple_model_matches_energyplus_zone_summary():
    """EnergyPlus' 4ZoneWithShading_Simple_1: four 20 x 20 x 10 m zones, 1,600 m2 of floor (the file's header)."""
    request = parse_upload(StoredInput.from_path(DATA / FOUR_ZONES), None)
    result = solve(request).result
    assert request.source["skipped"] == [] and request.source["faces"] == 24 + 9
    assert [z.id for z in result.zones] == ["ZONE 1", "ZONE 2", "ZONE 3", "ZONE 4"]
    for z in result.zones:
        assert z.closed and z.orientation == "outward" and z.volume == pytest.approx(4000.0)
    floors = [f for f in result.faces if f.id.endswith("Flr001")]
    assert sum(f.area for f in floors) == pytest.approx(1600.0)
    assert all(f.normal == pytest.approx([0, 0, -1]) for f in floors)
    pairs = {tuple(a.faces): a.area for a in result.adjacency}
    assert pairs == {("Zn001:Wall004", "Zn002:Wall004"): pytest.approx(200.0),
                     ("Zn001:Roof001", "Zn003:Flr001"): pytest.approx(400.0),
                     ("Zn002:Roof001", "Zn004:Flr001"): pytest.approx(400.0),
                     ("Zn003:Wall004", "Zn004:Wall004"): pytest.approx(200.0)}
    # a window and a door (3 x 5 m each) come off the south wall's net area
    wall = next(f for f in result.faces if f.id == "Zn001:Wall001")
    assert wall.area == pytest.approx(200.0) and wall.net_area == pytest.approx(170.0)


def test_rectangles_start_upper_left_counterclockwise_in_zone_coordinates():
    request = parse_upload(StoredInput.from_path(DATA / FOUR_ZONES), None)
    # Zone 2's origin is (26, 6, 0); its south wall starts at its lower-left corner (0, 0, 0)
    assert loop(request, "Zn002:Wall001") == pytest.approx(np.array(
        [[26, 6, 10], [26, 6, 0], [46, 6, 0], [46, 6, 10]]))
    # the floor (azimuth 90, tilt 180) is seen from below: counter-clockwise from there
    assert loop(request, "Zn001:Flr001") == pytest.approx(np.array([[26, 6, 0], [6, 6, 0], [6, 26, 0], [26, 26, 0]]))
    # the window: 4 m right and 3 m up the wall from its lower-left corner, 3 x 5 m
    assert loop(request, "Zn001:Wall001:Win001") == pytest.approx(np.array(
        [[10, 6, 8], [10, 6, 3], [13, 6, 3], [13, 6, 8]]))
    # the interzone window seen from either zone is the same rectangle, turned
    a, b = loop(request, "Zn003:Wall004:Win001"), loop(request, "Zn004:Wall004:Win001")
    assert sorted(map(tuple, a.round(9))) == sorted(map(tuple, b.round(9)))
    assert np.cross(a[1] - a[0], a[2] - a[1]) @ np.cross(b[1] - b[0], b[2] - b[1]) < 0


@pytest.mark.parametrize(("azimuth", "tilt", "normal"), [
    (180, 90, [0, -1, 0]), (0, 90, [0, 1, 0]), (90, 90, [1, 0, 0]), (270, 90, [-1, 0, 0]),
    (180, 0, [0, 0, 1]), (90, 180, [0, 0, -1]), (135, 30, [0.5 * math.sqrt(0.5), -0.5 * math.sqrt(0.5), math.sqrt(0.75)]),
])
def test_rectangle_normal_follows_azimuth_and_tilt(azimuth, tilt, normal):
    p = np.array(rectangle(azimuth, tilt, np.array([1.0, 2.0, 3.0]), 4.0, 2.5))
    assert p[1] == pytest.approx([1, 2, 3])  # the starting corner is the lower-left, vertex 2
    n = np.cross(p[1] - p[0], p[2] - p[1])
    assert np.linalg.norm(n) == pytest.approx(10.0)
    assert n / 10.0 == pytest.approx(normal, abs=1e-12)
    assert np.linalg.norm(p[2] - p[1]) == pytest.approx(4.0) and np.linalg.norm(p[0] - p[1]) == pytest.approx(2.5)


def _box(header: str, space: str = "") -> str:
    """A 4 x 3 x 2.5 m zone of simple objects (with a Space Name field when ``space`` is given)."""
    s = f"{space}," if space else ""
    return header + f"""
  Wall:Exterior,S,C,Z,{s}180,90,0,0,0,4,2.5;
  Wall:Underground,E,C,Z,{s}90,90,4,0,0,3,2.5;
  Wall:Adiabatic,N,C,Z,{s}0,,4,3,0,4,2.5;
  Wall:Interzone,W,C,Z,{s}W2,270,90,0,3,0,3,2.5;
  Floor:GroundContact,F,C,Z,{s}90,180,0,0,0,3,4;
  Ceiling:Adiabatic,R,C,Z,{s}180,0,0,0,2.5,4,3;
  GlazedDoor,GD,C,S,,,1,0.5,0,1,2;
  Door:Interzone,DI,C,W,X,1,1,0,0.9,2;
  GlazedDoor:Interzone,GI,C,E,X,1,1,0.5,1,1;
"""


def test_relative_north_turns_the_zone_and_its_rectangles():
    header = "GlobalGeometryRules,UpperLeftCorner,Counterclockwise,Relative;\nZone,Z,30,10,20,3;"
    request = upload("box.idf", _box(header).encode())
    result = solve(request).result
    (z,) = result.zones
    assert z.closed and z.volume == pytest.approx(30.0)
    c, s = math.cos(math.radians(-30)), math.sin(math.radians(-30))
    # the south wall's upper-right corner (4, 0, 2.5) in the zone, turned 30 deg clockwise and moved
    assert loop(request, "S")[3] == pytest.approx([10 + 4 * c, 20 + 4 * s, 5.5])
    face = {f.id: f for f in result.faces}
    assert face["S"].normal == pytest.approx([-math.sin(math.radians(30)), -math.cos(math.radians(30)), 0])
    assert face["S"].net_area == pytest.approx(10.0 - 2.0)
    assert face["W"].net_area == pytest.approx(7.5 - 1.8) and face["E"].net_area == pytest.approx(7.5 - 1.0)


def test_rectangular_surface_coordinate_system_world_ignores_zone_origins():
    header = "GlobalGeometryRules,UpperLeftCorner,Counterclockwise,Relative,Relative,World;\nZone,Z,30,10,20,3;"
    request = upload("box.idf", _box(header, space="Space 1").encode())
    assert request.source["skipped"] == []
    assert loop(request, "S")[1] == pytest.approx([0, 0, 0]) and loop(request, "R")[3] == pytest.approx([4, 3, 2.5])
    assert solve(request).result.zones[0].volume == pytest.approx(30.0)


def test_bad_simple_objects_are_skipped_naming_line_and_reason():
    text = _box("GlobalGeometryRules,UpperLeftCorner,Counterclockwise;\nZone,Z;") + \
        "Roof,BadRoof,C,Z,180,0,0,0,x,4,3;\nWindow,Lost,C,Nowhere,,,1,0,0,1,1;\nRoof,Short,C,Z,180,0,0,0,4,3;\n"
    request = upload("box.idf", text.encode())
    skipped = {s["object"]: s for s in request.source["skipped"]}
    assert "Starting Z Coordinate is 'x'" in skipped["roof 'BadRoof'"]["reason"]
    assert skipped["roof 'BadRoof'"]["line"] == 12
    assert "'Nowhere' is not a surface" in skipped["window 'Lost'"]["reason"]
    assert "9 fields" in skipped["roof 'Short'"]["reason"]
    with pytest.raises(InputRejected) as e:
        upload("bad.idf", b"Zone,Z;\nRoof,BadRoof,C,Z,180,0,0,0,x,4,3;\n")
    assert e.value.errors[0].loc == ("file", "line", 2) and "Starting Z Coordinate" in e.value.errors[0].msg


def test_zone_volume_and_floor_area_given_in_the_file_are_compared():
    header = ("GlobalGeometryRules,UpperLeftCorner,Counterclockwise,World;\n"
              "Zone,Z,0,0,0,0,1,1,autocalculate,30,13.2;")  # 30 m3 right, 13.2 m2 of floor (12 measured) wrong
    result = solve(upload("box.idf", _box(header).encode())).result
    (row,) = result.report.details["declared_comparison"]
    assert row["declared_volume"] == 30 and row["volume_difference"] == pytest.approx(0.0)
    assert row["floor_area"] == pytest.approx(12.0) and row["floor_area_difference"] == pytest.approx(12 / 13.2 - 1)
    (warning,) = [w for w in result.report.warnings if w.code == "declared_measures_differ"]
    assert warning.details["zones"] == ["Z"]
    autocalculated = upload("box.idf", _box("Zone,Z,0,0,0,0,1,1,autocalculate,autocalculate;").encode())
    assert autocalculated.source["declared"] == {}
