"""Rigidity: a LEGO model written in another order names, places and orients its inferred joints the same, and
names the same part as the repeat of a part placed twice.

The joints between two parts are found when the later of them is placed, from the later part's connectors:
their id (``a~b``), the order of their connections and the sign of their axis followed the file's order.
"""

from __future__ import annotations

from pathlib import Path

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.synthetic import gearbox
from plantsolve.solvers.rigidity.upload import parse_upload

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "rigidity"


def _joints(request) -> dict:
    result = solve(request).result
    return {j.id: (j.type, j.bodies, j.point, j.axis, j.connections, j.moves) for j in result.joints}, result


def test_parts_in_reverse_order_give_the_same_joint_ids_points_and_axes():
    request = parse_upload(StoredInput.from_path(EXAMPLES / "hinged_wall.ldr"), None)
    joints, result = _joints(request)
    again, reversed_result = _joints(request.model_copy(update={"parts": request.parts[::-1]}))
    assert again == joints  # exact: LDraw coordinates are integers of LDU
    # the example's known answer (its README), whatever the order
    assert (result.dof, reversed_result.dof) == (4, 4)
    # the base bricks on all eight studs: the first stud of the joint (smallest x, y, z), its axis the stud's line
    # given with its first non-zero component positive
    assert joints["L7~L8"] == ("rigid", ["L7", "L8"], [-30.0, 0.0, -10.0], [0.0, 1.0, 0.0], 8, False)


def test_a_part_placed_twice_is_named_the_repeat_of_the_same_part_in_any_order():
    parts = gearbox()  # one pin (2780) and the 8-tooth gear (3647) placed a second time at the same pose
    for listed in (parts, parts[::-1]):
        result = solve(RigidityRequest.model_validate({"parts": listed})).result
        warning = next(w for w in result.report.warnings if w.code == "duplicate_parts")
        assert warning.details["pairs"] == [["g0p8", "g0p13"], ["g0p5", "g0p14"]]
