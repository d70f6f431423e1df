"""Button electrodes (radius r_e, protrusion l_e): the small-button limit S = 1 - (r_e/R)^2/6,
the order between points and patches, the protrusion, scaling, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import InputRejected, no_progress
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.validation import check_input
from plantsolve.solvers.flowmeter.fem import solve_button
from plantsolve.solvers.flowmeter.synthetic import meter, small_button
from plantsolve.solvers.flowmeter.weight2d import sensitivity_first_order_button

RADIUS = 50.0


def run(button_radius, protrusion=0.0, **kwargs):
    kwargs.setdefault("velocity", {"type": "uniform", "mean": 1.0})
    body = meter(radius=RADIUS, liner_length=6 * RADIUS, shape="button", button_radius=button_radius,
                 protrusion=protrusion, **kwargs)
    request = FlowmeterRequest.model_validate(body)
    check_input(request)
    return solve(request, no_progress).result


def test_small_flush_buttons_tend_to_the_point_electrode_S_1():
    gaps = []
    for r_e in (0.3, 0.2, 0.1):
        s = solve_button(r_e, 0.0, 3.0, h=0.12).sensitivity
        # S - 1 = -(r_e/R)^2 / 6 to leading order; the next order is O((r_e/R)^3)
        assert s == pytest.approx(small_button(r_e), abs=0.02 * r_e**3 + 1e-4)
        gaps.append(1 - s)
    assert gaps[0] > gaps[1] > gaps[2] > 0
    assert gaps[2] < 2e-3


def test_a_flush_button_through_the_solver_with_its_first_order_value():
    result = run(5.0, method="fem", tolerance=2e-3, probes=[[0.0, 0.0]], reynolds=[1000.0, 1e5])
    assert result.method == "fem"
    assert result.sensitivity == pytest.approx(small_button(0.1), abs=1e-4)
    assert result.error_estimate < 2e-3
    # uniform current density on the disc: pi r^2 / integral 2 sqrt(r^2 - y^2)/sqrt(1 - y^2) dy,
    # for small r 1 - <y^2>/2 = 1 - r^2/8 (the mean of y^2 over a uniform disc is r^2/4, against the
    # edge-loaded density's r^2/3)
    assert result.sensitivity_first_order == pytest.approx(1 - 0.1**2 / 8, abs=2e-5)
    assert result.sensitivity_first_order > result.sensitivity
    for point in result.linearity:  # flush: W harmonic, the profile does not matter
        assert abs(point.sensitivity - result.sensitivity) < 2e-3


def test_the_first_order_button_value_by_brute_force():
    r = 0.5
    y = np.linspace(-r, r, 400_001)
    y = 0.5 * (y[1:] + y[:-1])
    dy = 2 * r / 400_000
    area_wall = np.sum(2 * np.sqrt(r * r - y * y) / np.sqrt(1 - y * y)) * dy
    assert sensitivity_first_order_button(r) == pytest.approx(np.pi * r * r / area_wall, rel=1e-6)


def test_a_button_lies_between_point_electrodes_and_the_patch_around_it():
    r_e = 0.2
    button = solve_button(r_e, 0.0, 3.0, h=0.12).sensitivity
    body = meter(radius=1.0, units="m", half_angle=float(np.degrees(np.arcsin(r_e))), half_length=r_e, liner_length=6.0,
                 velocity={"type": "uniform", "mean": 1.0})
    patch = solve(FlowmeterRequest.model_validate(body), no_progress).result
    assert patch.method == "integral_equation"
    # the patch |theta| <= asin(r_e), |z| <= r_e contains the disc: more edge, lower S
    assert patch.sensitivity + 1e-3 < button < 1.0


def test_a_protruding_button_reaches_into_the_flow_and_makes_the_profile_matter():
    flush = run(5.0, method="fem", tolerance=4e-3)
    out = run(5.0, protrusion=2.5, method="fem", tolerance=4e-3, reynolds=[1000.0, 1e5])
    further = run(5.0, protrusion=5.0, method="fem", tolerance=4e-3)
    # for uniform flow and field S is the current-weighted mean of x/R over the electrode: its tip
    # at x = R - l_e carries much of the current, so S drops by a good part of l_e/R
    assert flush.sensitivity - out.sensitivity > 0.4 * 0.05
    assert out.sensitivity - further.sensitivity > 0.4 * 0.05
    assert out.sensitivity > 1 - 0.05 and further.sensitivity > 1 - 0.1
    laminar, turbulent = (p.sensitivity for p in out.linearity)
    assert abs(laminar - turbulent) > 2e-3  # the tip weighs the flow near the wall, which the profiles differ in


def test_button_scaling_R_1_and_R_500():
    small = solve(FlowmeterRequest.model_validate(meter(radius=1.0, units="m", shape="button", button_radius=0.15,
                                                        protrusion=0.03, liner_length=6.0, method="fem", tolerance=0.01)),
                  no_progress).result
    large = solve(FlowmeterRequest.model_validate(meter(radius=500.0, units="mm", shape="button", button_radius=75.0,
                                                        protrusion=15.0, liner_length=3000.0, method="fem",
                                                        tolerance=0.01)), no_progress).result
    assert small.sensitivity == pytest.approx(large.sensitivity, abs=1e-9)


@pytest.mark.parametrize("electrodes, method, loc", [
    ({"shape": "button"}, "auto", ("electrodes", "radius")),
    ({"shape": "button", "radius": 45.0}, "auto", ("electrodes", "radius")),
    ({"shape": "button", "radius": 0.5}, "auto", ("electrodes", "radius")),
    ({"shape": "button", "radius": 5.0, "protrusion": 50.0}, "auto", ("electrodes", "protrusion")),
    ({"shape": "button", "radius": 5.0, "half_length": 10.0}, "auto", ("electrodes", "half_length")),
    ({"shape": "button", "radius": 5.0}, "first_order", ("options", "method")),
    ({"shape": "button", "radius": 5.0, "protrusion": 2.0}, "integral_equation", ("options", "method")),
    ({"shape": "patch", "radius": 5.0}, "auto", ("electrodes", "radius")),
    ({"shape": "point", "protrusion": 1.0}, "auto", ("electrodes", "protrusion")),
])
def test_bad_buttons_name_the_field(electrodes, method, loc):
    body = meter(radius=RADIUS, method=method)
    body["electrodes"] = electrodes
    with pytest.raises(InputRejected) as error:
        check_input(FlowmeterRequest.model_validate(body))
    assert error.value.errors[0].loc == loc


def test_a_button_wider_than_the_liner_is_refused():
    body = meter(radius=RADIUS, liner_length=20.0, shape="button", button_radius=12.0)
    with pytest.raises(InputRejected) as error:
        check_input(FlowmeterRequest.model_validate(body))
    assert error.value.errors[0].loc == ("electrodes", "radius")


def test_the_integral_equation_for_flush_buttons_reaches_the_small_button_limit():
    # (1 - S) / r^2 tends to 1/6 with a correction of order r^2
    from plantsolve.solvers.flowmeter.integral_equation_button import solve_button as ie_button

    ratios = []
    for r_e in (0.3, 0.2, 0.1):
        solution = ie_button(r_e, 3.0)
        assert solution.error_estimate < 1e-4
        ratios.append((1 - solution.sensitivity) / r_e**2)
        assert abs(ratios[-1] - 1 / 6) < 0.06 * r_e**2
    assert ratios[0] > ratios[1] > ratios[2] > 1 / 6


@pytest.mark.parametrize("r_e", [5.0, 10.0])
def test_integral_equation_and_finite_elements_agree_for_flush_buttons(r_e):
    probes = [[-20.0, 15.0], [10.0, -25.0]]
    ie = run(r_e, probes=probes)
    by_fem = run(r_e, method="fem", tolerance=1e-3, probes=probes)
    assert ie.method == "integral_equation" and by_fem.method == "fem"
    assert abs(ie.sensitivity - by_fem.sensitivity) < 3e-4
    assert np.allclose(ie.probes, by_fem.probes, atol=3e-3)
    # the current per wall area at z = 0 peaks at the rim
    theta, j = np.array(ie.electrode_current).T
    assert np.all(j > 0) and j[np.argmax(np.abs(theta))] > 3 * j[np.argmin(np.abs(theta))]


def test_flush_button_scaling_by_the_integral_equation():
    small = solve(FlowmeterRequest.model_validate(meter(radius=1.0, units="m", shape="button", button_radius=0.15,
                                                        liner_length=6.0)), no_progress).result
    large = solve(FlowmeterRequest.model_validate(meter(radius=500.0, units="mm", shape="button", button_radius=75.0,
                                                        liner_length=3000.0)), no_progress).result
    assert small.method == large.method == "integral_equation"
    assert small.sensitivity == pytest.approx(large.sensitivity, abs=1e-12)


def test_a_large_flush_button_by_both_methods():
    # r_e = R/2 covers the wall up to 30 degrees: the mesh must follow the wall arc, not only the centre
    from plantsolve.solvers.flowmeter.integral_equation_button import solve_button as ie_button

    ie = ie_button(0.5, 3.0)
    by_fem = solve_button(0.5, 0.0, 3.0, h=0.18).sensitivity
    assert abs(ie.sensitivity - by_fem) < 5e-4
    assert ie.sensitivity < small_button(0.5) - 1e-3  # beyond the small-button limit
