"""An .mpd whose ``0 FILE`` section of a placed sub-model was lost is no verdict on the model: the parts present may be
rigid, but what the missing ones would join or leave loose cannot be told. Before, the skipped line was a caveat and
``rigid`` said true of half a model; now the verdict submodels_missing (NOT DETERMINED) names the sub-model and
``rigid`` is null."""

from __future__ import annotations

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

STACK = """0 FILE tower.ldr
1 16 0 0 0 1 0 0 0 1 0 0 0 1 lower.ldr
1 16 0 -48 0 1 0 0 0 1 0 0 0 1 upper.ldr
0 FILE lower.ldr
1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat
1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat
0 FILE upper.ldr
1 1 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat
1 1 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat
"""


def _solved(text: str):
    return solve(parse_upload(StoredInput.from_bytes("tower.mpd", text.encode()), None)).result


def test_the_whole_tower_is_rigid():
    result = _solved(STACK)
    assert result.rigid is True and result.dof == 0 and len(result.parts) == 4
    assert "submodels_missing" not in {w.code for w in result.report.warnings}


def test_a_tower_without_its_upper_submodel_is_not_determined_naming_it():
    result = _solved(STACK[:STACK.index("0 FILE upper.ldr")])
    assert len(result.parts) == 2 and result.dof == 0  # the two bricks present are one rigid stack
    assert result.rigid is None  # before: True, of half the model
    verdict = result.report.warnings[0]
    assert verdict.code == "submodels_missing"
    assert "'upper.ldr' (line 3)" in verdict.message
    assert verdict.details["missing_submodels"] == ["upper.ldr"] and verdict.details["lines"] == {"upper.ldr": [3]}
