"""Inspection of an exactly known 'made' tube against its nominal: per-row deviations, pass/fail, verdict and
the corrections for the next part are the known errors (no scan: the made tube's LRA is exact)."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.schemas.tube import InspectionTolerances, LraRow, TubeOptions
from plantsolve.solvers.tube.corrections import corrections
from plantsolve.solvers.tube.inspection import inspect, reversed_rows
from plantsolve.solvers.tube.inspection_report import inspection_outcome, report_inspection
from plantsolve.solvers.tube.model import control_polygon, reverse_model
from plantsolve.solvers.tube.synthetic import make_model, random_rotation
from plantsolve.solvers.tube.tolerances import resolved

NOMINAL = [[50, 0, 90, 16], [30, 60, 45, 16], [40, -90, 60, 16], [50, 0, 0, 0]]


def rows(table):
    return [LraRow(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in table]


def made_with_errors():
    """Each bend 1.5° short, row 2's rotation 2° off, row 3's straight 3 mm long."""
    made = np.array(NOMINAL, float)
    made[:3, 2] -= 1.5
    made[1, 1] += 2.0
    made[2, 0] += 3.0
    return made


def placed(table):
    return make_model(table, 4.0, start=(10.0, -5.0, 3.0), frame=random_rotation(np.random.default_rng(4)))


@pytest.fixture(scope="module")
def inspected():
    return inspect(placed(made_with_errors()), rows(NOMINAL), 1.0, TubeOptions())


def test_deviations_are_the_known_errors(inspected):
    ins = inspected
    assert ins.matched and not ins.reversed
    dev = [[r.length.deviation, r.rotation.deviation if r.rotation else 0.0, r.angle.deviation if r.angle else 0.0]
           for r in ins.rows]
    np.testing.assert_allclose(dev, [[0, 0, -1.5], [0, 2, -1.5], [3, 0, -1.5], [0, 0, 0]], atol=1e-6)


def test_verdict_fails_the_right_rows_and_fields(inspected):
    ins = inspected
    assert ins.verdict == "fail" and ins.failed_rows == [1, 2, 3]
    assert [r.failed for r in ins.rows] == [["angle"], ["rotation", "angle"], ["length", "angle"], []]
    # the defaults, stated in the schema
    assert (ins.tolerances.length, ins.tolerances.rotation, ins.tolerances.angle, ins.tolerances.bend_radius,
            ins.tolerances.end_point) == (1.0, 1.0, 0.5, 1.0, 2.0)


def test_corrections_are_the_negated_errors(inspected):
    c = inspected.corrections
    np.testing.assert_allclose([x.delta_length for x in c], [0, 0, -3, 0], atol=1e-6)
    np.testing.assert_allclose([x.delta_rotation for x in c], [0, -2, 0, 0], atol=1e-6)
    np.testing.assert_allclose([x.springback for x in c[:3]], [1.5] * 3, atol=1e-6)
    assert c[3].springback is None
    np.testing.assert_allclose([[x.next.length, x.next.rotation, x.next.angle, x.next.bend_radius] for x in c],
                               [[50, 0, 91.5, 16], [30, 58, 46.5, 16], [37, -90, 61.5, 16], [50, 0, 0, 0]], atol=1e-6)


def test_the_nominal_itself_passes_wherever_it_lies():
    ins = inspect(placed(np.array(NOMINAL, float)), rows(NOMINAL), 1.0, TubeOptions())
    assert ins.verdict == "pass" and ins.failed_rows == []
    assert max(e.deviation for e in ins.end_points) < 1e-6
    assert all(abs(c.delta_angle) < 1e-9 and abs(c.delta_length) < 1e-9 for c in ins.corrections)


def test_end_points_follow_a_longer_last_straight():
    longer = np.array(NOMINAL, float)
    longer[-1, 0] += 6.0
    ins = inspect(placed(longer), rows(NOMINAL), 1.0, TubeOptions())
    assert ins.rows[-1].failed == ["length"] and ins.rows[-1].length.deviation == pytest.approx(6.0)
    assert not all(e.ok for e in ins.end_points) and ins.verdict == "fail"
    # no rigid motion brings both ends closer in sum than the change of the end-to-end distance (triangle
    # inequality)
    span = [np.linalg.norm(np.subtract(*control_polygon(make_model(t, 4.0))[0][[-1, 0]])) for t in (longer, NOMINAL)]
    assert sum(e.deviation for e in ins.end_points) >= span[0] - span[1] - 1e-9 > 1.0


def test_tolerances_decide_pass_and_fail():
    small = np.array(NOMINAL, float)
    small[:3, 2] -= 0.4
    table = placed(small)
    assert inspect(table, rows(NOMINAL), 1.0, TubeOptions()).rows[0].ok  # 0.4° within the default 0.5°
    tight = TubeOptions(inspection_tolerances=InspectionTolerances(angle=0.3, end_point=50.0))
    ins = inspect(table, rows(NOMINAL), 1.0, tight)
    assert ins.failed_rows == [1, 2, 3] and ins.rows[0].angle.tolerance == 0.3


def test_default_tolerances_convert_into_the_request_units():
    t = resolved(InspectionTolerances(rotation=2.0), "in")
    assert (t.length, t.bend_radius, t.end_point) == pytest.approx((1 / 25.4, 1 / 25.4, 2 / 25.4))
    assert (t.rotation, t.angle) == (2.0, 0.5)


def test_linear_springback_per_die():
    # die CLR 16: angle_out = 0.98·cmd − 0.3; the lone CLR 24 bend came out 1.2° short
    nominal = rows([[50, 0, 90, 16], [30, 60, 45, 16], [40, -90, 60, 24], [20, 30, 30, 16], [50, 0, 0, 0]])
    measured = [r.model_copy() for r in nominal]
    for r in measured[:-1]:
        r.angle = 0.98 * r.angle - 0.3 if r.bend_radius == 16 else r.angle - 1.2
    fixes, fits = corrections(nominal, measured, "linear_per_die")
    by_clr = {f.bend_radius: f for f in fits}
    assert by_clr[16.0].bends == [1, 2, 4] and by_clr[24.0].bends == [3]
    assert (by_clr[16.0].k, by_clr[16.0].b) == pytest.approx((0.98, -0.3))
    assert (by_clr[24.0].k, by_clr[24.0].b) == pytest.approx((1.0, -1.2))
    np.testing.assert_allclose([f.next.angle for f in fixes[:-1]],
                               [(90 + 0.3) / 0.98, (45 + 0.3) / 0.98, 61.2, (30 + 0.3) / 0.98], atol=1e-9)
    # the per-bend model gives each bend its own springback back
    per_bend, _ = corrections(nominal, measured)
    np.testing.assert_allclose([f.delta_angle for f in per_bend[:-1]], [n.angle - m.angle for n, m in
                                                                        zip(nominal[:-1], measured[:-1])])


def test_a_scan_walked_backwards_is_inspected_in_the_nominal_order(inspected):
    backwards = inspect(reverse_model(placed(made_with_errors())), rows(NOMINAL), 1.0, TubeOptions())
    assert backwards.reversed and backwards.failed_rows == inspected.failed_rows
    for a, b in zip(backwards.rows, inspected.rows):
        assert a.failed == b.failed and a.length.deviation == pytest.approx(b.length.deviation, abs=1e-6)
    np.testing.assert_allclose([c.delta_angle for c in backwards.corrections],
                               [c.delta_angle for c in inspected.corrections], atol=1e-6)


def test_other_bend_count_is_not_comparable_and_names_both_counts():
    ins = inspect(placed(np.array([[50, 0, 90, 16], [60, 0, 0, 0]], float)), rows(NOMINAL), 1.0, TubeOptions())
    assert not ins.matched and ins.verdict == "not_comparable"
    assert (ins.nominal_bends, ins.measured_bends) == (3, 1)
    assert ins.rows == [] and ins.corrections == [] and ins.failed_rows == [] and len(ins.end_points) == 2
    clause, warning = inspection_outcome(ins, "mm")
    assert warning.code == "inspection_not_comparable" and "NOT COMPARABLE" in clause
    assert "3 bend(s), the scan 1" in warning.message
    assert warning.details == {"nominal_bends": 3, "measured_bends": 1, "sheath_deviation": ins.sheath_deviation}


def test_a_failed_inspection_is_a_report_level_warning_first_in_the_list(inspected):
    report = Report(status="ok", message="3 bends reconstructed.",
                    warnings=[Diagnostic(code="many_outliers", message="x")])
    report_inspection(report, inspected, "mm")
    assert report.status == "warning"
    # the made tube's errors move both ends by about 3 mm after the best fit: they fail too, and are named
    assert report.message == ("3 bends reconstructed; inspection FAIL: rows 1, 2, 3 (length, rotation, angle); end "
                              f"points start {inspected.end_points[0].deviation:.3g} mm, end "
                              f"{inspected.end_points[1].deviation:.3g} mm off (tolerance 2 mm).")
    first = report.warnings[0]
    assert first.code == "inspection_failed" and [w.code for w in report.warnings] == ["inspection_failed",
                                                                                       "many_outliers"]
    assert first.details["rows"] == [1, 2, 3] and first.details["fields"] == ["length", "rotation", "angle"]
    assert first.details["end_points"] == ["start", "end"]
    by_row = {(f["row"], f["field"]): f for f in first.details["failed"]}
    assert by_row[(3, "length")]["deviation"] == pytest.approx(3.0) and by_row[(3, "length")]["unit"] == "mm"
    assert by_row[(2, "rotation")]["unit"] == "deg"


def test_a_passed_inspection_says_so_and_adds_no_warning():
    ins = inspect(placed(np.array(NOMINAL, float)), rows(NOMINAL), 1.0, TubeOptions())
    report = Report(status="ok", message="3 bends reconstructed.")
    report_inspection(report, ins, "mm")
    assert (report.status, report.warnings) == ("ok", [])
    assert report.message == "3 bends reconstructed; inspection PASS."


def measured_knowing(table, changes=None):
    """The made tube's LRA rows with what a scan determined of them: the end straights lower bounds (``spacing``
    their sigma), plus ``changes`` per row index."""
    out = rows(table)
    for i in (0, len(out) - 1):
        out[i].length_bound, out[i].sigma_length, out[i].undetermined = "lower", 0.05, ["length"]
    for i, update in (changes or {}).items():
        for k, v in update.items():
            setattr(out[i], k, v)
    return out


def test_an_end_straight_the_samples_stop_short_on_is_not_determined():
    # the scan stops 2.2 mm short of the last straight's end: the made tube may be right
    short = np.array(NOMINAL, float)
    short[-1, 0] -= 2.2
    ins = inspect(placed(short), rows(NOMINAL), 1.0, TubeOptions(), measured_rows=measured_knowing(short))
    last = ins.rows[-1]
    assert last.length.deviation == pytest.approx(-2.2)
    assert not last.length.determined and last.length.bound == "lower" and last.length.sigma == 0.05
    assert last.failed == [] and last.undetermined == ["length"] and last.ok is None and last.length.ok is None
    assert ins.failed_rows == [] and ins.undetermined_rows == [4] and ins.verdict == "not_determined"
    assert not ins.end_points[1].determined and ins.end_points[1].ok is None
    report = Report(message="3 bends reconstructed.")
    report_inspection(report, ins, "mm")
    assert report.status == "warning" and report.warnings[0].code == "inspection_not_determined"
    assert report.message == "3 bends reconstructed; inspection NOT DETERMINED: rows 4 (length); end points end."


def test_an_end_straight_longer_than_the_nominal_is_a_proven_failure():
    # samples beyond the nominal end: the tube is at least that long, whatever the scan missed
    longer = np.array(NOMINAL, float)
    longer[-1, 0] += 6.0
    ins = inspect(placed(longer), rows(NOMINAL), 1.0, TubeOptions(), measured_rows=measured_knowing(longer))
    assert ins.rows[-1].failed == ["length"] and ins.rows[-1].length.determined
    assert ins.verdict == "fail" and ins.failed_rows == [4]


def test_a_short_end_straight_next_to_a_failed_bend_still_fails_the_part():
    made = made_with_errors()
    made[0, 0] -= 3.0  # and the scan stops short at the start
    ins = inspect(placed(made), rows(NOMINAL), 1.0, TubeOptions(), measured_rows=measured_knowing(made))
    assert ins.verdict == "fail" and ins.failed_rows == [1, 2, 3] and ins.undetermined_rows == [1]
    assert ins.rows[0].failed == ["angle"] and ins.rows[0].undetermined == ["length"]
    clause, warning = inspection_outcome(ins, "mm")
    assert clause.startswith("inspection FAIL: rows 1, 2, 3 (length, rotation, angle)")
    assert clause.endswith("; not determined: rows 1 (length)") and warning.details["undetermined_rows"] == [1]


def test_a_bend_seen_from_one_side_is_a_lower_bound():
    made = np.array(NOMINAL, float)
    made[2, 2] -= 4.0  # the samples stop 4° into the last bend
    known = measured_knowing(made, {2: {"angle_bound": "lower", "undetermined": ["angle"]}})
    ins = inspect(placed(made), rows(NOMINAL), 1.0, TubeOptions(), measured_rows=known)
    assert ins.rows[2].undetermined == ["angle"] and not ins.rows[2].angle.determined
    assert ins.rows[2].angle.bound == "lower" and ins.rows[2].failed == []
    # over-bent by 4° is proven whatever the samples missed
    over = np.array(NOMINAL, float)
    over[2, 2] += 4.0
    known = measured_knowing(over, {2: {"angle_bound": "lower", "undetermined": ["angle"]}})
    ins = inspect(placed(over), rows(NOMINAL), 1.0, TubeOptions(), measured_rows=known)
    assert ins.rows[2].failed == ["angle"] and ins.verdict == "fail"


def test_a_sigma_larger_than_the_tolerance_decides_nothing_unless_the_deviation_is_proven():
    made = np.array(NOMINAL, float)
    made[1, 3] += 1.5  # CLR 1.5 mm over its ±1 mm
    loose = measured_knowing(made, {1: {"sigma_bend_radius": 1.2}})
    ins = inspect(placed(made), rows(NOMINAL), 1.0, TubeOptions(), measured_rows=loose)
    assert ins.rows[1].undetermined == ["bend_radius"] and ins.rows[1].bend_radius.sigma == 1.2
    tight = measured_knowing(made, {1: {"sigma_bend_radius": 0.1}})
    ins = inspect(placed(made), rows(NOMINAL), 1.0, TubeOptions(), measured_rows=tight)
    assert ins.rows[1].failed == ["bend_radius"] and ins.rows[1].undetermined == []
    # 8 mm off with a sigma of 1.2 mm: beyond the tolerance by more than 3 sigma, a proven failure
    made[1, 3] += 6.5
    ins = inspect(placed(made), rows(NOMINAL), 1.0, TubeOptions(), measured_rows=loose)
    assert ins.rows[1].failed == ["bend_radius"]


def test_what_the_samples_determine_follows_a_scan_walked_backwards():
    short = np.array(NOMINAL, float)
    short[-1, 0] -= 2.2
    known = measured_knowing(short, {2: {"angle_bound": "lower", "undetermined": ["angle"], "sigma_angle": 0.1}})
    model = placed(short)
    back = reverse_model(model)
    ins = inspect(back, rows(NOMINAL), 1.0, TubeOptions(), measured_rows=reversed_rows(known))
    assert ins.reversed
    assert ins.rows[-1].length.bound == "lower" and ins.rows[-1].undetermined == ["length"]
    assert ins.rows[2].angle.bound == "lower" and ins.rows[2].angle.sigma == pytest.approx(0.1)
    knowledge = ("sigma_length", "sigma_angle", "sigma_bend_radius", "undetermined", "length_bound", "angle_bound")
    twice = reversed_rows(reversed_rows(known))
    assert [[getattr(r, k) for k in knowledge] for r in twice] == [[getattr(r, k) for k in knowledge] for r in known]
