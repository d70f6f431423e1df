"""A scan with a stretch of tube no sample lies on: two tubes end to end or side by side, or one tube with an
occluded stretch (on a straight, across a bend). Known answers: where the gap is along the fitted centreline and
how long (the samples were cut there, or the pieces end there), whether one bend can join its sides, and that no
row across it gets an inspection verdict. The same scans whole raise no ``scan_gap``."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.tube.determined import one_bend_joins, scan_gaps
from plantsolve.solvers.tube.model import sample_centreline
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

R = 4.0
VIEW = np.array([0.2, 0.3, -1.0])
# the gap's ends are where the last sample projects: within the centreline step (r / 4) and the samples' spacing
TOL = 1.5  # mm
L_BEND = [[100.0, 0, 90, 12], [120.0, 0, 0, 0]]  # the bend from 100 to 118.85 mm along the centreline


def _scan(rows, n, seed, start=(0, 0, 0), frame=None):
    m = make_model(rows, R, start=start, frame=frame)
    return m, surface_samples(m, n, np.random.default_rng(seed), view=VIEW, noise=0.02)


def _occluded(m, pts, a, b):
    """The samples whose nearest centreline point is outside [a, b] (arc length, mm): a stretch the scanner missed."""
    c, _ = sample_centreline(m, R / 8)
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))])
    j = cKDTree(c).query(pts)[1]
    return pts[(s[j] < a) | (s[j] > b)]


def _solve(pts, **opts):
    return solve(TubeRequest(points=pts.tolist(), units="mm", options=opts)).result


def _gaps(res):
    return [w for w in res.report.warnings if w.code == "scan_gap"]


def _nominal(table):
    return [dict(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in table]


def _forward(res, gap):
    """The gap's ends in the walking direction of ``L_BEND`` (the result may walk the tube from its 120 mm end)."""
    total = sum(r.length for r in res.lra) + np.radians(res.lra[0].angle) * res.lra[0].bend_radius
    reversed_ = abs(res.lra[0].length - 120.0) < abs(res.lra[0].length - 100.0)
    return (total - gap["end"], total - gap["start"]) if reversed_ else (gap["start"], gap["end"])


def test_occlusion_on_a_straight_is_one_gap_of_its_length_and_the_whole_scan_none():
    m, pts = _scan(L_BEND, 2000, 3)
    assert not _gaps(_solve(pts))  # the whole scan: no false alarm (main: none either)
    res = _solve(_occluded(m, pts, 130.0, 190.0))
    (w,) = _gaps(res)  # main: no warning, status ok
    (g,) = w.details["gaps"]
    a, b = _forward(res, g)
    assert abs(a - 130.0) < TOL and abs(b - 190.0) < TOL and abs(g["length"] - 60.0) < TOL
    assert not g["two_pieces"] and res.report.status == "warning"
    assert "two tubes" in w.message and "not determined" in w.message


def test_occlusion_across_a_bend_gets_no_inspection_verdict():
    m, pts = _scan(L_BEND, 2000, 3)
    res = _solve(_occluded(m, pts, 80.0, 140.0), nominal=_nominal(L_BEND))
    (w,) = _gaps(res)
    (g,) = w.details["gaps"]
    assert abs(g["length"] - 60.0) < 10.0  # the fitted bend's arc in the gap is longer than the true one
    assert not g["two_pieces"]  # the sides' axes meet at the bend's corner: one tube can join them
    bend = next(r for r in res.lra if r.angle > 0)
    assert {"angle", "bend_radius"} <= set(bend.undetermined)
    # main: inspection FAIL on the bend radius the fit invented in the gap (32.8 for 12 mm)
    assert res.inspection.verdict == "not_determined"
    assert not res.inspection.failed_rows
    (open_row,) = [r for r in res.inspection.rows if "angle" in r.undetermined]  # the bend in the gap: no verdict
    assert open_row.ok is None and open_row.angle.ok is None and open_row.bend_radius.ok is None


def test_two_pieces_out_of_line_are_said_to_be_so_and_get_no_verdict():
    _, a = _scan([[120.0, 0, 0, 0]], 800, 1)
    rot = np.array([[np.cos(0.3), -np.sin(0.3), 0], [np.sin(0.3), np.cos(0.3), 0], [0, 0, 1]])
    _, b = _scan([[120.0, 0, 0, 0]], 800, 2, start=(220.0, 15.0, 25.0), frame=rot)
    # main: 2 invented bends, inspection FAIL (rows 1, 2 rotation and angle; end point 69.9 mm off), no word of pieces
    res = _solve(np.vstack([a, b]), nominal=_nominal([[120, 0, 90, 12], [90, 90, 90, 12], [120, 0, 0, 0]]))
    (w,) = _gaps(res)
    (g,) = w.details["gaps"]
    chord = float(np.linalg.norm([100.0, 15.0, 25.0]))  # from the end of one piece to the start of the other
    assert chord - TOL < g["length"] < 1.05 * chord
    assert abs(g["start"] - 120.0) < TOL  # (both pieces 120 mm long: either walking direction)
    assert g["two_pieces"] and w.details["two_pieces"] and "two pieces" in res.report.message
    assert all(not r.determined for r in res.lra[:-1])
    assert res.inspection.verdict == "not_determined" and not res.inspection.failed_rows
    # no verdict on anything: every row, field and end point null, none read as a pass (they said true before)
    ins = res.inspection
    assert [e.ok for e in ins.end_points] == [None, None] and all(r.ok is None for r in ins.rows)
    assert all(getattr(r, f) is None or getattr(r, f).ok is None
               for r in ins.rows for f in ("length", "rotation", "angle", "bend_radius"))


def test_two_tubes_side_by_side_leave_a_u_bend_no_sample_shows():
    _, a = _scan([[150.0, 0, 0, 0]], 800, 1)
    _, b = _scan([[150.0, 0, 0, 0]], 800, 2, start=(0, 100.0, 0))
    res = _solve(np.vstack([a, b]))  # main: a 180° bend of 50 mm, status ok
    (w,) = _gaps(res)
    (g,) = w.details["gaps"]
    assert abs(g["length"] - 50.0 * np.pi) < 2 * TOL and abs(g["start"] - 150.0) < TOL
    # parallel sides turning back: a U-bend could join them, so only 'two tubes or an occlusion'
    assert not g["two_pieces"] and {"angle", "bend_radius"} <= set(res.lra[0].undetermined)


def test_the_gap_rule_on_the_true_tube():
    """:func:`scan_gaps` on the model the samples were drawn from: a sparse scan (200 samples on 240 mm) has
    none, a 60 mm cut on the straight gives one from 130 to 190 mm; the sides' alignment by known geometry."""
    m, pts = _scan(L_BEND, 200, 5)
    assert scan_gaps(m, pts, np.ones(len(pts), bool)) == []
    cut = _occluded(m, pts, 130.0, 190.0)
    (g,) = scan_gaps(m, cut, np.ones(len(cut), bool))
    assert abs(g.start - 130.0) < 4.0 and abs(g.end - 190.0) < 4.0 and not g.two_pieces  # 200 samples: ~1.2 mm apart
    assert g.fields == {1: ["length"]}
    x, y, _ = np.eye(3)
    o = np.zeros(3)
    assert one_bend_joins(o, x, np.array([50.0, 0, 25.0]), y, 1.0) == (25.0, "the two sides' axes do not meet")
    assert one_bend_joins(o, x, np.array([50.0, 20.0, 0]), y, 1.0) == (0.0, None)  # a 90° corner ahead
    assert one_bend_joins(o, x, np.array([50.0, 20.0, 0]), x, 1.0)[1] == "the two sides run parallel, side by side"
    assert one_bend_joins(o, x, np.array([0, 20.0, 0]), -x, 1.0) == (0.0, None)  # a U-bend
    assert one_bend_joins(o, x, np.array([-50.0, 20.0, 0]), y, 1.0)[1] == "the two sides' axes meet behind one of them"
