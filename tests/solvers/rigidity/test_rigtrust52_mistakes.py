"""Users' mistakes with rigidity uploads and requests (rigtrust52): a subpart or primitive typed where a part was
meant, a part placed twice turned by its own symmetry, a mirrored part in a written request, a sub-model placed
under a name the file spells otherwise. Each is named by a warning, never answered as if nothing were wrong."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity import synthetic
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload
from tests.conftest import REPO

WALL = (REPO / "examples" / "rigidity" / "hinged_wall.ldr").read_text().replace("0 NOFILE\n", "")
XWING = (REPO / "tests" / "solvers" / "rigidity" / "omr" / "30051-1-X-wingFighter-Mini.mpd").read_text()


def parse(name: str, text: str) -> RigidityRequest:
    return parse_upload(StoredInput.from_bytes(name, text.encode()), None)


def codes(result) -> dict:
    return {w.code: w for w in result.report.warnings}


@pytest.mark.parametrize("line, named", [
    ("1 4 0 -200 0 1 0 0 0 1 0 0 0 1 s\\3001s01.dat", "line 22: 's\\3001s01.dat' (a subpart of 3001)"),
    ("1 4 0 -200 0 1 0 0 0 1 0 0 0 1 p/4-4disc.dat", "line 22: 'p/4-4disc.dat'"),
    ("1 4 0 -200 0 1 0 0 0 1 0 0 0 1 stud.dat", "line 22: 'stud.dat'"),  # a primitive without its folder
])
def test_a_subpart_or_primitive_placed_in_a_model_is_named_not_dropped_silently(line, named):
    request = parse("wall.ldr", WALL + line + "\n")
    result = solve(request).result
    placed = codes(result)["geometry_placed"]
    assert named in placed.message and placed.details["lines"] == [22]
    # the analysis is of the other parts, as without the line (stud.dat was an unknown part 'stud')
    assert (result.dof, len(result.parts), result.unknown_parts) == (4, 9, [])
    assert result.report.status == "warning"


def test_a_part_placed_twice_turned_by_its_own_symmetry_is_a_duplicate():
    """A 2 x 4 brick turned half about its y axis at its own place stands where it stood: one brick placed twice."""
    twice = WALL + "1 4 0 -24 0 -1 0 0 0 1 0 0 0 -1 3001.dat\n"
    found = codes(solve(parse("wall.ldr", twice)).result)
    assert found["duplicate_parts"].details["pairs"] == [["L8", "L22"]]
    # a quarter turn is no symmetry of a 2 x 4 brick: that is a brick across the other, no repeat
    across = WALL + "1 4 0 -24 0 0 0 1 0 1 0 -1 0 0 3001.dat\n"
    assert "duplicate_parts" not in codes(solve(parse("wall.ldr", across)).result)


def _request(rotation):
    return RigidityRequest.model_validate({"parts": [
        {"id": "base", "part": "3001", "position": [0, 0, 0]},
        {"id": "wing", "part": "41769", "position": [0, -8, 0], "rotation": rotation}]})


def test_a_handed_part_mirrored_in_a_written_request_is_named():
    mirror = [-1, 0, 0, 0, 1, 0, 0, 0, 1]
    result = solve(_request(mirror)).result
    found = codes(result)["mirrored_parts"]
    assert "parts[1] 'wing' (41769)" in found.message and found.details["parts"] == ["parts[1] 'wing' (41769)"]
    assert "mirrored_parts" not in codes(solve(_request([1, 0, 0, 0, 1, 0, 0, 0, 1])).result)


def test_a_symmetric_part_mirrored_in_a_written_request_is_the_rotation_it_equals():
    body = {"parts": [{"id": "a", "part": "3001", "position": [0, 0, 0]},
                      {"id": "b", "part": "3001", "position": [0, -24, 0], "rotation": [-1, 0, 0, 0, 1, 0, 0, 0, 1]}]}
    result = solve(RigidityRequest.model_validate(body)).result
    assert "mirrored_parts" not in codes(result) and result.rigid and result.dof == 0


@pytest.mark.parametrize("held, alike", [
    ("0 FILE 30051 - Engine.dat", "'30051 - engine.dat'"),  # saved under .dat, placed as .ldr
    ("0 FILE 30051 - Engin.ldr", "'30051 - engin.ldr'"),  # a letter lost
])
def test_a_submodel_placed_under_a_name_the_file_spells_otherwise_names_the_one_it_holds(held, alike):
    request = parse("xwing.mpd", XWING.replace("0 FILE 30051 - Engine.ldr", held))
    reasons = {s["line"]: s["reason"] for s in request.source["skipped"]}
    assert sorted(reasons) == [63, 64, 65, 66]
    assert f"which the file does not hold (it holds {alike}, named alike" in reasons[63]
    result = solve(request).result
    assert "unplaced_submodels" in codes(result) and result.report.status == "warning"
    assert len(result.parts) == 41  # the four engines' 20 parts are not analysed, and said so


def test_a_submodel_missing_altogether_keeps_the_cut_file_hint():
    text = XWING.replace("0 FILE 30051 - Engine.ldr", "0 FILE zzz.ldr")
    reason = parse("xwing.mpd", text).source["skipped"][0]["reason"]
    assert "named alike" not in reason and "an .mpd cut short" in reason


def test_the_symmetric_duplicate_rule_leaves_distinct_placements_of_a_handed_part_alone():
    """41769 has no symmetry but the identity: turned half about y at one place it is another placement."""
    body = {"parts": [{"id": "a", "part": "41769", "position": [0, 0, 0]},
                      {"id": "b", "part": "41769", "position": [0, 0, 0],
                       "rotation": np.diag([-1.0, 1.0, -1.0]).ravel().tolist()}]}
    assert "duplicate_parts" not in codes(solve(RigidityRequest.model_validate(body)).result)


def test_a_submodel_cycle_is_one_skipped_line_however_often_its_submodel_is_placed():
    """The engine, placed four times, places the fighter that places it: line 91 is skipped, once (it was counted
    as 4 lines skipped 'at line 91'); the model is analysed without it, as drawn."""
    looped = XWING.replace("0 FILE 30051 - Engine.ldr\n",
                           "0 FILE 30051 - Engine.ldr\n1 0 0 0 0 1 0 0 0 1 0 0 0 1 30051 - Fighter.ldr\n")
    request = parse("xwing.mpd", looped)
    assert request.source["skipped_count"] == 1
    (entry,) = request.source["skipped"]
    assert entry["line"] == 91 and "includes itself (30051 - fighter.ldr -> 30051 - engine.ldr" in entry["reason"]
    result, plain = solve(request).result, solve(parse("xwing.mpd", XWING)).result
    assert codes(result)["skipped_lines"].message.startswith("1 line(s)")
    assert (result.dof, len(result.parts)) == (plain.dof, len(plain.parts)) == (44, 61)


def test_unknown_parts_are_named_with_their_counts():
    text = WALL + "".join(f"1 4 0 {-100 * k} 0 1 0 0 0 1 0 0 0 1 {n}.dat\n" for k, n in
                          enumerate(["99999x", "99999x", "88888y"], start=2))
    found = codes(solve(parse("wall.ldr", text)).result)["unknown_parts"]
    assert found.message.startswith("3 of 12 part(s) are not in the catalogue")
    assert found.message.endswith("(not guessed): 2 number(s), 99999x (2), 88888y (1); dof, rigid and pieces are of "
                                  "the other 9")


@pytest.mark.parametrize("far, dof, uncertain", [(1e4, 1, False), (1e10, 2, True), (1e11, 2, True)])
def test_a_joint_typed_absurdly_far_says_the_float_rank_is_uncertain(far, dof, uncertain):
    """A planar four-bar has 1 degree of freedom wherever its hinges stand. With one hinge 1e10 mm from the others'
    50 mm the float rank, on coordinates scaled by the model's size, sees a lever 1e-10 of it: a singular value
    0.4 of the cut, counted zero, and dof 2. The answer is warned as uncertain, naming the margin (it read as a
    special position only); a hinge 1e4 mm off is resolved and not warned."""
    body = synthetic.four_bar()
    body["joints"][0]["point"] = [0.5, far, 0]
    result = solve(RigidityRequest.model_validate(body)).result
    assert result.rank_method == "svd" and result.dof == dof
    found = codes(result)
    assert ("rank_uncertain" in found) is uncertain
    if uncertain:
        assert found["rank_uncertain"].message.startswith("dof 2 may be up to 1 too high")
        assert 0.01 < found["rank_uncertain"].details["near_cut"][0] < 1
