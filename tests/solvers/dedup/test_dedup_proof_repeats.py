"""The proof reads the written file's world points without making them unique: a point written twice is as far
from the other set as its twin, so every deviation is the one of the unique points, bit for bit, whichever way
``proof.deviation`` finds it (through the matching's shape or two trees of its own)."""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.dedup import proof
from plantsolve.solvers.dedup.explicit import unique_rows
from plantsolve.solvers.dedup.matching import make_shape
from plantsolve.solvers.dedup.synthetic import tunnel_file
from plantsolve.solvers.dedup.worldgeom import world_points


def _with_repeated_point():
    """A small tunnel (polygonal face sets) whose first product lists its first coordinate twice."""
    model = tunnel_file(2, "IFC4")
    products = [p for p in model.by_type("IfcProduct") if p.Representation is not None]
    item = products[0].Representation.Representations[0].Items[0]
    coords = [list(c) for c in item.Coordinates.CoordList]
    item.Coordinates.CoordList = coords + [coords[0]]
    return model, products


def test_points_as_read_are_the_unique_points_with_the_repeat_kept():
    model, products = _with_repeated_point()
    unique, faces = world_points(model, products)
    raw, raw_faces = world_points(model, products, unique=False)
    assert raw_faces == faces and raw.keys() == unique.keys()
    first = products[0].id()
    assert len(raw[first]) == len(unique[first]) + 1  # the repeat is there
    for pid in unique:
        assert unique_rows(raw[pid]).tobytes() == unique[pid].tobytes()


def test_every_deviation_is_the_unique_points_one_bit_for_bit():
    model, products = _with_repeated_point()
    unique, _ = world_points(model, products)
    raw, _ = world_points(model, products, unique=False)
    rng = np.random.default_rng(7)
    tol = 1e-5
    for pid, before in unique.items():
        shape = make_shape(before)
        for noise in (0.0, 1e-9, 3e-6, 1e-3):  # within the tolerance, near it and far past it
            moved = rng.normal(size=(1, 3)) * noise
            kept, repeated = unique[pid] + moved, raw[pid] + moved
            for known in (shape, None):
                want = proof.deviation(before, kept, known, tol)
                got = proof.deviation(before, repeated, known, tol)
                assert np.float64(got).tobytes() == np.float64(want).tobytes(), (pid, noise, known is None)
