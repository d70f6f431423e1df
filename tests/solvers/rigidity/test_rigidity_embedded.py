"""Parts a model defines itself, recognised from the official primitives their definitions draw: a hand-made
``.mpd`` whose own plate is drawn with the primitives of the LDraw library's 2 x 2 plate (3022: four ``stud.dat`` on
top, one ``stud4.dat`` tube below), a 2 x 2 brick on its four studs and a 1 x 1 brick's stud in its tube."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.embedded import Resolver, transform
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

PLATE_LINES = ("1 16 0 4 0 1 0 0 0 -1 0 0 0 1 stud4.dat\n"  # as 3022.dat draws them
               "1 16 0 8 0 16 0 0 0 -4 0 0 0 16 box5.dat\n"
               "1 16 0 8 0 20 0 0 0 -8 0 0 0 20 box5.dat\n"
               "1 16 10 0 10 1 0 0 0 1 0 0 0 1 stud.dat\n"
               "1 16 -10 0 10 1 0 0 0 1 0 0 0 1 stud.dat\n"
               "1 16 10 0 -10 1 0 0 0 1 0 0 0 1 stud.dat\n"
               "1 16 -10 0 -10 1 0 0 0 1 0 0 0 1 stud.dat\n")


def model(plate: str) -> str:
    return ("0 FILE main.ldr\n"
            f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 {plate}\n"
            "1 14 0 -24 0 1 0 0 0 1 0 0 0 1 3003.dat\n"  # 2 x 2 brick on the plate's four studs
            "1 1 0 8 0 1 0 0 0 1 0 0 0 1 3005.dat\n"  # 1 x 1 brick below: its stud in the plate's tube
            "0 NOFILE\n"
            "0 FILE my plate.dat\n0 My Plate  2 x  2\n0 Name: my plate.dat\n0 !LDRAW_ORG Unofficial_Part\n"
            + PLATE_LINES + "0 NOFILE\n")


def parse(text: str):
    return parse_upload(StoredInput.from_bytes("m.mpd", text.encode()), None)


def joints_of(result) -> dict[frozenset, tuple[str, int]]:
    return {frozenset(j.bodies): (j.type, j.connections) for j in result.joints}


def test_an_embedded_part_drawn_with_stud_primitives_joins_as_the_official_part_it_copies():
    request = parse(model("my plate.dat"))
    record = request.source["parts_from_primitives"]["my plate"]
    assert record["n"] == "My Plate  2 x  2" and len(record["s"]) == 5  # four studs and the tube
    result = solve(request).result
    assert result.unknown_parts == []
    # by hand: the brick on four studs (one rigid joint of 4 points), the 1 x 1's one stud in the tube (a hinge about
    # the stud's axis): two joints, no part joined to nothing
    assert joints_of(result) == {frozenset({"L2", "L3"}): ("rigid", 4), frozenset({"L2", "L4"}): ("hinge", 1)}
    assert result.dof == 1 and len(result.pieces) == 1
    (marked,) = [w for w in result.report.warnings if w.code == "parts_from_primitives"]
    assert marked.details == {"parts": ["my plate"], "ids": ["L2"]}
    # the official plate those primitives draw: the same joints
    official = solve(parse(model("my plate.dat").replace("0 0 0 1 my plate.dat\n", "0 0 0 1 3022.dat\n"))).result
    assert joints_of(official) == joints_of(result)
    assert "parts_from_primitives" not in {w.code for w in official.report.warnings}


def test_a_nested_subpart_turned_a_quarter_places_its_studs_turned():
    # the plate draws its studs through its own subpart, turned a quarter about y: a 1 x 2 stud row along x becomes
    # one along z, where a 1 x 2 brick turned the same way sits on both studs (one rigid joint of 2 points by hand)
    text = ("0 FILE main.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 row.dat\n"
            "1 14 0 -24 0 0 0 1 0 1 0 -1 0 0 3004.dat\n0 NOFILE\n"
            "0 FILE row.dat\n0 Stud Row\n0 !LDRAW_ORG Unofficial_Part\n"
            "1 16 0 0 0 0 0 1 0 1 0 -1 0 0 s\\row s01.dat\n4 16 20 0 10 -20 0 10 -20 0 -10 20 0 -10\n0 NOFILE\n"
            "0 FILE s\\row s01.dat\n0 ~Stud Row Studs\n0 !LDRAW_ORG Unofficial_Subpart\n"
            "1 16 -10 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n1 16 10 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n0 NOFILE\n")
    request = parse(text)
    starts = sorted(tuple(s[4]) for s in request.source["parts_from_primitives"]["row"]["s"])
    assert starts == [(0.0, 0.0, -10.0), (0.0, 0.0, 10.0)]
    assert joints_of(solve(request).result) == {frozenset({"L2", "L3"}): ("rigid", 2)}
    # unturned, the row's studs run along x and miss the turned brick's anti-studs: joined to nothing
    flat = solve(parse(text.replace("0 0 0 0 0 1 0 1 0 -1 0 0 s\\row", "0 0 0 1 0 0 0 1 0 0 0 1 s\\row"))).result
    assert flat.joints == []


def test_an_embedded_part_that_draws_no_primitive_with_snaps_stays_unknown():
    text = model("my plate.dat").replace(PLATE_LINES, "4 16 20 0 20 -20 0 20 -20 0 -20 20 0 -20\n")
    request = parse(text)
    assert request.source["parts_from_primitives"] == {}
    result = solve(request).result
    assert [u.part for u in result.unknown_parts] == ["my plate"] and result.joints == []


def test_a_scaled_placement_stretches_an_axle_but_keeps_a_stud_centred():
    axle = ["cyl", "M", "none", 1, [0.0, 0.0, 0.0], [0.0, -1.0, 0.0], [["A", 6.0, 1.0]], 1]  # axle.dat: scale=YOnly
    stretched = transform(axle, np.diag([1.0, 40.0, 1.0]), np.zeros(3))
    assert stretched[4:7] == [[0.0, 0.0, 0.0], [0.0, -1.0, 0.0], [["A", 6.0, 40.0]]]
    stud = ["cyl", "M", "one", 0, [0.0, 0.0, 0.0], [0.0, -1.0, 0.0], [["R", 6.0, 4.0]], 0]
    moved = transform(stud, np.diag([1.0, 2.0, 1.0]), np.array([5.0, 0.0, 0.0]))
    # a stud does not stretch: 4 long about its stretched centre (y = -4 of a 2-high scale: from -2 to -6)
    assert moved[4:7] == [[5.0, -2.0, 0.0], [0.0, -1.0, 0.0], [["R", 6.0, 4.0]]]


@pytest.mark.parametrize("snap", [
    ["shp", "M", "box 26 29.8 2", [0.0, 29.75, 0.0], [0.0, -1.0, 0.0]],  # s/51266s01.dat: a pane's generic shape
    ["pvt", "F", "unijnt", [0.0, 29.75, 0.0], [0.0, -1.0, 0.0]]])  # a grouped clip's hinge
def test_a_shape_or_pivot_snap_placed_turned_keeps_its_kind_group_and_turns_its_axis(snap):
    quarter = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # y onto z
    placed = transform(snap, quarter, np.array([10.0, 0.0, 0.0]))
    assert placed == [snap[0], snap[1], snap[2], [10.0, 0.0, 29.75], [0.0, 0.0, -1.0]]


def test_a_sub_file_that_draws_itself_adds_nothing():
    files = {"a.dat": [(1, "1 16 0 0 0 1 0 0 0 1 0 0 0 1 a.dat"), (2, "1 16 0 0 0 1 0 0 0 1 0 0 0 1 stud.dat")]}
    record = Resolver(files, lambda name: name if name in files else None).record("a.dat")
    assert record is not None and len(record["s"]) == 1
    assert record["b"] == pytest.approx([-6, -4, -6, 6, 0, 6])


def test_an_embedded_dat_without_header_that_draws_stud_primitives_is_a_part():
    text = model("my plate.dat").replace("0 !LDRAW_ORG Unofficial_Part\n", "")
    request = parse(text)
    assert [p.part for p in request.parts] == ["my plate", "3003", "3005"]
    assert joints_of(solve(request).result) == joints_of(solve(parse(model("my plate.dat"))).result)


@pytest.mark.parametrize("record", [{"n": "x"}, {"n": "x", "b": [0] * 6, "s": [["cyl", "M"]]},
                                    {"n": "x", "b": [0, 0, 0, 1, 1, 1], "s": [["sph", "M", [float("nan"), 0, 0], 4]]}])
def test_a_request_whose_recorded_part_is_no_catalogue_record_leaves_it_unknown_with_a_warning(record):
    request = parse(model("my plate.dat"))
    body = request.model_dump()
    body["source"]["parts_from_primitives"] = {"my plate": record}
    result = solve(type(request).model_validate(body)).result
    assert [u.part for u in result.unknown_parts] == ["my plate"]
    (warning,) = [w for w in result.report.warnings if w.code == "parts_from_primitives_unreadable"]
    assert warning.details == {"parts": ["my plate"]}


def test_sub_files_fanning_out_past_the_snap_bound_leave_the_part_unknown_quickly():
    # level k places level k-1 ten times: 10^8 studs at level 8; the part stays unknown, nothing is gathered past
    # the bound
    files = {"l0.dat": [(1, "1 16 0 0 0 1 0 0 0 1 0 0 0 1 stud.dat")]}
    for k in range(1, 9):
        files[f"l{k}.dat"] = [(n, f"1 16 {n} 0 0 1 0 0 0 1 0 0 0 1 l{k - 1}.dat") for n in range(10)]
    resolver = Resolver(files, lambda name: name if name in files else None)
    assert resolver.record("l8.dat") is None
    assert len(resolver.record("l3.dat")["s"]) == 1000


# A copy of the official 1 x 1 plate 3024 embedded under the model's prefix, as the OMR names them, drawing its top and
# bottom faces only (no primitive with snap data): on a 3024 as drawn, one stud between them.
def renamed_copy(name: str, top: float = 0) -> str:
    return ("0 FILE main.ldr\n"
            "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3024.dat\n"
            f"1 14 0 -8 0 1 0 0 0 1 0 0 0 1 {name}\n"
            "0 NOFILE\n"
            f"0 FILE {name}\n0 Plate  1 x  1\n0 Name: {name}\n0 !LDRAW_ORG Unofficial_Part\n"
            f"4 16 -10 {top} -10 10 {top} -10 10 {top} 10 -10 {top} 10\n"
            "4 16 -10 8 10 10 8 10 10 8 -10 -10 8 -10\n0 NOFILE\n")


def test_a_renamed_copy_of_an_official_part_takes_the_official_parts_snaps():
    request = parse(renamed_copy("9999 - 3024.dat"))
    assert request.source["parts_from_primitives"]["9999 - 3024"]["n"] == "Plate  1 x  1"
    result = solve(request).result
    assert [(j.type, j.origin, j.connections) for j in result.joints] == [("hinge", "stud", 1)] and result.dof == 1


@pytest.mark.parametrize("name, top", [("9999 - 3024.dat", -20), ("my 3024.dat", 0)])
def test_a_copy_drawn_outside_the_official_box_or_not_named_as_a_copy_stays_unknown(name, top):
    result = solve(parse(renamed_copy(name, top))).result
    assert result.joints == [] and [u.part for u in result.unknown_parts] == [name[:-4]]
