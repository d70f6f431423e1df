"""A half-angle given with point or button electrodes changed nothing and was accepted without a word (a
patch's radius was refused): whoever wrote it may have meant patches, so it is refused naming the field."""

from __future__ import annotations

import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.flowmeter.validation import check_input


def request(electrodes: dict) -> FlowmeterRequest:
    return FlowmeterRequest.model_validate({"units": "mm", "pipe": {"radius": 50.0}, "electrodes": electrodes,
                                            "magnetic_field": {"type": "uniform", "magnitude": 0.01},
                                            "velocity": {"type": "uniform", "mean": 2.0}})


@pytest.mark.parametrize("electrodes", [{"shape": "point", "half_angle": 30.0},
                                        {"shape": "button", "radius": 5.0, "half_angle": 22.5}])
def test_a_half_angle_beside_points_or_buttons_is_refused_naming_it(electrodes):
    with pytest.raises(InputRejected) as refused:
        check_input(request(electrodes))
    (error,) = refused.value.errors
    assert error.loc == ("electrodes", "half_angle") and electrodes["shape"] in error.msg and "patch" in error.msg


@pytest.mark.parametrize("electrodes", [{"shape": "point"}, {"shape": "button", "radius": 5.0},
                                        {"shape": "patch", "half_angle": 30.0, "half_length": 20.0}])
def test_electrodes_without_an_unused_half_angle_pass(electrodes):
    check_input(request(electrodes))


def test_a_button_without_its_radius_is_named_beside_the_unused_half_angle():
    with pytest.raises(InputRejected) as refused:
        check_input(request({"shape": "button", "half_angle": 22.5}))
    assert {e.loc for e in refused.value.errors} == {("electrodes", "half_angle"), ("electrodes", "radius")}
