"""Options as users type them: ``{"position_tolerance": "1"}`` in an upload form is the number 1 (read), but
``true`` was read as 1 (a PCF aligned with a 1 mm position tolerance, and ``angle_tolerance: true`` with 1°,
without a word) and ``"1_0"`` as 10: both are refused naming the option, in the form and in a JSON request."""

import json
from pathlib import Path

import pytest

from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import InputRejected, StoredInput

EXAMPLES = Path(__file__).parents[3] / "examples" / "alignment"
PCF = (EXAMPLES / "ladder.pcf").read_bytes()
BODY = json.loads((EXAMPLES / "ladder.json").read_text())


def test_a_number_typed_as_a_string_is_that_number():
    request = parse_upload(StoredInput.from_bytes("ladder.pcf", PCF), {"position_tolerance": "1"})
    assert request.options.position_tolerance == 1.0


@pytest.mark.parametrize(("option", "value"), [("position_tolerance", True), ("angle_tolerance", True),
                                               ("connection_tolerance", True), ("pipe_stiffness", "1_0"),
                                               ("shape_tolerance", False)])
def test_true_false_and_underscored_digits_are_refused_naming_the_option(option, value):
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("ladder.pcf", PCF), {option: value})
    assert any(e.loc[-1] == option for e in refused.value.errors), refused.value.errors


def test_a_json_request_reads_the_same_way():
    body = {**BODY, "options": {**BODY["options"], "position_tolerance": True}}
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("ladder.json", json.dumps(body).encode()), None)
    assert refused.value.errors[0].loc[-2:] == ("options", "position_tolerance")
    radius = json.loads(json.dumps(BODY))
    radius["components"][0]["radius"] = True
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("ladder.json", json.dumps(radius).encode()), None)
    assert refused.value.errors[0].loc[-3:] == ("components", 0, "radius")


def test_the_schema_keeps_the_bounds_of_the_checked_fields():
    from plantsolve.schemas.alignment import AlignmentOptions, Component

    props = AlignmentOptions.model_json_schema()["properties"]
    assert props["position_tolerance"]["anyOf"][0] == {"exclusiveMinimum": 0, "maximum": 1000.0, "type": "number"}
    assert props["pipe_stiffness"]["minimum"] == 1e-6
    assert Component.model_json_schema()["properties"]["radius"]["anyOf"][0]["exclusiveMinimum"] == 0
