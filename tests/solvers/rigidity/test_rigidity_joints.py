"""Joints as LDraw models are built: small models whose joints are counted by hand (one way of joining each),
and official sets (OMR, CC BY 2.0: omr/README.md) whose parts are all joined and which come out as one build."""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity import generated
from plantsolve.solvers.rigidity.assembly import OFFSET_REACH
from plantsolve.solvers.rigidity.pieces import APART_GAP, clearance, drawn_apart, loose_sub_builds, sub_build
from plantsolve.solvers.rigidity.solve import APART_BY, HELD_BY, solve
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


def test_a_hand_coded_axle_through_the_round_hole_of_a_generated_technic_plate_turns_in_it():
    # as set 392-1 draws its axles: 3707 (160 LDU, along x) through the round hole of 3709a that the snap data
    # states as a cylinder only (local z at x = 0, 10 LDU below the plate's top): one turning fit, nothing else
    text = ("1 7 20 -32 440 0 0 -1 0 1 0 1 0 0 3709a.dat\n"
            "1 15 40 -22 440 -1 0 0 0 1 0 0 0 -1 3707.dat\n")
    assert joints(text) == [("hinge", "fit", "3707", "3709a", 1)]
    # the axle a stud beside the hole (z = 450, between two holes): in none of them
    assert joints(text.replace("40 -22 440", "40 -22 450")) == []


def test_a_pin_through_two_half_thick_liftarms_turns_in_both():
    # 2825's holes are 10 LDU deep, centred 5 LDU from the centres of the pin's halves: the pin's stated cylinder
    # fits each (a hinge), the liftarms themselves share no connection
    text = ("1 4 0 0 0 1 0 0 0 1 0 0 0 1 2825.dat\n1 4 0 10 0 1 0 0 0 1 0 0 0 1 2825.dat\n"
            "1 0 0 10 20 0 -1 0 1 0 0 0 0 1 3673.dat\n")
    assert joints(text) == [("hinge", "fit", "2825", "3673", 1)] * 2
    # the pin a stud along, in no hole: nothing
    assert joints(text.replace(" 10 20 0 -1", " 10 30 0 -1")) == []


@pytest.mark.parametrize("shift", [0, 3, 7])
def test_a_clip_holds_a_bar_wherever_along_it(shift):
    text = ("1 4 -10 -32 -10 -1 0 0 0 1 0 0 0 -1 4085c.dat\n"
            f"1 0 -10 {-86 + shift} 10 1 0 0 0 1 0 0 0 1 87994.dat\n")
    assert joints(text) == [("hinge", "clip", "4085c", "87994", 1)]


# 2921's handle is stated as two 8 LDU bars either side of its middle (local y 0..8 and 16..24 at z = -20); 6339-1 clips
# a 2555 tile on that middle (as here, y = 12), the clip 8 LDU wide: its jaws reach the bar on both sides.
CLIP_ON_HANDLE = "1 16 0 0 0 1 0 0 0 1 0 0 0 1 2921.dat\n1 15 0 {y} -26 -1 0 0 0 0 -1 0 -1 0 2555.dat\n"


@pytest.mark.parametrize("y", [4, 12, 20])  # on the upper bar, across the gap, on the lower bar
def test_a_clip_on_the_middle_of_a_handle_the_data_states_in_two_bars_holds_it(y):
    result = solve(parse("model.ldr", CLIP_ON_HANDLE.format(y=y))).result
    assert joints(CLIP_ON_HANDLE.format(y=y)) == [("hinge", "clip", "2555", "2921", 1)]
    assert result.dof == 1 and "offset_joints" not in {w.code for w in result.report.warnings}


def test_a_clip_whose_jaws_reach_one_bar_only_is_not_seated_across_the_gap():
    # 2 LDU down from the middle: the jaws (y 6..14) reach the upper bar's end, not the lower bar's start; the slip
    # pass joins it as a clip drawn 2 LDU past the upper bar's end, and says so
    result = solve(parse("model.ldr", CLIP_ON_HANDLE.format(y=10))).result
    warning = next(w for w in result.report.warnings if w.code == "offset_joints")
    assert [pair["offset_ldu"] for pair in warning.details["pairs"]] == [2.0]
    # two bars of two parts on one line with the gap between them: no part holds the clip on both sides
    two_bars = ("1 0 0 -52 -20 1 0 0 0 1 0 0 0 1 87994.dat\n1 0 0 76 -20 -1 0 0 0 -1 0 0 0 1 87994.dat\n"
                "1 15 0 12 -26 -1 0 0 0 0 -1 0 -1 0 2555.dat\n")
    assert [j for j in joints(two_bars) if "2555" in j] == []


# The chain tread link 3873: two clips on its x axis at x = -8.75 and 8.75 (2.5 wide), and 16 LDU along z its pin,
# stated as a cylinder only: radius 2 from x = -6 to 6, radius 1.5 from 6 to 10 and from -6 to -10. The next link, 16
# LDU along z, has its clips round those pin ends, as set 10227 runs 36 links round its sprockets.
TREAD = "1 0 0 0 0 1 0 0 0 1 0 0 0 1 3873.dat\n1 0 0 {y} 16 1 0 0 0 1 0 0 0 1 3873.dat\n"


def test_a_chain_link_clips_onto_the_thin_pin_of_the_next():
    result = solve(parse("model.ldr", TREAD.format(y=0))).result
    assert joints(TREAD.format(y=0)) == [("hinge", "clip", "3873", "3873", 1)] * 2
    assert result.dof == 1  # the two clips on one axis: the links turn about it


@pytest.mark.parametrize("y", [1.5, 4])
def test_a_clip_beside_a_thin_pin_is_not_on_it(y):
    # drawn more than FIT_SNAP (1 LDU) off the pin's axis, the clip is not round it; the rounding of the slip pass
    # does not take it either (it joins clips to bars only)
    assert joints(TREAD.format(y=y)) == []


def test_a_clip_on_a_pins_axis_round_a_section_as_thick_as_a_stud_is_not_on_a_thin_rod():
    # the clip plate 4085c's clip (centre (0, 4, -20), axis y, 8 wide) on the axis of a Technic pin turned along y,
    # 10 LDU into one radius-6 half: no clip goes round that, and nothing else joins the two
    text = ("1 4 0 0 0 1 0 0 0 1 0 0 0 1 4085c.dat\n"
            "1 0 0 14 -20 0 -1 0 1 0 0 0 0 1 3673.dat\n")
    assert joints(text) == []
    # the same clip round a thin rod there (a chain link's pin end, radius 1.5, turned along y): a bar's clip (radius
    # 4) does not grip a rod that thin, the link's own clips (radius 1.5) do (above)
    link = "1 0 0 {y} -36 0 -1 0 1 0 0 0 0 1 3873.dat\n"
    assert joints("1 4 0 0 0 1 0 0 0 1 0 0 0 1 4085c.dat\n" + link.format(y=-4.75)) == []


# A bar 87994 (along y from its origin, 60 long) through a clip's centre along its axis, 30 LDU of bar on either side:
# the clip plate 4085c's clip (radius 4, centre (0, 4, -20)) and the magnet holder 753's (radius 6, centre (0, 4, -30)),
# a clip for a rod as thick as a pin, which a bar (radius 4) rattles in.
BAR_THROUGH = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 {part}.dat\n1 0 0 -26 {z} 1 0 0 0 1 0 0 0 1 87994.dat\n"


def test_a_clip_of_a_bars_radius_holds_a_bar_through_it():
    assert joints(BAR_THROUGH.format(part="4085c", z=-20)) == [("hinge", "clip", "4085c", "87994", 1)]


@pytest.mark.parametrize("part, z", [("753", -30), ("509", -30)])
def test_a_clip_wider_than_a_bar_does_not_hold_a_bar_through_it(part, z):
    result = solve(parse("model.ldr", BAR_THROUGH.format(part=part, z=z))).result
    assert joints(BAR_THROUGH.format(part=part, z=z)) == []
    assert "offset_joints" not in {w.code for w in result.report.warnings}  # nor the slip pass


def hand_and_revolver(tilt: float, cross: float = 0.0) -> str:
    """A minifigure hand 3820 (its clip centred at (0, -0.823, -9.895) along (0, -0.968, -0.25), 11 LDU wide) and a
    revolver 30132 (its grip a bar from (0, -3, 0) along y, 9 long) whose grip is turned ``tilt`` degrees off the
    clip's axis (about x), its middle where its line crosses the clip's axis ``cross`` LDU from the clip's centre."""
    centre, axis = np.array([0.0, -0.823, -9.895]), np.array([0.0, -0.968, -0.25])
    axis /= np.linalg.norm(axis)
    a = math.atan2(0.25, 0.968) + math.radians(tilt)  # turns y onto (0, cos a, sin a): the clip's line, less tilt
    rotation = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    position = centre + axis * cross - rotation @ np.array([0.0, 1.5, 0.0])
    numbers = " ".join(f"{v:.6f}" for v in [*position, *rotation.ravel()])
    return f"1 14 0 0 0 1 0 0 0 1 0 0 0 1 3820.dat\n1 0 {numbers} 30132.dat\n"


@pytest.mark.parametrize("tilt", [0, 4, -8])
def test_a_hand_holds_a_grip_turned_a_few_degrees_off_its_clip(tilt):
    # rotations printed with 3 digits through arm and hand leave a held accessory 4° off the hand's clip (6755-1);
    # at 8° the jaws' edges are 5.5 sin 8° = 0.77 LDU off the grip's line, inside FIT_SNAP
    assert joints(hand_and_revolver(tilt)) == [("hinge", "clip", "30132", "3820", 1)]


@pytest.mark.parametrize("tilt, cross", [(15, 0.0), (8, 3.0)])
def test_a_grip_turned_too_far_or_crossing_the_clip_off_centre_is_not_held(tilt, cross):
    # 15° off: more than FIT_ALIGN's 10°; 8° off crossing the clip's axis 3 LDU from its centre: the line passes
    # 0.42 LDU from the centre but 8.5 sin 8° = 1.18 LDU from the far jaw's edge
    assert joints(hand_and_revolver(tilt, cross)) == []


# A 1 x 2 tile 3069b (anti-studs at x = -10 and 10, no post between them) on the stud of a 1 x 1 plate, its middle
# drawn ``s`` LDU along its length from the stud: midway, its long walls grip the stud (seated within rounding); a
# slip of up to 3 LDU from there is joined as any point drawn off its mate and named with its offset.
TILE_ON_STUD = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3024.dat\n1 15 {s} -8 0 1 0 0 0 1 0 0 0 1 {part}.dat\n"


@pytest.mark.parametrize("s", [2, -3])
def test_a_one_wide_tile_drawn_a_little_off_the_stud_its_walls_grip_is_joined_and_named(s):
    result = solve(parse("model.ldr", TILE_ON_STUD.format(s=s, part="3069b"))).result
    assert [(j.type, j.origin) for j in result.joints] == [("hinge", "stud")]
    warning = next(w for w in result.report.warnings if w.code == "offset_joints")
    assert [pair["offset_ldu"] for pair in warning.details["pairs"]] == [abs(s)]


@pytest.mark.parametrize("s, part", [(4, "3069b"), (2, "3023")])
def test_a_stud_further_off_the_midway_place_or_under_a_post_is_not_gripped(s, part):
    # 4 LDU off: more than a slip; the plate 1 x 2 3023 states a post under its middle, where no stud fits
    assert joints(TILE_ON_STUD.format(s=s, part=part)) == []


# Two Technic arms, each on a pin joiner: 6217 (3 fingers) and 6048 (2 fingers) whose finger runs share the x axis,
# the 6048 drawn ``d`` LDU off the 6217's finger axis (6544-1 closes such a linkage 5.3 and 5.8 LDU off).
def arms(d: float) -> str:
    r1, joiner, r2 = "0 -1 0 -1 0 0 0 0 -1", "0 -1 0 0 0 1 -1 0 0", "0 -1 0 1 0 0 0 0 1"
    return (f"1 0 0 0 0 {r1} 6217.dat\n1 16 0 0 22 {joiner} 75535.dat\n"
            f"1 0 0 {d} -24 {r2} 6048.dat\n1 16 0 {d} -46 {joiner} 75535.dat\n")


ARM_PINS = [("hinge", "pin", "6048", "75535", 1), ("hinge", "pin", "6217", "75535", 1)]


@pytest.mark.parametrize("d", [0, 5.8, 7.5])
def test_hinge_fingers_drawn_off_their_axis_by_less_than_the_knuckles_diameter_are_one_hinge(d):
    result = solve(parse("model.ldr", arms(d))).result
    assert joints(arms(d)) == [("hinge", "hinge", "6048", "6217", 1), *ARM_PINS] and result.dof == 3
    offsets = [w.details["pairs"] for w in result.report.warnings if w.code == "offset_joints"]
    assert offsets == ([] if d == 0 else [[{"parts": ["L1", "L3"], "numbers": ["6217", "6048"], "offset_ldu": d}]])


def test_hinge_fingers_a_knuckles_diameter_apart_are_not_joined():
    assert joints(arms(8.5)) == ARM_PINS


def test_a_steering_wheel_on_its_stands_column_turns_on_it():
    # as 6544-1 places them: the shadow library states the wheel's hub male, as the column is; the catalogue reads
    # the hub as the column's bore
    text = "1 1 0 0 0 1 0 0 0 1 0 0 0 1 3829a.dat\n1 0 0 -26.015 0 0 0 1 -0.8 0.6 0 -0.6 -0.8 0 3828.dat\n"
    assert joints(text) == [("cylindrical", "bar", "3828", "3829a", 1)]
    assert solve(parse("model.ldr", text)).result.dof == 2
    # beside the column (a stud's width along x): nothing
    assert joints(text.replace("1 0 0 -26.015", "1 0 20 -26.015")) == []


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


LITTLE_APART = (  # the pairs above drawn 2 LDU off: above the stud, beside the hole, above the stud
    "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 0 -6 0 1 0 0 0 1 0 0 0 1 6141.dat\n",
    "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3700.dat\n1 0 0 12 7 0 0 -1 0 1 0 1 0 0 3705.dat\n",
    "1 4 0 0 0 1 0 0 0 1 0 0 0 1 6141.dat\n1 4 0 -10 0 1 0 0 0 1 0 0 0 1 4740.dat\n")


@pytest.mark.parametrize("text", LITTLE_APART)
def test_parts_drawn_two_ldu_off_their_mate_are_joined_and_named_with_the_offset(text):
    result = solve(parse("model.ldr", text)).result
    assert len(result.joints) == 1 and len(result.pieces) == 1
    warning = next(w for w in result.report.warnings if w.code == "offset_joints")
    assert [pair["offset_ldu"] for pair in warning.details["pairs"]] == [2.0]
    assert sorted(warning.details["pairs"][0]["parts"]) == ["L1", "L2"]


@pytest.mark.parametrize("text", LITTLE_APART)
def test_parts_four_ldu_off_their_mate_are_not_joined(text):
    # sunk 4 LDU into the brick, 4 beside the hole, 4 beside the stud (4 above it the dish rests on its tip: below)
    far = text.replace(" -6 0 1", " -4 0 1").replace(" 12 7 ", " 14 7 ").replace(" 0 -10 0 1", " 4 -8 0 1")
    assert far != text and joints(far) == []


@pytest.mark.parametrize("between, joined", [("3068b", False), ("3022", True)])
def test_a_brick_resting_on_a_tile_is_joined_to_nothing_though_its_anti_studs_lie_a_plates_height_over_studs(
        between, joined):
    """A 2 x 2 brick over the left half of a 2 x 4 brick with a 2 x 2 part between them: its four anti-studs lie 8 LDU
    (a plate's height) up the axes of four studs. On a tile (3068b) it rests, held by nothing (10179-1 draws a Technic
    brick 3700 so, on the tile 3068b over two 3894): the 8 LDU are no slip to join. On a plate (3022) it sits on
    the plate's four studs."""
    text = ("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
            f"1 4 -20 -8 0 1 0 0 0 1 0 0 0 1 {between}.dat\n1 4 -20 -32 0 1 0 0 0 1 0 0 0 1 3003.dat\n")
    assert joints(text) == [("rigid", "stud", "3001", between, 4)] + [("rigid", "stud", "3003", between, 4)] * joined
    result = solve(parse("tile.ldr", text)).result
    assert [pc.parts for pc in result.pieces] == ([["L1", "L2", "L3"]] if joined else [["L1", "L2"], ["L3"]])
    if not joined:
        why = next(w for w in result.report.warnings if w.code == "floating_parts").details["why"]
        assert why[0]["nearest"]["gap_ldu"] == 8.0 and why[0]["nearest"]["other_number"] == "3001"


def dish_on_plate(y: float, x: float = 0.0) -> str:
    # the 6 x 6 inverted dish 4285b over a 2 x 2 plate: seated at y = -8, its four corner anti-studs on the studs
    return f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 3022.dat\n1 4 {x} {y} 0 1 0 0 0 1 0 0 0 1 4285b.dat\n"


def test_a_dish_drawn_on_the_tips_of_the_studs_it_is_pressed_on_is_joined_and_named_with_the_studs_length():
    # 4 LDU up, every anti-stud's mouth on a stud's tip (as 10019-1 draws its dishes): held by the four studs
    result = solve(parse("model.ldr", dish_on_plate(-12))).result
    assert [(j.type, j.origin, j.connections) for j in result.joints] == [("rigid", "stud", 4)]
    warning = next(w for w in result.report.warnings if w.code == "offset_joints")
    assert [(sorted(pair["numbers"]), pair["offset_ldu"]) for pair in warning.details["pairs"]] == [
        (["3022", "4285b"], 4.0)]
    assert warning.details["stud_tip_ldu"] == 4.0 and "4 for an anti-stud drawn on a stud's tip" in warning.message
    assert joints(dish_on_plate(-8)) == [("rigid", "stud", "3022", "4285b", 4)]


@pytest.mark.parametrize("y, joined", [(-24, True), (-28, True), (-29, False)])
def test_a_cone_whose_sliding_bore_opens_on_a_studs_tip_turns_on_it_as_seated(y, joined):
    # the cone 4589's bore holds a stud's base anywhere along its last 2 LDU (a run ending at its mouth, y = 24): seated
    # at -24, its mouth on the round plate's stud tip at -28 (as 10179-1 draws its cones), 1 LDU past the tip at -29
    text = f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 6141.dat\n1 4 0 {y} 0 1 0 0 0 1 0 0 0 1 4589.dat\n"
    assert joints(text) == ([("hinge", "stud", "4589", "6141", 1)] if joined else [])


@pytest.mark.parametrize("y, x", [(-13, 0), (-12.5, 0), (-12, 0.5), (-16, 0)])
def test_a_dish_off_the_stud_tips_is_not_joined(y, x):
    assert joints(dish_on_plate(y, x)) == []


def test_no_offset_is_assumed_where_most_parts_meet_nothing():
    # three round plates each 2 LDU above a stud of their own brick, bricks a stud apart: six parts, all floating
    # as matched within rounding; a model this far off is read in another unit or as no build, not joined by slips
    text = "".join(f"1 4 {x} 0 0 1 0 0 0 1 0 0 0 1 3005.dat\n1 4 {x} -10 0 1 0 0 0 1 0 0 0 1 4073.dat\n"
                   for x in (0, 200, 400))
    result = solve(parse("model.ldr", text)).result
    assert result.joints == [] and "offset_joints" not in {w.code for w in result.report.warnings}
    # with a seventh part that meets a brick as drawn, 4 of 7 still float: the same
    result = solve(parse("model.ldr", text + "1 4 0 24 0 1 0 0 0 1 0 0 0 1 3005.dat\n")).result
    assert len(result.joints) == 1


def test_parts_meeting_within_rounding_carry_no_offset_warning():
    # a round plate on one stud as drawn, and a second one 2 LDU beside the next stud: only the second is named
    text = ("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 10 -8 10 1 0 0 0 1 0 0 0 1 6141.dat\n"
            "1 4 -12 -8 10 1 0 0 0 1 0 0 0 1 6141.dat\n")
    result = solve(parse("model.ldr", text)).result
    assert len(result.joints) == 2
    warning = next(w for w in result.report.warnings if w.code == "offset_joints")
    assert [(sorted(pair["parts"]), pair["offset_ldu"]) for pair in warning.details["pairs"]] == [(["L1", "L3"], 2.0)]


def test_a_stud_half_a_stud_along_the_outer_row_of_a_2_wide_plate_is_gripped_between_tube_and_wall():
    # 1 x 1 plate under the 2 x 4 plate's outer row midway between two anti-studs: a tube inside, the wall outside
    assert joints("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3020.dat\n1 4 0 8 10 1 0 0 0 1 0 0 0 1 3024.dat\n") == [
        ("hinge", "stud", "3020", "3024", 1)]
    # under a 1 x 4 plate the same place has no tube beside it, and under the middle of the 2 x 4 no wall: nothing
    assert joints("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3710.dat\n1 4 0 8 0 1 0 0 0 1 0 0 0 1 3024.dat\n") == []
    assert joints("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3020.dat\n1 4 10 8 0 1 0 0 0 1 0 0 0 1 3024.dat\n") == []


def test_a_brick_whose_data_states_its_tubes_only_grips_the_studs_between_them(monkeypatch):
    # 6192 (2 x 4 brick with curved top) as its sub-files alone state it (the data before its own shadow lines were
    # restored): three tubes and no anti-stud under its studs. On a 2 x 4 plate each of the plate's eight studs
    # stands half a pitch diagonally from a tube, inside the brick's walls.
    from dataclasses import replace

    from plantsolve.solvers.rigidity import assembly, catalogue

    def tubes_only(name):
        shape = catalogue.lookup(name)
        if shape is None or shape.number != "6192":
            return shape
        return replace(shape, connectors=tuple(c for c in shape.connectors if c.type != "antistud"
                                               or (c.point[0], c.point[2]) in ((-20.0, 0.0), (0.0, 0.0), (20.0, 0.0))))

    monkeypatch.setattr(assembly, "lookup", tubes_only)
    assert joints("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3020.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 6192.dat\n") == [
        ("rigid", "stud", "3020", "6192", 8)]
    # a 1 x 4 plate's studs would stand half a pitch from the tubes, in them: nothing
    assert joints("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3710.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 6192.dat\n") == []


def test_a_stud_midway_under_a_part_one_stud_wide_is_held_by_its_walls_unless_a_post_stands_there():
    # a 1 x 2 plate with one centre stud (15573) under a 1 x 2 part: its stud midway between the part's two anti-studs
    # (gripped by the long walls of a part that states no post there: the snap of the 1 x 2 tile 3069b, which
    # draws no post)
    jumper = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 15573.dat\n"
    assert joints(jumper + "1 4 0 -8 0 1 0 0 0 1 0 0 0 1 3069b.dat\n") == [("hinge", "stud", "15573", "3069b", 1)]
    # turned a quarter turn it is the same grip; a quarter pitch along, the stud is neither midway nor under one
    assert joints(jumper + "1 4 0 -8 0 0 0 1 0 1 0 -1 0 0 3069b.dat\n") == [("hinge", "stud", "15573", "3069b", 1)]
    assert joints(jumper + "1 4 5 -8 0 1 0 0 0 1 0 0 0 1 3069b.dat\n") == []
    # a 1 x 2 brick states the post under its middle (the data's male cylinder): no room for a 1 x 1 plate's stud
    plate = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3024.dat\n"
    assert joints(plate + "1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3004.dat\n") == []


def test_the_post_of_a_part_drawn_with_the_edgeless_post_primitive_stands_in_a_hollow_stud_and_blocks_a_solid_one():
    # the Technic brick 1 x 2 (3700) draws its post with stud3a.dat, which the snap data states through stud3.dat's
    # line: OMR 21309 hangs four of them on jumper plates (15573), whose hollow stud takes the post (a round peg in
    # a round bore: a hinge), quarter-turned or not
    jumper = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 15573.dat\n"
    assert joints(jumper + "1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3700.dat\n") == [("hinge", "fit", "15573", "3700", 1)]
    assert joints(jumper + "1 4 0 -24 0 0 0 1 0 1 0 -1 0 0 3700.dat\n") == [("hinge", "fit", "15573", "3700", 1)]
    assert joints(jumper + "1 4 5 -24 0 1 0 0 0 1 0 0 0 1 3700.dat\n") == []
    # a 1 x 1 plate's solid stud where the post stands cannot be there: nothing (its walls were taken to grip it)
    plate = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3024.dat\n"
    assert joints(plate + "1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3700.dat\n") == []
    assert joints(plate + "1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3701.dat\n") == []
    # the generated slope 3040b's post (y 20..24 at z = -10) is a bar: in the jumper 3794a's hollow stud it turns and
    # slides (as OMR 7140's R2-D2 stands on its legs' posts); over the jumper's stud by its anti-stud, a stud joint
    jumper = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3794a.dat\n"
    assert joints(jumper + "1 4 0 -24 10 1 0 0 0 1 0 0 0 1 3040b.dat\n") == [
        ("cylindrical", "bar", "3040b", "3794a", 1)]
    assert joints(jumper + "1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3040b.dat\n") == [("hinge", "stud", "3040b", "3794a", 1)]


def test_a_male_cylinder_shorter_than_a_fit_depth_is_held_when_all_of_it_is_in_the_bore():
    # the flex-system hose end u9053 states a 1-LDU bar stub: in 32039's axle hole it is held by the hole's ribs
    # (OMR 8002's eight hose ends), half out of the hole it is not
    bush = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 32039.dat\n"
    end = "1 4 0 0 {z} 1 0 0 0 0 1 0 -1 0 u9053.dat\n"
    assert joints(bush + end.format(z=4)) == [("hinge", "fit", "32039", "u9053", 1)]
    assert joints(bush + end.format(z=10.5)) == []


def test_6192_with_its_own_shadow_lines_sits_on_studs_as_a_2_x_4_brick_does():
    for plate in ("3020", "3710"):
        placed = f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 {plate}.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 {{}}.dat\n"
        curved = [j[:2] + j[4:] for j in joints(placed.format("6192"))]
        assert curved == [j[:2] + j[4:] for j in joints(placed.format("3001"))] != []


def test_a_tyre_on_a_wheel_the_snap_data_gives_no_rim_is_held_by_it():
    # 122c01 (plate with wheels) states no rim: the tyre pushed onto its wheel (OMR 889's placement) is held by the
    # hub's cylinder on its axis; the same tyre a stud further out is held by nothing
    wheels = "1 7 0 8 -40 1 0 0 0 1 0 0 0 1 122c01.dat\n"
    tyre = "1 0 {x} 14 -40 0 0 1 0 1 0 -1 0 0 3641.dat\n"
    assert joints(wheels + tyre.format(x=-30)) == [("rigid", "group", "122c01", "3641", 1)]
    assert joints(wheels + tyre.format(x=-50)) == []


def test_a_minifigure_arm_swung_about_the_torsos_x_axis_is_in_its_socket():
    # the arm's own tilt (0.985, 0.17) turned 30° about x (as editors swing arms): its peg 5° off the socket's axis
    import math
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    rotation = np.array([[1, 0, 0], [0, c, -s], [0, s, c]]) @ np.array([[0.985, -0.17, 0], [0.17, 0.985, 0], [0, 0, 1]])
    matrix = " ".join(f"{v:.6f}" for v in rotation.ravel())
    text = f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 973.dat\n1 4 -15.552 9 0 {matrix} 3818.dat\n"
    assert [j[:2] for j in joints(text)] == [("hinge", "fit")]
    # turned 30° about z instead, the peg leaves the socket's line: nothing
    c, s = math.cos(math.radians(40)), math.sin(math.radians(40))
    turned = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    matrix = " ".join(f"{v:.6f}" for v in turned.ravel())
    assert joints(f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 973.dat\n1 4 -15.552 9 0 {matrix} 3818.dat\n") == []


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
    "30051-1-X-wingFighter-Mini.mpd": (61, 1, []),
    "30054-1-AT-ST-Mini.mpd": (47, 1, []),
    "4489-1-AT-AT-Mini.mpd": (82, 1, []),
    "4494-1-ImperialShuttle-Mini.mpd": (84, 1, []),
    "4838-1-MiniVehicles.mpd": (79, 1, ["4838 - car.ldr"]),  # the car rides on the carrier, held by nothing
    "4915-1-MiniConstruction.mpd": (67, 1, []),
    "4918-1-MiniFlyers.mpd": (75, 1, []),
    "6965-1-TIEIntercep_4h4MXk5.mpd": (32, 1, []),
    "6966-1-JediStarfighter-Mini.mpd": (39, 1, []),
    "889-1-RadarTruck.mpd": (35, 1, []),
    "1621-1-LunarMPVVehicle.mpd": (100, 1, ["1621 - Droid.ldr"]),  # the droid stands beside the vehicle
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
    assert [(h["sub_build"], h["recognised_by"]) for h in result.report.details["held_pieces"]] == [
        (name, HELD_BY["whole"]) for name in apart]
    assert ("stand apart as held pieces" in result.report.message) == bool(apart)
    assert all(held in result.report.message for held in apart)
    assert result.collisions == []
    # one build: no piece drawn apart, and no separate_pieces either
    assert [pc.drawn_apart for pc in result.pieces] == [False] * len(result.pieces)
    assert result.report.details["separate_builds"] == []
    assert not {"separate_builds", "separate_pieces"} & {w.code for w in result.report.warnings}


def test_the_at_at_head_hangs_on_a_hinge_drawn_two_ldu_off_its_fingers():
    """OMR 4489 (2018) hangs the head on a locking hinge whose fingers the 2024 library draws 2 LDU above
    where the model puts the mating fingers (44567 moved to 44567a): the hinge joins them, and the warning names
    the pair and the offset."""
    request, result = omr("4489-1-AT-AT-Mini.mpd")
    number = {p.id: p.part for p in request.parts}
    assert len(result.pieces) == 1
    warning = next(w for w in result.report.warnings if w.code == "offset_joints")
    assert [(sorted(number[p] for p in pair["parts"]), pair["offset_ldu"]) for pair in warning.details["pairs"]] == [
        (["30553", "44567"], 2.0)]
    hinge = next(j for j in result.joints if sorted(number[b] for b in j.bodies) == ["30553", "44567"])
    assert (hinge.type, hinge.origin) == ("hinge", "hinge")


def test_larger_sets_leave_at_most_five_percent_of_their_known_parts_joined_to_nothing():
    """Island Hopper (5935: its pteranodon is placed in the air beside the plane; the skis hang half a stud along
    the wings' outer rows) and the X-wing with its support cart (7140, 48 parts not in the catalogue; the cart
    with the pilot on it stands apart, two pairs of its parts joined to nothing of it: held, see below)."""
    for name, floating_parts, build_pieces, apart in (("5935-1-IslandHopper.mpd", ["30478"], 2, ["L14"]),
                                                      ("7140-1-X-wingFighter.mpd", [], 1, [])):
        request, result = omr(name)
        floating = [p.part for p in result.parts if not p.joints]
        assert floating == floating_parts and len(floating) <= 0.05 * len(result.parts)
        assert len([p for p in result.pieces if p.sub_build is None]) == build_pieces
        # the pteranodon touches nothing and has no mate within 40 LDU: the drawing places it apart, which the result
        # says (a separate build), not a piece whose joint was not found
        assert [pc.parts for pc in result.pieces if pc.drawn_apart] == [[p] for p in apart]
        assert [b["first"] for b in result.report.details["separate_builds"]] == apart
        assert "separate_pieces" not in {w.code for w in result.report.warnings}


def test_a_part_joined_to_nothing_is_named_in_a_floating_parts_warning():
    text = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3003.dat\n" \
           "1 4 200 -24 0 1 0 0 0 1 0 0 0 1 3024.dat\n"
    result = solve(parse("float.ldr", text)).result
    warning = next(w for w in result.report.warnings if w.code == "floating_parts")
    assert warning.details["parts"] == [{"id": "L3", "part": "3024", "line": 3}]
    assert "1 of 3 known part(s)" in warning.message and "L3 (3024)" in warning.message
    assert [(p.id, p.joints, p.joined_to) for p in result.parts] == [
        ("L1", ["L1~L2"], ["L2"]), ("L2", ["L1~L2"], ["L1"]), ("L3", [], [])]


def test_the_warnings_say_how_far_a_part_apart_misses_its_nearest_mate_and_what_unknown_part_lies_beside_it():
    # on a stack of two 2 x 2 bricks, a third drawn 5 LDU up (more than the 3 LDU a slip is joined at, 1 LDU above the
    # studs' tips); a 1 x 1 plate beside a part the catalogue does not know; a pair of plates far from anything
    text = ("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3003.dat\n"
            "1 4 0 -53 0 1 0 0 0 1 0 0 0 1 3003.dat\n"
            "1 4 0 -8 100 1 0 0 0 1 0 0 0 1 3024.dat\n1 4 0 0 110 1 0 0 0 1 0 0 0 1 no_such_part.dat\n"
            "1 4 500 -8 0 1 0 0 0 1 0 0 0 1 3023.dat\n1 4 500 -16 0 1 0 0 0 1 0 0 0 1 3023.dat\n")
    result = solve(parse("apart.ldr", text)).result
    warnings = {w.code: w for w in result.report.warnings}
    floating = warnings["floating_parts"]
    assert [p["id"] for p in floating.details["parts"]] == ["L3", "L4"]
    brick, plate = floating.details["why"]
    assert brick == {"nearest": {"part": "L3", "number": "3003", "type": "antistud", "other": "L2",
                                 "other_number": "3003", "other_type": "stud", "gap_ldu": 5.0,
                                 "sideways_ldu": 0.0}, "unknown_near": []}
    assert plate == {"nearest": None, "unknown_near": ["L5"]}
    assert "L3 (3003) antistud 5 LDU from L2 (3003) stud" in floating.message
    assert "L4: no mate within 40 LDU beside part(s) not in the catalogue: L5" in floating.message
    # the pair of plates 500 LDU off touches nothing and has no mate within 40 LDU: drawn apart, a separate build;
    # the brick 5 LDU up and the plate beside the unknown part are no build apart (a slip, or held by that part)
    assert "separate_pieces" not in warnings
    assert warnings["separate_builds"].details["builds"] == [
        {"first": "L6", "parts": 2, "numbers": ["3023"], "placements": ["main model"], "nearest_ldu": None}]
    assert "L6 (2 part(s): 3023; in main model; no mate within 40 LDU)" in warnings["separate_builds"].message
    assert [(pc.parts, pc.drawn_apart) for pc in result.pieces] == [
        (["L1", "L2"], False), (["L6", "L7"], True), (["L3"], False), (["L4"], False)]


@pytest.mark.parametrize("degrees, shift, joined", [(0, 0, True), (15, 0, True), (25, 0, True), (40, 0, False),
                                                     (15, 1, False)])
def test_a_control_stick_swung_sideways_on_its_base_is_a_hinge_in_its_fingers(degrees, shift, joined):
    """Sets 10179 and 75827 draw the control stick 4593 swung 15 to 25 degrees sideways (about z) on its base 4592: its
    knuckle's finger run shares its middle with the base's, its axis turned off theirs. Joints counted by hand: the
    base on a 1 x 1 plate's stud (a hinge about the stud) and the stick in the base (a hinge): dof 2. Up to 30 degrees
    it is joined (named in tilted_joints; at 0 by the matching itself); turned 40 degrees, or with its middle 1 LDU off
    the base's, it is joined to nothing (dof 2 + 6 - 1: the plate and base's hinge, and the stick loose)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    text = ("1 4 0 8 0 1 0 0 0 1 0 0 0 1 3024.dat\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 4592.dat\n"
            f"1 4 {shift} 0 0 {c:.6f} {-s:.6f} 0 {s:.6f} {c:.6f} 0 0 0 1 4593.dat\n")
    result = solve(parse("stick.ldr", text)).result
    assert [(j.id, j.type, j.origin) for j in result.joints] == [("L1~L2", "hinge", "stud")] + [
        ("L2~L3", "hinge", "hinge")] * joined
    assert result.dof == (2 if joined else 7)
    warnings = {w.code: w for w in result.report.warnings}
    if joined and degrees:
        assert warnings["tilted_joints"].details["pairs"] == [
            {"parts": ["L2", "L3"], "numbers": ["4592", "4593"], "angle_degrees": float(degrees)}]
        assert f"L2 (4592) and L3 (4593) {degrees} degrees" in warnings["tilted_joints"].message
        axis = next(j.axis for j in result.joints if j.id == "L2~L3")
        assert np.allclose(axis, [c, s, 0], atol=1e-6)  # about the stick's own (turned) finger axis
    else:
        assert "tilted_joints" not in warnings
    assert ("floating_parts" in warnings) != joined


BUILD = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"  # two 2 x 4 bricks stacked


def _pair(x: float, y: float, z: float = 0) -> str:
    """Two 1 x 2 plates stacked, the lower one's top at height ``y`` (LDU, up negative), its centre at ``x``, ``z``."""
    return f"1 4 {x} {y} {z} 1 0 0 0 1 0 0 0 1 3023.dat\n1 4 {x} {y - 8} {z} 1 0 0 0 1 0 0 0 1 3023.dat\n"


@pytest.mark.parametrize("extra, apart, nearest", [
    (_pair(200, -8), True, None),  # 200 LDU off on the floor: touching nothing, no mate within 40 LDU
    (_pair(0, -40, 10), False, 8.0),  # over the top brick's studs with a plate's height of air (a plate left out?)
    (_pair(0, -56, 10), False, 24.0),  # a brick's height straight over the studs: a brick left out, not a build
    (_pair(0, -64, 10), False, 32.0),  # and a brick and a plate
    (_pair(60, -8), False, 22.36),  # against the lower brick's side: lying against the build
    (_pair(62, -8), False, 24.17),  # 2 LDU off that side: drawn off what it is pressed on, within a slip
    (_pair(200, -8) + "1 4 210 0 0 1 0 0 0 1 0 0 0 1 no_such_part.dat\n", False, None),  # beside an unknown part
])
def test_a_piece_touching_nothing_with_no_mate_within_half_a_pitch_is_a_separate_build(extra, apart, nearest):
    """Joints counted by hand: the bricks' eight studs (one rigid joint) and the plates' two (one rigid joint), two
    pieces, so 6 degrees of freedom between them. Only the pair on the floor 200 LDU off is drawn apart; a plate's
    height of air over studs, a side lying against the build and an unknown part beside them may each hide a joint,
    and the pair stays a piece whose joint was not found (separate_pieces)."""
    result = solve(parse("builds.ldr", BUILD + extra)).result
    assert [(len(j.bodies), j.type) for j in result.joints] == [(2, "rigid"), (2, "rigid")]
    assert (result.dof, result.report.details["connected_pieces"]) == (6, 2)
    assert [(pc.parts, pc.sub_build, pc.drawn_apart) for pc in result.pieces] == [
        (["L1", "L2"], None, False), (["L3", "L4"], None, apart)]
    warnings = {w.code: w for w in result.report.warnings}
    assert ("separate_builds" in warnings, "separate_pieces" in warnings) == (apart, not apart)
    if apart:
        assert result.report.details["separate_builds"] == warnings["separate_builds"].details["builds"] == [
            {"first": "L3", "parts": 2, "numbers": ["3023"], "placements": ["main model"], "nearest_ldu": nearest}]
        assert warnings["separate_builds"].details["rule"] == result.report.details["separate_builds_rule"] == APART_BY
        assert "so it is 2 or more builds as drawn" in warnings["separate_builds"].message
        assert "the drawing places 1 piece(s) apart as separate builds: L3 (2 parts)" in result.report.message
    else:
        assert result.report.details["separate_builds"] == []
        assert [(w["nearest"] or {}).get("gap_ldu") for w in warnings["separate_pieces"].details["why"]] == [nearest]


def test_drawn_apart_needs_more_than_a_slip_clear_no_mate_within_half_a_pitch_and_no_unknown_part_beside():
    assert APART_GAP == OFFSET_REACH  # a piece a slip off the rest may be a part drawn off its mate
    assert drawn_apart(3.1, None, False) and drawn_apart(40.0, 10.01, False)
    assert not drawn_apart(3.0, None, False)  # 3 LDU off the rest: drawn off what it is pressed on (set 4096's wheel)
    assert not drawn_apart(40.0, 10.0, False)  # a mate within half a pitch: a slip or a plate's height off
    assert not drawn_apart(40.0, None, True)  # an unknown part beside it may hold it
    assert not drawn_apart(40.0, 24.0, False, lined_up=True)  # studs facing anti-studs a brick off: one left out


def test_a_whole_sub_model_standing_apart_stays_a_held_sub_build_not_a_separate_build():
    """A held sub-build (whole placed sub-models touching nothing) is named as before; the drawn-apart rule is only
    for the pieces that are no held sub-build, and a file whose parts mostly meet nothing tells no build apart."""
    text = ("0 FILE main.ldr\n" + BUILD + "1 4 200 0 0 1 0 0 0 1 0 0 0 1 pair.ldr\n0 FILE pair.ldr\n" + _pair(0, -8))
    result = solve(parse("held.mpd", text)).result
    assert [(pc.sub_build, pc.drawn_apart) for pc in result.pieces] == [(None, False), ("pair.ldr", False)]
    loose = "".join(f"1 4 {100 * k} 0 0 1 0 0 0 1 0 0 0 1 3023.dat\n" for k in range(5))  # a parts list
    result = solve(parse("list.ldr", _pair(0, -8) + loose)).result
    assert result.report.details["separate_builds"] == [] and not any(pc.drawn_apart for pc in result.pieces)


def test_a_piece_of_whole_sub_models_is_a_held_sub_build_and_a_piece_of_part_of_one_is_not():
    # a cart (sub-model at line 2) with a minifigure (line 3) standing on it, apart from the main build (line 1)
    ids = ["L1/L5", "L1/L6", "L2/L5", "L2/L6", "L3/L4/L8", "L3/L4/L9", "L3/L7"]
    placements = {"L1/": "main.ldr", "L2/": "cart.ldr", "L3/": "pilot.ldr", "L3/L4/": "legs.ldr"}
    names = dict.fromkeys(ids, "Brick  2 x  2")
    assert sub_build(["L2/L5", "L2/L6", "L3/L4/L8", "L3/L4/L9", "L3/L7"], ids, placements, names) == \
        "cart.ldr + pilot.ldr"
    assert sub_build(["L3/L4/L8", "L3/L4/L9"], ids, placements, names) == "legs.ldr"
    assert sub_build(["L2/L5", "L3/L4/L8", "L3/L4/L9"], ids, placements, names) is None  # half the cart
    assert sub_build(["L2/L5"], ids, placements, {**names, "L2/L5": "Minifig Arm Left"}) == "minifigure"
    # LDraw marks obsolete parts with '~' before the name (OMR 31066's legs 3816/3817): still minifigure parts
    legs = {**names, "L2/L5": "~Minifig Leg Right (Obsolete)", "L2/L6": "Minifig Hand"}
    assert sub_build(["L2/L5", "L1/L5"], ids, placements, {**legs, "L1/L5": "Minifig Hand"}) == "minifigure"
    assert sub_build(["L2/L5", "L1/L5"], ids, placements, legs) is None


S9, C9 = "0.156434", "0.987688"  # sin and cos of 9 degrees


@pytest.mark.parametrize("placement, held", [
    (f"1 4 0 -24 0 1 0 0 0 {C9} -{S9} 0 {S9} {C9} roof.ldr", False),  # tilted 9 degrees, lying on the top brick
    ("1 4 100 0 0 1 0 0 0 1 0 0 0 1 roof.ldr", True),  # beside them, its lower brick level with the top one
])
def test_whole_sub_models_lying_against_the_build_are_no_held_sub_build(placement, held):
    """OMR 10174 (UCS AT-ST) draws its roof, a sub-model of 36 parts, 9 degrees off the head it sits on: no stud
    meets, and the roof came out as a held sub-build, a broken build passed off as one standing apart. Two
    stacked 2x2 bricks (one joint) as a sub-model on three stacked 2x4 bricks: tilted 9 degrees on them, their
    boxes overlap the top brick's and the piece is named in separate_pieces; beside them (60 LDU apart), held."""
    text = ("0 FILE main.ldr\n1 4 0 48 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
            f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n{placement}\n0 FILE roof.ldr\n"
            "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3003.dat\n")
    result = solve(parse("roof.mpd", text)).result
    assert [(pc.parts, pc.sub_build) for pc in result.pieces] == [
        (["L2", "L3", "L4"], None), (["L5/L7", "L5/L8"], "roof.ldr" if held else None)]
    warnings = {w.code: w for w in result.report.warnings}
    assert ("separate_pieces" in warnings) != held
    assert [h["recognised_by"] for h in result.report.details["held_pieces"]] == [HELD_BY["whole"]] * held


def test_the_clearance_of_two_pieces_is_the_least_gap_between_their_boxes():
    lower = {"a": np.zeros(3), "b": np.array([10.0, 0, 0]), "c": np.array([10.4, 3, 0]), "d": np.array([5, 40, 5])}
    upper = {k: v + 10.0 for k, v in lower.items()}  # 10 LDU cubes: a spans 0..10 in x, y and z
    assert clearance(["b"], ["a"], lower, upper) == 0.0  # face to face
    assert abs(clearance(["c"], ["a"], lower, upper) - 0.4) < 1e-12  # 0.4 apart in x, overlapping in y and z
    assert clearance(["d"], ["a"], lower, upper) == 30.0  # above it, overlapping in x and z
    assert clearance(["b", "d"], ["a"], lower, upper) == 0.0  # the closest part counts
    assert clearance(["minifig arm"], ["a"], lower, upper) == float("inf")  # no box: nothing to be close to
    points = {**lower, "p": np.array([5.0, -6, 5])}
    assert clearance(["p"], ["a"], points, {**upper, "p": points["p"]}) == 6.0  # a part at its origin, 6 above a



def test_the_x_wings_support_cart_and_the_parts_loose_in_it_stand_apart_as_one_held_sub_build():
    """OMR 7140: the support vehicle (sub-model at line 18) with its technician (line 16) standing on it is 67
    parts in one piece, and with the two 3003 bricks lying on their side in its bed, wedged between the bed's two
    tiles 2431 standing on edge (joined by contact, no snap meeting; one contact, the parallel second holds nothing
    more), 69; a 750/755 pair among the hose's 756
    segments (not in the catalogue) is a piece of its own. Together they are every known part of the two
    sub-models and touch nothing of the X-wing: the two pieces are one held sub-build, each named so, and
    the report says how it was recognised. Biggs is a held sub-build of one piece; R2-D2 stands in the X-wing, each
    leg's post (30362, drawn with stud3a.dat) in the hollow stud of a jumper plate 3794a."""
    request, result = omr("7140-1-X-wingFighter.mpd")
    number = {p.id: p.part for p in request.parts}
    cart = "7140 - Minifig - Rebel Technician.ldr + 7140 - Support Vehicle.ldr"
    assert [(len(pc.parts), pc.sub_build) for pc in result.pieces[1:]] == [
        (69, cart), (10, "7140 - Minifig - Biggs Darklighter.ldr"), (2, cart)]
    assert [sorted(number[p] for p in pc.parts) for pc in result.pieces[3:]] == [["750", "755"]]
    assert [sorted(number[b] for b in j.bodies) for j in result.joints if j.origin == "contact"] == [
        ["2431", "3003"], ["2431", "3003"]]
    assert [h["recognised_by"] for h in result.report.details["held_pieces"]] == [
        HELD_BY["loose"], HELD_BY["whole"], HELD_BY["loose"]]
    legs = [j for j in result.joints if sorted(number[b] for b in j.bodies) == ["30362", "3794a"]]
    assert [(j.type, j.origin) for j in legs] == [("cylindrical", "bar")] * 2
    assert "separate_pieces" not in {w.code for w in result.report.warnings}


def test_pieces_standing_apart_are_one_sub_build_only_when_together_they_are_whole_sub_models():
    ids = ["L1", "L2/L5", "L2/L6", "L2/L7", "L3/L8", "L4/L9", "L4/L10"]
    placements = {"L2/": "cart.ldr", "L3/": "pilot.ldr", "L4/": "crate.ldr"}
    # the cart and its pilot in one piece, a brick loose in the cart, and half of a crate
    apart = [["L2/L5", "L2/L6", "L3/L8"], ["L2/L7"], ["L4/L9"]]
    assert loose_sub_builds(apart, ids, placements) == ["cart.ldr + pilot.ldr", "cart.ldr + pilot.ldr", None]
    # the loose brick bound to the main build's part: the cart's pieces are not the cart's parts only
    assert loose_sub_builds([["L2/L5", "L2/L6", "L3/L8"], ["L2/L7", "L1"]], ids, placements) == [None, None]
    assert loose_sub_builds([["L2/L5", "L2/L6"]], ids, placements) == [None]  # one piece: sub_build's to judge


@pytest.mark.parametrize("x, held", [(100, True), (50, False)])
def test_loose_pieces_of_a_sub_model_are_held_only_two_studs_clear_of_the_build(x, held):
    """Three stacked 2x4 bricks (x from -20 to 20) and a sub-model of two 2x2 bricks 60 apart, joined to nothing:
    placed at x = 100 its bricks start 70 LDU clear of the build (at least 40): the two pieces are the sub-model
    loose, held; at x = 50 they are 20 clear, as close as hose segments joined through unknown parts: not held."""
    text = ("0 FILE main.ldr\n1 4 0 48 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
            f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 {x} 0 0 1 0 0 0 1 0 0 0 1 cart.ldr\n0 FILE cart.ldr\n"
            "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 60 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n")
    result = solve(parse("cart.mpd", text)).result
    assert [(pc.parts, pc.sub_build) for pc in result.pieces] == [
        (["L2", "L3", "L4"], None), (["L5/L7"], "cart.ldr" if held else None),
        (["L5/L8"], "cart.ldr" if held else None)]
    assert [h["recognised_by"] for h in result.report.details["held_pieces"]] == [HELD_BY["loose"]] * (2 * held)


def test_a_minifigure_part_loose_in_a_sub_model_standing_apart_completes_it():
    """A cart (a 2 x 4 plate and a 1 x 2 brick on it) with its minifigure seat 4079 drawn 8 LDU above the brick's
    studs, 70 LDU clear of three stacked bricks (as 3181-1 leaves the seat of its tow car): the seat alone is minifigure
    parts only, and with it the cart's two pieces are the whole cart standing apart: both held as the cart."""
    text = ("0 FILE main.ldr\n1 4 0 48 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
            "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 150 48 0 1 0 0 0 1 0 0 0 1 cart.ldr\n0 FILE cart.ldr\n"
            "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3020.dat\n1 4 0 -24 10 1 0 0 0 1 0 0 0 1 3004.dat\n"
            "1 4 0 -40 10 1 0 0 0 1 0 0 0 1 4079.dat\n")
    result = solve(parse("cart.mpd", text)).result
    assert [(pc.parts, pc.sub_build) for pc in result.pieces] == [
        (["L2", "L3", "L4"], None), (["L5/L7", "L5/L8"], "cart.ldr"), (["L5/L9"], "cart.ldr")]
    assert [h["recognised_by"] for h in result.report.details["held_pieces"]] == [HELD_BY["loose"]] * 2


def test_wheels_turn_on_the_pull_back_motors_wheel_pins():
    """10039 (pull-back motor, Speed Champions) draws its axle's ends with wpin4.dat, a wheel holding pin the
    shadow library states no snap for: OMR 40190's rear rims were joined to nothing. The catalogue gives it
    wpin.dat's pin (radius 4, 12 long, x from 32 to 44 at y = 5, z = 60 in 10039's frame): a notched rim pushed on
    each end turns on it (a hinge each, two in all); the same rim 10 LDU further out meets nothing."""
    assert joints("1 0 0 0 0 1 0 0 0 1 0 0 0 1 10039.dat\n1 0 43 5 60 0 0 -1 0 1 0 1 0 0 30027b.dat\n"
                  "1 0 -43 5 60 0 0 1 0 1 0 -1 0 0 30027b.dat\n") == [("hinge", "fit", "10039", "30027b", 1)] * 2
    assert joints("1 0 0 0 0 1 0 0 0 1 0 0 0 1 10039.dat\n1 0 53 5 60 0 0 -1 0 1 0 1 0 0 30027b.dat\n") == []


# 122c01 (plate 2 x 2 with red wheels) draws each wheel centre 20.dat with a stud on its outer face: x from 36 to
# 40 (y = 6) on the right, -36 to -40 on the left. The solid wheel 4288 is pushed onto it: its bore's mouth (local
# z = 3, the bore running to -z) turned onto the stud's axis, at x = +-(x - 3). 122c07 (the same plate with the
# wheels on, as LDraw draws it) places them at x = +-39: the mouth on the stud's base; set 6831 at 40: the stud 3 LDU
# inside the mouth, which 4288 draws round for 3 LDU before its axle hole starts.
def wheels_on_holder(x: float = 39.0, up: float = 0.0) -> str:
    return ("1 0 0 0 0 1 0 0 0 1 0 0 0 1 122c01.dat\n"
            f"1 256 {x:g} {6 + up:g} 0 0 0 -1 0 1 0 1 0 0 4288.dat\n"
            f"1 256 {-x:g} {6 + up:g} 0 0 0 1 0 1 0 -1 0 0 4288.dat\n")


@pytest.mark.parametrize(("x", "origin"), [(39, "stud"), (40, "fit")])
def test_solid_wheels_pushed_onto_a_wheel_holders_studs_turn_on_them(x, origin):
    """The shadow library states 4288's whole bore as an axle hole, into which no stud goes: 6831's four wheels
    floated. Read as drawn (3 LDU round mouth), each wheel on its stud turns about the axle: the mouth on the stud's
    base (122c07's placement) a stud's hinge, the stud 3 LDU in (6831's) a round fit. Counted by hand: two revolute
    joints, one turning freedom per wheel."""
    result = solve(parse("model.ldr", wheels_on_holder(x))).result
    assert joints(wheels_on_holder(x)) == [("hinge", origin, "122c01", "4288", 1)] * 2
    assert result.dof == 2 and result.generic_dof == 2
    assert not {"offset_joints", "floating_parts"} & {w.code for w in result.report.warnings}


def test_the_solid_wheels_bore_is_round_at_its_mouth_and_an_axle_hole_beyond():
    assert part_snaps("4288") == [["cyl", "F", "none", 1, [0.0, 0.0, 3.0], [0.0, 0.0, -1.0],
                                   [["R", 6.0, 3.0], ["A", 6.0, 17.0]]]]
    # an axle through it is still keyed in the axle hole: one rigid joint
    assert joints("1 0 0 0 0 1 0 0 0 1 0 0 0 1 3705.dat\n1 256 10 0 0 0 0 -1 0 1 0 1 0 0 4288.dat\n") == [
        ("rigid", "axle", "3705", "4288", 1)]


@pytest.mark.parametrize(("x", "up"), [(43, 0), (39, 4)])
def test_solid_wheels_four_ldu_off_the_holders_studs_are_not_joined(x, up):
    # the mouth 4 LDU out from the stud's base (the stud's tip only reaches it) or 4 LDU above it: past the 3 LDU an
    # offset joint reaches, and no fit (no depth shared; the axes 4 LDU apart)
    assert joints(wheels_on_holder(x, up)) == []


# 4265a's axle hole: an 8 LDU axle section from local z = -5 (its mouth), its point at z = -1; turned so that
# local z runs along +x, it faces the end of 3705 (x from -40 to 40) with its mouth at x = 40 + gap
def bush_past_axle_end(gap: float) -> str:
    return ("1 0 0 0 0 1 0 0 0 1 0 0 0 1 3705.dat\n"
            f"1 4 {45 + gap:g} 0 0 0 0 1 0 1 0 -1 0 0 4265a.dat\n")


def test_a_bush_on_the_tip_of_an_axle_is_held_by_it():
    # its point 1 LDU inside the axle's end: joined as drawn, no offset
    result = solve(parse("model.ldr", bush_past_axle_end(-5))).result
    assert joints(bush_past_axle_end(-5)) == [("rigid", "axle", "3705", "4265a", 1)]
    assert "offset_joints" not in {w.code for w in result.report.warnings}


@pytest.mark.parametrize("gap", [1, 2])
def test_a_bush_drawn_just_past_the_end_of_its_axle_is_joined_with_the_offset_of_its_mouth(gap):
    # as 1682-1's tank draws two: the bush's point 5 + gap LDU past the axle's end, its mouth gap LDU past it
    result = solve(parse("model.ldr", bush_past_axle_end(gap))).result
    assert [(j.type, j.origin) for j in result.joints] == [("rigid", "axle")]
    warning = next(w for w in result.report.warnings if w.code == "offset_joints")
    assert [pair["offset_ldu"] for pair in warning.details["pairs"]] == [float(gap)]


def test_a_bush_four_ldu_past_the_end_of_its_axle_is_not_joined():
    assert joints(bush_past_axle_end(4)) == []


# 15395 (dome 2 x 2 inverted) draws its top stud with stud2a.dat, the open stud whose shadow lines state no hole:
# the catalogue gives it stud2.dat's (radius 4, from the stud's top at local y = -4 down to y = 0).
def part_snaps(number: str) -> list:
    return generated.record(number)["s"]


DOME_ON_BAR = "1 15 0 -19 0 -1 0 0 0 1 0 0 0 -1 30374.dat\n1 135 0 24 0 -1 0 0 0 1 0 0 0 -1 15395.dat\n"


def test_a_dome_threaded_on_a_bar_through_its_open_stud_slides_and_turns_on_it():
    # as set 21309 draws it: the bar (y from -19 to 61) through the stud's hole (y from 20 to 24): one bar fit
    assert joints(DOME_ON_BAR) == [("cylindrical", "bar", "15395", "30374", 1)]
    # the bar a stud aside (x = 20) passes the hole by: nothing
    assert joints(DOME_ON_BAR.replace("0 -19 0", "20 -19 0")) == []


@pytest.mark.parametrize("top", [-84, -86])  # the antenna's tip 4 and 2 LDU down the 4 LDU hole
def test_an_antenna_tip_pushed_into_an_open_stud_is_held_in_its_hole(top):
    # 3957a upside down: its bar (radius 4) from local y = -4 to -84, world y from top + 4 to top + 84
    text = f"1 135 0 0 0 1 0 0 0 1 0 0 0 1 15395.dat\n1 4 0 {top} 0 1 0 0 0 -1 0 0 0 -1 3957a.dat\n"
    assert joints(text) == [("cylindrical", "bar", "15395", "3957a", 1)]


def test_an_open_stud_still_holds_a_brick_and_a_part_whose_own_hole_is_stated_keeps_only_it():
    # a 1 x 1 brick on the dome's open stud, and the dome's tube on one stud of a 2 x 4 brick: one stud each
    assert joints("1 135 0 0 0 1 0 0 0 1 0 0 0 1 15395.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3005.dat\n") == [
        ("hinge", "stud", "15395", "3005", 1)]
    assert joints("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 135 10 -8 10 1 0 0 0 1 0 0 0 1 15395.dat\n") == [
        ("hinge", "stud", "15395", "3001", 1)]
    # 3062b states its own hole (radius 4 from y = 4 up through the stud to y = -4): no second one is added
    holes = [s for s in part_snaps("3062b") if s[0] == "cyl" and s[1] == "F" and any(r == 4 for _, r, _ in s[6])]
    assert holes == [["cyl", "F", "none", 0, [0.0, 24.0, 0.0], [0.0, -1.0, 0.0], [["R", 6.0, 20.0], ["R", 4.0, 8.0]]]]
    assert ["cyl", "F", "one", 0, [0.0, -4.0, 0.0], [0.0, 1.0, 0.0], [["R", 4.0, 4.0]]] in part_snaps("15395")
