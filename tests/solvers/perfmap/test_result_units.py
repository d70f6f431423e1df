"""Every number of a perfmap result states its unit in the schema (x-unit), and pint reads each."""

from plantsolve.schemas.perfmap import PerfmapQueryResult, PerfmapResult
from tests.support.units import numbers_without_unit, unreadable_units


def test_every_number_of_the_result_has_a_unit():
    assert numbers_without_unit(PerfmapResult) == []


def test_every_unit_of_the_result_reads():
    assert unreadable_units(PerfmapResult) == []


def test_every_number_of_a_query_answer_has_a_unit():
    assert numbers_without_unit(PerfmapQueryResult) == [] and unreadable_units(PerfmapQueryResult) == []
