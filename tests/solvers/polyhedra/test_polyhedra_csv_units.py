"""zones.csv names a unit or '[-]' on every column of a quantity, in the request's unit: the face normals' columns
were bare (normal_x), the only dimensionless quantities of the table not marked so."""

from __future__ import annotations

import csv
import io
import json

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.polyhedra.artifacts import render_artifacts
from plantsolve.solvers.polyhedra.solve import solve
from tests.conftest import REPO


def test_zones_csv_marks_the_normals_dimensionless_and_states_the_requests_unit():
    body = json.loads((REPO / "examples" / "polyhedra" / "gable_house.json").read_text())
    request = PolyhedraRequest.model_validate({**body, "units": "ft"})  # the same numbers, in feet
    (table,) = [a for a in render_artifacts(request, solve(request)) if a.name == "zones.csv"]
    rows = list(csv.DictReader(io.StringIO(table.data.decode())))
    assert {"normal_x [-]", "normal_y [-]", "normal_z [-]", "volume [ft3]", "area [ft2]", "perimeter [ft]",
            "planarity_error [ft]"} <= set(rows[0])
    assert float(rows[0]["volume [ft3]"]) == 320.0 and float(rows[0]["floor_area [ft2]"]) == 80.0
    floor = next(r for r in rows if r["id"] == "floor")
    assert [float(floor[f"normal_{c} [-]"]) for c in "xyz"] == [0.0, 0.0, -1.0]
