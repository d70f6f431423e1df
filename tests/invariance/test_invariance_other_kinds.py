"""Invariance violations found in kinds this branch does not own: each test states the invariance and fails
until the kind's owner mends it (strict xfail: the lead flips it after the fix)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.polyhedra.solve import solve as solve_polyhedra
from plantsolve.solvers.polyhedra.synthetic import open_box
from plantsolve.solvers.tube.solve import solve as solve_tube
from plantsolve.solvers.tube.synthetic import example as tube_example


def test_the_tube_example_in_metres_fits_the_same_tube():
    body = tube_example()
    in_mm = solve_tube(TubeRequest.model_validate(body)).result
    in_m = solve_tube(TubeRequest.model_validate(
        {**body, "units": "m", "points": (np.array(body["points"]) / 1000).tolist()})).result
    assert in_mm.pipe_radius == pytest.approx(4.0, abs=0.01)  # the synthetic scan's tube: 4 mm
    assert 1000 * in_m.pipe_radius == pytest.approx(in_mm.pipe_radius, rel=1e-6)
    assert [1000 * row.length for row in in_m.lra] == pytest.approx([row.length for row in in_mm.lra], abs=1e-6)


def test_an_open_zones_signed_volume_does_not_depend_on_where_a_loop_starts():
    body = open_box()
    turned = copy.deepcopy(body)
    south = next(f for f in turned["faces"] if f["id"] == "south")
    south["loops"] = [loop[2:] + loop[:2] for loop in south["loops"]]  # the same wall, its orientation kept
    as_given = solve_polyhedra(PolyhedraRequest.model_validate(body)).result.zones[0]
    again = solve_polyhedra(PolyhedraRequest.model_validate(turned)).result.zones[0]
    assert (as_given.closed, again.closed) == (False, False)
    assert again.signed_volume == pytest.approx(as_given.signed_volume, rel=1e-9)
