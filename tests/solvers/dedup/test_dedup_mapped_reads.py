"""The proof reads a written ``mapped_item`` file's transformation operators once each: the post-pass merges
those of equal values, and a ring's operator is named by its members of every class. Each product's points
are still the ones the library's own mapped-item maths gives for its item, bit for bit."""

from __future__ import annotations

import ifcopenshell.util.placement
import numpy as np

from plantsolve.solvers.dedup.explicit import ExplicitReader, unique_rows
from plantsolve.solvers.dedup.synthetic import tunnel_file
from plantsolve.solvers.dedup.worldgeom import world_points
from tests.solvers.dedup.support import reopen, run


def _library_points(out, product) -> np.ndarray:
    """The product's unique world points, each of its mapped items evaluated on its own by the library."""
    reader = ExplicitReader(out)
    parts = []
    for item in product.Representation.Representations[0].Items:
        m = np.asarray(ifcopenshell.util.placement.get_mappeditem_transformation(item), dtype=float)
        pts, _ = reader.items_points(item.MappingSource.MappedRepresentation.Items, 1)
        parts.append(pts @ m[:3, :3].T + m[:3, 3])
    p = np.asarray(ifcopenshell.util.placement.get_local_placement(product.ObjectPlacement), dtype=float)
    return unique_rows(np.concatenate(parts) @ p[:3, :3].T + p[:3, 3])


def test_each_operator_is_evaluated_once_and_each_product_gets_the_librarys_points(monkeypatch):
    out = reopen(run(tunnel_file(6, "IFC4"), sharing="mapped_item"))
    items = out.by_type("IfcMappedItem")
    operators = {i.MappingTarget.id() for i in items}
    assert len(items) == 48 and len(operators) < len(items) / 4  # merged by the post-pass, shared across classes
    evaluate = ifcopenshell.util.placement.get_cartesiantransformationoperator3d
    calls = []

    def counted(operator):
        calls.append(operator.id())
        return evaluate(operator)

    monkeypatch.setattr(ifcopenshell.util.placement, "get_cartesiantransformationoperator3d", counted)
    products = [p for p in out.by_type("IfcProduct") if p.Representation is not None]
    points, _ = world_points(out, products)
    assert len(points) == 48
    assert sorted(calls) == sorted(operators)  # each item on its own: 48 calls
    monkeypatch.setattr(ifcopenshell.util.placement, "get_cartesiantransformationoperator3d", evaluate)
    for product in products:
        assert np.array_equal(points[product.id()], _library_points(out, product)), product.GlobalId
