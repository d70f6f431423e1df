"""A model whose IfcUnitAssignment says CENTI over numbers written in metres: its 2.1 m doors read as 2.1 cm, which
the median product's size (5 mm - 200 m) lets through. Doors, walls and storeys, which every building has at known
sizes, name it with the unit the numbers are likely in."""

from __future__ import annotations

import ifcopenshell.api
import pytest

from plantsolve.solvers.dedup.synthetic import ModelSpec, Product, build_model
from tests.solvers.dedup.support import run

METRE = "IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.)"


def _house():
    """Four 0.9 × 2.1 m doors and three 5 × 3 m walls, in metres, in a building of storeys at 0, 3 and 6 m."""
    doors = [Product("Door", entity="IfcDoor", extrusion=(0.9, 0.05, 2.1), name=f"Door {k}") for k in range(4)]
    walls = [Product("Wall", entity="IfcWall", extrusion=(5.0, 0.2, 3.0), name=f"Wall {k}") for k in range(3)]
    model = build_model(ModelSpec(products=doors + walls))
    building = model.by_type("IfcBuilding")[0]
    for k, elevation in enumerate((0.0, 3.0, 6.0)):
        storey = ifcopenshell.api.run("root.create_entity", model, ifc_class="IfcBuildingStorey", name=f"L{k}")
        storey.Elevation = elevation
        ifcopenshell.api.run("aggregate.assign_object", model, products=[storey], relating_object=building)
    return model


def _warnings(model):
    return [w for w in run(model).result.report.warnings if w.code == "implausible_product_size"]


def test_centimetres_stated_over_numbers_in_metres_are_named_by_door_wall_and_storey_heights():
    model = _house()
    assert not _warnings(model)  # in metres, as stated: nothing to say
    (unit,) = [u for u in model.by_type("IfcSIUnit") if u.UnitType == "LENGTHUNIT"]
    unit.Prefix = "CENTI"
    (warning,) = _warnings(model)
    assert warning.details["values"] == pytest.approx({"door height": 2.1, "wall height": 3.0, "storey height": 3.0})
    assert warning.details["likely_units"][0] == "m" and "written in m?" in warning.message


def test_odd_storey_levels_under_walls_of_the_right_height_are_no_unit_mistake():
    """Revit writes a slab level 300 mm above its floor level: storeys 0.3 m apart in a millimetre model whose walls
    are 3 m high; read in cm they would all be plausible, but the walls say the unit is right (a false alarm before)."""
    walls = [Product("Wall", entity="IfcWall", extrusion=(5000.0, 200.0, 3000.0), name=f"Wall {k}") for k in range(3)]
    model = build_model(ModelSpec(products=walls))
    (unit,) = [u for u in model.by_type("IfcSIUnit") if u.UnitType == "LENGTHUNIT"]
    unit.Prefix = "MILLI"
    building = model.by_type("IfcBuilding")[0]
    for k, elevation in enumerate((0.0, 300.0, 3000.0, 3300.0)):
        storey = ifcopenshell.api.run("root.create_entity", model, ifc_class="IfcBuildingStorey", name=f"L{k}")
        storey.Elevation = elevation
        ifcopenshell.api.run("aggregate.assign_object", model, products=[storey], relating_object=building)
    assert not _warnings(model)
