"""Contact joints: a part wedged in a gap of another piece (its collision box touching two of that piece's face on
face, on opposite sides, as drawn, where no snap meets and no face carries studs across the contact) is joined by a
planar joint (3 degrees of freedom held); parts apart, touching on one side only, touching in a row, or resting on
faces whose studs do not meet, stay unjoined."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.contacts import CONTACT_GAP
from plantsolve.solvers.rigidity.screws import FREEDOM, allowed_twists, constraint_rows, freedom_screws
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

I = "1 0 0 0 1 0 0 0 1"


def result(text: str):
    return solve(parse_upload(StoredInput.from_bytes("model.ldr", text.encode()), None)).result


def two(first: str, second: str, at: str) -> str:
    return f"1 4 0 0 0 {I} {first}.dat\n1 4 {at} {I} {second}.dat\n"


@pytest.mark.parametrize("at, why", [
    ("81 0 0", "two 2 x 4 bricks side by side 1 LDU apart"),
    ("90 0 0", "side by side 10 LDU apart"),
    ("80 0 41", "corner to corner, 1 LDU apart across"),
])
def test_bricks_not_touching_stay_two_pieces(at, why):
    found = result(two("3001", "3001", at))
    assert [pc.parts for pc in found.pieces] == [["L1"], ["L2"]], why
    assert found.joints == [] and found.dof == 6
    floating = next(w for w in found.report.warnings if w.code == "floating_parts")
    assert [p["id"] for p in floating.details["parts"]] == ["L1", "L2"]


@pytest.mark.parametrize("number", ["3010", "3005"])
def test_a_brick_on_another_half_a_stud_along_stays_unjoined(number):
    # a 1 x 4 (or 1 x 1) brick on another drawn 10 LDU along: its anti-studs lie between the studs, which face across
    # the touching faces, so the snap data says how they connect, and no stud meeting says they do not
    found = result(two(number, number, "10 -24 0"))
    assert [pc.parts for pc in found.pieces] == [["L1"], ["L2"]] and found.joints == []
    assert "contact_joints" not in {w.code for w in found.report.warnings}


def test_a_brick_on_a_tile_stays_resting_held_by_nothing():
    text = f"1 4 0 0 0 {I} 3001.dat\n1 4 -20 -8 0 {I} 3068b.dat\n1 4 -20 -32 0 {I} 3003.dat\n"
    found = result(text)
    assert [pc.parts for pc in found.pieces] == [["L1", "L2"], ["L3"]]
    assert [j.origin for j in found.joints] == ["stud"]


# a 1 x 4 brick with two 1 x 1 bricks on its end studs (one piece), and a 2 x 2 brick drawn in the 40-LDU gap between
# them a plate's height over the studs (so no stud meets): its sides touch the 1 x 1 bricks' inner faces
WALLS = f"1 4 0 0 0 {I} 3010.dat\n1 4 -30 -24 0 {I} 3005.dat\n1 4 30 -24 0 {I} 3005.dat\n"


def wedged(x: float = 0.0, width: str = "3003") -> str:
    return WALLS + f"1 4 {x:g} -32 0 {I} {width}.dat\n"


def test_bricks_touching_side_by_side_stay_two_pieces():
    # nothing holds two bricks whose sides touch: one face, no gap of a build
    found = result(two("3001", "3001", "80 0 0"))
    assert [pc.parts for pc in found.pieces] == [["L1"], ["L2"]] and found.joints == []
    assert "contact_joints" not in {w.code for w in found.report.warnings}


def test_bricks_touching_in_a_row_stay_three_pieces():
    # the middle brick touches two on opposite sides, but they are two pieces: nothing presses the row together
    found = result(two("3001", "3001", "80 0 0") + f"1 4 -80 0 0 {I} 3001.dat\n")
    assert len(found.pieces) == 3 and found.joints == []


@pytest.mark.parametrize("gap", [0.0, CONTACT_GAP / 2])  # a wall drawn off by rounding, still on its stud
def test_a_brick_wedged_in_a_gap_of_a_build_is_joined_by_one_planar_contact(gap):
    text = WALLS + f"1 4 0 -32 0 {I} 3003.dat\n" if not gap else (
        f"1 4 0 0 0 {I} 3010.dat\n1 4 {-30 - gap:g} -24 0 {I} 3005.dat\n1 4 30 -24 0 {I} 3005.dat\n"
        f"1 4 0 -32 0 {I} 3003.dat\n")
    found = result(text)
    contact = [(j.type, j.bodies, j.axis) for j in found.joints if j.origin == "contact"]
    # one contact with the piece that holds it (the first wall in line order; the other, parallel, would hold nothing
    # more)
    assert contact == [("planar", ["L2", "L4"], [1.0, 0.0, 0.0])]
    point = next(j.point for j in found.joints if j.origin == "contact")
    assert point == pytest.approx([-20 - gap / 2, -16, 0])
    # one piece; counted by hand: each 1 x 1 brick on one stud turns about it (1 + 1), the wedged brick keeps the
    # slide in the wall's plane and the turn about x (3), where apart it had 6
    assert [pc.parts for pc in found.pieces] == [["L1", "L2", "L3", "L4"]] and found.dof == 5 == found.generic_dof
    warning = next(w for w in found.report.warnings if w.code == "contact_joints")
    assert warning.details["pairs"] == [{"parts": ["L2", "L4"], "numbers": ["3005", "3003"],
                                         "normal": [1.0, 0.0, 0.0]}]
    assert "floating_parts" not in {w.code for w in found.report.warnings}


@pytest.mark.parametrize("text, why", [
    (wedged(width="3004"), "a 1 x 2 brick (40 wide along x as well, 20 along z): wedged too"),
])
def test_a_narrower_part_wedged_the_same_way_is_joined(text, why):
    assert len(result(text).pieces) == 1, why


@pytest.mark.parametrize("text, why", [
    (wedged(width="3022"), "a 2 x 2 plate, 8 high, from 32 to 24 LDU up: it meets the walls' tops only along edges"),
    (WALLS + f"1 4 0 -32 0 {I} 3010.dat\n", "a 1 x 4 brick (80 long) drawn through the walls: a collision"),
    (WALLS + f"1 4 1 -32 0 {I} 3004.dat\n", "1 LDU into one wall and 1 LDU off the other: a collision"),
    (WALLS.replace("1 4 30 -24", "1 4 31 -24") + f"1 4 0 -32 0 {I} 3003.dat\n",
     "the gap 1 LDU wider than the brick: it touches one wall only"),
])
def test_a_part_not_wedged_stays_apart(text, why):
    found = result(text)
    assert len(found.pieces) == 2 and "contact" not in {j.origin for j in found.joints}, why


def test_a_brick_between_two_bricks_studs_across_stays_unjoined():
    # a 2 x 2 brick stacked on a 2 x 2 brick half a stud along, a 2 x 2 brick on top drawn half a stud back: it touches
    # the parts below and above only on stud faces, which the snap data governs
    text = (f"1 4 0 0 0 {I} 3003.dat\n1 4 10 -24 10 {I} 3005.dat\n1 4 0 -48 0 {I} 3003.dat\n")
    found = result(text)
    assert "contact" not in {j.origin for j in found.joints}


def test_contacts_do_not_depend_on_the_order_of_the_lines():
    lines = (WALLS + f"1 4 0 -32 0 {I} 3003.dat\n").splitlines()
    forward = result("\n".join(lines) + "\n")
    backward = result("\n".join(reversed(lines)) + "\n")
    name = {f"L{k + 1}": f"L{len(lines) - k}" for k in range(len(lines))}  # line k is line n - k + 1 reversed
    contacts = [sorted(name[b] for b in j.bodies) for j in backward.joints if j.origin == "contact"]
    assert len(contacts) == 1 and contacts[0][1] == "L4" and contacts[0][0] in ("L2", "L3")
    assert forward.dof == backward.dof == 5 and len(forward.pieces) == len(backward.pieces) == 1


def test_a_planar_joints_rows_are_reciprocal_to_its_twists_and_leave_three_freedoms():
    point, normal = np.array([3.0, -2.0, 5.0]), np.array([1.0, 2.0, -2.0])
    rows = constraint_rows("planar", point, normal)
    twists = allowed_twists("planar", point, normal)
    assert FREEDOM["planar"] == 3 == len(twists) and np.linalg.matrix_rank(rows) == 6 - 3
    assert np.abs(rows @ twists.T).max() < 1e-12
    screws = freedom_screws("planar", point.astype(int), normal.astype(int))
    assert screws.dtype.kind == "i" and np.linalg.matrix_rank(screws.astype(float)) == 3
    assert np.abs(rows @ screws.astype(float)).max() < 1e-12
    # what it holds: the translation along the normal and the tilts about axes in the plane
    v = np.concatenate([np.zeros(3), normal])
    tilt = np.concatenate([np.cross(normal, [1.0, 0, 0]), np.cross(point, np.cross(normal, [1.0, 0, 0]))])
    assert abs(rows @ v).max() > 0 and abs(rows @ tilt).max() > 0


def test_bricks_meeting_only_along_an_edge_stay_two_pieces():
    # the second brick one brick higher and one brick along: their boxes share an edge, no face
    found = result(two("3001", "3001", "80 -24 0"))
    assert [pc.parts for pc in found.pieces] == [["L1"], ["L2"]] and found.joints == []


@pytest.mark.parametrize("turn", ["1 0 0 0 1 0 0 0 1", "0.9999999 0 0.0004 0 1 0 -0.0004 0 0.9999999"])
def test_a_brick_wedged_is_joined_whether_the_boxes_or_fcl_answer(turn):
    # the wedged brick along the axes (its box is its world box: the boxes answer) or turned by 0.02 degrees, as a
    # rotation printed with 7 digits leaves it (FCL answers): one contact either way
    found = result(WALLS + f"1 4 0 -32 0 {turn} 3003.dat\n")
    assert [(j.type, j.bodies) for j in found.joints if j.origin == "contact"] == [("planar", ["L2", "L4"])]
