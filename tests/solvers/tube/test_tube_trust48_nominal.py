"""Inspection verdicts the samples do not carry, and nominal tables with a cell lost: a lower bound within the
tolerance passed whatever its sigma (a sparse scan's end straight 0.36 ± 0.48 mm past the nominal end passed a
part made 1.8 mm long), and an empty rotation cell was read as 0° without a word."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.common import Report
from plantsolve.schemas.tube import LraRow, TubeOptions, TubeRequest
from plantsolve.solvers.tube.inspection import inspect, inspect_request
from plantsolve.solvers.tube.inspection_report import inspection_outcome, report_inspection
from plantsolve.solvers.tube.nominal_files import read_nominal_csv
from plantsolve.solvers.tube.synthetic import make_model

NOMINAL = [[120, 0, 90, 30], [100, 60, 45, 30], [130, 0, 0, 0]]


def _rows(table) -> list[LraRow]:
    return [LraRow(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in table]


def _inspected(past_end: float, sigma: float):
    """The part as the samples show it, its last straight ``past_end`` mm past the nominal's, a lower bound (the
    samples end there) with the samples' spacing ``sigma``."""
    seen = np.array(NOMINAL, float)
    seen[-1, 0] += past_end
    known = _rows(seen)
    for row, spacing in ((known[0], 0.05), (known[-1], sigma)):  # the start densely sampled
        row.length_bound, row.sigma_length, row.undetermined = "lower", spacing, ["length"]
    return inspect(make_model(seen, 8.0), _rows(NOMINAL), 0.8, TubeOptions(), measured_rows=known)


def test_a_lower_bound_within_the_tolerance_but_not_by_three_sigmas_is_no_verdict():
    ins = _inspected(0.36, 0.48)  # the part may end 0.36 + 3 x 0.48 = 1.8 mm past the nominal: tolerance 1 mm
    last = ins.rows[-1].length
    assert last.deviation == pytest.approx(0.36) and last.bound == "lower"
    assert not last.determined and last.ok is None and ins.rows[-1].undetermined == ["length"]
    assert ins.verdict == "not_determined" and ins.undetermined_rows == [3]  # before: "pass"
    assert ins.end_points[1].determined and ins.end_points[1].ok is True  # 0.34 + 3 x 0.48 mm: within its 2 mm
    _, warning = inspection_outcome(ins, "mm")
    assert warning.code == "inspection_not_determined" and "rows 3 (length)" in warning.message
    assert "or within the tolerance by less than three sigmas (the part may end further on)" in warning.message


@pytest.mark.parametrize("past_end, sigma, verdict", [
    (0.36, 0.05, "pass"),  # dense samples: 0.51 mm at most, within 1 mm
    (-0.6, 0.4, "pass"),  # 0.6 mm at most, the end point 1.8 mm
    (1.4, 0.05, "fail"),  # samples past the nominal end by more than the tolerance: proven too long
    (-1.4, 0.05, "not_determined"),  # short of the nominal: the scan may be short, not the part
    (0.5, 0.3, "not_determined"),  # within 1 mm, but the part may end 1.4 mm past: a pass before the 3-sigma rule
])
def test_a_lower_bound_is_judged_by_how_far_the_part_may_reach(past_end, sigma, verdict):
    ins = _inspected(past_end, sigma)
    assert ins.verdict == verdict
    assert ins.rows[-1].length.determined == (verdict != "not_determined")


def test_an_end_point_passes_only_when_the_part_may_not_reach_past_its_tolerance():
    ins = _inspected(0.36, 0.6)  # the end point about 0.36 mm off, the part's end up to 2.16 mm: tolerance 2 mm
    end = ins.end_points[1]
    assert end.deviation == pytest.approx(0.36, abs=0.05) and end.ok is None and not end.determined


def test_an_empty_rotation_cell_is_read_as_0_and_said_naming_its_line_in_the_jobs_report():
    table = "length,rotation,angle,clr\n80,0,90,18\n45,,45,18\n30,-45,30,18\n70,0,0,0\n"
    nominal = read_nominal_csv(table)
    assert [r.rotation for r in nominal.rows] == [0, 0, -45, 0]
    (warning,) = nominal.warnings
    assert warning.code == "nominal_rotation_empty" and warning.details == {"lines": [3]}
    assert "line 3: the rotation cell is empty, read as 0°" in warning.message
    # the request as the service validates it, inspected as a job does (a part made to the nominal), its report
    request = TubeRequest(points=[[0.0, 0.0, 0.0]] * 3, options={"nominal_csv": table})
    part = make_model([[r.length, r.rotation, r.angle, r.bend_radius] for r in nominal.rows], 4.0)
    ins = inspect_request(part, request.options, request.units)
    assert ins.verdict == "pass" and [w.code for w in ins.warnings] == ["nominal_rotation_empty"]
    report = Report(status="ok", message="Solved.")
    report_inspection(report, ins, request.units)
    assert report.status == "warning" and [w.code for w in report.warnings] == ["nominal_rotation_empty"]
    assert report.warnings[0].message == warning.message


def test_rotations_written_out_and_the_first_and_last_rows_left_empty_say_nothing():
    nominal = read_nominal_csv("length,rotation,angle,clr\n80,,90,18\n45,90,45,18\n30,-45,30,18\n70\n")
    assert nominal.warnings == [] and [r.rotation for r in nominal.rows] == [0, 90, -45, 0]
