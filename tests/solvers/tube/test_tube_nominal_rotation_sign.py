"""A nominal whose rotations are counted left-handed (clockwise looking along the tube, as some benders and CAD
programs count them) describes the part's mirror image: every row with a rotation failed and corrections.csv turned
each by twice its angle, with nothing saying why. The rotations' other sign is named now; a nominal walked from the
other end, and a part that is its own mirror image, say nothing."""

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


def _rows(table) -> list[LraRow]:
    return [LraRow(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in table]


def _mirrored(table):
    return [[a, -b, c, d] for a, b, c, d in table]


def _codes(measured_table, nominal_table) -> set[str]:
    measured = model_from_rows(_rows(measured_table), 6.0)
    return {w.code for w in nominal_mixups(measured, _rows(nominal_table), "mm")}


def test_rotations_of_the_other_sign_are_named():
    (warning,) = [w for w in nominal_mixups(model_from_rows(_rows(PART), 6.0), _rows(_mirrored(PART)), "mm")
                  if w.code == "nominal_rotations_mirrored"]
    assert warning.details["nominal_rotations"] == [-90, 45]
    assert warning.details["measured_rotations"] == pytest.approx([90, -45])
    assert warning.details["mean_deviation_negated"] == pytest.approx(0, abs=1e-9)


@pytest.mark.parametrize("nominal", [PART, [[70, 0, 30, 18], [30, -45, 45, 18], [45, 90, 90, 18], [80, 0, 0, 0]]],
                         ids=["as measured", "walked from the other end"])
def test_the_same_part_says_nothing(nominal):
    assert "nominal_rotations_mirrored" not in _codes(PART, nominal)


def test_a_part_that_is_its_own_mirror_image_walked_backwards_says_nothing():
    own_mirror = [[60, 0, 45, 18], [40, 30, 45, 18], [40, -30, 45, 18], [60, 0, 0, 0]]
    assert "nominal_rotations_mirrored" not in _codes(own_mirror, _mirrored(own_mirror))


def test_rotations_of_no_telling_sign_say_nothing():
    planar = [[80, 0, 90, 18], [45, 180, 45, 18], [70, 0, 0, 0]]
    assert "nominal_rotations_mirrored" not in _codes(planar, _mirrored(planar))


def test_a_scan_inspected_against_the_mirrored_nominal_names_it_beside_the_verdict():
    pts = surface_samples(make_model(np.array(PART, float), 6.0), 4000, np.random.default_rng(3), noise=0.02)
    nominal = [{"length": a, "rotation": b, "angle": c, "bend_radius": d} for a, b, c, d in _mirrored(PART)]
    result = solve(TubeScan(TubeRequest(points=pts.tolist(), options={"nominal": nominal}))).result
    codes = [w.code for w in result.report.warnings]
    assert "nominal_rotations_mirrored" in codes and result.inspection.verdict != "pass"
