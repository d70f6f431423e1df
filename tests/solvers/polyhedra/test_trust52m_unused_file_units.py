"""`options.file_units` says in what unit an uploaded file's numbers are. Beside a JSON body's vertices, which are in
its `units`, it changed nothing: vertices meant in feet were measured in metres without a word. Refused naming it;
uploads that use it keep it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

ROOT = Path(__file__).parents[3]
HOUSE = json.loads((ROOT / "examples" / "polyhedra" / "gable_house.json").read_text())


def test_file_units_beside_a_json_body_is_refused_naming_it():
    body = {**HOUSE, "options": {**HOUSE.get("options", {}), "file_units": "ft"}}
    with pytest.raises(InputRejected) as refused:
        check_input(PolyhedraRequest.model_validate(body))
    (error,) = refused.value.errors
    assert error.loc == ("options", "file_units") and "'ft'" in error.msg and '"units": "ft"' in error.msg


def test_a_json_body_in_its_own_units_passes():
    check_input(PolyhedraRequest.model_validate({**HOUSE, "units": "ft"}))


@pytest.mark.parametrize("name, content", [
    ("model.idf", (ROOT / "examples" / "polyhedra" / "two_offices.idf").read_bytes()),
    ("house.json", json.dumps(HOUSE).encode()),
])
def test_an_upload_read_in_file_units_keeps_the_option(name, content):
    request = parse_upload(StoredInput.from_bytes(name, content), {"file_units": "ft"})
    check_input(request)
    assert request.source["units"]["basis"] == "options.file_units"
    metres = parse_upload(StoredInput.from_bytes(name, content), None)
    ratio = solve(request).result.total_volume / solve(metres).result.total_volume
    assert ratio == pytest.approx(0.3048 ** 3)
