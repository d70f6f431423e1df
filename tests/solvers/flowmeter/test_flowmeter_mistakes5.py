"""Lengths of a grid field and of a button's protrusion written in another unit than the request's: warned naming
the field (a 1000-times unit slip leaves a confident answer otherwise: the field's variation across the pipe lost
between two grid nodes, a 2 mm protrusion read as 2 µm)."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.flowmeter.plausibility import request_warnings


def grid_request(units: str, radius: float, reach: float) -> FlowmeterRequest:
    axis = [-reach, 0.0, reach]
    count = 27
    return FlowmeterRequest.model_validate({
        "units": units, "pipe": {"radius": radius, "liner_length": 6 * radius},
        "electrodes": {"shape": "patch", "half_angle": 22.5, "half_length": 0.3 * radius},
        "magnetic_field": {"type": "grid", "x": axis, "y": axis, "z": [-4 * reach, 0.0, 4 * reach],
                           "bx": [0.0] * count, "by": list(np.linspace(0.009, 0.011, count))}})


def codes(request, field=0.01):
    return {w.code: w for w in request_warnings(request, field)}


def test_a_grid_in_mm_with_units_m_is_warned_naming_the_axis():
    warning = codes(grid_request("m", 0.05, 60.0))["implausible_field_grid"]
    assert warning.details["quantity"] == "magnetic_field.x" and warning.details["radii"] == 1200
    assert "magnetic_field.x" in warning.message and "'m'" in warning.message


def test_a_grid_a_few_radii_round_the_pipe_is_not_warned():
    assert "implausible_field_grid" not in codes(grid_request("mm", 50.0, 60.0))
    assert "implausible_field_grid" not in codes(grid_request("m", 0.05, 0.5))


def button(protrusion: float) -> FlowmeterRequest:
    return FlowmeterRequest.model_validate({"units": "mm", "pipe": {"radius": 50.0},
                                            "electrodes": {"shape": "button", "radius": 5.0,
                                                           "protrusion": protrusion}})


def test_a_protrusion_in_metres_with_units_mm_is_warned_naming_it():
    warning = codes(button(0.002))["implausible_electrode_protrusion"]
    assert warning.details["quantity"] == "electrodes.protrusion" and "0.002 mm" in warning.message


def test_flush_and_protruding_buttons_are_not_warned():
    assert "implausible_electrode_protrusion" not in codes(button(0.0))
    assert "implausible_electrode_protrusion" not in codes(button(2.0))
