"""Options as users type them: an upload form's ``{"pipe_radius": "6"}`` is the number 6 (read, as a JSON body's is),
but ``true`` was read as 1 (``"tolerance": true`` solved with ε = 1 mm without a word) and ``"6_0"`` as 60 (Python's
float reads digit-group underscores): both are refused naming the option."""

from pathlib import Path

import pytest

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.upload import parse_upload

SCAN = (Path(__file__).parents[3] / "examples" / "tube" / "scan.xyz").read_bytes()


def _upload(options):
    return parse_upload(StoredInput.from_bytes("scan.xyz", SCAN), options)


@pytest.mark.parametrize("text", ["6", " 6 ", "6.0", "6e0", "+6"])
def test_a_number_typed_as_a_string_is_that_number(text):
    assert _upload({"pipe_radius": text}).options.pipe_radius == 6.0


@pytest.mark.parametrize(("option", "value"), [("tolerance", True), ("pipe_radius", False), ("pipe_radius", "6_0"),
                                               ("bend_radius", True), ("damping", True), ("dies", [True])])
def test_true_false_and_underscored_digits_are_refused_naming_the_option(option, value):
    with pytest.raises(InputRejected) as refused:
        _upload({option: value})
    assert refused.value.errors[0].loc[:2] == ("options", option)


def test_a_json_body_reads_the_same_way():
    points = [[float(i % 7), float(i % 11), float(i % 13)] for i in range(120)]
    assert TubeRequest.model_validate({"points": points, "options": {"pipe_radius": "6"}}).options.pipe_radius == 6
    with pytest.raises(ValueError, match="not true or false"):
        TubeRequest.model_validate({"points": points, "options": {"inspection_tolerances": {"angle": True}}})
    with pytest.raises(ValueError, match="not true or false"):
        TubeRequest.model_validate({"points": points, "options": {"nominal": [{"length": True, "rotation": 0,
                                                                              "angle": 0, "bend_radius": 0}]}})
