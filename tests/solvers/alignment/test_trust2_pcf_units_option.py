"""A ``units`` option given with an uploaded PCF was refused as 'Extra inputs are not permitted' (pydantic's word for
a field of no model), which said neither why nor what to do: a PCF's UNITS-CO-ORDS and UNITS-BORE records decide its
units. The 422 names ``options.units`` and says so, quoting the records the file holds."""

from __future__ import annotations

import json
import re
import tempfile
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput
from tests.conftest import service_settings

REPO = Path(__file__).resolve().parents[3]
LADDER = (REPO / "examples" / "alignment" / "ladder.pcf").read_text()
INCH = (Path(__file__).parent / "data" / "sp3d_inch_tabs.pcf").read_text()


@pytest.fixture(scope="module")
def client():
    with tempfile.TemporaryDirectory() as folder:
        with TestClient(create_app(service_settings(Path(folder)), run_jobs=False)) as test_client:
            yield test_client


def _post(client, text: str, options: dict):
    return client.post("/v1/alignment/jobs", files={"file": ("line.pcf", text.encode())},
                       data={"options": json.dumps(options)})


@pytest.mark.parametrize(("text", "stated"), [
    (LADDER, "UNITS-BORE MM (line 2), UNITS-CO-ORDS MM (line 3)"),
    (INCH, "UNITS-BORE INCH (line 2), UNITS-CO-ORDS INCH (line 3)"),
    (re.sub(r"(?m)^UNITS-.*\n", "", LADDER), "states neither, so it is read in millimetres"),
])
@pytest.mark.parametrize("unit", ["in", "mm"])
def test_a_units_option_is_refused_naming_the_records_that_decide(client, text, stated, unit):
    response = _post(client, text, {"units": unit})
    assert response.status_code == 422, response.text
    (error,) = response.json()["errors"]
    assert error["loc"] == ["options", "units"] and error["type"] == "extra_forbidden"
    assert "UNITS-CO-ORDS record gives the coordinates' unit" in error["msg"] and stated in error["msg"]


def test_the_forms_other_bad_options_are_named_along_with_it(client):
    response = _post(client, LADDER, {"units": "in", "method": "newton", "max_iterations": 20})
    assert response.status_code == 422
    assert [e["loc"] for e in response.json()["errors"]] == [["options", "units"], ["options", "method"]]


def test_the_ladder_without_the_option_is_taken(client):
    assert _post(client, LADDER, {"max_iterations": 20}).status_code == 202


LADDER_JSON = json.loads((REPO / "examples" / "alignment" / "ladder.json").read_text())


def _post_json(client, document: dict, options: dict):
    return client.post("/v1/alignment/jobs", files={"file": ("line.json", json.dumps(document).encode())},
                       data={"options": json.dumps(options)})


def test_a_json_files_form_units_give_the_unit_it_leaves_out(client):
    """It was laid into the request's options and refused as 'Extra inputs are not permitted' at file.options.units."""
    document = {key: value for key, value in LADDER_JSON.items() if key != "units"}
    assert _post_json(client, document, {"units": "inches"}).status_code == 202
    source = StoredInput.from_bytes("line.json", json.dumps(document).encode())
    assert parse_upload(source, {"units": "inches"}).units == "in" and parse_upload(source, None).units == "mm"


def test_a_json_files_form_units_contradicting_the_files_are_refused_naming_both(client):
    assert LADDER_JSON["units"] == "mm"
    response = _post_json(client, LADDER_JSON, {"units": "in"})
    assert response.status_code == 422
    (error,) = response.json()["errors"]
    assert error["loc"] == ["options", "units"] and "'in'" in error["msg"] and "'mm'" in error["msg"]
    assert _post_json(client, LADDER_JSON, {"units": "millimetres"}).status_code == 202


def test_a_json_files_bad_form_option_is_named_as_the_form_names_it(client):
    """It was named file.options.method, a place in the file that holds no such value."""
    document = {**LADDER_JSON, "options": {**LADDER_JSON.get("options", {}), "max_iterations": "many"}}
    response = _post_json(client, document, {"method": "newton"})
    assert response.status_code == 422
    assert sorted(e["loc"] for e in response.json()["errors"]) == [
        ["file", "options", "max_iterations"], ["options", "method"]]
