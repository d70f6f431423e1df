"""Uploads as exporters write them: EnergyPlus/OpenStudio IDF, SketchUp and Revit OBJ, ASCII and binary STL."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest
import trimesh

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

DATA = Path(__file__).parent / "data"


def upload(name: str, content: bytes, options: dict | None = None):
    return parse_upload(StoredInput.from_bytes(name, content), options)


def solved(name: str, options: dict | None = None):
    request = parse_upload(StoredInput.from_path(DATA / name), options)
    return request, solve(request).result


def zone(result, name):
    return next(z for z in result.zones if z.id == name)


def test_energyplus_1zone_uncontrolled():
    request, result = solved("1ZoneUncontrolled.idf")
    (z,) = result.zones
    assert z.id == "ZONE ONE" and z.closed and z.orientation == "outward"
    assert z.volume == pytest.approx(1061.88, abs=0.005)
    floor = next(f for f in result.faces if f.id == "Zn001:Flr001")
    assert floor.area == pytest.approx(232.26, abs=0.005) and floor.normal == pytest.approx([0, 0, -1])
    assert z.surface_area == pytest.approx(2 * 15.24 ** 2 + 4 * 15.24 * 4.572)
    assert request.source["format"] == "idf" and request.source["skipped"] == []


def test_openstudio_export_with_space_names_relative_coordinates_and_interzone_walls():
    request, result = solved("openstudio_two_offices.idf")
    a, b = zone(result, "Office A Thermal Zone"), zone(result, "Office B Thermal Zone")
    assert a.volume == pytest.approx(60.0) and b.volume == pytest.approx(60.0) and a.closed and b.closed
    assert a.surface_area == pytest.approx(94.0) and a.net_surface_area == pytest.approx(94.0 - 3.0)
    window = next(f for f in result.faces if f.id == "Office A Window")
    assert window.parent == "Office A South" and window.area == pytest.approx(3.0)
    (adj,) = result.adjacency  # the wall written once per zone, at x = 5 m once moved to the zone origins
    assert adj.zones == ["Office A Thermal Zone", "Office B Thermal Zone"] and adj.area == pytest.approx(12.0)
    assert sorted(adj.faces) == ["Office A East", "Office B West"]
    text = (DATA / "openstudio_two_offices.idf").read_text().splitlines()
    skipped = {s["object"]: s for s in request.source["skipped"]}
    shade = skipped["buildingsurface:detailed 'Office B Broken Shade'"]
    assert "oops" in shade["reason"] and "line 264" in shade["reason"] and "oops" in text[263]
    assert text[shade["line"] - 1] == "buildingsurface:detailed," and "Broken Shade" in text[shade["line"]]
    orphan = skipped["fenestrationsurface:detailed 'Office B Orphan Window'"]
    assert "Office B Nowhere" in orphan["reason"] and "Orphan Window" in text[orphan["line"]]
    assert [w.code for w in result.report.warnings] == ["skipped_lines"]


def test_legacy_idf_clockwise_and_free_formatting():
    request, result = solved("legacy_clockwise.idf")
    (z,) = result.zones
    assert z.id == "Shop" and z.closed and z.orientation == "outward" and z.volume == pytest.approx(40.0)
    window = next(f for f in result.faces if f.id == "Shop Window")
    assert window.parent == "Shop South" and window.area == pytest.approx(1.0)
    assert window.normal == pytest.approx([0, -1, 0])  # clockwise entry turned counter-clockwise
    assert z.net_surface_area == pytest.approx(z.surface_area - 1.0) and request.source["skipped"] == []


def test_idf_with_nothing_usable_is_refused_naming_the_line():
    text = b"Version,9.3;\n\nBuildingSurface:Detailed,\n  W1, Wall, C, Z, Outdoors, , SunExposed, WindExposed, 0.5, 4,\n" \
           b"  0, 0, 1,\n  0, 0, zero,\n  1, 0, 0,\n  1, 0, 1;\n"
    with pytest.raises(InputRejected) as error:
        upload("bad.idf", text, None)
    (fe,) = error.value.errors
    assert fe.loc == ("file", "line", 3) and "zero" in fe.msg
    with pytest.raises(InputRejected, match="no BuildingSurface"):
        upload("empty.idf", b"Version,9.3;\nTimestep,4;\n", None)


def test_sketchup_obj_groups_are_zones():
    request, result = solved("sketchup_two_rooms.obj")
    assert request.source["format"] == "obj" and len(request.faces) == 24
    r1, r2 = zone(result, "Room_1"), zone(result, "Room_2")
    assert r1.volume == pytest.approx(4 * 3 * 2.7) and r2.volume == pytest.approx(3.5 * 3 * 2.7)
    assert r1.closed and r2.closed and r1.orientation == r2.orientation == "outward"
    assert result.report.details["merged_vertices"] > 0  # SketchUp writes every triangle's corners afresh
    (adj,) = result.adjacency  # the shared wall, triangulated along different diagonals on each side
    assert adj.zones == ["Room_1", "Room_2"] and adj.area == pytest.approx(3 * 2.7) and len(adj.faces) == 4


def test_revit_obj_objects_negative_indices_and_continuations():
    request, result = solved("revit_room.obj")
    (z,) = result.zones
    assert z.id == "Level_1_Room_101" and z.closed and z.volume == pytest.approx(6 * 4 * 3.2)
    (skip,) = request.source["skipped"]
    lines = (DATA / "revit_room.obj").read_text().splitlines()
    assert lines[skip["line"] - 1] == "f 1 2 99" and "99" in skip["reason"]


def test_obj_with_no_usable_face_is_refused():
    with pytest.raises(InputRejected) as error:
        upload("x.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 3\n", None)
    assert error.value.errors[0].loc == ("file", "line", 3)


def test_ascii_stl():
    request, result = solved("ascii_box.stl")
    (z,) = result.zones
    assert z.id == "pump_housing" and z.closed and z.volume == pytest.approx(2.0 * 1.0 * 0.5)
    assert z.surface_area == pytest.approx(2 * (2 + 1 + 0.5) * 1) and z.orientation == "outward"


def test_binary_stl_of_a_torus_agrees_with_trimesh():
    mesh = trimesh.creation.torus(major_radius=2.0, minor_radius=0.5, major_sections=48, minor_sections=24)
    content = trimesh.exchange.stl.export_stl(mesh)
    stored = trimesh.load(io.BytesIO(content), file_type="stl")  # binary STL holds float32 coordinates
    result = solve(upload("torus.stl", content, {"units": "m"})).result
    (z,) = result.zones
    assert z.id == "default" and z.closed and z.genus == 1 and z.orientation == "outward"
    assert z.volume == pytest.approx(stored.volume, rel=1e-12) and z.surface_area == pytest.approx(stored.area, rel=1e-12)
    assert z.volume == pytest.approx(mesh.volume, rel=1e-6)


def test_json_upload_and_form_options():
    body = {"faces": [{"id": "a", "loops": [[[0, 0, 0], [1, 0, 0], [0, 1, 0]]]}]}
    request = upload("r.json", json.dumps(body).encode(), {"units": "ft", "merge_tolerance": 0.01})
    assert request.units == "ft" and request.options.merge_tolerance == 0.01
    with pytest.raises(InputRejected) as error:
        upload("r.json", json.dumps(body).encode(), {"merge_tolerance": -1})
    assert error.value.errors[0].loc == ("options", "merge_tolerance")


def test_relative_coordinates_follow_the_zone_relative_north():
    # office B turned by 90 degrees (EnergyPlus turns zone coordinates clockwise by the relative north)
    # and placed at (5, 5): its local south wall (y = 0) lands on x = 5, against office A's east wall
    lines = (DATA / "openstudio_two_offices.idf").read_text().splitlines()
    assert lines[32].strip().startswith("Office B Thermal Zone,") and lines[33].strip().startswith("0,")
    lines[33] = "  90,                                     !- Direction of Relative North {deg}"
    lines[35] = "  5,                                      !- Y Origin {m}"
    result = solve(upload("turned.idf", "\n".join(lines).encode(), None)).result
    b = zone(result, "Office B Thermal Zone")
    assert b.volume == pytest.approx(60.0) and b.closed
    (adj,) = result.adjacency
    assert sorted(adj.faces) == ["Office A East", "Office B South"] and adj.area == pytest.approx(12.0)
    south = next(f for f in result.faces if f.id == "Office B South")
    assert south.normal == pytest.approx([-1.0, 0.0, 0.0], abs=1e-12)


# ---------------------------------------------------------------- files cut short


def test_idf_cut_inside_its_last_surface_warns_naming_the_line():
    # EnergyPlus's own file, cut in transfer after the roof's third vertex: no closing ';'
    lines = (DATA / "1ZoneUncontrolled.idf").read_bytes().splitlines(keepends=True)
    roof = next(n for n, ln in enumerate(lines, 1) if b"Zn001:Roof001" in ln) - 1
    request = upload("cut.idf", b"".join(lines[:roof + 13]))
    assert request.source["skipped"][-1]["line"] == roof and "no closing ';'" in request.source["skipped"][-1]["reason"]
    result = solve(request).result
    assert result.report.status == "warning"
    cut = {w.code: w for w in result.report.warnings}["truncated_file"]
    assert cut.details["line"] == roof and f"line {roof}" in cut.message and "Zn001:Roof001" in cut.message
    (z,) = result.zones
    assert not z.closed and len(result.faces) == 5  # the walls and floor are read; the cut roof is not


def test_idf_whose_only_surface_is_cut_is_refused_naming_its_line():
    text = b"Version,9.3;\n\nBuildingSurface:Detailed,\n  W1, Wall, C, Z, Outdoors, , SunExposed, WindExposed, 0.5, 4,\n" \
           b"  0, 0, 1,\n  0, 0, 0,\n  1, 0, 0,\n  1, 0,"
    with pytest.raises(InputRejected) as error:
        upload("cut.idf", text, None)
    (fe,) = error.value.errors
    assert fe.loc == ("file", "line", 3) and "no closing ';'" in fe.msg


def test_surface_objects_ending_before_their_vertex_fields_are_skipped_naming_their_lines():
    # each object is closed but stops short of its Number of Vertices field: skipped with a reason, the rest read
    lines = (DATA / "1ZoneUncontrolled.idf").read_bytes()
    text = lines + b"\nWall:Detailed, Stub Wall, C, ZONE ONE, Outdoors;\n" \
        b"FenestrationSurface:Detailed, Stub Window, Window, C, Zn001:Wall001;\n"
    request = upload("short.idf", text)
    skipped = {s["object"]: s for s in request.source["skipped"]}
    wall = skipped["wall:detailed 'Stub Wall'"]
    assert "ends before its 'Number of Vertices'" in wall["reason"]
    assert wall["line"] == text.count(b"\n", 0, text.index(b"Stub Wall")) + 1
    assert "ends before its 'Number of Vertices'" in skipped["fenestrationsurface:detailed 'Stub Window'"]["reason"]
    (z,) = solve(request).result.zones
    assert z.volume == pytest.approx(1061.88, abs=0.005)  # the six real surfaces still close the zone


def test_obj_cut_inside_its_last_face_line_warns_naming_the_line():
    content = (DATA / "sketchup_two_rooms.obj").read_bytes().rstrip()
    cut = content[:content.rfind(b" ")]  # 'f 70/70/24 71/71/24': two vertices of the last triangle
    last = cut.count(b"\n") + 1
    result = solve(upload("cut.obj", cut)).result
    warnings = {w.code: w for w in result.report.warnings}
    assert warnings["truncated_file"].details["line"] == last and f"line {last}" in warnings["truncated_file"].message
    assert warnings["skipped_lines"].details["lines"] == [last] and warnings["skipped_lines"].details["count"] == 1


def test_ascii_stl_cut_before_endsolid_reads_its_whole_facets_and_warns():
    content = (DATA / "ascii_box.stl").read_bytes()
    cut = content[:content.rfind(b"vertex")]  # inside the last facet's loop
    request = upload("cut.stl", cut)
    assert len(request.mesh.triangles) == 11 and request.faces == []  # the box's 12 triangles but the cut one
    result = solve(request).result
    (warning,) = [w for w in result.report.warnings if w.code == "truncated_file"]
    lines = cut.decode().splitlines()
    assert lines[warning.details["line"] - 1].strip().startswith("facet normal")  # the cut facet's first line
    with pytest.raises(InputRejected, match="before its first facet"):
        upload("cut.stl", content[:content.find(b"endfacet")])


def test_binary_stl_cut_short_reads_its_whole_triangles_and_warns():
    mesh = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    content = trimesh.exchange.stl.export_stl(mesh)  # 12 triangles of 50 bytes after an 84-byte header
    request = upload("cut.stl", content[:84 + 50 * 9 + 17])
    assert len(request.mesh.triangles) == 9
    (warning,) = [w for w in solve(request).result.report.warnings if w.code == "truncated_file"]
    assert warning.details == {"declared": 12, "read": 9, "bytes": 84 + 50 * 9 + 17}
    with pytest.raises(InputRejected, match="ends before the first"):
        upload("cut.stl", content[:84 + 30])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_bytes_named_stl_are_refused_not_read_as_a_cut_binary_stl(seed):
    """Random bytes read as a binary STL cut short (their count field says billions): the 2 % of triangles whose
    garbage floats passed were reported as an open zone of 1e23 m³. A cut file whose triangles are mostly
    unreadable is refused; a cut real file still reads (the test above)."""
    import numpy as np

    content = np.random.default_rng(seed).bytes(20_000)
    with pytest.raises(InputRejected, match="not a binary STL"):
        upload("noise.stl", content)


def test_obj_cut_inside_a_line_that_still_reads_warns_that_the_file_was_cut():
    """Revit's room cut inside a quad's face line ('f 1//1 3//1 4//1' of 'f 1//1 3//1 4//1 2//1') read a triangle,
    and a SketchUp file cut in a 'vn' line lost its later faces: both without a word before."""
    revit = (DATA / "revit_room.obj").read_bytes()
    quad = revit.index(b"f 1//1 3//1 4//1 2//1")
    sketchup = (DATA / "sketchup_two_rooms.obj").read_bytes()
    for cut in (revit[:quad + len(b"f 1//1 3//1 4//1")], sketchup[:sketchup.index(b"vn ", 500) + 10]):
        result = solve(upload("cut.obj", cut)).result
        note = next(w for w in result.report.warnings if w.code == "truncated_file")
        assert note.details["line"] == cut.count(b"\n") + 1 and "no line ending" in note.message


def test_idf_cut_after_an_objects_semicolon_warns_that_the_objects_after_it_are_missing():
    """EnergyPlus' 1ZoneUncontrolled cut inside the comment after a ';' lost every later surface without a word."""
    content = (DATA / "1ZoneUncontrolled.idf").read_bytes()
    end = content.index(b";", content.index(b"BuildingSurface:Detailed"))
    cut = content[:end + 6]  # ';  !-' of a surface's last vertex
    result = solve(upload("cut.idf", cut)).result
    note = next(w for w in result.report.warnings if w.code == "truncated_file")
    assert note.details["line"] == cut.count(b"\n") + 1 and "every object up to the last ';' was read" in note.message
