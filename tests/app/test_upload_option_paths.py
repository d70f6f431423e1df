"""Through the API: a refused upload's problem names each value where the user sent it, the multipart ``options``
part's ``units`` as ``/options/units`` in every kind and a request file's own values under ``/file``; an option the
form and the file give differently is a 422 naming both, never the form's value taken without a word."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings

REPO = Path(__file__).resolve().parents[2]
PROBLEM = "application/problem+json"


@pytest.fixture(scope="module")
def client():
    with tempfile.TemporaryDirectory() as folder:
        with TestClient(create_app(service_settings(Path(folder)), run_jobs=False)) as test_client:
            yield test_client


def _json(path: str, **changes) -> tuple[str, bytes]:
    body = {**json.loads((REPO / path).read_text()), **changes}
    return Path(path).name, json.dumps({k: v for k, v in body.items() if v is not None}).encode()


def _example(path: str) -> tuple[str, bytes]:
    return Path(path).name, (REPO / path).read_bytes()


def _errors(client, kind: str, file: tuple[str, bytes], options: dict) -> list[dict]:
    response = client.post(f"/v1/{kind}/jobs", files={"file": file}, data={"options": json.dumps(options)})
    assert response.status_code == 422 and response.headers["content-type"] == PROBLEM, response.text
    return response.json()["errors"]


@pytest.mark.parametrize(("kind", "file"), [
    ("alignment", _json("examples/alignment/ladder.json", units=None)),  # was /file/units
    ("polyhedra", _example("examples/polyhedra/two_offices.idf")),  # was /units
    ("rigidity", _example("examples/rigidity/hinged_wall.ldr")),  # was /units
    ("tube", _example("examples/tube/scan.xyz")),
    ("flowmeter", _json("examples/flowmeter/meter.json", units=None)),  # was 'Extra inputs are not permitted'
])
def test_a_form_units_of_no_unit_is_named_options_units(client, kind, file):
    (error,) = _errors(client, kind, file, {"units": 5})
    assert error["pointer"] == "/options/units" and "'mm'" in error["msg"], error


def test_a_tube_request_files_own_bad_option_is_named_in_the_file(client):
    file = _json("examples/tube/scan_request.json", options={"damping": "abc"})
    (error,) = _errors(client, "tube", file, {"seed": 1})
    assert error["pointer"] == "/file/options/damping", error  # was /options/damping, a place the form left empty


def test_an_option_the_form_and_the_file_give_differently_is_a_422_naming_both(client):
    file = _json("examples/flowmeter/meter.json")  # its options.tolerance is 0.002
    (error,) = _errors(client, "flowmeter", file, {"tolerance": 0.003})
    assert error["pointer"] == "/options/tolerance" and "file.options.tolerance 0.002" in error["msg"], error


def test_a_form_units_contradicting_a_tube_request_files_is_a_422_naming_both(client):
    file = _json("examples/tube/scan_request.json")  # in mm: it was read as metres
    (error,) = _errors(client, "tube", file, {"units": "m"})
    assert error["pointer"] == "/options/units" and "file.units 'mm'" in error["msg"], error
