"""Plausible mistakes in EnergyPlus files, a sixth round: a zone whose Spaces leave surfaces over (EnergyPlus'
'-Remainder' space), an epJSON that writes a Yes/No choice as a JSON boolean."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
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


def test_a_zones_remainder_space_is_measured_beside_what_its_spaces_state():
    """Surfaces of a zone that name no Space go to EnergyPlus' '<zone>-Remainder' space, whose floor area is that of its
    Floor surfaces: the zone's is the Spaces' stated 12 m² plus the remainder's 8 m². The Spaces' 12 m² alone was
    compared with the 20 m² measured: a false declared_measures_differ on a right model. The remainder's volume is
    EnergyPlus' own reckoning: a Space's stated volume then claims nothing about the zone."""
    split = _split_office_a("A1", "", "")
    result = _solved("offices.idf", split + _space("A1", "", "12"))
    assert not [w for w in result.report.warnings if w.code == "declared_measures_differ"]
    (row,) = result.report.details["declared_comparison"]
    assert row["declared_floor_area"] == pytest.approx(20.0) and row["floor_area"] == pytest.approx(20.0)
    wrong = _solved("offices.idf", split + _space("A1", "", "99"))  # 99 + 8 declared against 20 measured: named
    (warning,) = [w for w in wrong.report.warnings if w.code == "declared_measures_differ"]
    assert wrong.report.details["declared_comparison"][0]["declared_floor_area"] == pytest.approx(107.0)
    volume = _solved("offices.idf", split + _space("A1", "36", ""))
    assert "declared_comparison" not in volume.report.details
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


WINDOW = ("  1.5, 0, 2.5,                            !- X,Y,Z Vertex 1 {m}\n"
          "  1.5, 0, 1,                              !- X,Y,Z Vertex 2 {m}\n"
          "  3.5, 0, 1,                              !- X,Y,Z Vertex 3 {m}\n"
          "  3.5, 0, 2.5;                            !- X,Y,Z Vertex 4 {m}")


def _window_at(*corners: tuple[float, float, float]) -> str:
    assert WINDOW in OFFICES
    return OFFICES.replace(WINDOW, "  " + ",\n  ".join(", ".join(map(str, c)) for c in corners) + ";")


def _south_wall(result):
    return next(f for f in result.faces if f.id == "Office A South")


@pytest.mark.parametrize("corners, off_plane, outside", [
    (((6, 0, 2.5), (6, 0, 1), (8, 0, 1), (8, 0, 2.5)), 0.0, 3.0),  # beside its wall, in its plane
    (((1.5, 0.5, 2.5), (1.5, 0.5, 1), (3.5, 0.5, 1), (3.5, 0.5, 2.5)), 0.5, 0.0),  # half a metre out of the wall
    (((3.5, 4, 2.5), (3.5, 4, 1), (1.5, 4, 1), (1.5, 4, 2.5)), 4.0, 0.0),  # the north wall's coordinates
])
def test_a_window_that_is_not_in_its_wall_is_named(corners, off_plane, outside):
    """A window beside its wall, off its plane or drawn on another wall had its 3 m² taken off the wall's net area
    (15 − 3 = 12 m²) with no word. The area is still taken, as EnergyPlus takes it, and the window is named with how
    far it is off the plane and outside the outline."""
    result = _solved("offices.idf", _window_at(*corners))
    assert _south_wall(result).net_area == pytest.approx(12.0)
    (warning,) = [w for w in result.report.warnings if w.code == "subsurface_outside_host"]
    (entry,) = warning.details["subsurfaces"]
    assert entry["face"] == "Office A Window" and entry["host"] == "Office A South"
    assert entry["off_plane"] == pytest.approx(off_plane, abs=1e-9)
    assert entry["outside"] == pytest.approx(outside, abs=1e-9)
    plain = _solved("offices.idf", OFFICES)  # in its wall, a corner on the wall's edge too: nothing said
    on_edge = _solved("offices.idf", _window_at((1.5, 0, 3), (1.5, 0, 0), (3.5, 0, 0), (3.5, 0, 3)))
    for right in (plain, on_edge):
        assert not [w for w in right.report.warnings if w.code in ("subsurface_outside_host", "subsurfaces_overlap")]


def test_a_window_pasted_twice_is_named_with_the_area_counted_twice():
    """Two windows over one opening (a block pasted twice under a new name) took 6 m² off the wall for 3 m² of glass,
    no word."""
    copy = OFFICES[OFFICES.index("FenestrationSurface:Detailed"):].replace("Office A Window", "Office A Window copy")
    result = _solved("offices.idf", OFFICES + "\n" + copy)
    assert _south_wall(result).net_area == pytest.approx(9.0)
    (warning,) = [w for w in result.report.warnings if w.code == "subsurfaces_overlap"]
    (pair,) = warning.details["pairs"]
    assert pair["faces"] == ["Office A Window", "Office A Window copy"] and pair["host"] == "Office A South"
    assert pair["overlap_area"] == pytest.approx(3.0)
    beside = OFFICES + "\n" + copy.replace("1.5, 0,", "0.5, 0,").replace("3.5, 0,", "1.5, 0,")  # touching: no overlap
    assert not [w for w in _solved("offices.idf", beside).report.warnings if w.code == "subsurfaces_overlap"]


def _skipped(result) -> list[dict]:
    return result.report.details["source"]["skipped"]


def test_a_coordinate_beyond_the_bound_skips_its_object_naming_the_line():
    """A vertex of 1e300 (a writer's garbage), or a Zone origin that puts its surfaces past ±1e12 m, was a 422 on
    'file.faces[1].loops[0][1][0]', an index the IDF does not have. Now the object is skipped with its line, as any
    object that cannot be read, and the zone it leaves open has no volume."""
    vertex = "  5, 4, 3,                                !- X,Y,Z Vertex 2 {m}"
    text = OFFICES.replace(vertex, "  1e300, 4, 3,  !- X,Y,Z Vertex 2 {m}", 1)
    result = _solved("offices.idf", text)
    (entry,) = _skipped(result)
    assert entry["object"] == "buildingsurface:detailed 'Office A Roof'" and "1e300" in entry["reason"]
    assert entry["line"] == OFFICES[:OFFICES.index("  Office A Roof,")].count("\n")
    assert [z.volume for z in result.zones] == [None, pytest.approx(60.0)]
    origin = "  5,                                      !- X Origin {m}"
    far = _solved("offices.idf", OFFICES.replace(origin, "  1e12,  !- X Origin {m}"))
    zone_line = OFFICES[:OFFICES.index("  Office B Thermal Zone,                  !- Name")].count("\n")
    reasons = {s["reason"] for s in _skipped(far)}
    assert reasons == {f"its Zone 'Office B Thermal Zone' (line {zone_line}) origin puts it beyond ±1e+12 m"}
    assert far.zones[1].volume is None


def test_an_obj_vertex_beyond_the_bound_skips_it_naming_the_line():
    vertices = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1e300\nv 0 0 1\n"
    result = _solved("room.obj", vertices + "f 1 3 2\nf 1 2 5\nf 2 3 5\nf 3 1 5\nf 1 2 4\n")
    assert {(s["line"], s["object"]) for s in _skipped(result)} == {(4, "v"), (10, "f")}
    assert result.zones[0].volume == pytest.approx(1 / 6)


def test_a_simple_rectangle_beyond_the_bound_skips_it_naming_the_line():
    text = (EXAMPLES / "four_zones_simple.idf").read_text()
    wall = "Wall:Exterior,Zn002:Wall002,EXTERIOR,ZONE 2,90,90,20,0,0,20,10;"
    result = _solved("simple.idf", text.replace(wall, wall.replace("90,90,20,", "90,90,1e300,")))
    entry, window = _skipped(result)  # and its window, whose host is gone
    assert window["object"] == "window 'Zn002:Wall002:Win001'"
    assert entry["line"] == text[:text.index(wall)].count("\n") + 1 and "Starting X Coordinate is '1e300'" in \
        entry["reason"]
    four = pytest.approx(4000.0)
    assert [z.volume for z in result.zones] == [four, None, four, four]


def test_an_ifc_schema_label_ifcopenshell_does_not_read_is_named():
    """'unreadable IFC file: No schema loaded' named nothing of the file; an IFC 4.3 model labelled 'IFC4X3' (a release
    candidate's name) is refused naming its label and the one IfcOpenShell reads."""
    from plantsolve.solvers.base import InputRejected

    text = (Path(__file__).parent / "data" / "ifcopenshell_spaces.ifc").read_text()
    assert "FILE_SCHEMA(('IFC4'))" in text
    with pytest.raises(InputRejected, match=r"its header's FILE_SCHEMA is 'IFC4X3'; IfcOpenShell reads IFC2X3, IFC4, "
                                            r"IFC4X3_ADD2"):
        parse_upload(StoredInput.from_bytes("spaces.ifc", text.replace("'IFC4'", "'IFC4X3'").encode()), None)
    request = parse_upload(StoredInput.from_bytes("spaces.ifc", text.replace("'IFC4'", "'IFC4X3_ADD2'").encode()), None)
    assert request.source["schema"] == "IFC4X3"


def test_an_obj_named_stl_is_refused_as_the_text_it_is():
    """Text under an .stl name passed for a binary STL cut short (its characters read as a count of 825 million
    triangles and as garbage floats), and the refusal named a face 't1' of it. Now it is refused as text, naming what
    it holds."""
    from plantsolve.solvers.base import InputRejected

    obj = "g room\n" + "".join(f"v {x} {y} {z}\n" for x in (0, 5) for y in (0, 4) for z in (0, 3)) + \
        "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n"
    assert _solved("room.obj", obj).zones[0].volume == pytest.approx(60.0)
    with pytest.raises(InputRejected, match=r"this file holds a Wavefront OBJ mesh, not an STL mesh as its name "
                                            r"says$"):
        parse_upload(StoredInput.from_bytes("room.stl", obj.encode()), None)


GBXML = (Path(__file__).parent / "data" / "openstudio_offices.xml").read_text(encoding="utf-8-sig")


def test_a_gbxml_saved_as_utf16_with_its_utf8_declaration_is_read():
    """Notepad's 'Unicode' keeps the declaration's encoding="utf-8" over UTF-16 bytes and their mark; expat refused the
    file ('encoding specified in XML declaration is incorrect'). The mark says what the bytes are: it is read."""
    assert GBXML.startswith('<?xml version="1.0" encoding="utf-8"?>')
    plain = _solved("offices.xml", GBXML)
    for encoding in ("utf-16", "utf-16-be"):
        content = ("\ufeff" + GBXML if encoding == "utf-16-be" else GBXML).encode(encoding)
        request = parse_upload(StoredInput.from_bytes("offices.xml", content), None)
        check_input(request)
        result = solve(request).result
        assert [(z.id, z.volume) for z in result.zones] == [(z.id, z.volume) for z in plain.zones]


def test_a_gbxml_coordinate_beyond_the_bound_skips_its_surface_naming_the_line():
    at = GBXML.index("<Coordinate>", GBXML.index("<PlanarGeometry>", GBXML.index('<Surface id="su-A-south"')))
    text = GBXML[:at] + "<Coordinate>1e300</Coordinate>" + GBXML[GBXML.index("</Coordinate>", at) + 13:]
    result = _solved("offices.xml", text)
    (entry,) = [s for s in _skipped(result) if s["object"] == "Surface 'su-A-south'"]
    assert entry["line"] == GBXML[:GBXML.index('<Surface id="su-A-south"')].count("\n") + 1
    assert entry["reason"].endswith("CartesianPoint 1 is beyond ±1e+12 m")
    assert [z.volume for z in result.zones][:2] == [None, pytest.approx(60.0)]


def test_surfaces_relative_to_a_zone_no_zone_object_defines_are_named():
    """Office B's Zone object left out (a block not copied): its surfaces, written relative to its origin at x = 5 m,
    were read at x = 0, on top of office A, the 12 m² wall between them lost, with no word (EnergyPlus refuses them)."""
    start = OFFICES.index("Zone,\n  Office B Thermal Zone")
    text = OFFICES[:start] + OFFICES[OFFICES.index("BuildingSurface:Detailed", start):]
    result = _solved("offices.idf", text)
    (warning,) = [w for w in result.report.warnings if w.code == "zones_not_defined"]
    assert warning.details["zones"] == ["Office B Thermal Zone"]
    assert warning.details["lines"] == [text[:text.index("  Office B Floor,")].count("\n")]
    assert not result.adjacency
    whole = _solved("offices.idf", OFFICES)
    assert whole.adjacency and not [w for w in whole.report.warnings if w.code == "zones_not_defined"]
    world = text.replace("  Relative,                               !- Coordinate System", "  World,  !- Coordinate")
    assert not [w for w in _solved("offices.idf", world).report.warnings if w.code == "zones_not_defined"]


def test_the_solids_of_an_ascii_stl_are_zones_of_their_own():
    """Two rooms exported as two named solids of one ASCII STL were joined into one zone named after the last solid,
    with both rooms' 120 m³ (and a non-manifold warning where they touch). Now each solid is a zone, their shared wall
    an adjacency."""
    import trimesh

    def solid(name: str, shift: float) -> str:
        box = trimesh.creation.box(extents=(5, 4, 3))
        box.apply_translation([shift, 0, 0])
        text = box.export(file_type="stl_ascii")
        return f"solid {name}\n" + text.split("\n", 1)[1].rsplit("endsolid", 1)[0] + f"endsolid {name}\n"

    result = _solved("rooms.stl", solid("room_a", 0) + solid("room_b", 5))
    assert [(z.id, z.volume, z.floor_area) for z in result.zones] == [("room_a", pytest.approx(60.0), 20.0),
                                                                      ("room_b", pytest.approx(60.0), 20.0)]
    (shared,) = result.adjacency
    assert shared.zones == ["room_a", "room_b"] and shared.area == pytest.approx(12.0)
    assert not result.report.warnings
    (one,) = _solved("room.stl", solid("room_a", 0)).zones  # one solid: the mesh as before
    assert one.id == "room_a" and one.volume == pytest.approx(60.0)


def test_one_room_written_as_a_solid_per_wall_stays_one_zone():
    """CAD tools also write one room as a solid per object or group (floor, roof, four walls): none closes alone, so
    they are one zone, as before solids were zones (each solid a zone, six open zones and no volume)."""
    import trimesh

    box = trimesh.creation.box(extents=(5, 4, 3))
    parts = []
    for k, (normal, name) in enumerate([((0, 0, -1), "floor"), ((0, 0, 1), "roof"), ((1, 0, 0), "wall_e"),
                                        ((-1, 0, 0), "wall_w"), ((0, 1, 0), "wall_n"), ((0, -1, 0), "wall_s")]):
        side = box.face_normals @ np.array(normal, dtype=float) > 0.5
        part = trimesh.Trimesh(box.vertices, box.faces[side], process=False)
        text = part.export(file_type="stl_ascii")
        parts.append(f"solid {name}\n" + text.split("\n", 1)[1].rsplit("endsolid", 1)[0] + f"endsolid {name}\n")
    (zone,) = _solved("room.stl", "".join(parts)).zones
    assert zone.volume == pytest.approx(60.0) and zone.floor_area == pytest.approx(20.0)


def test_a_building_none_of_whose_zones_one_stands_in_is_named():
    """A gbXML whose lengthUnit says Feet over numbers in metres (and states no Space measures) gave three offices
    0.91 m high, 1.7 m³ each: each one plausible alone (a plenum), no word. A building of several zones whose tallest
    is under 1.8 m is named, with the unit that makes it a storey."""
    import re

    bare = re.sub(r"<Area>[^<]*</Area>|<Volume>[^<]*</Volume>", "", GBXML)
    feet = _solved("offices.xml", bare.replace('lengthUnit="Meters"', 'lengthUnit="Feet"'))
    (warning,) = [w for w in feet.report.warnings if w.code == "implausible_building_height"]
    assert warning.details["tallest_zone"] == "Space_A" and warning.details["height"] == pytest.approx(3 * 0.3048)
    assert warning.details["likely_file_unit"] == "m" and "options.file_units 'm'" in warning.message
    right = _solved("offices.xml", bare)
    assert not [w for w in right.report.warnings if w.code.startswith("implausible")]
    plenum = _solved("box.stl", (Path(__file__).parent / "data" / "ascii_box.stl").read_text())  # one low zone alone
    assert not [w for w in plenum.report.warnings if w.code.startswith("implausible")]


def test_a_self_intersecting_window_over_another_is_measured_as_the_area_it_covers():
    """A window whose corners are in a bow-tie order overlapping another window: GEOS refused to intersect the invalid
    polygon and the pair was skipped, no word. Its two triangles (0.5 m² each, meeting at y = 2, z = 1.5) reach into the
    pane (y 1.5 to 2.5) by 0.125 m² each: 0.25 m² in all."""
    body = json.loads((Path(__file__).parents[3] / "examples" / "polyhedra" / "gable_house.json").read_text())
    body["faces"] += [
        {"id": "bowtie", "parent": "wall-west", "loops": [[[0, 1, 1], [0, 3, 2], [0, 3, 1], [0, 1, 2]]]},
        {"id": "pane", "parent": "wall-west", "loops": [[[0, 1.5, 0.5], [0, 1.5, 2.5], [0, 2.5, 2.5], [0, 2.5, 0.5]]]}]
    result = _solved("house.json", json.dumps(body))
    (warning,) = [w for w in result.report.warnings if w.code == "subsurfaces_overlap"]
    (pair,) = warning.details["pairs"]
    assert sorted(pair["faces"]) == ["bowtie", "pane"] and pair["overlap_area"] == pytest.approx(0.25)
