"""One component's radius typed in another unit or with a wrong exponent: refused naming it in a JSON request, and
not used as a PCF item's size (said in a warning). Before, an elbow of radius 1e6 mm between 50 mm pipes was
weighted so that the network was cut around it as a 'conflict', and a pipe of radius 5e4 mm, at least 5 m long by
its minimum length, dragged eleven components 2.3 m; a PCF elbow whose bores were typed 1e7 did both."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.alignment.validation import check_input
from plantsolve.solvers.base import InputRejected, StoredInput

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "alignment"


def _ladder(index: int, radius: float) -> AlignmentRequest:
    body = json.loads((EXAMPLES / "ladder.json").read_text())
    body["components"][index]["radius"] = radius
    return AlignmentRequest.model_validate(body)


@pytest.mark.parametrize(("index", "radius"), [(1, 1e6), (1, 1e12), (6, 5e4)])  # the elbow N0-1, the pipe P1
def test_a_radius_a_hundred_times_its_neighbours_is_refused_naming_it(index, radius):
    request = _ladder(index, radius)
    with pytest.raises(InputRejected) as refused:
        check_input(request)
    (error,) = refused.value.errors
    assert error.loc == ("components", index, "radius")
    assert f"of component {request.components[index].id!r} is more than 100 times" in error.msg
    assert "(50 mm)" in error.msg  # the largest radius beside it, in the request's unit


def test_a_reducer_step_is_no_mistake():
    check_input(_ladder(1, 500.0))  # ten times its pipes': a large step, but a bore


def test_a_pcf_items_bore_typed_1e7_is_not_its_size_and_the_network_closes_uncut():
    text = (EXAMPLES / "ladder.pcf").read_text()
    for end in ("202997.80344555186 9995.887503446393", "202848.42626192237 9996.563449806907"):  # N0-1's two ends
        text = text.replace(f"{end} 100.0000", f"{end} 1e7", 1)
    request = parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), {"fixed_components": ["N0-0"]})
    check_input(request)
    assert next(c for c in request.components if c.id == "N0-1").radius is None
    result = solve(request).result
    assert result.converged and not result.cut_connections
    (note,) = [w for w in result.report.warnings if w.code == "pcf_radius_ignored"]
    assert "N0-1 (line 11) 5e+06 mm beside 50 mm" in note.message
