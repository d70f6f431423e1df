"""Plausible mistakes in zone files, a seventh round: a Zone origin that is no number under relative coordinates, a
ZoneList naming a zone the file lacks, a gbXML saved in Windows-1252 under encoding="utf-8", an OBJ naming both
objects ('o') and groups ('g')."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

EXAMPLES = Path(__file__).parents[3] / "examples" / "polyhedra"
OFFICES = (EXAMPLES / "two_offices.idf").read_text()
GBXML = (EXAMPLES / "offices.xml").read_bytes()
B_ORIGIN = "  5,                                      !- X Origin {m}"


def _solved(name: str, content: bytes):
    request = parse_upload(StoredInput.from_bytes(name, content), None)
    check_input(request)
    return request, solve(request).result


def _codes(request) -> list[str]:
    return [w["code"] if isinstance(w, dict) else w.code for w in request.source["warnings"]]


def test_an_unreadable_zone_origin_under_relative_coordinates_is_refused_naming_the_zone_line():
    """Office B's X Origin '5m' was taken as 0 and the zone read on top of office A (its shared wall lost), the only
    word a skipped-list entry for a Zone that was not skipped."""
    assert OFFICES.count(B_ORIGIN) == 1
    line = OFFICES[:OFFICES.index(B_ORIGIN)].count("\n") - 2  # the Zone object's first line
    with pytest.raises(InputRejected) as refused:
        _solved("offices.idf", OFFICES.replace(B_ORIGIN, "  5m,").encode())
    (error,) = refused.value.errors
    assert error.loc == ("file", "line", line)
    assert "Office B Thermal Zone" in error.msg and "'5m'" in error.msg
    # under World coordinates the origin is not used (EnergyPlus ignores it): the file reads
    world = OFFICES.replace("  Relative,                               !- Coordinate System",
                            "  World,  !- Coordinate System").replace(B_ORIGIN, "  5m,")
    _, result = _solved("offices.idf", world.encode())
    assert [z.volume for z in result.zones] == pytest.approx([60.0, 60.0])


def _zone_group(members: str) -> str:
    return f"\nZoneList,\n  Floors,\n  {members};\n\nZoneGroup,\n  Floors x3,\n  Floors,\n  3;\n"


def test_a_zone_group_whose_list_names_a_zone_the_file_lacks_is_refused_naming_it():
    """'Office B Zone' (for 'Office B Thermal Zone'): the group's multiplier 3 went nowhere, office B counted once."""
    right, _ = _solved("offices.idf", (OFFICES + _zone_group("Office B Thermal Zone")).encode())
    assert right.zone_multipliers == {"Office B Thermal Zone": 3}
    text = OFFICES + _zone_group("Office B Zone")
    with pytest.raises(InputRejected) as refused:
        _solved("offices.idf", text.encode())
    (error,) = refused.value.errors
    line = text[:text.index("Office B Zone")].count("\n") + 1
    assert "'Office B Zone'" in error.msg and error.loc == ("file", "line", line)


def test_a_zone_list_naming_a_zone_the_file_lacks_is_named():
    request, _ = _solved("offices.idf", (OFFICES + "\nZoneList,\n  Offices,\n  Office A Thermal Zone,\n"
                                                  "  Ofice B Thermal Zone;\n").encode())
    (warning,) = [w for w in request.source["warnings"] if w["code"] == "zone_list_names_unknown_zone"]
    assert warning["details"]["zones"] == ["Ofice B Thermal Zone"] and warning["details"]["zone_list"] == "Offices"


def test_a_windows_1252_gbxml_declaring_utf8_is_read_and_says_so():
    """A space named 'Büro' saved by a Windows tool (byte 0xFC) under encoding="utf-8" was refused as 'not
    well-formed XML: invalid token'."""
    text = GBXML.replace(b"<Name>Office A</Name>", "<Name>Büro A</Name>".encode("cp1252"))
    request, result = _solved("offices.xml", text)
    assert request.source["spaces"]["Space_A"] == "Büro A"
    (warning,) = [w for w in request.source["warnings"] if w["code"] == "encoding_assumed"]
    assert warning["details"] == {"declared": "utf-8", "read_as": "cp1252", "line": 11}
    _, right = _solved("offices.xml", GBXML)
    assert [z.volume for z in result.zones] == pytest.approx([z.volume for z in right.zones])
    assert "encoding_assumed" not in _codes(parse_upload(StoredInput.from_bytes("offices.xml", GBXML), None))


CUBE_FACES = ("f 1 4 3 2", "f 5 6 7 8", "f 1 2 6 5", "f 2 3 7 6", "f 3 4 8 7", "f 4 1 5 8")


def _cube(x0: float) -> list[str]:
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    return [f"v {x + x0} {y} {z}" for x, y, z in corners]


def _faces(faces: tuple[str, ...], offset: int) -> list[str]:
    return [" ".join(["f", *(str(int(i) + offset) for i in f.split()[1:])]) for f in faces]


def _rooms(lines: list[str]):
    request, result = _solved("rooms.obj", ("\n".join(lines) + "\n").encode())
    assert sorted(z.id for z in result.zones) == ["Room0", "Room1"]
    assert [z.volume for z in result.zones] == pytest.approx([1.0, 1.0])
    return [w for w in request.source["warnings"] if w["code"] == "obj_zones_chosen"]


def test_an_obj_naming_objects_and_groups_makes_the_zones_of_the_cut_that_closes():
    """Blender writes 'o Room' and, with material groups, 'g Room_Wall' / 'g Room_Floor' within it: the zones were the
    groups, each room cut into two open pieces with no volume. Rhino writes an object per surface and a group per
    layer: there the groups are the rooms."""
    lines = []
    for k, x0 in enumerate((0.0, 3.0)):
        lines += [f"o Room{k}", *_cube(x0), f"g Room{k}_Floor", *_faces(CUBE_FACES[:1], 8 * k),
                  f"g Room{k}_Walls", *_faces(CUBE_FACES[1:], 8 * k)]
    (warning,) = _rooms(lines)
    assert warning["details"] == {"zones_by": "o", "zones": 2, "closed": 2, "objects": 2, "groups": 4,
                                  "closed_by_g": 0}
    lines = []
    for k, x0 in enumerate((0.0, 3.0)):
        lines += [f"g Room{k}", *_cube(x0)]
        lines += [line for j, face in enumerate(_faces(CUBE_FACES, 8 * k)) for line in (f"o Surface{k}_{j}", face)]
    (warning,) = _rooms(lines)
    assert warning["details"] == {"zones_by": "g", "zones": 2, "closed": 2, "objects": 12, "groups": 2,
                                  "closed_by_o": 0}
    # one file-wide object with a group per room (both cuts close as many): the groups stay the zones
    lines = ["o Building"]
    for k, x0 in enumerate((0.0, 3.0)):
        lines += [f"g Room{k}", *_cube(x0), *_faces(CUBE_FACES, 8 * k)]
    _rooms(lines)


def test_interzone_twins_that_do_not_meet_are_named():
    """Office B's X Origin typed 50 for 5: both volumes right, the shared wall (Office A East, whose other side is
    Office B West) silently lost from the adjacency. The twins' centres lie 45 m apart."""
    request, result = _solved("offices.idf", OFFICES.replace(B_ORIGIN, "  50,").encode())
    assert [z.volume for z in result.zones] == pytest.approx([60.0, 60.0]) and not result.adjacency
    (warning,) = [w for w in request.source["warnings"] if w["code"] == "interzone_surfaces_apart"]
    (pair,) = warning["details"]["pairs"]
    assert {pair["surface"], pair["twin"]} == {"Office A East", "Office B West"}
    assert pair["distance"] == pytest.approx(45.0)
    assert "interzone_surfaces_apart" not in _codes(parse_upload(StoredInput.from_bytes("o.idf", OFFICES.encode()),
                                                                 None))
    # 1 cm (5.01 for 5) is past what the solver pairs (merge_tolerance 1e-6 m): the adjacency is lost all the same
    request, result = _solved("offices.idf", OFFICES.replace(B_ORIGIN, "  5.01,").encode())
    assert not result.adjacency
    (warning,) = [w for w in request.source["warnings"] if w["code"] == "interzone_surfaces_apart"]
    assert warning["details"]["pairs"][0]["distance"] == pytest.approx(0.01)
