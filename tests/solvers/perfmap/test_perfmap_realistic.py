"""Realistic inputs: CSV files as rig software and Excel write them, rig layouts and units
other than the benchmark's, duty-point queries on the boundary, far away and in bulk.

The real map is the N+3 fan map of pyCycle (Apache-2.0, see tests/solvers/perfmap/data/README.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.query import query
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.validation import load
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.families import bernstein
from plantsolve.solvers.perfmap.fitting import concave_floor
from plantsolve.solvers.perfmap.performance_map import cross2, distance_to_region, max_efficiency
from plantsolve.solvers.perfmap.families import curveset_from_fits
from plantsolve.solvers.perfmap.synthetic import PHI_MAX, THETA_MAX, family_curves, true_map

HEADER = "theta,phi,flow,pressure,efficiency"


def _rows(n3_csv: bytes) -> list[list[str]]:
    return [ln.split(",") for ln in n3_csv.decode().strip().splitlines()[1:]]


def _key(req: PerfmapRequest):
    """Order-free content of a request: settings and their points, sorted."""
    return sorted((p.theta, p.phi, tuple(sorted(zip(p.flow, p.pressure, p.efficiency))))
                  for p in req.positions)


def _variants(n3_csv: bytes) -> dict[str, bytes]:
    rows = _rows(n3_csv)
    plain = [",".join(r) for r in rows]
    euro = [";".join(c.replace(".", ",") for c in r) for r in rows]
    return {
        "bom_crlf": ("\ufeff" + "\r\n".join([HEADER] + plain) + "\r\n").encode(),
        "semicolon_decimal_comma": ("theta;phi;flow;pressure;efficiency\r\n"
                                    + "\r\n".join(euro)).encode(),
        "tab_decimal_comma_utf16": ("Theta\tPhi\tFlow\tPressure\tEfficiency\r\n" + "\r\n".join(
            "\t".join(c.replace(".", ",") for c in r) for r in rows)).encode("utf-16"),
        "units_other_order_case": ("Efficiency [-];Pressure ratio;Flow (m3/s);phi;Theta [deg]\n"
                                   + "\n".join(";".join([r[4], r[3], r[2], r[1], r[0]])
                                               for r in rows)).encode(),
        "comments_blank_trailing": ("# rig 3, 2024-05-02\n# operator: x\n\n" + HEADER + "\n"
                                    + "\n".join(plain[:20]) + "\n# speed line break\n"
                                    + "\n".join(plain[20:]) + "\n\n,,,,\n\n").encode(),
        "excel_sep_line": ("sep=;\r\n" + "theta;phi;flow;pressure;efficiency\r\n"
                           + "\r\n".join(euro)).encode("cp1252"),
        "unsorted": ("\n".join([HEADER] + plain[::-1])).encode(),
        "cp1252_degree_sign": ("theta [\xb0],phi,flow,pressure,efficiency\n"
                               + "\n".join(plain)).encode("cp1252"),
        "quoted_excel": "\n".join(",".join(f'"{c}"' for c in ln.split(","))
                                  for ln in [HEADER] + plain).encode(),
        "percent_column": ("theta,phi,flow,pressure,efficiency [%]\n" + "\n".join(
            ",".join(r[:4] + [repr(float(r[4]) * 100)]) for r in rows)).encode(),
    }


@pytest.mark.parametrize("variant", ["bom_crlf", "semicolon_decimal_comma",
                                     "tab_decimal_comma_utf16", "units_other_order_case",
                                     "comments_blank_trailing", "unsorted", "excel_sep_line",
                                     "cp1252_degree_sign", "quoted_excel", "percent_column"])
def test_csv_dialects_parse_to_the_same_request(n3_csv, n3_request, variant):
    req = parse_upload(StoredInput.from_bytes("rig.csv", _variants(n3_csv)[variant]), None)
    got, ref = _key(req), _key(n3_request)
    assert len(got) == 18 and [g[:2] for g in got] == [r[:2] for r in ref]
    for g, r in zip(got, ref):
        np.testing.assert_allclose(np.array(g[2]), np.array(r[2]), rtol=1e-14, atol=0)


def test_extra_columns_ignored_with_a_warning_in_the_report(n3_csv):
    rows = _rows(n3_csv)[:22]  # theta 0, phi 0.5 .. 0.7: three settings
    text = "Speed [rpm],theta,phi,flow,pressure,efficiency,T_in [K]\n" + "\n".join(
        ",".join(["9000"] + r + ["288.15"]) for r in rows)
    req = parse_upload(StoredInput.from_bytes("rig.csv", text.encode()), {"map": False})
    res = solve(req).result
    notes = [w for w in res.report.warnings if w.code == "upload_columns_ignored"]
    assert len(notes) == 1 and notes[0].details["columns"] == ["Speed [rpm]", "T_in [K]"]


def _reject(content: bytes, options=None):
    """The refusal of a table, by the reader or by loading it (the checks at submission)."""
    with pytest.raises(InputRejected) as exc:
        source = StoredInput.from_bytes("rig.csv", content)
        load(parse_upload(source, options), source)
    return exc.value.errors


def test_an_unreadable_row_is_skipped_with_a_warning_naming_its_file_row_and_column(n3_csv):
    """A row that cannot be read is left out and said in the warnings (its file row and why); the file is
    refused only when no row is usable, naming the rows."""
    lines = [HEADER] + [",".join(r) for r in _rows(n3_csv)]
    for bad, loc, needle in (("0.0,0.5,,1.0394,0.6642", ("file", "row", 7, "flow"), "no flow"),
                             ("0.0,0.5,1742.0557,1.0394", ("file", "row", 7, "efficiency"),
                              "no efficiency"),
                             ("0.0,0.5,1742.0557,NaN,0.66", ("file", "row", 7, "pressure"),
                              "NaN"),
                             ("0.0,0.5,1742.0557,1.0394,n/a", ("file", "row", 7, "efficiency"),
                              "not a number")):
        req = parse_upload(StoredInput.from_bytes("rig.csv", "\n".join(lines[:6] + [bad] + lines[7:]).encode()), None)
        (warning,) = [w for w in req.upload_warnings if w.code == "upload_rows_skipped"]
        assert warning.details["lines"] == [7] and warning.details["count"] == 1
        assert needle in warning.details["skipped"][0]["reason"] and "line 7" in warning.message
        assert sum(len(p.flow) for p in req.positions) == len(lines) - 2  # every other row was read
        errs = _reject(("\n".join([HEADER, bad, bad.replace("0.5", "0.6", 1)]) + "\n").encode())  # nothing usable
        assert [e.loc for e in errs] == [(*loc[:2], 2, loc[3]), (*loc[:2], 3, loc[3])] and needle in errs[0].msg


def test_decimal_comma_with_comma_separator_is_read_quoted_and_refused_split():
    rows = [b"0,0,\"1,5\",1.1,0.8", b"0,0,\"2,5\",1.05,0.85", b"0,0,\"3,5\",1.0,0.7"]
    req = parse_upload(StoredInput.from_bytes("rig.csv", b"\n".join([b"theta,phi,flow,pressure,efficiency", *rows])
                                              + b"\n"), {"map": False})
    assert req.positions[0].flow == [1.5, 2.5, 3.5]
    errs = _reject(b"theta,phi,flow,pressure,efficiency\n0,0,1,5,1.1,0.8\n")  # unquoted: six cells
    assert errs[0].loc == ("file", "row", 2) and "';'" in errs[0].msg and "6 cells" in errs[0].msg


def test_semantic_rejections_point_at_file_rows(n3_csv):
    rows = _rows(n3_csv)
    lines = [HEADER] + [",".join(r) for r in rows]
    # percent efficiencies without a '%' unit: the first offending row, and how to fix it
    pct = [HEADER] + [",".join(r[:4] + [str(float(r[4]) * 100)]) for r in rows]
    errs = _reject("\n".join(pct).encode())
    assert errs[0].loc == ("file", "row", 2, "efficiency") and "divide by 100" in errs[0].msg
    assert len(errs) == 18  # one per setting
    # the same flow twice with different readings: accepted, averaged and reported (see test_perfmap_choke)
    dup = list(rows[3])
    dup[3] = "1.2"
    assert parse_upload(StoredInput.from_bytes("rig.csv", "\n".join(lines + [",".join(dup)]).encode()), None)
    # exact repeats are merged (with a warning, see test_perfmap_io)
    req = parse_upload(StoredInput.from_bytes("rig.csv", "\n".join(lines + lines[1:4]).encode()), None)
    assert len(req.positions[0].flow) == 10 and _key(req)[0][2][0] == _key(req)[0][2][1]
    # a setting with a single row (a typo in phi) -> that row
    typo = list(rows[5])
    typo[1] = "0.55"
    errs = _reject("\n".join(lines[:6] + [",".join(typo)] + lines[7:]).encode())
    assert [e.loc for e in errs] == [("file", "row", 7)] and "at least 3" in errs[0].msg
    # non-positive pressure
    neg = list(rows[2])
    neg[3] = "-1.0"
    errs = _reject("\n".join(lines[:3] + [",".join(neg)] + lines[4:]).encode())
    assert [e.loc for e in errs] == [("file", "row", 4, "pressure")]


@pytest.mark.parametrize("content,loc,needle", [
    (b"theta,phi,flow,pressure,efficiency\n", ("file",), "no data rows"),
    (b"\r\n\r\n# only a comment\r\n", ("file",), "empty"),
    (bytes(range(256)) * 4, ("file",), "binary"),
    (b"PK\x03\x04" + bytes(100), ("file",), "xlsx"),
    (b"theta,phi,Q,pressure,efficiency\n0,0,1,1,0.5\n", ("file", "header"), "missing: flow"),
    (b"theta,phi,flow,flow rate,pressure,efficiency\n", ("file", "header"), "both name"),
])
def test_unreadable_files_name_why(content, loc, needle):
    errs = _reject(content)
    assert [e.loc for e in errs] == [loc] and needle in errs[0].msg


# ------------------------------------------------------------------ rig layouts and units

def _body(layout, npts=6, xscale=1.0, yscale=1.0, surge=0.0, options=None):
    """Settings (theta, phi, a, b) with the affine synthetic family at (a, b)."""
    pos = []
    t = np.linspace(0.0, 1.0, npts)
    B = bernstein(3, t)
    for th, ph, a, b in layout:
        x_min, x_max, c, d = family_curves(a, b)
        y = B @ c - surge * np.exp(-8.0 * t)  # surge > 0: a rising surge-side branch
        pos.append({"theta": th, "phi": ph, "flow": ((x_min + t * (x_max - x_min)) * xscale).tolist(),
                    "pressure": (y * yscale).tolist(), "efficiency": (B @ d).tolist()})
    return {"positions": pos, "options": {"model": "cubic", "efficiency_model": "cubic",
                                          **(options or {})}}


def _grid_layout(n_theta, n_phi, theta_max=60.0, phi_max=3.0):
    return [(float(th), float(ph), th / theta_max, ph / phi_max)
            for th in np.linspace(0.0, theta_max, n_theta)
            for ph in np.linspace(0.0, phi_max, n_phi)]


def _arr(m):
    return np.array([[np.nan if v is None else v for v in r] for r in m], dtype=float)


def _all_finite(obj) -> bool:
    if isinstance(obj, float):
        return math.isfinite(obj)
    if isinstance(obj, dict):
        return all(_all_finite(v) for v in obj.values())
    if isinstance(obj, list):
        return all(_all_finite(v) for v in obj)
    return True


def test_grid_rig_in_m3h_and_pa_matches_dense_truth():
    """4 theta (deg, 0-60) x 7 phi (mm, 0-3), flows ~1e4 m3/h, pressures ~1e5 Pa: the exact
    map equals the dense ground truth of the family (the same as in dimensionless units),
    with null exactly where the truth is unreachable."""
    xs, ys = 1.2e4, 1.1e5
    res = solve(PerfmapRequest.model_validate(_body(_grid_layout(4, 7), xscale=xs, yscale=ys,
                                                    options={"grid": [36, 30]}))).result
    assert _all_finite(res.model_dump())
    m = res.map
    te, tt, tp = true_map(np.array(m.flow) / xs, np.array(m.pressure) / ys, n_t=20001)
    eta = _arr(m.efficiency)
    assert np.array_equal(np.isfinite(eta), np.isfinite(te))
    ok = np.isfinite(te)
    assert np.max(np.abs(eta - te)[ok]) < 5e-5
    assert np.mean(np.abs(_arr(m.theta)[ok] - tt[ok] / THETA_MAX * 60.0)) < 0.05
    assert np.mean(np.abs(_arr(m.phi)[ok] - tp[ok] / PHI_MAX * 3.0)) < 0.005
    assert not res.report.warnings  # exact family data: nothing to warn about


def test_units_do_not_change_the_answer():
    """The same rig in dimensionless units and in m3/h, Pa: identical efficiencies and
    settings, flows and pressures scaled; floors and warnings identical."""
    layout = _grid_layout(3, 3)
    a = solve(PerfmapRequest.model_validate(_body(layout, surge=0.02,
                                                  options={"grid": [20, 20]}))).result
    b = solve(PerfmapRequest.model_validate(_body(layout, surge=0.02, xscale=3.6e3,
                                                  yscale=1e5, options={"grid": [20, 20]}))).result
    np.testing.assert_allclose(_arr(a.map.efficiency), _arr(b.map.efficiency),
                               atol=1e-9, equal_nan=True)
    np.testing.assert_allclose(np.array(b.map.flow), 3.6e3 * np.array(a.map.flow), rtol=1e-12)
    np.testing.assert_allclose([s.floor for s in a.settings], [s.floor for s in b.settings],
                               rtol=1e-6, atol=1e-12)
    assert [w.code for w in a.report.warnings] == [w.code for w in b.report.warnings]


def test_floor_is_invariant_to_units_and_large_values():
    x = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    y = np.array([1.00, 1.02, 1.01, 0.97, 0.90])  # surge-side rise: floor > 0
    f = concave_floor(x, y)
    assert f > 1e-3
    for sx, sy in ((1e4, 1e5), (1e8, 1e9), (1e-6, 1e-6)):
        assert concave_floor(sx * x + 7.0, sy * y) == pytest.approx(f, rel=1e-6)
        assert concave_floor(sx * x, sy * np.array([1.0, 0.99, 0.96, 0.9, 0.8])) == 0.0


def test_surge_rise_three_and_twenty_points_clustered_settings():
    # non-monotone (surge-side rise) characteristics: floor warning, not failure
    res = solve(PerfmapRequest.model_validate(_body(_grid_layout(3, 3), npts=8, surge=0.05,
                                                    options={"grid": [24, 24]}))).result
    floors = [w for w in res.report.warnings if w.code == "data_not_decreasing_concave"]
    assert len(floors) == 9 and all(w.details["floor"] > 0.005 for w in floors)
    assert res.map is not None and 0.2 < res.map.reachable_fraction < 0.9
    assert _all_finite(res.model_dump())
    # the minimum: 3 points per setting; and 20 points per setting
    for npts in (3, 20):
        body = _body(_grid_layout(3, 3), npts=npts, options={"grid": [16, 16], "model": "auto"})
        res = solve(PerfmapRequest.model_validate(body)).result
        assert res.map.reachable_fraction > 0.2 and _all_finite(res.model_dump())
    # clustered settings (a tight 3x3 cluster and one far setting): thin triangles
    layout = [(10 + 0.1 * i, 1 + 0.01 * j, 0.3 + 0.01 * i, 0.3 + 0.01 * j)
              for i in range(3) for j in range(3)] + [(40.0, 2.5, 0.9, 0.9)]
    res = solve(PerfmapRequest.model_validate(_body(layout, options={"grid": [24, 24]}))).result
    assert res.map.reachable_fraction > 0.2 and _all_finite(res.model_dump())


def test_exact_map_is_never_beaten_by_a_random_setting_on_real_data(n3_result):
    """Brute force without a grid tolerance: 20,000 random (triangle, weights, t) curve
    points of the real fan map; the exact max efficiency at each of them is feasible and
    at least the efficiency of the random setting there."""
    res = n3_result
    curves = curveset_from_fits(res.settings)
    tri = np.asarray(res.triangles)
    th = np.array([s.theta for s in res.settings])
    ph = np.array([s.phi for s in res.settings])
    rng = np.random.default_rng(7)
    n = 20000
    t = rng.uniform(0.0, 1.0, n)
    idx = tri[rng.integers(0, len(tri), n)].T
    W = rng.dirichlet([1.0, 1.0, 1.0], n).T
    W[:, :2000] = 0.0  # some on the edges of the triangulation, where maxima sit
    W[0, :2000], W[1, :2000] = (s := rng.uniform(0, 1, 2000)), 1 - s
    x, y, e = curves.evaluate(idx, np.broadcast_to(t, idx.shape))
    X, Y, E = (W * x).sum(axis=0), (W * y).sum(axis=0), (W * e).sum(axis=0)
    eta = max_efficiency(curves, tri, np.column_stack([th, ph]), np.linspace(0, 1, res.map.t_samples), X, Y,
                         (*res.flow_range, *res.pressure_range))[0]
    assert np.all(np.isfinite(eta))
    assert np.max(E - eta) < 1e-9


def test_query_measured_points_boundary_far_and_bulk(synthetic_result, synthetic_request):
    res = synthetic_result
    # measured points of exact family data lie on their characteristic: feasible, and the
    # best efficiency there is at least that setting's
    pts = [(x, y, e) for p in synthetic_request.positions
           for x, y, e in zip(p.flow, p.pressure, p.efficiency)]
    q = query(res, PerfmapQueryRequest(points=[{"flow": x, "pressure": y} for x, y, _ in pts]))
    assert all(a.feasible and a.distance_to_map == 0.0 for a in q.points)
    assert min(a.efficiency - e for a, (_, _, e) in zip(q.points, pts)) > -1e-9
    # points on the characteristics of the corner settings = the region's boundary
    curves = curveset_from_fits(res.settings)
    corners = [k for k, s in enumerate(res.settings)
               if s.theta in (0.0, THETA_MAX) and s.phi in (0.0, PHI_MAX)]
    t = np.linspace(0.0, 1.0, 37)
    bnd = []
    for k in corners:
        x, y, _ = curves.evaluate(np.full(len(t), k), t)
        bnd += [{"flow": float(a), "pressure": float(b)} for a, b in zip(x, y)]
    q = query(res, PerfmapQueryRequest(points=bnd))
    assert all(a.feasible for a in q.points)
    # far away: infeasible, no setting, distance in normalised units
    span = res.flow_range[1] - res.flow_range[0]
    far = query(res, PerfmapQueryRequest(points=[
        {"flow": res.flow_range[1] + 3 * span, "pressure": np.mean(res.pressure_range)}]))
    a = far.points[0]
    assert not a.feasible and a.theta is None and a.efficiency is None
    assert 3.0 <= a.distance_to_map <= 4.0


def test_distance_to_region_equals_dense_evaluation(n3_result):
    """The branch-and-bound distance equals the distance to every sampled triangle."""
    res = n3_result
    curves = curveset_from_fits(res.settings)
    tri = np.asarray(res.triangles)
    t = np.linspace(0.0, 1.0, 33)
    rng = np.random.default_rng(3)
    x0, x1, y0, y1 = (*res.flow_range, *res.pressure_range)
    X = rng.uniform(x0 - 0.3 * (x1 - x0), x1 + 0.3 * (x1 - x0), 400)
    Y = rng.uniform(y0 - 0.3 * (y1 - y0), y1 + 0.3 * (y1 - y0), 400)
    got = distance_to_region(curves, tri, t, X, Y, (x0, x1, y0, y1))
    Xs, Ys, _ = curves.sample(t)
    Xs, Ys = (Xs - x0) / (x1 - x0), (Ys - y0) / (y1 - y0)
    A = np.stack([Xs[tri], Ys[tri]], axis=-1).transpose(0, 2, 1, 3).reshape(-1, 3, 2)
    p = np.stack([(X - x0) / (x1 - x0), (Y - y0) / (y1 - y0)], axis=-1)[:, None, :]
    d = np.full((len(X), len(A)), np.inf)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        a, ab = A[:, i], A[:, j] - A[:, i]
        h = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0, 1)
        d = np.minimum(d, np.linalg.norm(p - a - h[..., None] * ab, axis=-1))
    a, b, c = A[:, 0], A[:, 1], A[:, 2]
    s = np.stack([cross2(b - a, p - a), cross2(c - b, p - b), cross2(a - c, p - c)])
    inside = (np.all(s >= 0, axis=0) | np.all(s <= 0, axis=0)).any(axis=1)
    want = np.where(inside, 0.0, d.min(axis=1))
    assert np.sum(want == 0) > 20 and np.sum(want > 0) > 100
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)


# ---------------------------------------------------------------- files cut short


def test_rig_csv_cut_inside_its_last_row_is_read_without_it_and_warns(n3_csv):
    cut = n3_csv.rstrip()[:-10]  # the rig's CRLF export, stopped inside the last row's pressure
    last = cut.count(b"\n") + 1
    req = parse_upload(StoredInput.from_bytes("rig.csv", cut), {"map": False})
    whole = parse_upload(StoredInput.from_bytes("rig.csv", n3_csv), {"map": False})
    assert len(req.positions[-1].flow) == len(whole.positions[-1].flow) - 1
    res = solve(req).result
    (warning,) = [w for w in res.report.warnings if w.code == "truncated_file"]
    assert warning.details["line"] == last and f"line {last}" in warning.message and res.report.status == "warning"


def test_rig_csv_whose_only_row_is_cut_is_refused_on_the_file():
    errs = _reject(b"theta,phi,flow,pressure,efficiency\r\n0.0,0.5,1104.3")
    assert [e.loc for e in errs] == [("file",)] and "line 2, is cut short" in errs[0].msg
