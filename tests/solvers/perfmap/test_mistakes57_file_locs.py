"""A perfmap upload's refusals by the checks across fields (``validation.load``) name where the user wrote the value:
``file.<path>`` in an uploaded JSON request (as every other reader names it), ``file.<i>...`` in a bare list of
positions, the form's ``options.<name>`` when the value came from the form; a JSON body keeps its own paths."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "perfmap" / "n3_fan_map.json"


def _body() -> dict:
    return json.loads(EXAMPLE.read_text())


def _percent_with_one_fraction() -> dict:
    body = _body()
    body["units"] = {**(body.get("units") or {}), "efficiency": "%"}
    for position in body["positions"]:
        position["efficiency"] = [e * 100 for e in position["efficiency"]]
    body["positions"][0]["efficiency"][1] /= 100  # typed as a fraction among per cent
    return body


def _refused(data: bytes, name: str = "map.json", options: dict | None = None) -> list:
    source = StoredInput(name, content=data)
    with pytest.raises(InputRejected) as caught:
        load(parse_upload(source, options), source)
    return caught.value.errors


def test_a_stray_efficiency_of_an_uploaded_json_request_is_named_at_its_path_in_the_file():
    (error,) = _refused(json.dumps(_percent_with_one_fraction()).encode())
    assert error.loc == ("file", "positions", 0, "efficiency", 1)
    assert "a fraction among per cent" in error.msg


def test_the_same_request_as_a_body_keeps_its_own_path():
    with pytest.raises(InputRejected) as caught:
        load(PerfmapRequest.model_validate(_percent_with_one_fraction()))
    assert caught.value.errors[0].loc == ("positions", 0, "efficiency", 1)


def test_a_repeated_setting_in_a_bare_list_of_positions_is_named_by_its_index_in_the_file():
    positions = _body()["positions"]
    positions[2] = dict(positions[1])
    (error,) = _refused(json.dumps(positions).encode())
    assert error.loc == ("file", 2) and "repeats positions[1]" in error.msg


def test_a_result_unit_from_the_form_is_named_as_the_form_option_and_one_in_the_file_in_the_file():
    body = _body()
    body.pop("units", None)  # no unit stated for the flow: a result unit cannot be converted to
    for where, options in (("file", None), ("form", {"result_units": {"flow": "kg/s"}})):
        if where == "file":
            document = {**body, "options": {**body.get("options", {}), "result_units": {"flow": "kg/s"}}}
        else:
            document = body
        (error,) = _refused(json.dumps(document).encode(), options=options)
        expected = ("options", "result_units", "flow")
        assert error.loc == (("file", *expected) if where == "file" else expected), where
