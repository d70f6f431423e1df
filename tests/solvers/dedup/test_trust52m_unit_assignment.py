"""What a project's IfcUnitAssignment says against itself. IfcOpenShell's unit scale multiplies every length unit
listed: METRE and FOOT gave `length_unit: METRE`, `units: ft`, 0.3048 m per unit, two MILLI METREs a micrometre.
Two units of different sizes are refused naming both; one unit listed twice is that unit; a FOOT or INCH whose
conversion factor is another unit's is warned naming both."""

from __future__ import annotations

import ifcopenshell.api
import pytest

from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.dedup.synthetic import ModelSpec, Product, build_model
from tests.solvers.dedup.support import run


def _house(scale: float = 1.0):
    doors = [Product("Door", entity="IfcDoor", extrusion=(0.9 * scale, 0.05 * scale, 2.1 * scale), name=f"D{k}")
             for k in range(4)]
    walls = [Product("Wall", entity="IfcWall", extrusion=(5.0 * scale, 0.2 * scale, 3.0 * scale), name=f"W{k}")
             for k in range(3)]
    return build_model(ModelSpec(products=doors + walls))


def _length_unit(model):
    (unit,) = [u for u in model.by_type("IfcSIUnit") if u.UnitType == "LENGTHUNIT"]
    return unit, model.by_type("IfcUnitAssignment")[0]


def _named(model, name: str, metres: float | None = None):
    """The project's length unit replaced by a conversion-based one named ``name`` (its factor ``metres``)."""
    unit, assignment = _length_unit(model)
    new = ifcopenshell.api.run("unit.add_conversion_based_unit", model, name=name.lower())
    if metres is not None:
        new.ConversionFactor.ValueComponent = model.create_entity("IfcReal", metres)
    assignment.Units = [u for u in assignment.Units if u != unit] + [new]
    return model


def test_two_length_units_of_different_sizes_are_refused_naming_both():
    model = _house()
    _, assignment = _length_unit(model)
    foot = ifcopenshell.api.run("unit.add_conversion_based_unit", model, name="foot")
    assignment.Units = [*assignment.Units, foot]
    with pytest.raises(InputRejected) as refused:
        run(model)
    (error,) = refused.value.errors
    assert error.loc == ("file",) and "METRE" in error.msg and "foot" in error.msg and "2 length units" in error.msg


def test_one_length_unit_listed_twice_is_that_unit():
    model = _house(1000.0)
    unit, assignment = _length_unit(model)
    unit.Prefix = "MILLI"
    twin = model.createIfcSIUnit(None, "LENGTHUNIT", "MILLI", "METRE")
    assignment.Units = [*assignment.Units, twin]
    result = run(model).result
    assert result.metres_per_unit == pytest.approx(1e-3) and result.units == "mm"
    assert "implausible_product_size" not in {w.code for w in result.report.warnings}


def test_an_inch_whose_factor_is_a_foot_is_warned_naming_both():
    result = run(_named(_house(1 / 0.3048), "INCH", 0.3048)).result
    (warning,) = [w for w in result.report.warnings if w.code == "length_unit_factor_differs"]
    assert warning.details["named_metres"] == 0.0254 and warning.details["factor_metres"] == pytest.approx(0.3048)
    assert "'inch'" in warning.message and result.metres_per_unit == pytest.approx(0.3048)


def test_a_foot_of_its_own_size_says_nothing():
    result = run(_named(_house(1 / 0.3048), "FOOT")).result
    assert result.units == "ft" and not result.report.warnings
