"""Sub-models a file places but does not hold: named once whatever the case of each line's name (LDraw matches names
regardless of case), with their lines ('lines 6, 7'), under their own verdict code ``submodels_missing`` (NOT
DETERMINED); a hand-written request's ``source.missing_submodels`` of another shape is refused at intake naming the
field, and passed over by a solve called without intake, no longer a crash after the 202; the lines kept are
bounded."""

from __future__ import annotations

import pytest

from plantsolve.schemas.common import VERDICT_CODES
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import MAX_SKIPPED_LISTED, parse_ldraw, parse_upload
from plantsolve.solvers.rigidity.validation import check_input

TOWER = """0 FILE tower.ldr
1 16 0 0 0 1 0 0 0 1 0 0 0 1 lower.ldr
1 16 0 -48 0 1 0 0 0 1 0 0 0 1 lower.ldr
0 FILE lower.ldr
1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat
1 4 0 -24 0 1 0 0 0 1 0 0 0 1 Upper.ldr
1 4 0 -24 0 1 0 0 0 1 0 0 0 1 upper.ldr
"""


def _request():
    return parse_upload(StoredInput.from_bytes("tower.mpd", TOWER.encode()), None)


def test_a_missing_submodel_written_in_two_cases_is_one_named_with_its_lines():
    result = solve(_request()).result
    verdict = result.report.warnings[0]
    assert verdict.code == "submodels_missing" and VERDICT_CODES["submodels_missing"] == "NOT DETERMINED"
    assert result.rigid is None and result.report.verdict.code == "submodels_missing"
    assert "places 1 sub-model(s) it does not hold — 'Upper.ldr' (lines 6, 7)" in verdict.message  # before: 2, two
    assert verdict.details == {"missing_submodels": ["Upper.ldr"], "lines": {"Upper.ldr": [6, 7]}}


@pytest.mark.parametrize("written", [["upper.ldr"], {"upper.ldr": 3}, "upper.ldr", {"upper.ldr": ["6"]}])
def test_a_hand_written_missing_submodels_of_another_shape_is_passed_over(written):
    request = _request()
    none = solve(request.model_copy(update={"source": {**request.source, "missing_submodels": {}}})).result
    request = request.model_copy(update={"source": {**request.source, "missing_submodels": written}})
    result = solve(request).result  # before: AttributeError or TypeError after the 202
    assert "submodels_missing" not in {w.code for w in result.report.warnings}
    assert (result.dof, result.rigid, len(result.parts)) == (none.dof, none.rigid, 2)


def test_the_lines_placing_a_missing_submodel_are_kept_to_the_listed_bound_in_order():
    text = "0 FILE main.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n" + "".join(
        f"1 16 {k} 0 0 1 0 0 0 1 0 0 0 1 {'GONE' if k % 2 else 'gone'}.ldr\n" for k in range(MAX_SKIPPED_LISTED + 50))
    missing = parse_ldraw(text)["source"]["missing_submodels"]
    assert missing == {"gone.ldr": list(range(3, MAX_SKIPPED_LISTED + 3))}


@pytest.mark.parametrize("written", [["upper.ldr"], {"upper.ldr": 3}, "upper.ldr", {"upper.ldr": ["6"]}])
def test_a_written_request_with_missing_submodels_of_another_shape_is_refused_naming_the_field(written):
    request = _request()
    check_input(request)
    with pytest.raises(InputRejected) as refused:  # before: accepted, and the solve crashed after the 202
        check_input(request.model_copy(update={"source": {**request.source, "missing_submodels": written}}))
    (error,) = refused.value.errors
    assert error.loc == ("source", "missing_submodels") and "the lines placing it" in error.msg
