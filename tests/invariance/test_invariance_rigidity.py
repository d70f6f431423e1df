"""Rigidity: a LEGO model written in another order names, places and orients its inferred joints the same.

The joints between two parts are found when the later of them is placed, from the later part's connectors:
their id (``a~b``), the order of their connections and the sign of their axis followed the file's order.
"""

from __future__ import annotations

from pathlib import Path

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
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
