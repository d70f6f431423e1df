"""Every number of a flowmeter result states its unit in the schema (x-unit), and pint reads each."""

from plantsolve.schemas.flowmeter import FlowmeterResult
from tests.support.units import numbers_without_unit, unreadable_units


def test_every_number_of_the_result_has_a_unit():
    assert numbers_without_unit(FlowmeterResult) == []


def test_every_unit_of_the_result_reads():
    assert unreadable_units(FlowmeterResult) == []
