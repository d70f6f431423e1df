"""Mistakes of the third probe: sampled velocities in mm/s written as m/s were judged by nobody (the mean-velocity
check skipped samples), so only the signal warned, naming the bore first."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.flowmeter.solve import solve

RINGS = [[0.0, 0.0]] + [[r * np.cos(a), r * np.sin(a)] for r in (20.0, 40.0, 50.0)
                        for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)]


def _sampled(values: list[float]) -> FlowmeterRequest:
    # full-length electrodes: the closed form, so the solve takes milliseconds
    return FlowmeterRequest.model_validate({
        "units": "mm", "pipe": {"radius": 50.0}, "electrodes": {"shape": "patch", "half_angle": 22.5},
        "magnetic_field": {"type": "uniform", "magnitude": 0.01},
        "velocity": {"type": "samples", "points": RINGS, "values": values}})


def test_samples_in_mm_per_s_written_as_m_per_s_are_warned_naming_the_values():
    result = solve(_sampled([800.0] * len(RINGS))).result  # a uniform 0.8 m/s flow sampled in mm/s
    assert abs(result.report.details["mean_velocity"] - 800.0) < 1e-6
    (warning,) = [w for w in result.report.warnings if w.code == "implausible_velocity"]
    assert warning.details["quantity"] == "velocity.values" and abs(warning.details["value"] - 800.0) < 1e-6
    assert "velocity.values" in warning.message and "mm/s or cm/s written as m/s?" in warning.message


def test_samples_of_a_plausible_flow_are_not_warned():
    result = solve(_sampled([2.0] * len(RINGS))).result
    assert abs(result.report.details["mean_velocity"] - 2.0) < 1e-9
    assert not [w for w in result.report.warnings if w.code == "implausible_velocity"]


def test_probe_points_in_metres_with_units_mm_are_warned_naming_the_field():
    """W at (0.025, 0) mm is W at the centre: the probe table looked like a meter's W at 25 mm and 45 mm."""
    from plantsolve.solvers.flowmeter.plausibility import request_warnings
    from plantsolve.solvers.flowmeter.synthetic import example

    def warned(points):
        request = FlowmeterRequest.model_validate({**example(), "options": {"probe_points": points}})
        assert request.units == "mm" and request.pipe.radius == 50.0
        return [w for w in request_warnings(request, 0.01) if w.code == "implausible_probe_points"]

    (warning,) = warned([[0.025, 0.0], [0.045, 0.01]])
    assert warning.details["quantity"] == "options.probe_points" and "in m with units 'mm'" in warning.message
    assert not warned([[25.0, 0.0], [45.0, 10.0]]) and not warned([[0.0, 0.0]]) and not warned([[0.0, 0.0], [1.0, 0.0]])
