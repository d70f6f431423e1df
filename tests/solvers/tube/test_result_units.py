"""Every number of the tube result states its unit in the schema (OpenAPI ``x-unit``), and pint reads each."""

from __future__ import annotations

from plantsolve.schemas.tube import TubeResult
from tests.support.units import numbers_without_unit, units_of, unreadable_units


def test_every_number_of_the_result_has_a_unit():
    assert numbers_without_unit(TubeResult) == []


def test_every_unit_is_readable():
    assert unreadable_units(TubeResult) == []


def test_lengths_follow_the_result_units_and_angles_are_degrees():
    found = units_of(TubeResult)  # by schema path: /properties/<field> or /$defs/<Model>/properties/<field>
    assert found["/properties/pipe_radius"] == "{units}"
    assert found["/$defs/Inspection/properties/sheath_deviation"] == "{units}"
    assert found["/$defs/LraRow/properties/sigma_angle"] == "deg" and found["/$defs/SpringbackFit/properties/b"] == "deg"
    assert found["/$defs/LengthCheck/properties/deviation"] == "{units}"
    assert found["/$defs/AngleCheck/properties/deviation"] == "deg"
    assert found["/$defs/BendRadiusModel/properties/rss"] == "{units}^2"
    # the placeholder names a field the result has
    assert "units" in TubeResult.model_fields
