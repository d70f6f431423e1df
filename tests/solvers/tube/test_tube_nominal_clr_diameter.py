"""A nominal whose CLR column holds the bend's diameter: every CLR check failed with nothing saying why (the ratio,
2, is no unit's). Named now when the straights between bends match and only the CLRs are twice the measured."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.tube import LraRow, TubeRequest
from plantsolve.solvers.tube.inspection import nominal_mixups
from plantsolve.solvers.tube.lra import model_from_rows
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

PART = [[80, 0, 90, 18], [45, 90, 45, 18], [30, -45, 30, 18], [70, 0, 0, 0]]


def _warnings(nominal_table) -> dict:
    measured = model_from_rows([LraRow(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in PART], 6.0)
    rows = [LraRow(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in nominal_table]
    return {w.code: w for w in nominal_mixups(measured, rows, "mm")}


def test_clrs_twice_the_measured_with_matching_straights_are_named():
    warning = _warnings([[a, b, c, 2 * d] for a, b, c, d in PART])["nominal_clr_as_diameter"]
    assert warning.details["clr_ratio"] == pytest.approx(2.0) and warning.details["length_ratio"] == pytest.approx(1.0)


@pytest.mark.parametrize("nominal", [PART, [[a * 2, b, c, d * 2] for a, b, c, d in PART],
                                     [[a, b, c, d * 1.5] for a, b, c, d in PART]],
                         ids=["the part", "everything doubled", "another die"])
def test_other_nominals_are_not_taken_for_diameters(nominal):
    assert "nominal_clr_as_diameter" not in _warnings(nominal)


def test_a_scan_inspected_against_diameters_names_them_beside_the_verdict():
    pts = surface_samples(make_model(np.array(PART, float), 6.0), 4000, np.random.default_rng(3), noise=0.02)
    nominal = [{"length": a, "rotation": b, "angle": c, "bend_radius": 2 * d} for a, b, c, d in PART]
    result = solve(TubeScan(TubeRequest(points=pts.tolist(), options={"nominal": nominal}))).result
    assert "nominal_clr_as_diameter" in [w.code for w in result.report.warnings]
    assert result.inspection.verdict == "fail"
