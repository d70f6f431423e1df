"""Mistakes an STL or OBJ without a stated unit, and a file of another kind under an .stl name, made: a room drawn in
inches read as metres (118 m high, 3.7e6 m³: inside every single zone's range) is named with the unit that makes it a
room; a PLY scan named .stl is refused naming what it holds (it was read as a binary STL cut short: garbage floats)."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

ROOT = Path(__file__).resolve().parents[3]
INCH = 0.0254


def box_stl(dx: float, dy: float, dz: float) -> bytes:
    """A closed box as a binary STL, its 12 triangles facing out."""
    c = [(x, y, z) for x in (0, dx) for y in (0, dy) for z in (0, dz)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b, c_, d in quads for t in ((a, b, c_), (a, c_, d))]
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *c[i], *c[j], *c[k], 0) for i, j, k in tris)
    return b"room".ljust(80, b" ") + struct.pack("<I", len(tris)) + body


def two_rooms_obj(k: float) -> bytes:
    """Two 4 x 3 x 2.7 m rooms side by side, every coordinate times ``k``, no header."""
    text = ""
    for room, x0 in (("a", 0.0), ("b", 4.0)):
        points = [((x0 + x) * k, y * k, z * k) for x in (0, 4) for y in (0, 3) for z in (0, 2.7)]
        base = 8 if room == "b" else 0
        text += f"o {room}\n" + "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in points)
        text += "".join("f " + " ".join(str(base + i) for i in q) + "\n"
                        for q in ((1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)))
    return text.encode()


def solved(name: str, content: bytes, options: dict | None = None):
    return solve(parse_upload(StoredInput.from_bytes(name, content), options)).result


def codes(result) -> set[str]:
    return {w.code for w in result.report.warnings}


def test_an_stl_room_drawn_in_inches_read_as_metres_is_named_with_inches():
    result = solved("room.stl", box_stl(5 / INCH, 4 / INCH, 3 / INCH))
    (warning,) = [w for w in result.report.warnings if w.code == "implausible_lowest_zone_height"]
    assert warning.details["likely_file_unit"] == "in"
    assert warning.details["height"] == pytest.approx(3 / INCH, rel=1e-6)
    assert "file_units" in warning.message and "in" in warning.message
    # said in inches, it is the 5 x 4 x 3 m room, and nothing is said
    right = solved("room.stl", box_stl(5 / INCH, 4 / INCH, 3 / INCH), {"file_units": "in", "units": "m"})
    assert right.zones[0].volume == pytest.approx(60.0, rel=1e-6)
    assert "implausible_lowest_zone_height" not in codes(right)


def test_a_room_in_metres_and_a_hall_beside_rooms_are_not_named():
    assert "implausible_lowest_zone_height" not in codes(solved("room.stl", box_stl(5, 4, 3)))
    hall = solved("hall.stl", box_stl(120, 80, 40))  # a 40 m hangar alone: a hall, not a unit
    assert not {c for c in codes(hall) if c.startswith("implausible")}


def test_a_tower_or_an_atrium_drawn_as_one_zone_is_no_room_in_inches():
    # taller than wide: no room's shape (a 60 m tower in metres was named 'inches read as metres')
    for tower in (box_stl(30, 30, 60), box_stl(20, 12, 150)):
        assert not {c for c in codes(solved("tower.stl", tower)) if c.startswith("implausible")}


def test_a_hall_wider_than_high_is_named_saying_what_it_would_have_to_be():
    (warning,) = [w for w in solved("hall.stl", box_stl(250, 200, 100)).report.warnings
                  if w.code == "implausible_lowest_zone_height"]
    assert "stadium" in warning.message and warning.details["likely_file_unit"] == "in"
    assert "2.54 m" in warning.message  # 100 in, a storey's height
    # 60 m read as inches is 1.52 m, as feet 18 m: neither a storey's, and no unit is named ('60 ft' was, as one)
    (low,) = [w for w in solved("hall.stl", box_stl(200, 150, 60)).report.warnings
              if w.code == "implausible_lowest_zone_height"]
    assert low.details["likely_file_unit"] is None


def test_a_large_room_in_inches_is_named_once_by_its_volume():
    result = solved("room.stl", box_stl(10 / INCH, 8 / INCH, 3.5 / INCH))
    assert "implausible_zone_volume" in codes(result) and "implausible_lowest_zone_height" not in codes(result)


def test_obj_rooms_in_inches_without_a_header_are_named_with_inches():
    result = solved("rooms.obj", two_rooms_obj(1 / INCH))
    (warning,) = [w for w in result.report.warnings if w.code == "implausible_lowest_zone_height"]
    assert warning.details["likely_file_unit"] == "in" and warning.details["zones"] == 2
    assert "implausible_lowest_zone_height" not in codes(solved("rooms.obj", two_rooms_obj(1.0)))


def rooms_and_stair_obj(k: float) -> bytes:
    """Two 4 x 3 x 2.7 m rooms and a 2 x 2 x 5.4 m stair (two storeys: taller than wide), every coordinate times
    ``k``, no header."""
    text, base = "", 0
    for zone, x0, (dx, dy, dz) in (("a", 0.0, (4, 3, 2.7)), ("b", 4.0, (4, 3, 2.7)), ("stair", 8.0, (2, 2, 5.4))):
        points = [((x0 + x) * k, y * k, z * k) for x in (0, dx) for y in (0, dy) for z in (0, dz)]
        text += f"o {zone}\n" + "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in points)
        text += "".join("f " + " ".join(str(base + i) for i in q) + "\n"
                        for q in ((1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)))
        base += 8
    return text.encode()


def test_a_stair_taller_than_wide_beside_rooms_in_inches_does_not_silence_the_rooms():
    # the stair is no room's shape and is left out; the rooms, 106 in high read as metres, are still named
    result = solved("rooms.obj", rooms_and_stair_obj(1 / INCH))
    (warning,) = [w for w in result.report.warnings if w.code == "implausible_lowest_zone_height"]
    assert warning.details["likely_file_unit"] == "in" and warning.details["zones"] == 2
    assert warning.details["height"] == pytest.approx(2.7 / INCH, rel=1e-6)
    assert "implausible_lowest_zone_height" not in codes(solved("rooms.obj", rooms_and_stair_obj(1.0)))


def test_a_ply_scan_named_stl_is_refused_naming_ply():
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("room.stl", (ROOT / "examples/tube/scan.ply").read_bytes()), None)
    (error,) = refused.value.errors
    assert error.loc == ("file",) and "PLY" in error.msg
    # one sentence: the format named says what the reader's own 'not an STL file: …' said again
    assert error.msg == "this file holds a PLY point cloud or mesh, not an STL mesh as its name says"


@pytest.mark.parametrize("header", [b"", b"plywood shelf", b"ply", b"{part 7}", b"<Part1>", b"[mesh]"])
def test_a_binary_stl_cut_short_is_still_read_with_its_whole_triangles(header):
    # a header is free text: its first word ('ply', '{') is no other format's signature (they were refused)
    room = box_stl(5, 4, 3)
    cut = (header.ljust(80, b" ") if header else room[:80]) + room[80:-25]
    result = solved("room.stl", cut)
    assert "truncated_file" in codes(result) and result.report.details["source"]["faces"] == 11


def test_a_ply_written_in_text_after_its_binary_header_word_is_still_refused():
    ply = b"ply\r\nformat binary_little_endian 1.0\r\nelement vertex 3\r\nend_header\r\n" + bytes(range(256)) * 4
    with pytest.raises(InputRejected):
        parse_upload(StoredInput.from_bytes("room.stl", ply), None)


def test_a_closed_zone_of_no_volume_is_named():
    # one face listed both ways round: every edge borne twice, so closed, and its volume 0 m³ was given without a word
    sheet = solved("sheet.obj", b"o sheet\nv 0 0 0\nv 5 0 0\nv 5 4 0\nv 0 4 0\nf 1 2 3 4\nf 4 3 2 1\n")
    assert sheet.zones[0].volume == 0.0
    (warning,) = [w for w in sheet.report.warnings if w.code == "implausible_zone_volume"]
    assert warning.details["zones"] == {"sheet": 0.0} and "enclose nothing" in warning.message
    assert warning.details["likely_file_unit"] is None
