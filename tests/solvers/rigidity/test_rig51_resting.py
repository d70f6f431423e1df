"""A whole placed sub-model that touches the build only lying on top of its parts where they have no stud (a tile)
is a held sub-build, recognised as resting: nothing there can hold it (set 10214 stands its four cars on a road of
8 x 16 tiles; they were pieces whose joint was not found). Lying on studs, or against a part's side, it is still a
piece whose joint was not found."""

from __future__ import annotations

import math

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import HELD_BY, solve
from plantsolve.solvers.rigidity.upload import parse_upload

C45 = S45 = f"{math.sqrt(0.5):.6f}"
# two 2 x 4 bricks stacked, a 2 x 4 tile on the top one's studs (its top at y = -8)
ROAD = ("0 FILE main.ldr\n1 4 0 48 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
        "1 4 0 16 0 1 0 0 0 1 0 0 0 1 87079.dat\n")
# the sub-model: two 2 x 2 bricks stacked (one rigid joint)
CAR = "0 FILE car.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3003.dat\n"


def pieces(main: str):
    result = solve(parse_upload(StoredInput.from_bytes("car.mpd", (main + CAR).encode()), None)).result
    return ([(pc.parts, pc.sub_build) for pc in result.pieces], [h["recognised_by"] for h in
                                                                 result.report.details.get("held_pieces") or []],
            {w.code for w in result.report.warnings})


def test_a_sub_model_lying_on_a_tile_is_held_resting():
    found, held_by, warnings = pieces(ROAD + "1 4 0 -8 0 1 0 0 0 1 0 0 0 1 car.ldr\n")
    assert found == [(["L2", "L3", "L4"], None), (["L5/L7", "L5/L8"], "car.ldr")]
    assert held_by == [HELD_BY["resting"]] and "separate_pieces" not in warnings


@pytest.mark.parametrize("main", [
    # turned 45 degrees on the top brick's studs, where no anti-stud meets one
    ("0 FILE main.ldr\n1 4 0 48 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
     f"1 4 0 0 0 {C45} 0 {S45} 0 1 0 -{S45} 0 {C45} car.ldr\n"),
    # on a 2 x 2 tile and against the side of a 2 x 2 brick beside it, both on a 2 x 4 brick
    ("0 FILE main.ldr\n1 4 0 48 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 -20 40 0 1 0 0 0 1 0 0 0 1 3068b.dat\n"
     "1 4 20 24 0 1 0 0 0 1 0 0 0 1 3003.dat\n1 4 -20 16 0 1 0 0 0 1 0 0 0 1 car.ldr\n"),
])
def test_a_sub_model_lying_on_studs_or_against_a_side_is_no_held_sub_build(main):
    found, held_by, warnings = pieces(main)
    assert found[-1][1] is None and held_by == [] and "separate_pieces" in warnings
