"""The integral equation on the electrode: S of the seed's geometry, agreement with the finite
elements, the long-electrode limit, and its Bessel ratios."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import iv

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import no_progress
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.integral_equation import bessel_ratio_table, solve_patch
from plantsolve.solvers.flowmeter.synthetic import exact_full_length, meter


def run(**kwargs):
    body = meter(radius=50.0, liner_length=300.0, velocity={"type": "uniform", "mean": 1.0}, **kwargs)
    return solve(FlowmeterRequest.model_validate(body), no_progress).result


def test_the_bessel_ratio_recurrence_matches_scipy_where_scipy_is_finite():
    orders = np.arange(1, 40, 2).astype(float)
    k = np.array([0.0, 0.01, 0.5, 3.0, 20.0])
    table = bessel_ratio_table(orders, k)
    want = iv(orders[:, None] + 1, k[None]) / np.where(k[None] > 0, iv(orders[:, None], k[None]), 1.0)
    assert np.allclose(table, want, rtol=1e-12, atol=1e-300)
    huge = bessel_ratio_table(np.array([3001.0]), np.array([5.0]))  # I_3001(5) underflows; the ratio does not
    assert 0 < huge[0, 0] < 5.0 / 6002 + 1e-12


def test_the_seed_geometry_gives_S_0965():
    result = run(half_angle=22.5, half_length=50 * np.pi / 10, reynolds=[1000.0, 1e5], probes=[[0.0, 0.0]])
    assert result.method == "integral_equation"
    assert abs(result.sensitivity - 0.965) < 5e-4
    assert result.error_estimate < 1e-4
    assert result.probes[0] == pytest.approx(result.sensitivity, abs=1e-9)  # W is harmonic: S = W(0)
    assert all(abs(p.sensitivity - result.sensitivity) < 1e-8 for p in result.linearity)


@pytest.mark.parametrize("beta, a", [(22.5, 50 * np.pi / 10), (45.0, 50.0), (5.0, 5.0)])
def test_integral_equation_and_finite_elements_agree(beta, a):
    # W near the electrodes converges slowly with the FEM mesh; the probes there approach the
    # integral equation's as the mesh is refined
    probes = [[10.0, 5.0], [-20.0, 15.0], [35.0, -5.0]]
    ie = run(half_angle=beta, half_length=a, method="integral_equation", probes=probes)
    coarse = run(half_angle=beta, half_length=a, method="fem", tolerance=4e-3, probes=probes)
    fine = run(half_angle=beta, half_length=a, method="fem", tolerance=1e-3, probes=probes)
    assert abs(ie.sensitivity - coarse.sensitivity) < 1e-3
    assert abs(ie.sensitivity - fine.sensitivity) < 3e-4
    assert np.allclose(ie.probes[:2], fine.probes[:2], atol=2e-2)
    assert abs(ie.probes[2] - fine.probes[2]) < 0.05 * ie.probes[2]


def test_long_electrodes_tend_to_the_2d_value():
    beta = np.radians(30.0)
    exact = exact_full_length(30.0)
    gaps = [solve_patch(beta, a, 3.0).sensitivity - exact for a in (0.5, 1.5, 2.5, 2.9)]
    assert all(g > 0 for g in gaps)
    assert gaps[0] > gaps[1] > gaps[2] > gaps[3]
    assert gaps[3] < 5e-4


def test_scaling_R_1_and_R_500():
    small = solve(FlowmeterRequest.model_validate(meter(radius=1.0, units="m", half_angle=22.5, half_length=0.4,
                                                        liner_length=6.0)), no_progress).result
    large = solve(FlowmeterRequest.model_validate(meter(radius=500.0, units="mm", half_angle=22.5, half_length=200.0,
                                                        liner_length=3000.0)), no_progress).result
    assert small.method == large.method == "integral_equation"
    assert small.sensitivity == pytest.approx(large.sensitivity, abs=1e-12)


def test_the_electrode_current_peaks_at_the_edges_and_the_2d_one_integrates_to_one():
    from scipy.special import roots_chebyt

    patch = run(half_angle=30.0, half_length=20.0)
    full = run(half_angle=30.0, half_length=None)
    for result in (patch, full):
        theta, j = np.array(result.electrode_current).T
        assert np.all(j > 0)
        centre, edge = j[np.argmin(np.abs(theta))], j[np.argmax(np.abs(theta))]
        assert edge > 3 * centre
    # the 2-D density is given at Gauss-Chebyshev nodes, whose rule integrates it over the electrode
    beta = np.radians(30.0)
    theta, j = np.array(full.electrode_current).T
    t, w = roots_chebyt(len(theta))
    assert np.allclose(np.sort(np.radians(theta)), np.sort(beta * t))
    order = np.argsort(theta)
    assert np.sum(w * np.sqrt(1 - t * t) * j[order]) * beta == pytest.approx(1.0, abs=1e-6)


def test_long_liners_are_cut_where_the_current_has_decayed_and_huge_mode_counts_go_to_fem():
    short = run(half_angle=22.5, half_length=50 * np.pi / 10)
    body = meter(radius=50.0, liner_length=10_000.0, half_angle=22.5, half_length=50 * np.pi / 10,
                 velocity={"type": "uniform", "mean": 1.0})
    long = solve(FlowmeterRequest.model_validate(body), no_progress).result
    assert long.method == "integral_equation"
    assert long.sensitivity == pytest.approx(short.sensitivity, abs=1e-5)
    narrow = meter(radius=50.0, liner_length=300.0, half_angle=89.0, half_length=1.0,
                   velocity={"type": "uniform", "mean": 1.0}, tolerance=0.01)
    assert solve(FlowmeterRequest.model_validate(narrow), no_progress).result.method == "fem"


def test_the_electrode_current_map_carries_the_unit_current():
    # Gauss-Chebyshev in theta and z: the rule's weight is the basis's edge factor, so the product
    # rule integrates the density exactly
    result = run(half_angle=22.5, half_length=15.7)
    rows = np.array(result.electrode_current_map)
    assert len(rows) == 625
    beta, a = np.radians(22.5), 15.7 / 50.0
    t, s = np.radians(rows[:, 0]) / beta, rows[:, 1] / 15.7
    total = np.sum(rows[:, 2] * np.sqrt((1 - t * t) * (1 - s * s))) * (np.pi / 25) ** 2 * beta * a
    assert total == pytest.approx(1.0, abs=1e-10)


def test_the_density_of_long_electrodes_at_z_0_is_the_2d_equipotential_density():
    # the 2-D density j = 1 / (2 K(sin beta) sqrt(sin^2 beta - sin^2 theta)) per unit length (from
    # F' = C / sqrt(z^4 - 2 cos(2 beta) z^2 + 1): on the wall d(phi)/dr = C / (2 sqrt(sin^2 beta - sin^2 theta))),
    # compared in shape (normalised across) on the part without the edge factor
    from plantsolve.solvers.flowmeter.weight2d import electrode_current_integral

    beta = np.radians(30.0)
    result = run(half_angle=30.0, half_length=125.0)
    theta, j = np.array(result.electrode_current).T
    theta = np.radians(theta)
    exact = 1 / (2 * np.sqrt(np.sin(beta) ** 2 - np.sin(theta) ** 2)) / electrode_current_integral(beta)
    smooth = np.sqrt(1 - (theta / beta) ** 2)
    shape = j * smooth / np.sum(j * smooth)
    want = exact * smooth / np.sum(exact * smooth)
    deviation = np.abs(shape - want) / np.max(want)
    centre = np.abs(theta) < beta / 2
    assert np.max(deviation[centre]) < 5e-3
    assert np.max(deviation) < 2.5e-2  # the density converges like 1/M at the edges, slower than S
    # the reported change by the extrapolation bounds that error
    assert result.report.details["electrode_current_change"] > np.max(deviation)


def test_the_button_density_carries_the_unit_current():
    from scipy.special import roots_legendre

    from plantsolve.solvers.flowmeter.integral_equation_button import current_density, solve_button

    r = 0.2
    solution = solve_button(r, 3.0)
    u, wu = roots_legendre(40)
    u, wu = (u + 1) * np.pi / 4, wu * np.pi / 4  # rho = r sin(u) removes the rim's inverse square root
    psi = (np.arange(64) + 0.5) * 2 * np.pi / 64
    uu, pp = np.meshgrid(u, psi)
    rho = r * np.sin(uu)
    theta = np.arcsin(rho * np.cos(pp))
    per_projected_area = current_density(solution, r, theta, rho * np.sin(pp)) / np.cos(theta)
    total = np.sum(per_projected_area * rho * r * np.cos(uu) * wu[None, :]) * 2 * np.pi / 64
    assert total == pytest.approx(1.0, abs=1e-10)


@pytest.mark.parametrize("half_angle", [22.5, 45.0])
def test_long_electrodes_extrapolate_to_the_exact_2d_value_at_1e_4(half_angle):
    # an independent check of the integral equation at its own accuracy: S(a) = S_2D + c/a + d/a^2
    # for electrodes far from the liner ends (L/2 = a + 8R), fitted on a/R = 4, 8, 16
    beta = np.radians(half_angle)
    lengths = np.array([4.0, 8.0, 16.0])
    values = [solve_patch(beta, a, a + 8.0, 1e-5).sensitivity for a in lengths]
    fit = np.linalg.solve(np.column_stack([np.ones(3), 1 / lengths, 1 / lengths**2]), values)
    assert abs(fit[0] - exact_full_length(half_angle)) < 1e-4
    assert values[0] - exact_full_length(half_angle) > 1e-3 * np.sin(beta)  # the finite ends do matter
