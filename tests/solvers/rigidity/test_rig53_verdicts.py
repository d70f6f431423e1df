"""The verdicts of a LEGO model's report: a model mostly of parts outside the catalogue is NOT DETERMINED (rigid
null), a build that comes apart as analysed is NOT DETERMINED (loose or a joint the catalogue lacks), two parts typed a world apart are warned."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from plantsolve.schemas.rigidity import PartIn, RigidityRequest
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.verdicts import unknown_elements

BRICK = "3001"  # 2 x 4 brick: 80 LDU along x, 40 along z, 24 high


def parts(*placed) -> RigidityRequest:
    return RigidityRequest(parts=[PartIn(id=f"p{k}", part=number, position=list(at))
                                 for k, (number, at) in enumerate(placed)])


def stack(count: int) -> list:
    return [(BRICK, (0, -24 * k, 0)) for k in range(count)]


def codes(result) -> list[str]:
    return [w.code for w in result.report.warnings]


def test_a_model_half_of_unknown_parts_is_not_determined_and_not_rigid():
    result = solve(parts(*stack(2), ("99999x", (0, -48, 0)), ("99998y", (200, 0, 0)))).result
    assert result.rigid is None and result.dof == 0  # the two known bricks alone are rigid
    verdict = result.report.verdict
    assert (verdict.label, verdict.code) == ("NOT DETERMINED", "rigidity_not_determined")
    assert codes(result)[0] == "rigidity_not_determined"
    w = result.report.warnings[0].details
    assert (w["unknown_elements"], w["known_parts"], w["unknown_share"]) == (2, 2, 0.5)


def test_a_model_of_unknown_parts_only_is_not_determined():
    result = solve(parts(("99999x", (0, 0, 0)), ("99998y", (0, -24, 0)))).result
    assert result.rigid is None and result.report.verdict.code == "rigidity_not_determined"


def test_a_known_majority_keeps_its_answer_with_the_unknown_parts_named():
    result = solve(parts(*stack(3), ("99999x", (0, -72, 0)))).result
    assert result.rigid is True and result.report.verdict is None
    assert "unknown_parts" in codes(result)


def test_a_hose_drawn_as_a_chain_of_segments_is_one_element():
    # 40 segments 2 LDU apart, as LSynth draws a hose: one element beside two known bricks, not 40 of 42 parts
    hose = [("ls60", (100 + 2 * k, 0, 0)) for k in range(40)]
    result = solve(parts(*stack(2), *hose)).result
    assert result.rigid is True and result.report.verdict is None
    # the same 40 parts a stud apart are 40 elements
    assert unknown_elements(["ls60"] * 40, np.array([(20 * k, 0, 0) for k in range(40)])) == 40
    assert unknown_elements(["ls60"] * 40, np.array([at for _, at in hose])) == 1
    assert unknown_elements(["a", "b"], np.zeros((2, 3))) == 2  # two numbers at one place: two parts


def test_bricks_side_by_side_with_no_joint_are_not_determined_as_one_piece():
    # two bricks touching face to face (the second 40 LDU along z): nothing holds them together
    result = solve(parts((BRICK, (0, 0, 0)), (BRICK, (0, 0, 40)), (BRICK, (0, -24, 0)))).result
    assert result.rigid is None and len(result.pieces) == 2 and not result.pieces[1].drawn_apart
    verdict = result.report.verdict
    assert (verdict.label, verdict.code) == ("NOT DETERMINED", "one_piece_not_determined")
    details = result.report.warnings[0].details
    assert (details["pieces"], details["single_parts"], details["parts"]) == (1, 1, 1)
    assert "floating_parts" in codes(result)


def test_a_build_drawn_apart_is_separate_builds_not_a_verdict():
    result = solve(parts(*stack(2), *[(BRICK, (1000, -24 * k, 0)) for k in range(2)])).result
    assert result.rigid is False and result.pieces[1].drawn_apart
    assert result.report.verdict is None and "separate_builds" in codes(result)


def test_one_build_has_no_verdict():
    result = solve(parts(*stack(3))).result
    assert result.rigid is True and result.report.verdict is None and result.report.status == "ok"


def test_bodies_and_joints_in_two_pieces_are_no_verdict():
    request = RigidityRequest(bodies=[{"id": n} for n in "ABCD"], joints=[
        {"id": "j1", "type": "rigid", "bodies": ["A", "B"], "point": [0, 0, 0]},
        {"id": "j2", "type": "rigid", "bodies": ["C", "D"], "point": [5, 0, 0]}])
    result = solve(request).result
    assert result.rigid is False and result.report.verdict is None


@pytest.mark.parametrize("apart, warned", [(1e12, True), (3e5, True), (2000.0, False)])
def test_two_parts_typed_a_world_apart_are_warned(apart, warned):
    result = solve(parts((BRICK, (0, 0, 0)), (BRICK, (apart, 0, 0)))).result
    far = next((w for w in result.report.warnings if w.code == "implausible_part_position"), None)
    assert (far is not None) == warned
    if warned:  # which of the two is off cannot be told: both are named
        assert [p["id"] for p in far.details["parts"]] == ["p0", "p1"]
        assert far.details["parts"][0]["distance_ldu"] == pytest.approx(apart / 2)


def test_copies_of_an_unknown_part_at_one_spot_are_one_element_in_bounded_memory():
    """5,000 copies at one origin: every pair of them within a segment's step (12.5 M pairs, 200 MB of pair indices
    before); one stands for all parts of a cell now."""
    tracemalloc.start()
    try:
        assert unknown_elements(["zzz"] * 5000, np.zeros((5000, 3))) == 1
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6
