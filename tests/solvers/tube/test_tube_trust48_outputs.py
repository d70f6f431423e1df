"""What the tube's output files say: CSV headers name their units in the house style (``length [mm]``) and read
back as the nominal they describe, and a failed inspection is never a table of passes."""

from __future__ import annotations

import csv
import io
from types import SimpleNamespace

import numpy as np
import pytest

from plantsolve.schemas.tube import LraRow, TubeOptions, TubeRequest
from plantsolve.solvers.tube.artifacts import corrections_csv, lra_csv, model_from_result, xyz_clr_csv
from plantsolve.solvers.tube.inspection import inspect
from plantsolve.solvers.tube.nominal_files import read_nominal_csv
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

ROWS_MM = np.array([[60.0, 0, 90, 24], [40, 70, 45, 24], [50, 0, 0, 0]])


@pytest.fixture(scope="module")
def inch_result():
    rows = ROWS_MM.copy()
    rows[:, [0, 3]] /= 25.4
    model = make_model(rows, 6.0 / 25.4)
    pts = surface_samples(model, 3000, np.random.default_rng(3), noise=0.0005)
    return solve(TubeScan(TubeRequest(points=pts.tolist(), units="in"))).result


def _header(data: bytes) -> list[str]:
    return next(csv.reader(io.StringIO(data.decode())))


def test_lra_and_xyz_clr_headers_name_their_units_in_brackets(inch_result):
    assert _header(lra_csv(inch_result)) == ["row", "length [in]", "rotation [deg]", "angle [deg]", "bend_radius [in]"]
    assert _header(xyz_clr_csv(inch_result, model_from_result(inch_result))) == [
        "point", "x [in]", "y [in]", "z [in]", "clr [in]"]


def test_own_tables_in_inches_read_back_in_millimetres(inch_result):
    want = np.array([[r.length * 25.4, r.rotation, r.angle, r.bend_radius * 25.4] for r in inch_result.lra])
    for text in (lra_csv(inch_result), xyz_clr_csv(inch_result, model_from_result(inch_result))):
        got = read_nominal_csv(text.decode(), units="mm").rows
        np.testing.assert_allclose([[r.length, r.rotation, r.angle, r.bend_radius] for r in got], want, atol=1e-3)
    # and the reconstruction is the tube that was made: 90 and 45 degree bends on a 24 mm die
    np.testing.assert_allclose(want[:2, 2], [90, 45], atol=0.3)
    np.testing.assert_allclose(want[:2, 3], [24, 24], rtol=0.05)


# every row within its tolerances (angles 0.45 degrees over, lengths 0.4 mm over, rotations 0.9 degrees off), but
# the deviations stack along 1.2 m of tube: both ends of the part lie 2.7 and 4.5 mm off the nominal's (2 mm allowed)
NOMINAL = [[300, 0, 90, 30], [300, 90, 90, 30], [300, -90, 90, 30], [300, 0, 0, 0]]
MADE = [[300.4, 0, 90.45, 30], [300.4, 90.9, 90.45, 30], [300.4, -89.1, 90.45, 30], [300.4, 0, 0, 0]]


def test_a_part_failed_on_its_end_points_alone_is_no_table_of_passes():
    nominal = [LraRow(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in NOMINAL]
    ins = inspect(make_model(MADE, 6.0), nominal, 0.8, TubeOptions())
    assert ins.verdict == "fail" and ins.failed_rows == [] and all(r.ok is True for r in ins.rows)
    assert [e.end for e in ins.end_points if e.ok is False] == ["start", "end"]
    table = list(csv.DictReader(io.StringIO(corrections_csv(SimpleNamespace(inspection=ins, units="mm")).decode())))
    assert [t["status"] for t in table] == ["pass"] * 4  # each row alone is within its tolerances ...
    assert {t["part_verdict"] for t in table} == {"fail"}  # ... the part is not
    assert {t["end_points_failed"] for t in table} == {"start end"}
