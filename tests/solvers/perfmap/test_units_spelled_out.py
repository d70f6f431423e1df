"""Units spelled out as data sheets write them, and words pint would split into a prefix and an angle."""

import pytest

from plantsolve.solvers.perfmap.units import UnitError, check_quantity, registry


@pytest.mark.parametrize("quantity,text,expected", [
    ("flow", "pounds mass per second", "lbm/s"),
    ("flow", "pound-mass/s", "lbm/s"),
    ("flow", "Pound Mass / min", "lbm/min"),
    ("pressure", "pounds force per square inch", "lbf/in**2"),
])
def test_pound_mass_and_pound_force_spelled_out_are_read_as_such(quantity, text, expected):
    unit = check_quantity(quantity, text).unit
    assert registry().Quantity(1, unit).to(expected).magnitude == pytest.approx(1.0)


@pytest.mark.parametrize("quantity,text,reason", [
    ("flow", "kg mass/s", "angle"),  # kilogram·milli-arcsecond per second: a mass flow off by 5e-9
    ("pressure", "Pa*rad", "angle"),
    ("flow", "rad/s", "not a unit of flow"),
    ("efficiency", "mas", "no unit of a ratio"),
])
def test_a_unit_with_an_angle_among_its_factors_is_refused(quantity, text, reason):
    with pytest.raises(UnitError, match=reason):
        check_quantity(quantity, text)
