"""Review 48: a proven end-point failure downgraded to 'not determined' because an end straight was undetermined
only by the 3-sigma rule of lower bounds (the part may end up to three sigmas past its last samples), which then
counted as a scan stopping short; and an end point failed although the part's end, that much further on, may lie
within the tolerance."""

from __future__ import annotations

import pytest

from plantsolve.schemas.tube import LengthCheck, LraRow, TubeOptions
from plantsolve.solvers.tube.inspection import inspect
from plantsolve.solvers.tube.synthetic import make_model
from plantsolve.solvers.tube.tolerances import PROVEN
from plantsolve.solvers.tube.tolerances import stops_short as short

NOMINAL = [[300, 0, 90, 30], [300, 90, 90, 30], [300, -90, 90, 30], [300, 0, 0, 0]]
# each straight 0.4 mm long and each bend 0.45° over: deviations that stack along the tube, so that after the
# best-fit alignment the start lies 2.7 mm and the end 4.5 mm off the nominal's (end-point tolerance 2 mm)
MADE = [[300.4, 0, 90.45, 30], [300.4, 90.9, 90.45, 30], [300.4, -89.1, 90.45, 30], [300.4, 0, 0, 0]]


def _rows(table) -> list[LraRow]:
    return [LraRow(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in table]


def _inspected(spacing: float):
    """Both end straights lower bounds (the samples end there) 0.4 mm past the nominal, the samples ``spacing``
    apart (their sigma)."""
    known = _rows(MADE)
    for row in (known[0], known[-1]):
        row.length_bound, row.sigma_length, row.undetermined = "lower", spacing, ["length"]
    return inspect(make_model(MADE, 6.0), _rows(NOMINAL), 0.8, TubeOptions(), measured_rows=known)


def test_an_end_point_beyond_the_tolerance_plus_the_reach_fails_on_a_sparse_scan():
    """Spacing 0.3 mm: each end straight is within its 1 mm but not by three sigmas (0.4 + 0.9 mm), so no length
    verdict; the part's end lies at most 0.9 mm further on. The end 4.5 mm off fails whatever those 0.9 mm (main
    said 'not determined': the part passed no check and failed none); the start 2.7 mm off may lie 1.8 mm off, within
    its 2 mm, and 3.6 mm off: no verdict (before the 3-sigma rule it failed)."""
    ins = _inspected(0.3)
    assert [(r.length.determined, r.length.ok) for r in (ins.rows[0], ins.rows[-1])] == [(False, None)] * 2
    start, end = ins.end_points
    assert start.deviation == pytest.approx(2.71, abs=0.02) and end.deviation == pytest.approx(4.52, abs=0.02)
    assert (end.ok, end.determined) == (False, True)
    assert (start.ok, start.determined) == (None, False)
    assert ins.verdict == "fail"


def test_dense_samples_fail_both_end_points():
    """Spacing 0.05 mm: the lengths are determined (0.4 + 0.15 mm within 1 mm) and both ends beyond 2 mm + 0.15 mm."""
    ins = _inspected(0.05)
    assert all(r.length.determined and r.length.ok for r in (ins.rows[0], ins.rows[-1]))
    assert [(e.ok, e.determined) for e in ins.end_points] == [(False, True), (False, True)]
    assert ins.verdict == "fail"


@pytest.mark.parametrize("past_nominal, stops_short", [(-1.4, True), (-0.6, False), (0.4, False), (1.4, False)])
def test_only_a_lower_bound_short_by_more_than_the_tolerance_stops_short(past_nominal, stops_short):
    sigma = 0.3
    determined = past_nominal > 1.0 or -1.0 <= past_nominal and past_nominal + PROVEN * sigma <= 1.0
    check = LengthCheck(nominal=300.0, measured=300.0 + past_nominal, deviation=past_nominal, tolerance=1.0,
                        ok=abs(past_nominal) <= 1.0 if determined else None, determined=determined, sigma=sigma,
                        bound="lower")
    assert short(check) == stops_short
    assert short(check.model_copy(update={"bound": None, "determined": False}))  # a gap, a sigma too wide
