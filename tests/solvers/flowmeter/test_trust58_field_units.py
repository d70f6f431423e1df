"""A field file whose header states no length unit or no unit of B is read in the request's units and in tesla, and
the report says so, naming what was assumed; a file stating both says nothing of it. (The reading itself is checked
against the file that states its units: the same field.)"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.flowmeter.field import request_field
from plantsolve.solvers.flowmeter.plausibility import request_warnings

EXAMPLES = Path(__file__).parents[3] / "examples" / "flowmeter"
COMSOL = (EXAMPLES / "magnet_comsol.txt").read_text()
NO_LENGTH = re.sub(r"% Length unit:.*\n", "", COMSOL)
NO_FIELD = COMSOL.replace(" (T)", "")


def _request(text: str) -> FlowmeterRequest:
    body = json.loads((EXAMPLES / "meter.json").read_text())
    body.pop("magnetic_field")
    body["options"]["magnetic_field_file"] = text
    return FlowmeterRequest.model_validate(body)


def _said(text: str):
    request = _request(text)
    field = request_field(request)
    return field, [w for w in request_warnings(request, 0.003, grid=field) if w.code == "field_file_unit_not_stated"]


@pytest.mark.parametrize("text, missing, words", [
    (NO_LENGTH, ["length"], "no length unit: its coordinates were read in the request's units ('mm')"),
    (NO_FIELD, ["field"], "no unit of B: its B values were read as tesla"),
    (re.sub(r"% Length unit:.*\n", "", NO_FIELD), ["length", "field"], "no length unit and no unit of B"),
])
def test_a_field_file_without_a_unit_is_read_in_the_requests_units_and_says_so(text, missing, words):
    field, (warning,) = _said(text)
    stated, _ = _said(COMSOL)
    assert (field.x == stated.x).all() and (field.by == stated.by).all()  # the same field, read as assumed
    assert words in warning.message and warning.details["not_stated"] == missing
    assert warning.details["quantity"] == "options.magnetic_field_file"


def test_a_field_file_stating_its_units_says_nothing_of_them():
    _, said = _said(COMSOL)
    assert said == []


@pytest.mark.parametrize("cut, value", [(2, "0.0016411162"), (8, "0.0016"), (12, "0.")])
def test_a_field_file_ending_inside_its_last_number_is_read_and_warned_naming_the_value(cut, value):
    whole = COMSOL.rstrip("\n")
    request = _request(whole[:-cut])
    field = request_field(request)
    (warning,) = [w for w in request_warnings(request, 0.003, grid=field) if w.code == "truncated_file"]
    assert f"its last value {value!r}" in warning.message and "the column's other values have 11 to 13" in \
        warning.message  # decimals: the zeros written '0' tell nothing of them
    assert field.by.shape == request_field(_request(COMSOL)).by.shape  # read whole: every point of the grid


@pytest.mark.parametrize("text", [COMSOL, COMSOL.rstrip("\n"), COMSOL.rstrip("\n").rsplit(None, 1)[0] + " -0"])
def test_a_whole_field_file_with_or_without_its_last_line_end_says_nothing_of_a_cut(text):
    request = _request(text)
    assert "truncated_file" not in {w.code for w in request_warnings(request, 0.003, grid=request_field(request))}
