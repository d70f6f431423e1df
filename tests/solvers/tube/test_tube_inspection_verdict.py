"""Inspection of an exactly known 'made' tube against its nominal: per-row deviations, pass/fail, verdict and
the corrections for the next part are the known errors (no scan: the made tube's LRA is exact)."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.tube import InspectionTolerances, LraRow, TubeOptions
from plantsolve.solvers.tube.corrections import corrections
from plantsolve.solvers.tube.inspection import inspect
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


def test_other_bend_count_fails_without_rows():
    ins = inspect(placed(np.array([[50, 0, 90, 16], [60, 0, 0, 0]], float)), rows(NOMINAL), 1.0, TubeOptions())
    assert not ins.matched and ins.verdict == "fail"
    assert ins.rows == [] and ins.corrections == [] and len(ins.end_points) == 2
