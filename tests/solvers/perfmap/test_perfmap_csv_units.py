"""The exported tables' setting columns mark a dimensionless setting '[-]', as every other dimensionless column and
the plots' axes do (a GasTurb map's speed, unit '1', was 'Nc [1]'), and curves.csv reads back as an upload (its
docstring's promise; no test read it back): the same settings, units and fitted curves' samples."""

from __future__ import annotations

import json

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.artifacts import curves_csv
from plantsolve.solvers.perfmap.families import curveset_from_fits
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.conftest import REPO


def test_a_gasturb_maps_speed_column_is_marked_dimensionless_as_on_the_plot():
    source = StoredInput.from_path(REPO / "tests" / "solvers" / "perfmap" / "data" / "gasturb" / "compmap.map")
    result = solve(parse_upload(source, {"map": False})).result
    assert result.setting_names == ["Nc"] and result.setting_units == ["1"]
    assert curves_csv(result).decode().splitlines()[0] == "Nc [-],t [-],flow,pressure [-],efficiency [-]"


def test_curves_csv_reads_back_as_the_same_speed_lines_in_the_same_units():
    body = json.loads((REPO / "examples" / "perfmap" / "n3_fan_map.json").read_text())
    body["options"] = {**body["options"], "map": False}
    body["positions"] = body["positions"][:4]  # theta 0, four speeds: enough to read back, cheap to fit twice
    result = solve(PerfmapRequest.model_validate(body)).result
    again = parse_upload(StoredInput.from_bytes("curves.csv", curves_csv(result)), {"map": False})
    assert again.units.flow == "lbm/s" and again.setting_names == ["theta", "phi"]
    assert again.setting_units == ["deg", "-"]
    X, Y, E = curveset_from_fits(result.settings).sample(np.linspace(0.0, 1.0, 51))  # what the rows hold
    assert len(again.positions) == len(result.settings) == 4
    for k, (s, p) in enumerate(zip(result.settings, again.positions)):
        assert tuple(p.setting or (p.theta, p.phi)) == tuple(s.setting or (s.theta, s.phi))
        assert np.array(p.flow) == pytest.approx(X[k], rel=1e-12)
        assert np.array(p.pressure) == pytest.approx(Y[k], rel=1e-12)
        assert np.array(p.efficiency) == pytest.approx(E[k], rel=1e-12)
