"""2-D known answers: full-length electrodes (elliptic integral), Shercliff's point electrodes, the
mean-value property, the first-order iterate and the scaling rule, through the whole solver."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import no_progress
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.synthetic import exact_full_length, meter, shercliff
from plantsolve.solvers.flowmeter.weight2d import electrode_current_integral, weight_first_order, weight_full_length


def run(**kwargs):
    return solve(FlowmeterRequest.model_validate(meter(**kwargs)), no_progress).result


@pytest.mark.parametrize("beta, known", [(5, 0.9981), (18, 0.9754), (30, 0.9318), (45, None), (60, 0.7284)])
def test_full_length_electrodes_give_pi_over_2K(beta, known):
    exact = exact_full_length(beta)
    if known is not None:
        assert exact == pytest.approx(known, abs=6e-5)  # the values quoted for the method
    result = run(half_angle=beta, half_length=None, velocity={"type": "uniform", "mean": 1.0})
    assert result.method == "closed_form_2d"
    assert abs(result.sensitivity - exact) < 2e-4
    assert result.error_estimate < 2e-4
    assert result.sensitivity_first_order == pytest.approx(np.sin(np.radians(beta)) / np.radians(beta), rel=1e-12)


def test_the_electrode_current_quadrature_is_the_elliptic_integral():
    from scipy.special import ellipk

    for beta in np.radians([1, 10, 45, 80, 89, 89.99]):
        assert electrode_current_integral(beta) == pytest.approx(ellipk(np.sin(beta) ** 2), rel=1e-8)


def test_point_electrodes_follow_shercliff_and_give_S_1():
    radius = 50.0
    probes = [[0.0, 0.0], [10.0, 20.0], [-30.0, 5.0], [40.0, -25.0], [0.0, 49.99], [45.0, 1.0]]
    result = run(shape="point", radius=radius, probes=probes, velocity={"type": "uniform", "mean": 1.0})
    assert result.method == "closed_form_point"
    want = shercliff(*np.array(probes).T, radius=radius)
    assert np.max(np.abs(np.array(result.probes) - want)) < 1e-3
    assert result.probes[0] == pytest.approx(1.0, abs=1e-12)
    assert result.probes[4] == pytest.approx(0.5, abs=1e-3)  # on the wall W = 1/2
    assert abs(result.sensitivity - 1.0) < 2e-4


def test_a_vanishing_half_angle_tends_to_shercliff():
    x, y = np.array([0.2, -0.5, 0.7, 0.0]), np.array([0.3, 0.1, -0.6, 0.9])
    assert np.allclose(weight_full_length(x, y, 1e-6), shercliff(x, y), atol=1e-9)


@pytest.mark.parametrize("shape, beta", [("patch", 30.0), ("point", None)])
def test_every_axisymmetric_profile_gives_the_same_S(shape, beta):
    reynolds = [500.0, 2000.0, 3000.0, 1e4, 1e5, 1e6]
    base = run(shape=shape, half_angle=beta or 22.5, velocity={"type": "uniform", "mean": 1.0}, reynolds=reynolds)
    laminar = run(shape=shape, half_angle=beta or 22.5, velocity={"type": "laminar", "mean": 3.0})
    power = run(shape=shape, half_angle=beta or 22.5, velocity={"type": "power_law", "mean": 3.0, "n": 9})
    exact = 1.0 if shape == "point" else exact_full_length(beta)
    for s in (base.sensitivity, laminar.sensitivity, power.sensitivity, *(p.sensitivity for p in base.linearity)):
        assert abs(s - exact) < 2e-4
    assert [p.profile for p in base.linearity] == ["laminar", "laminar", "power_law", "power_law", "power_law", "power_law"]
    assert base.linearity[4].n == pytest.approx(7.3)


def test_a_non_axisymmetric_profile_changes_S_as_the_weight_function_says():
    # v = 1 + x/R on the upper and lower parts only: samples of v = 1 + 0.5 (y/R)^2 - an even,
    # non-axisymmetric profile; S = integral W v / integral v by the closed form W on a fine polar rule
    radius = 50.0
    r, t = np.meshgrid(np.linspace(0, 1, 40), np.linspace(0, 2 * np.pi, 120, endpoint=False))
    pts = np.column_stack([(r * np.cos(t)).ravel(), (r * np.sin(t)).ravel()])
    pts = np.unique(np.round(pts, 12), axis=0)
    values = 1 + 0.5 * pts[:, 1] ** 2
    result = run(half_angle=30.0, radius=radius,
                 velocity={"type": "samples", "points": (pts * radius).tolist(), "values": values.tolist()})
    n = 2000
    rr, tt = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(2 * n) + 0.5) * np.pi / n)
    x, y = rr * np.cos(tt), rr * np.sin(tt)
    w = weight_full_length(x, y, np.radians(30.0))
    v = 1 + 0.5 * y**2
    want = np.sum(w * v * rr) / np.sum(v * rr)
    assert result.sensitivity == pytest.approx(want, abs=2e-3)
    assert abs(result.sensitivity - exact_full_length(30.0)) > 5e-3  # the profile matters here


def test_first_order_is_sin_beta_over_beta_and_W_is_harmonic():
    beta = np.radians(22.5)
    result = run(half_angle=22.5, method="first_order", velocity={"type": "laminar", "mean": 1.0})
    assert result.method == "first_order"
    assert result.sensitivity == pytest.approx(np.sin(beta) / beta, abs=2e-4)
    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    for r in (0.3, 0.8):
        assert np.mean(weight_first_order(r * np.cos(t), r * np.sin(t), beta)) == pytest.approx(np.sin(beta) / beta, abs=1e-10)
    # uniform current density on the electrodes is not equipotential: its S is above the exact one
    assert result.sensitivity > exact_full_length(22.5) + 0.01


def test_scaling_R_1_and_R_500_give_the_same_S_and_W():
    small = run(radius=1.0, half_angle=40.0, units="m", probes=[[0.3, 0.4]], velocity={"type": "laminar", "mean": 2.0})
    large = run(radius=500.0, half_angle=40.0, units="mm", probes=[[150.0, 200.0]], velocity={"type": "laminar", "mean": 2.0})
    assert small.sensitivity == pytest.approx(large.sensitivity, abs=1e-12)
    assert small.probes == pytest.approx(large.probes, abs=1e-12)
    # U = 2 R B v S: 2 m diameter versus 1 m
    assert small.signal == pytest.approx(2 * large.signal, rel=1e-12)
    assert small.signal == pytest.approx(2 * 1.0 * 0.01 * 2.0 * small.sensitivity, rel=1e-12)


def test_the_ideal_meter_residual_is_the_mean_deviation_of_W():
    n = 1500
    r, t = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(2 * n) + 0.5) * np.pi / n)
    w = weight_full_length(r * np.cos(t), r * np.sin(t), np.radians(30.0))
    s = exact_full_length(30.0)
    want = np.sum(np.abs(w - s) * r) / np.sum(r) / s
    result = run(half_angle=30.0, half_length=None)
    assert result.ideal_meter_residual == pytest.approx(want, abs=2e-3)
    # point electrodes weigh the flow near them far more than wide electrodes do
    assert run(shape="point").ideal_meter_residual > result.ideal_meter_residual + 0.05
