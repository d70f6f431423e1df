"""Mistakes of the fourth probe: a velocity option that the profile does not use went unused without a word — a mean
stated beside samples of another mean (the signal is the samples', 1.77 m/s where 2 m/s was written), and a power-law
exponent without its type (``{"mean": 2, "n": 7}`` is the uniform profile)."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.validation import check_input

RINGS = [[0.0, 0.0]] + [[r * np.cos(a), r * np.sin(a)] for r in (20.0, 40.0, 50.0)
                        for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)]
LAMINAR = [2 * 1.5 * (1 - (x * x + y * y) / 2500.0) for x, y in RINGS]  # 1.5 m/s mean, sampled


def _meter(velocity: dict) -> FlowmeterRequest:
    # full-length electrodes: the closed form, so a solve takes milliseconds
    return FlowmeterRequest.model_validate({
        "units": "mm", "pipe": {"radius": 50.0}, "electrodes": {"shape": "patch", "half_angle": 22.5},
        "magnetic_field": {"type": "uniform", "magnitude": 0.01}, "velocity": velocity})


def _refusal(velocity: dict):
    with pytest.raises(InputRejected) as refused:
        check_input(_meter(velocity))
    (error,) = refused.value.errors
    return error


@pytest.fixture(scope="module")
def sampled():
    return solve(_meter({"type": "samples", "points": RINGS, "values": LAMINAR})).result


def test_a_mean_beside_samples_of_another_mean_is_refused_naming_both(sampled):
    error = _refusal({"type": "samples", "mean": 2.0, "points": RINGS, "values": LAMINAR})
    samples_mean = sampled.report.details["mean_velocity"]
    assert error.loc == ("velocity", "mean") and "mean 2 m/s" in error.msg and f"{samples_mean:.4g} m/s" in error.msg
    # the signal is the samples': U = 2 R B v_mean S
    assert sampled.signal == pytest.approx(2 * 0.05 * 0.01 * samples_mean * sampled.sensitivity, rel=1e-12)


def test_a_mean_agreeing_with_the_samples_is_read(sampled):
    check_input(_meter({"type": "samples", "mean": round(sampled.report.details["mean_velocity"], 3), "points": RINGS,
                        "values": LAMINAR}))


@pytest.mark.parametrize("kind", [None, "uniform", "laminar"])
def test_a_power_law_exponent_without_its_type_is_refused_naming_n(kind):
    velocity = {"mean": 2.0, "n": 7.0} | ({"type": kind} if kind else {})
    error = _refusal(velocity)
    assert error.loc == ("velocity", "n") and "'power_law'" in error.msg
    check_input(_meter({"type": "power_law", "mean": 2.0, "n": 7.0}))
