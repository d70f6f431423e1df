"""Every number of the alignment result states its unit in the schema (and so in the OpenAPI document)."""

from plantsolve.schemas.alignment import AlignmentResult
from tests.support.units import numbers_without_unit, units_of, unreadable_units


def test_every_number_of_the_result_has_a_unit():
    assert numbers_without_unit(AlignmentResult) == []


def test_every_unit_of_the_result_is_readable():
    assert unreadable_units(AlignmentResult) == []


def test_lengths_are_in_the_results_units_and_angles_in_degrees():
    units = units_of(AlignmentResult)
    by_field = {path.rsplit("/", 1)[-1]: u for path, u in units.items()}
    assert by_field["max_position_error"] == "{units}" and by_field["max_angle_error"] == "deg"
    assert by_field["displacement"] == "{units}" and by_field["rotation_angle"] == "deg"
    assert by_field["position_error"] == "{units}" and by_field["angle_error"] == "deg"
    assert by_field["translation"] == "{units}" and by_field["rotation"] == "1"
