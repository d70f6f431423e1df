"""Stage-level checks against closed forms."""

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.tube import arcline, curve, local_fit, spine
from plantsolve.solvers.tube.model import build_spine, sample_centreline, spine_distance
from plantsolve.solvers.tube.synthetic import make_model, surface_samples


def _cylinder(n=4000, r=5.0, length=60.0, seed=0, noise=0.0):
    rng = np.random.default_rng(seed)
    z = rng.uniform(0, length, n)
    a = rng.uniform(0, 2 * np.pi, n)
    nrm = np.column_stack([np.cos(a), np.sin(a), np.zeros(n)])
    p = np.column_stack([r * np.cos(a), r * np.sin(a), z]) + rng.normal(0, noise, n)[:, None] * nrm
    return p, nrm


def test_local_fit_curvature_normals_and_tangent_on_cylinder():
    p, nrm = _cylinder()
    tree = cKDTree(p)
    probes = p[(p[:, 2] > 10) & (p[:, 2] < 50)][:400]
    f = local_fit.fit_at(tree, p, probes, 2 / 3 * 5.0)
    assert f.ok.all()
    r_est = np.median(1 / f.kmax)
    assert abs(r_est - 5.0) / 5.0 < 0.08  # the quadric over a 2/3 r disc slightly overestimates κ
    true_n = probes.copy(); true_n[:, 2] = 0
    true_n /= np.linalg.norm(true_n, axis=1, keepdims=True)
    assert np.min(np.einsum("ij,ij->i", f.normal, true_n)) > 0.999  # outward
    assert np.min(np.abs(f.dir_min[:, 2])) > 0.99  # κmin direction = axis
    assert np.median(np.abs(f.kmin)) < 0.01
    assert (local_fit.classify(f, r_est) == 0).mean() > 0.9


def test_local_fit_flags_stray_points_as_outliers():
    p, _ = _cylinder(noise=0.02)
    stray = np.array([[0, 0, 30.0], [1, 2, 20.0], [7, 7, 40.0]])
    allp = np.vstack([p, stray])
    f = local_fit.fit_at(cKDTree(allp), allp, stray, 2 / 3 * 5.0)
    assert (local_fit.classify(f, 5.0) != 0).all()


def test_mls_spine_on_torus_within_paper_bound():
    m = make_model([[30, 0, 90, 10], [30, 0, 0, 0]], 4.0)
    p = surface_samples(m, 8000, np.random.default_rng(1))
    tree = cKDTree(p)
    probes = p[:1500]
    f = local_fit.fit_at(tree, p, probes, 2 / 3 * 4.0)
    sc = spine.mls_spine(tree, p, probes, f.normal, f.dir_min, 4.0, free_radius=False)
    d, seg = spine_distance(sc.points[sc.ok], build_spine(m))
    # §3.2: worst-case shrinkage on a torus with r_B > 2 r_P is below 0.038 r_P
    assert np.percentile(d, 99) < 0.04 * 4.0
    assert sc.ok.mean() > 0.95


def test_nn_crust_orders_a_helix_and_simplify_keeps_corners():
    t = np.linspace(0, 4 * np.pi, 200)
    helix = np.column_stack([10 * np.cos(t), 10 * np.sin(t), 2 * t])
    shuffled = helix[np.random.default_rng(0).permutation(len(helix))]
    poly, method = curve.reconstruct_polyline(shuffled)
    assert method == "nn_crust" and len(poly) == len(helix)
    if np.linalg.norm(poly[0] - helix[0]) > 1e-9:
        poly = poly[::-1]
    np.testing.assert_allclose(poly, helix)
    # an L made of 41 collinear points per leg simplifies to its 3 corner points
    leg = np.linspace(0, 1, 41)[:, None]
    L = np.vstack([leg * [10, 0, 0], [10, 0, 0] + leg[1:] * [0, 10, 0]])
    s = curve.simplify(L, 1e-6)
    np.testing.assert_allclose(s, [[0, 0, 0], [10, 0, 0], [10, 10, 0]], atol=1e-12)


def test_mst_fallback_gives_the_longest_path():
    pts = np.column_stack([np.linspace(0, 10, 50), np.zeros(50), np.zeros(50)])
    path = curve.mst_diameter_path(pts[::-1])
    assert len(path) == 50


def test_arcline_exact_polygons():
    for rows, n in [([[40, 0, 90, 12], [40, 0, 0, 0]], 1), ([[40, 0, 200, 12], [40, 0, 0, 0]], 1),
                    ([[40, 0, 90, 12], [0, 90, 90, 12], [40, 0, 0, 0]], 2),
                    ([[30, 0, 45, 10], [15, 70, 90, 14], [25, 0, 0, 0]], 2)]:
        m = make_model(rows, 4.0)
        c, _ = sample_centreline(m, 0.5)
        poly = curve.simplify(c, 0.05)
        got = arcline.fit_arcline(poly, 0.05, 1.0)
        assert got is not None and got.n_bends == n, rows
        np.testing.assert_allclose(np.degrees(got.angles), np.array(rows)[:-1, 2], atol=1.5)
        # the G1 spline stays within ε of every polygon vertex (+ the sampling error)
        d, _ = spine_distance(poly, build_spine(got))
        assert d.max() < 0.05 + 1e-6
