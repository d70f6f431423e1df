"""A part drawn beside the single studs of several parts it lies on: its anti-studs all shifted by one offset across
the studs' plane, one stud of each partner (set 21109 lays 1 x 3 tiles across three parts' single studs, every
anti-stud 4 LDU aside). The shift is the lying part's own, shared by two or more of its points: it is joined as if
drawn on the grid (the joints at the partners' studs), and named in ``offset_joints``."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

BRICK = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n"  # a 2 x 4 brick, studs at x = -30, -10, 10, 30 and z = -10, 10


def plates(*xs) -> str:  # 1 x 1 plates on the brick's studs at z = 10, one stud each
    return "".join(f"1 4 {x} -8 10 1 0 0 0 1 0 0 0 1 3024.dat\n" for x in xs)


def solved(text: str):
    request = parse_upload(StoredInput.from_bytes("model.ldr", text.encode()), None)
    result = solve(request).result
    number = {p.id: p.part for p in request.parts}
    joints = sorted((j.type, *sorted(number[b] for b in j.bodies), j.connections, tuple(j.point)) for j in result.joints)
    offsets = next((w.details["pairs"] for w in result.report.warnings if w.code == "offset_joints"), [])
    return result, joints, offsets


def test_a_tile_drawn_4_ldu_beside_three_plates_single_studs_is_joined_as_drawn_on_them():
    # a 1 x 3 tile 63864 (anti-studs at x -20, 0, 20 of its own) over the three plates' studs, drawn 4 LDU along z
    shifted, joints, offsets = solved(BRICK + plates(-30, -10, 10) + "1 4 -10 -16 14 1 0 0 0 1 0 0 0 1 63864.dat\n")
    placed, drawn, none = solved(BRICK + plates(-30, -10, 10) + "1 4 -10 -16 10 1 0 0 0 1 0 0 0 1 63864.dat\n")
    # hand count: the brick holds each plate by one stud (a hinge), each plate the tile by one stud (a hinge) at the
    # plate's stud (-30/-10/10, -8, 10): the joints of the tile drawn in place, and each plate spins: dof 3
    assert joints == drawn and none == []
    assert [j for j in joints if "63864" in j] == [("hinge", "3024", "63864", 1, (x, -8.0, 10.0)) for x in (-30, -10, 10)]
    assert shifted.dof == placed.dof == 3 and len(shifted.pieces) == 1 and shifted.report.verdict is None
    assert sorted((p["parts"][1], p["offset_ldu"]) for p in offsets) == [("L2", 4.0), ("L3", 4.0), ("L4", 4.0)]


@pytest.mark.parametrize("top", [
    plates(-30) + "1 4 -10 -16 14 1 0 0 0 1 0 0 0 1 63864.dat\n",  # one plate under it: one stud, it may turn
    plates(-30, -10, 10) + "1 4 -10 -24 14 1 0 0 0 1 0 0 0 1 63864.dat\n",  # a plate's height up as well: air
    plates(-30, -10, 10) + "1 4 -10 -16 20 1 0 0 0 1 0 0 0 1 63864.dat\n",  # half a pitch aside: between studs
])
def test_a_tile_not_lying_beside_two_partners_studs_in_their_plane_is_not_joined(top):
    result, joints, _ = solved(BRICK + top)
    assert not [j for j in joints if "63864" in j] and result.report.verdict.code == "one_piece_not_determined"
