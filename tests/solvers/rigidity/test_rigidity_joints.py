"""Joints as LDraw models are built: small models whose joints are counted by hand (one way of joining each),
and official sets (OMR, CC BY 2.0: omr/README.md) whose parts are all joined and which come out as one build."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

HERE = Path(__file__).parent
OMR = HERE / "omr"


def parse(name, text):
    return parse_upload(StoredInput.from_bytes(name, text.encode()), None)


def joints(text: str) -> list[tuple[str, str, str, str, int]]:
    """(type, origin, part a, part b, connections) of each joint, parts by number."""
    request = parse("model.ldr", text)
    result = solve(request).result
    number = {p.id: p.part for p in request.parts}
    return sorted((j.type, j.origin, *sorted(number[b] for b in j.bodies), j.connections) for j in result.joints)


C = "0.707107"  # cos 45°, as editors print it


def test_a_plate_on_a_plate_turned_45_degrees_with_positions_printed_to_two_decimals_is_held_by_four_studs():
    # the top plate sits at R (20, -8, 0) = (19.799, 8.485, 0) of the turned base, printed 19.8 8.49
    text = (f"1 4 0 0 0 {C} -{C} 0 {C} {C} 0 0 0 1 3020.dat\n"
            f"1 4 19.8 8.49 0 {C} -{C} 0 {C} {C} 0 0 0 1 3022.dat\n")
    assert joints(text) == [("rigid", "stud", "3020", "3022", 4)]


def test_an_axle_pushed_into_a_hole_off_the_half_stud_grid_is_in_the_hole():
    # 3705 (80 LDU) turned onto z through the 1 x 2 technic brick's hole at (0, 10, 0), 7 LDU off centre
    text = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3700.dat\n1 0 0 10 7 0 0 -1 0 1 0 1 0 0 3705.dat\n"
    assert joints(text) == [("cylindrical", "axle", "3700", "3705", 1)]


@pytest.mark.parametrize("shift", [0, 3, 7])
def test_a_clip_holds_a_bar_wherever_along_it(shift):
    text = ("1 4 -10 -32 -10 -1 0 0 0 1 0 0 0 -1 4085c.dat\n"
            f"1 0 -10 {-86 + shift} 10 1 0 0 0 1 0 0 0 1 87994.dat\n")
    assert joints(text) == [("hinge", "clip", "4085c", "87994", 1)]


def test_a_dish_sunk_one_ldu_onto_a_stud_sits_on_it():
    # 4740's bore (radius 6, 5.3 deep, the stud slides in it): its mouth 1 LDU below the stud's base
    text = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 6141.dat\n1 4 0 -7 0 1 0 0 0 1 0 0 0 1 4740.dat\n"
    assert joints(text) == [("hinge", "stud", "4740", "6141", 1)]


@pytest.mark.parametrize("plate", ["3022", "3068b"])  # hand-coded 2 x 2 plate, generated 2 x 2 tile
def test_a_stud_under_the_centre_of_a_2x2_plate_is_held_by_its_tube(plate):
    text = f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 {plate}.dat\n1 4 0 8 0 1 0 0 0 1 0 0 0 1 3024.dat\n"
    assert joints(text) == [("hinge", "stud", *sorted((plate, "3024")), 1)]


def test_a_round_plate_centred_on_four_studs_stands_between_them():
    text = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 0 -8 0 1 0 0 0 1 0 0 0 1 6141.dat\n"
    assert joints(text) == [("rigid", "stud", "3003", "6141", 4)]


def test_a_round_plate_on_one_stud_is_a_hinge_not_also_held_by_its_ring():
    text = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 10 -8 10 1 0 0 0 1 0 0 0 1 6141.dat\n"
    assert joints(text) == [("hinge", "stud", "3003", "6141", 1)]


def test_nothing_is_joined_a_little_apart():
    # the same pairs 2 LDU off: no joint (the tolerance is for rounding, not for parts that do not meet)
    for text in ("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 0 -6 0 1 0 0 0 1 0 0 0 1 6141.dat\n",
                 "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3700.dat\n1 0 0 12 7 0 0 -1 0 1 0 1 0 0 3705.dat\n",
                 "1 4 0 0 0 1 0 0 0 1 0 0 0 1 6141.dat\n1 4 0 -10 0 1 0 0 0 1 0 0 0 1 4740.dat\n"):
        assert joints(text) == []


def omr(name: str):
    path = OMR / name
    request = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), None)
    return request, solve(request).result


def test_a_minifigures_arms_hands_hips_and_head_are_joined_as_the_snap_cylinders_fit():
    """The Lunar MPV's astronaut (sub-model '1621 - Minifig.ldr', arms turned by rotations printed to three
    digits): each arm in the torso and each hand in its arm a fit that turns, the hips held on the torso."""
    request, result = omr("1621-1-LunarMPVVehicle.mpd")
    number = {p.id: p.part for p in request.parts}
    fig = "L10/L241/L83/"
    pairs = Counter((j.origin, *sorted(number[b] for b in j.bodies)) for j in result.joints
                    if all(b.startswith(fig) for b in j.bodies))
    for pair in (("3818", "973p6c"), ("3819", "973p6c"), ("3818", "3820"), ("3819", "3820")):
        assert pairs[("fit", *pair)] >= 1, pair  # (an arm's two stated pegs are two fits on one axis)
    assert pairs[("stud", "3815", "973p6c")] == 1  # the hips' two pegs in the torso's two sockets: rigid
    assert {k[0] for k in pairs} <= {"fit", "stud", "hinge"}  # the legs turn on the hips' hinge


SETS = {  # set -> (known parts, pieces of the build, sub-builds standing apart)
    "30023-1-Lighthouse.ldr": (25, 1, []),
    "30054-1-AT-ST-Mini.mpd": (47, 1, []),
    "6965-1-TIEIntercep_4h4MXk5.mpd": (32, 1, []),
    "1621-1-LunarMPVVehicle.mpd": (100, 1, ["1621 - Droid.ldr"]),
}


@pytest.mark.parametrize("name", sorted(SETS))
def test_an_official_set_has_every_known_part_joined_and_is_one_build(name):
    known, build_pieces, apart = SETS[name]
    request, result = omr(name)
    assert len(request.parts) - len(result.unknown_parts) == known
    floating = [p for p in result.parts if not p.joints]
    assert floating == [] and len(result.parts) == known
    assert "floating_parts" not in {w.code for w in result.report.warnings}
    assert len([p for p in result.pieces if p.sub_build is None]) == build_pieces
    assert [p.sub_build for p in result.pieces if p.sub_build] == apart
    assert result.collisions == []


def test_the_at_at_head_hangs_on_a_hinge_drawn_two_ldu_off_its_fingers():
    """OMR 4489 (2018) hangs the head on a locking hinge whose fingers the 2024 library draws 2 LDU above
    where the model puts the mating fingers (44567 moved to 44567a): every part is joined, and the head is a
    piece of its own, named in a warning."""
    request, result = omr("4489-1-AT-AT-Mini.mpd")
    assert all(p.joints for p in result.parts) and len(result.parts) == 82
    assert [len(p.parts) for p in result.pieces] == [57, 25]
    # the head sub-model ('4489 - Head.ldr', placed at line 98) with the hinge arm whose fingers miss
    head = {p.id for p in request.parts if p.id.startswith("L14/L98/")} | {"L14/L36"}
    assert set(result.pieces[1].parts) == head and result.pieces[1].sub_build is None
    warning = next(w for w in result.report.warnings if w.code == "separate_pieces")
    assert warning.details["pieces"] == [result.pieces[1].parts]


def test_a_part_joined_to_nothing_is_named_in_a_floating_parts_warning():
    text = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3003.dat\n" \
           "1 4 200 -24 0 1 0 0 0 1 0 0 0 1 3024.dat\n"
    result = solve(parse("float.ldr", text)).result
    warning = next(w for w in result.report.warnings if w.code == "floating_parts")
    assert warning.details["parts"] == [{"id": "L3", "part": "3024", "line": 3}]
    assert "1 of 3 known part(s)" in warning.message and "L3 (3024)" in warning.message
    assert [(p.id, p.joints, p.joined_to) for p in result.parts] == [
        ("L1", ["L1~L2"], ["L2"]), ("L2", ["L1~L2"], ["L1"]), ("L3", [], [])]
