"""A patch electrode's half-length in metres under a request in mm (0.0157 for 15.7 mm on a 50 mm radius): the
patch is a hair long, S is the vanishing patch's (0.9729 instead of 0.9649, 0.8 % off, with an error estimate of
7e-4), and nothing was said. It warns ``implausible_electrode_half_length`` naming the field; patches of any real
length, and electrodes along the whole liner, do not."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.flowmeter.plausibility import request_warnings

REPO = Path(__file__).resolve().parents[3]


def _request(**electrodes) -> FlowmeterRequest:
    body = json.loads((REPO / "examples" / "flowmeter" / "meter.json").read_text())
    body["electrodes"].update(electrodes)
    return FlowmeterRequest.model_validate(body)


def _codes(request: FlowmeterRequest) -> dict:
    return {w.code: w for w in request_warnings(request, 0.01)}


def test_a_half_length_in_metres_under_mm_is_warned_naming_the_field():
    warning = _codes(_request(half_length=0.0157)).get("implausible_electrode_half_length")
    assert warning is not None
    assert warning.details["quantity"] == "electrodes.half_length"
    assert warning.details["value"] == 0.0157 and warning.details["radius"] == 50.0
    assert "metres with units 'mm'" in warning.message


@pytest.mark.parametrize("half_length", [15.707963, 2.5, 0.05, None])
def test_real_patches_and_full_length_electrodes_are_not_warned(half_length):
    assert "implausible_electrode_half_length" not in _codes(_request(half_length=half_length))


def test_a_button_has_no_half_length_to_judge():
    request = FlowmeterRequest.model_validate({"units": "mm", "pipe": {"radius": 50.0, "liner_length": 300.0},
                                              "electrodes": {"shape": "button", "radius": 5.0}})
    assert "implausible_electrode_half_length" not in _codes(request)
