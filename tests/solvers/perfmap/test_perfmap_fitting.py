"""Characteristics: recovery to round-off, exact side conditions, floor, LOO, minimax."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from plantsolve.solvers.perfmap.families import (
    N_COEFFICIENTS,
    basis,
    bernstein,
    difference_transform,
    log_eval,
    log_params_from_public,
    log_params_to_public,
    uniform_quadratic_bspline,
)
from plantsolve.solvers.perfmap.fitting import (
    concave_floor,
    fit_efficiency,
    fit_log,
    fit_pressure,
    leave_one_out,
    max_rel_error,
)

LINEAR = ["parabola", "cubic", "spline2", "spline3"]
T = np.array([0.0, 0.13, 0.31, 0.5, 0.64, 0.82, 1.0])


def _admissible(family: str, rng) -> np.ndarray:
    n = N_COEFFICIENTS[family]
    z = np.concatenate([[1.2], -rng.uniform(0.01, 0.1, 1), -rng.uniform(0.01, 0.3, n - 2)])
    return difference_transform(n) @ z


def _derivatives_nonpositive(family, params, tol=1e-12):
    t = np.linspace(0, 1, 4001)
    y = log_eval(params, t) if family == "log" else basis(family, t) @ params
    d1 = np.diff(y)
    d2 = np.diff(y, 2)
    return d1.max() <= tol, d2.max() <= tol


def test_uniform_quadratic_bspline_matches_scipy():
    t = np.linspace(0, 1, 97)
    for K in (2, 3):
        ref = BSpline.design_matrix(t * K, np.arange(-2.0, K + 3.0), 2).toarray()
        assert np.allclose(uniform_quadratic_bspline(K, t), ref, atol=1e-15)


def test_bernstein_partition_of_unity_and_values():
    t = np.linspace(0, 1, 11)
    B = bernstein(3, t)
    assert np.allclose(B.sum(axis=1), 1.0)
    assert np.allclose(B[:, 1], 3 * t * (1 - t) ** 2)


@pytest.mark.parametrize("family", LINEAR)
@pytest.mark.parametrize("minimax", [False, True])
def test_linear_family_recovered_to_round_off(family, minimax):
    c = _admissible(family, np.random.default_rng(3))
    y = basis(family, T) @ c
    fit = fit_pressure(family, T, y, minimax)
    assert np.max(np.abs(fit.params - c)) < 1e-12
    assert max_rel_error(fit(T), y) < 1e-13


def test_log_family_recovered_to_round_off():
    params = np.array([0.25, 1.3, 0.9])
    y = log_eval(params, T)
    fit = fit_log(T, y, minimax=False)
    assert np.allclose(fit.params, params, rtol=1e-10, atol=1e-12)
    assert max_rel_error(fit(T), y) < 1e-13
    mm = fit_log(T, y, minimax=True)
    assert max_rel_error(mm(T), y) < 1e-7  # bounded 1-D search on b: not round-off


def test_log_public_coefficients_round_trip():
    p = np.array([0.25, 1.3, 0.9])
    pub = log_params_to_public(p, 2.0, 5.0)
    x = 2.0 + 3.0 * T
    assert np.allclose(pub[0] * np.log(pub[1] - x) + pub[2], log_eval(p, T))
    assert pub[1] > 5.0
    assert np.allclose(log_params_from_public(pub, 2.0, 5.0), p)


@pytest.mark.parametrize("family", LINEAR + ["log"])
@pytest.mark.parametrize("minimax", [False, True])
def test_side_conditions_hold_exactly_on_bad_data(family, minimax):
    rng = np.random.default_rng(11)
    for trial in range(6):
        # increasing, convex, noisy: everything the side conditions forbid
        y = 1.0 + 0.3 * T**2 + 0.1 * T + 0.05 * rng.standard_normal(len(T))
        fit = fit_pressure(family, T, y, minimax)
        dec, conc = _derivatives_nonpositive(family, fit.params)
        assert dec and conc, (family, trial)
        assert fit.active >= 1


def test_concave_efficiency_option():
    eta = np.array([0.6, 0.7, 0.72, 0.8, 0.85, 0.83, 0.7])  # bump at 0.31..0.5 not concave
    free = fit_efficiency("spline3", T, eta, False, False)
    conc = fit_efficiency("spline3", T, eta, False, True)
    y = basis("spline3", np.linspace(0, 1, 2001))
    assert np.diff(y @ conc.params, 2).max() <= 1e-12
    assert np.diff(y @ free.params, 2).max() > 0  # the option changes something


def test_floor_zero_for_concave_and_closed_form_otherwise():
    x = np.array([0.0, 1.0, 2.0, 3.0])
    assert concave_floor(x, np.array([2.0, 1.9, 1.6, 1.0])) == 0.0
    # y rises 1 -> 1.1: the best decreasing fit puts both at c with
    # (c - 1)/1 = (1.1 - c)/1.1  ->  c = 2.2/2.1, error 1/21
    f = concave_floor(np.array([0.0, 1.0, 2.0]), np.array([1.0, 1.1, 1.0]))
    assert abs(f - 1 / 21) < 1e-9


@pytest.mark.parametrize("family", LINEAR)
def test_floor_bounds_every_admissible_fit(family):
    rng = np.random.default_rng(5)
    x = np.sort(rng.uniform(0, 1, 8))
    x[0], x[-1] = 0.0, 1.0
    y = 1.5 - 0.2 * x + 0.04 * np.sin(9 * x)
    floor = concave_floor(x, y)
    mm = fit_pressure(family, x, y, minimax=True)
    assert floor > 0
    assert max_rel_error(mm(x), y) >= floor - 1e-9


def test_loo_zero_on_family_data_and_known_value():
    c = _admissible("cubic", np.random.default_rng(1))
    y = basis("cubic", T) @ c
    eta = basis("cubic", T) @ np.array([0.6, 0.95, 0.9, 0.5])
    ey, ee = leave_one_out("cubic", T, y, eta, False)
    assert ey < 1e-12 and ee < 1e-12
    # hat-matrix LOO equals explicit refits
    eta2 = eta + 0.01 * np.sin(20 * T)
    _, ee_hat = leave_one_out("cubic", T, y, eta2, False)
    B = basis("cubic", T)
    explicit = max(abs(B[i] @ np.linalg.lstsq(np.delete(B, i, 0), np.delete(eta2, i), rcond=None)[0]
                       - eta2[i]) / eta2[i] for i in range(len(T)))
    assert abs(ee_hat - explicit) < 1e-12


def test_loo_none_when_too_few_points():
    t = np.array([0.0, 0.5, 1.0])
    assert leave_one_out("cubic", t, np.array([3.0, 2.5, 1.0]), np.array([0.5, 0.8, 0.6]),
                         False) == (None, None)
