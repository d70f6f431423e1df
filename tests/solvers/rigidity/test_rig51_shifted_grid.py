"""A part on one stud of a grid that other parts show drawn off by one shift: set 6761 draws its base plate 9.8 LDU off
the grid of the parts standing on it, and a 1 x 4 plate over the plate's raised hill has one of the plate's studs
under its row, drawn by the same shift. Two or more other parts, each on two or more studs, establish the shift; the
part on one stud is then joined (a hinge about the stud, as one stud holds it) and named in ``offset_joints``."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

# a 6 x 6 plate (studs at x, z in -50, -30 ... 50) on three 2 x 4 bricks: most parts joined, as the slip pass needs
BASE = ("1 4 0 0 0 1 0 0 0 1 0 0 0 1 3958.dat\n" + "".join(f"1 4 0 8 {z} 1 0 0 0 1 0 0 0 1 3001.dat\n"
                                                          for z in (-40, 0, 40)))
# two 2 x 2 plates, each on four of its studs, drawn 4 LDU along x and 3 along z off them
PARTNERS = ("1 1 -36 -8 -37 1 0 0 0 1 0 0 0 1 3022.dat\n"
            "1 1 44 -8 -37 1 0 0 0 1 0 0 0 1 3022.dat\n")


def solved(text: str):
    request = parse_upload(StoredInput.from_bytes("model.ldr", text.encode()), None)
    result = solve(request).result
    number = {p.id: p.part for p in request.parts}
    joints = sorted((j.type, j.origin, *sorted(number[b] for b in j.bodies), j.connections)
                    for j in result.joints)
    warning = next((w for w in result.report.warnings if w.code == "offset_joints"), None)
    return joints, warning


def test_a_plate_on_one_stud_of_a_grid_two_parts_show_shifted_is_joined_by_that_stud():
    joints, warning = solved(BASE + PARTNERS + "1 14 14 -8 33 1 0 0 0 1 0 0 0 1 3024.dat\n")
    assert joints == [("hinge", "stud", "3024", "3958", 1), ("rigid", "stud", "3001", "3958", 8),
                      ("rigid", "stud", "3001", "3958", 8), ("rigid", "stud", "3001", "3958", 8),
                      ("rigid", "stud", "3022", "3958", 4), ("rigid", "stud", "3022", "3958", 4)]
    assert sorted(pair["offset_ldu"] for pair in warning.details["pairs"]) == [5.0, 5.0, 5.0]


@pytest.mark.parametrize("text", [
    BASE + PARTNERS + "1 14 13 -8 34 1 0 0 0 1 0 0 0 1 3024.dat\n",  # another shift: the part stands otherwise
    BASE + PARTNERS.splitlines(keepends=True)[0] + "1 14 14 -8 33 1 0 0 0 1 0 0 0 1 3024.dat\n",  # one partner
    BASE + PARTNERS + "1 14 14 -16 33 1 0 0 0 1 0 0 0 1 3024.dat\n",  # a plate's height up: air between
])
def test_a_part_on_one_stud_is_not_joined_without_the_grid_shift_two_parts_establish(text):
    joints, _ = solved(text)
    assert all("3024" not in joint for joint in joints)
