"""A part drawn beside the studs it lies on: its anti-studs' mouths in the plane of the studs' bases, every one shifted
by the same offset across that plane, more than a slip and at most half a pitch (set 6761 draws its base plate 9.8 LDU
off the grid of the 18 parts standing on it). In that plane the studs would stand inside the part, which no build
allows but on its anti-studs: the part is joined and the shift named in ``offset_joints``."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.assembly import common_shift
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

BRICKS = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"  # two 2 x 4 bricks stacked


def solved(top: str):
    request = parse_upload(StoredInput.from_bytes("model.ldr", (BRICKS + top).encode()), None)
    result = solve(request).result
    number = {p.id: p.part for p in request.parts}
    joints = sorted((j.type, j.origin, *sorted(number[b] for b in j.bodies), j.connections) for j in result.joints)
    return joints, next((w for w in result.report.warnings if w.code == "offset_joints"), None)


@pytest.mark.parametrize("x, y, z", [(4, 0, 3), (-6, 0.157, 0), (0, -0.4, 9.8)])
def test_a_plate_drawn_beside_the_studs_it_lies_on_is_held_by_all_of_them_and_named_with_its_shift(x, y, z):
    # the 2 x 4 plate's eight anti-studs each (x, y, z) from a stud of the top brick (y: off the studs' plane by less
    # than SHIFT_PLANE); joined on main only within a slip (3.1 LDU)
    joints, warning = solved(f"1 4 {x} {-8 + y} {z} 1 0 0 0 1 0 0 0 1 3020.dat\n")
    assert joints == [("rigid", "stud", "3001", "3001", 8), ("rigid", "stud", "3001", "3020", 8)]
    shift = float(np.hypot(np.hypot(x, y), z))
    assert [(pair["parts"], pair["offset_ldu"]) for pair in warning.details["pairs"]] == [(["L1", "L3"],
                                                                                          round(shift, 3))]
    assert warning.details["shifted_rows_ldu"] == 10.0
    assert "under 10 for a part's studs all drawn one way" in warning.message


@pytest.mark.parametrize("top", [
    "1 4 4 -8 3 1 0 0 0 1 0 0 0 1 3024.dat\n",  # a 1 x 1 plate: one stud, about which it may turn
    "1 4 10 -8 0 1 0 0 0 1 0 0 0 1 3710.dat\n",  # a 1 x 4 plate half a pitch along: between studs, no shift
    "1 4 4 -16 3 1 0 0 0 1 0 0 0 1 3020.dat\n",  # the 2 x 4 plate a plate's height up as well: air between
    "1 4 4 -9 3 1 0 0 0 1 0 0 0 1 3020.dat\n",  # 1 LDU up: not in the studs' plane
])
def test_a_part_not_lying_beside_two_or_more_studs_in_their_plane_is_not_joined(top):
    joints, warning = solved(top)
    assert joints == [("rigid", "stud", "3001", "3001", 8)] and warning is None


def test_a_plate_on_a_tile_drawn_beside_the_studs_is_held_by_nothing_the_tile_by_the_studs():
    joints, warning = solved("1 4 4 -8 3 1 0 0 0 1 0 0 0 1 3068b.dat\n1 4 4 -16 3 1 0 0 0 1 0 0 0 1 3020.dat\n")
    assert joints == [("rigid", "stud", "3001", "3001", 8), ("rigid", "stud", "3001", "3068b", 4)]
    assert [pair["numbers"] for pair in warning.details["pairs"]] == [["3001", "3068b"]]


def test_two_shifts_that_each_reach_two_studs_equally_are_no_shift():
    # a grid drawn half a pitch along meets the studs either side as well: neither is the joint
    a, b = np.array([10.0, 0, 0]), np.array([-10.0, 0, 0])
    pairs = [(("s", 0), ("m", 0), a), (("s", 1), ("m", 1), a), (("s", 0), ("m", 2), b), (("s", 1), ("m", 3), b)]
    assert common_shift(pairs) == (None, [])
    shift, held = common_shift(pairs + [(("s", 2), ("m", 4), a)])
    assert np.allclose(shift, a) and len(held) == 3
    # one stud reaching two mouths with one offset is no second stud
    assert common_shift([(("s", 0), ("m", 0), a), (("s", 0), ("m", 1), a + 0.01)]) == (None, [])
