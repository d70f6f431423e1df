"""A magnetic field on a grid: a uniform grid is the uniform field, the liner's mean field weighs the
2-D current exactly, and the FEM with the field on every eighth agrees with the closed form."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import InputRejected, no_progress
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.validation import check_input
from plantsolve.solvers.flowmeter.synthetic import exact_full_length, grid_field, meter
from plantsolve.solvers.flowmeter.weight2d import complex_weight_full_length

RADIUS, LINER = 50.0, 300.0
B0 = 0.01


def run(field, **kwargs):
    body = meter(radius=RADIUS, liner_length=LINER, velocity={"type": "uniform", "mean": 1.0}, **kwargs)
    body["magnetic_field"] = field
    return solve(FlowmeterRequest.model_validate(body), no_progress).result


def tilted_x(x, y, z):
    return 0.3 * B0 * x * y


def tilted_y(x, y, z):
    # B_y falls linearly to half at the liner ends (L/2 = 3 R): its liner mean is 3/4 of the centre's
    return B0 * (1 + 0.2 * x + 0.1 * y) * (1 - 0.5 * np.abs(z) / 3.0)


def test_a_uniform_grid_is_the_uniform_field():
    grid = grid_field(RADIUS, LINER, lambda x, y, z: 0.0 * x, lambda x, y, z: B0 + 0.0 * x, nx=3, nz=3)
    for kwargs in ({"half_length": None}, {"half_length": 15.0, "method": "fem", "tolerance": 0.01}):
        uniform = run({"type": "uniform", "magnitude": B0}, **kwargs)
        gridded = run(grid, **kwargs)
        assert gridded.sensitivity == pytest.approx(uniform.sensitivity, abs=1e-10)
        assert gridded.signal == pytest.approx(uniform.signal, rel=1e-10)


def test_full_length_electrodes_see_the_liner_mean_of_the_field():
    result = run(grid_field(RADIUS, LINER, tilted_x, tilted_y), half_angle=30.0, half_length=None)
    n = 1500
    r, t = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(2 * n) + 0.5) * np.pi / n)
    x, y = r * np.cos(t), r * np.sin(t)
    c = complex_weight_full_length(x, y, np.radians(30.0))
    by_mean = 0.75 * (1 + 0.2 * x + 0.1 * y)
    bx_mean = 0.3 * x * y
    want = np.sum((by_mean * c.real + bx_mean * c.imag) * r) / np.sum(r)
    assert result.sensitivity == pytest.approx(want, abs=1e-3)
    assert abs(result.sensitivity - 0.75 * exact_full_length(30.0)) > 5e-3  # B_x matters here


def test_fem_with_a_grid_agrees_with_the_closed_form():
    field = grid_field(RADIUS, LINER, tilted_x, tilted_y)
    exact = run(field, half_angle=30.0, half_length=None)
    by_fem = run(field, half_angle=30.0, half_length=LINER / 2, method="fem", tolerance=0.004)
    assert by_fem.method == "fem" and exact.method == "closed_form_2d"
    assert by_fem.sensitivity == pytest.approx(exact.sensitivity, abs=2e-3)
    probes = [[10.0, 20.0], [-20.0, -10.0], [30.0, -15.0]]
    a = run(field, half_angle=30.0, half_length=None, probes=probes)
    b = run(field, half_angle=30.0, half_length=LINER / 2, method="fem", tolerance=0.004, probes=probes)
    assert np.allclose(a.probes, b.probes, atol=2e-2)


@pytest.mark.parametrize("change, loc", [
    (lambda f: f.update(x=[v * 0.5 for v in f["x"]]), ("magnetic_field", "x")),
    (lambda f: f.update(z=[v * 0.5 for v in f["z"]]), ("magnetic_field", "z")),
    (lambda f: f.update(by=f["by"][:-1]), ("magnetic_field", "by")),
    (lambda f: f.update(y=f["y"][::-1]), ("magnetic_field", "y")),
    (lambda f: f.update(by=[0.0] * len(f["by"])), ("magnetic_field", "by")),
])
def test_a_grid_that_does_not_cover_the_pipe_or_mismatches_is_refused(change, loc):
    field = grid_field(RADIUS, LINER, tilted_x, tilted_y, nx=5, nz=5)
    change(field)
    body = meter(radius=RADIUS, liner_length=LINER)
    body["magnetic_field"] = field
    with pytest.raises(InputRejected) as error:
        check_input(FlowmeterRequest.model_validate(body))
    assert error.value.errors[0].loc == loc


IE_GEOMETRIES = [{"half_angle": 22.5, "half_length": 15.7}, {"shape": "button", "button_radius": 5.0}]


@pytest.mark.parametrize("geometry", IE_GEOMETRIES)
def test_the_integral_equation_in_a_uniform_or_z_odd_grid_gives_the_uniform_answer(geometry):
    # B_y = B0 (1 + 0.1 z/R): the part odd in z does not couple to the (even) virtual current
    uniform = run({"type": "uniform", "magnitude": B0}, probes=[[10.0, 5.0]], **geometry)
    for by in (lambda x, y, z: B0 + 0.0 * x, lambda x, y, z: B0 * (1 + 0.1 * z) + 0.0 * x):
        gridded = run(grid_field(RADIUS, LINER, lambda x, y, z: 0.0 * x, by, nx=3, nz=7), probes=[[10.0, 5.0]], **geometry)
        assert gridded.method == uniform.method == "integral_equation"
        assert gridded.sensitivity == pytest.approx(uniform.sensitivity, abs=1e-6)
        assert gridded.probes == pytest.approx(uniform.probes, abs=1e-6)


def test_the_integral_equation_in_a_field_varying_along_z_obeys_the_divergence_theorem():
    # B = B0 g(z) e_y and uniform flow: integral W dA = (pi/2) integral g(z) oint phi cos(theta) dtheta dz
    # over the wall, which keeps the m = 1 wall mode only - a sum over z modes that bypasses the
    # volume evaluation (Bessel quotients, ring FFTs, field interpolation) of the solver
    from plantsolve.solvers.flowmeter import grid_weight, integral_equation
    from plantsolve.solvers.flowmeter.field import field_grid

    field = grid_field(RADIUS, LINER, lambda x, y, z: 0.0 * x, lambda x, y, z: B0 * np.exp(-(z / 1.5) ** 2) + 0.0 * x,
                       nx=5, nz=61)
    result = run(field, half_angle=45.0, half_length=50.0)
    body = meter(radius=RADIUS, liner_length=LINER, half_angle=45.0, half_length=50.0)
    body["magnetic_field"] = field
    solution = integral_equation.solve_patch(np.radians(45.0), 1.0, 3.0, 1e-3)
    _, by = grid_weight.field_modes(field_grid(FlowmeterRequest.model_validate(body)), solution.cut, solution.wall.shape[1])
    k = np.arange(solution.wall.shape[1]) * np.pi / solution.cut
    green = 1 / (1 + k * integral_equation.bessel_ratio_table(np.array([1.0]), k)[0])
    weight_n = np.where(k == 0, 1.0, 2.0) / (2 * solution.cut) * (2 / np.pi)
    want = (np.pi / 2) * np.sum(solution.wall[0] * weight_n * green * by[2, 2])
    assert result.method == "integral_equation"
    assert result.sensitivity == pytest.approx(want, abs=1e-6)
    assert abs(result.sensitivity - 0.8472) > 0.1  # the field's decay along z matters


def gaussian_y(x, y, z):
    return B0 * (1 + 0.2 * x + 0.1 * y) * np.exp(-(z / 1.5) ** 2)


def gaussian_x(x, y, z):
    return 0.3 * B0 * x * y * np.exp(-(z / 1.5) ** 2)


@pytest.mark.parametrize("geometry", [{"half_angle": 45.0, "half_length": 50.0}, {"shape": "button", "button_radius": 10.0}])
def test_integral_equation_and_finite_elements_agree_in_a_field_decaying_along_z(geometry):
    field = grid_field(RADIUS, LINER, gaussian_x, gaussian_y, nx=21, nz=25)
    probes = [[10.0, 5.0], [-20.0, 15.0]]
    ie = run(field, probes=probes, **geometry)
    coarse = run(field, method="fem", tolerance=4e-3, **geometry)
    by_fem = run(field, method="fem", tolerance=1e-3, probes=probes, **geometry)
    assert ie.method == "integral_equation" and by_fem.method == "fem"
    assert ie.error_estimate < 1e-4
    # the FEM converges slowly here (a field varying along z meets its long axial cells; the
    # patches' calibration is exact for a uniform field only): it approaches the integral equation
    assert abs(ie.sensitivity - by_fem.sensitivity) < 5e-3
    assert abs(ie.sensitivity - by_fem.sensitivity) < abs(ie.sensitivity - coarse.sensitivity)
    assert np.allclose(ie.probes, by_fem.probes, atol=1e-2)
