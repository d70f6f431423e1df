"""Every number of the dedup result states its unit in the schema (the OpenAPI document)."""

from plantsolve.schemas.dedup import DedupResult
from tests.support.units import numbers_without_unit, unreadable_units


def test_every_number_of_the_result_has_a_unit():
    assert numbers_without_unit(DedupResult) == []
    assert unreadable_units(DedupResult) == []
