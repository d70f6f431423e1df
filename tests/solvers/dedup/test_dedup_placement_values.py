"""``sharing.Placements`` reads an IfcAxis2Placement3D's values by attribute position: placements without an axis or
a reference direction, or whose values differ only there (one location for all), still get the library's matrices,
bit for bit: none is taken for another."""

import ifcopenshell.util.placement
import numpy as np

from plantsolve.solvers.dedup.sharing import Placements
from plantsolve.solvers.dedup.synthetic import tunnel_file


def test_placements_without_axis_or_reference_direction_are_the_librarys():
    model = tunnel_file(2, "IFC4")
    products = [p for p in model.by_type("IfcProduct") if p.ObjectPlacement is not None]
    first = products[0].ObjectPlacement.RelativePlacement
    shapes = [(None, None), ((0.0, 0.0, 1.0), None), (None, (0.0, 1.0, 0.0)), ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
              ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0))]
    for product, (axis, ref) in zip(products[1:], shapes, strict=False):
        axes = product.ObjectPlacement.RelativePlacement
        axes.Location = model.create_entity("IfcCartesianPoint", first.Location.Coordinates)
        axes.Axis = model.create_entity("IfcDirection", axis) if axis else None
        axes.RefDirection = model.create_entity("IfcDirection", ref) if ref else None
    placements = Placements()
    for product in products:
        ours = placements.of(product)
        library = np.asarray(ifcopenshell.util.placement.get_local_placement(product.ObjectPlacement), dtype=float)
        assert ours.tobytes() == library.tobytes(), product
