"""A plant model (pipes and valves, no doors, walls or storeys) written in metres under a FOOT assignment: every
product's size is plausible either way, so the median product and the building heights said nothing. The pipes'
outside diameters, catalogue numbers, name the unit; a model whose pipes are no catalogue size in any unit is left
alone (no evidence, no guess)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import ifcopenshell.api

from plantsolve.solvers.dedup.pipe_sizes import outside_diameter, standard_share
from plantsolve.solvers.dedup.synthetic import ModelSpec, Product, build_model, pose
from tests.solvers.dedup.support import run

# NPS 2, 3, 4, 6 and 8 (ASME B36.10M), in metres
OUTSIDE_M = (0.0603, 0.0889, 0.1143, 0.1683, 0.2191)


def _pipe(outside: float, length: float, matrix: np.ndarray, name: str) -> Product:
    tube = trimesh.creation.annulus(r_min=0.4 * outside, r_max=outside / 2, height=length, sections=24)
    verts = np.asarray(tube.vertices) @ matrix[:3, :3].T + matrix[:3, 3]
    return Product("Pipe", entity="IfcPipeSegment", verts=verts, faces=np.asarray(tube.faces).tolist(), name=name)


def _plant(scale: float = 1.0, outside=OUTSIDE_M):
    """Two runs of each pipe size (lengths 2 and 3) in several directions, and four valves, all lengths × scale."""
    products = []
    for k, d in enumerate(outside):
        for j, length in enumerate((2.0, 3.0)):
            matrix = pose(30.0 * k, 70.0 * j, 40.0 * k + 25.0 * j, [5.0 * k, 4.0 * j, 1.5])
            matrix[:3, 3] *= scale
            products.append(_pipe(d * scale, length * scale, matrix, f"Pipe {k}.{j}"))
    products += [Product("Valve", entity="IfcValve", extrusion=(0.3 * scale, 0.2 * scale, 0.4 * scale),
                         name=f"Valve {k}") for k in range(4)]
    return build_model(ModelSpec(products=products))


def _foot(model):
    (unit,) = [u for u in model.by_type("IfcSIUnit") if u.UnitType == "LENGTHUNIT"]
    assignment = model.by_type("IfcUnitAssignment")[0]
    foot = ifcopenshell.api.run("unit.add_conversion_based_unit", model, name="foot")
    assignment.Units = [u for u in assignment.Units if u != unit] + [foot]
    return model


def _warnings(model):
    return {w.code: w for w in run(model).result.report.warnings}


def test_the_outside_diameter_of_a_tessellated_pipe_in_any_direction():
    for d, length in ((0.1143, 2.0), (0.2191, 0.1)):  # a long pipe and a short one (its axis the smallest spread)
        tube = trimesh.creation.annulus(r_min=0.4 * d, r_max=d / 2, height=length, sections=24)
        moved = np.asarray(tube.vertices) @ pose(25.0, 70.0, -30.0, [0, 0, 0])[:3, :3].T + 1e5
        assert outside_diameter(moved) == pytest.approx(d, rel=1e-8)
    assert outside_diameter(trimesh.creation.box((1.0, 0.3, 0.2)).vertices) is None  # no round section
    assert standard_share(np.array(OUTSIDE_M), 1.0) == 1.0 and standard_share(np.array(OUTSIDE_M), 0.3048) == 0.0


def test_metres_under_a_foot_assignment_are_named_by_the_pipe_diameters():
    model = _plant()
    assert "implausible_product_size" not in _warnings(model)  # in metres, as stated: nothing to say
    # before: nothing said (the median product, 0.6 ft across, is no odd product)
    warning = _warnings(_foot(_plant()))["implausible_product_size"]
    assert warning.details["quantity"] == "pipe outside diameter" and warning.details["likely_units"][0] == "m"
    # 4.5 and 8.625 in read as feet are 34.8 and 66.8 mm, a copper tube's 35 and 66.7: 4 of 10 plausible, no majority
    assert warning.details["pipes_measured"] == 10 and warning.details["standard_share"] == 0.4
    assert "written in m?" in warning.message and "114.3 mm" in warning.message


def test_a_plant_in_feet_under_a_foot_assignment_and_pipes_drawn_at_nominal_size_say_nothing():
    assert "implausible_product_size" not in _warnings(_foot(_plant(scale=1 / 0.3048)))
    # DN 50 … 200 drawn as 50 … 200 mm: a standard size in no unit, so no evidence of one
    nominal = _foot(_plant(outside=(0.05, 0.08, 0.1, 0.15, 0.2)))
    assert "implausible_product_size" not in _warnings(nominal)


def test_ifc2x3_flow_segments_typed_as_pipe_segments_are_measured_too():
    """IFC2X3 has no IfcPipeSegment: its pipes are IfcFlowSegments typed by an IfcPipeSegmentType (an untyped flow
    segment may be a duct or a cable carrier, and is not measured)."""
    def plant(typed: bool):
        products = []
        for k, d in enumerate(OUTSIDE_M):
            pipe = _pipe(d, 2.0 + k, pose(30.0 * k, 70.0, 40.0 * k, [5.0 * k, 0.0, 1.5]), f"Pipe {k}")
            pipe.entity = "IfcFlowSegment"
            products.append(pipe)
        model = build_model(ModelSpec(schema="IFC2X3", products=products))
        if typed:
            pipe_type = ifcopenshell.api.run("root.create_entity", model, ifc_class="IfcPipeSegmentType", name="Pipe")
            ifcopenshell.api.run("type.assign_type", model, related_objects=model.by_type("IfcFlowSegment"),
                                 relating_type=pipe_type)
        return _foot(model)

    warning = _warnings(plant(typed=True))["implausible_product_size"]
    assert warning.details["quantity"] == "pipe outside diameter" and warning.details["pipes_measured"] == 5
    assert "implausible_product_size" not in _warnings(plant(typed=False))


def _millimetre(model):
    (unit,) = [u for u in model.by_type("IfcSIUnit") if u.UnitType == "LENGTHUNIT"]
    unit.Prefix = "MILLI"
    return model


@pytest.mark.parametrize("outside_mm", [
    (18.0, 22.0, 28.0, 42.0),  # copper EN 1057: as inches, 18, 22 and 28 in are steel pipes of NPS 18 to 28
    (20.0, 32.0, 40.0),  # PE ISO 4065 (20 and 40 in are NPS 20 and 40)
    (16.0, 20.0, 26.0, 32.0, 40.0),  # multilayer
])
def test_an_honest_millimetre_plant_in_copper_or_plastic_tube_is_not_called_inches(outside_mm):
    model = _millimetre(_plant(scale=1000.0, outside=tuple(d / 1000.0 for d in outside_mm)))
    assert "implausible_product_size" not in _warnings(model)


def test_an_honest_foot_plant_in_astm_b88_copper_is_not_called_metres():
    # 3/4, 1-1/4 and 2-1/2 copper: 7/8, 1-3/8 and 2-5/8 in outside; 2-5/8 in is 0.0729 ft, as metres NPS 2-1/2's 73.0 mm
    model = _foot(_plant(scale=1 / 0.3048, outside=tuple(d * 0.0254 for d in (0.875, 1.375, 2.625))))
    assert "implausible_product_size" not in _warnings(model)
