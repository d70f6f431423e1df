"""Every number of the rigidity result states its unit in the schema (the OpenAPI document's ``x-unit``)."""

from __future__ import annotations

from plantsolve.schemas.rigidity import RigidityResult
from tests.support.units import numbers_without_unit, units_of, unreadable_units


def test_every_number_of_the_result_has_a_readable_unit():
    assert numbers_without_unit(RigidityResult) == []
    assert unreadable_units(RigidityResult) == []


def test_lengths_are_in_the_results_own_length_unit_and_directions_are_pure_numbers():
    units = units_of(RigidityResult)
    assert {u for path, u in units.items() if "point" in path or "depth" in path or "position" in path} == \
        {"{length_unit}"}
    assert {u for path, u in units.items() if "axis" in path or "rotation" in path} == {"1"}
    assert "length_unit" in RigidityResult.model_fields
