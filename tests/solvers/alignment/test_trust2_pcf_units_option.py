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
