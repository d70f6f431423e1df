"""Every number of the polyhedra result states its unit in the schema (the OpenAPI document)."""

from plantsolve.schemas.polyhedra import PolyhedraResult
from tests.support.units import numbers_without_unit, unreadable_units


def test_every_number_of_the_result_has_a_unit():
    assert numbers_without_unit(PolyhedraResult) == []
    assert unreadable_units(PolyhedraResult) == []
