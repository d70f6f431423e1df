"""The batched arc search of Algorithm 1's edges against the search of one edge at a time."""

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.tube import arcline, curve
from plantsolve.solvers.tube.arcline import TOO_FAR
from plantsolve.solvers.tube.model import sample_centreline
from plantsolve.solvers.tube.synthetic import make_model


def _dist_to_arcline(q: np.ndarray, t1: np.ndarray, R: np.ndarray, phi: float,
                     a2: np.ndarray, u2: np.ndarray, n2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The reference: the one-family formula the search used before batching. 2D distances of chain points q
    (K, 2) to the left-turning curves given by t1 (G,): ray along +x ending at (t1, 0), arc about C = (t1, R) by
    phi, ray along u2 from T2."""
    # centre C = (t1, R), arc end T2 = C − R·n2; all (G, K) arrays built from coordinates
    T2x, T2y = t1 - R * n2[0], R - R * n2[1]
    t2 = (T2x - a2[0]) * u2[0] + (T2y - a2[1]) * u2[1]
    qx, qy = q[None, :, 0], q[None, :, 1]
    dx1 = qx - t1[:, None]
    dT1 = np.sqrt(dx1 * dx1 + qy * qy)
    d1 = np.where(qx <= t1[:, None], np.abs(qy), dT1)
    qa = q - a2
    s2 = (qa @ u2)[None]  # (1, K)
    ex, ey = qx - T2x[:, None], qy - T2y[:, None]
    dT2 = np.sqrt(ex * ex + ey * ey)
    d3 = np.where(s2 >= t2[:, None], np.abs(qa @ n2)[None], dT2)
    vy = qy - R[:, None]  # v = q − C = (dx1, vy)
    # angle from the start direction (0, -1) counter-clockwise
    th = np.arctan2(dx1, -vy)
    th = np.where(th < 0, th + 2 * np.pi, th)
    rho = np.sqrt(dx1 * dx1 + vy * vy)
    d2 = np.where(th <= phi, np.abs(rho - R[:, None]), np.minimum(dT1, dT2))
    return np.minimum(np.minimum(d1, d2), d3), t2


def _search_alone(f, r_min, grid=64):
    """The zoomed grid search of one family of arcs, written as one loop over its grid (no batching)."""
    best = None
    t_grid = arcline._linspace(f.lo, f.hi, grid) if f.hi > f.lo else np.array([f.lo])
    for _ in range(4):
        R = f.alpha + f.beta * t_grid
        d, t2 = _dist_to_arcline(f.q, t_grid, R, f.phi, f.a2, f.u2, f.n2)
        viol = np.max(d - f.epsk[None], axis=1)
        valid = (viol <= 1e-12) & (R >= r_min * (1 - 1e-9))
        sums = np.zeros(len(t_grid))
        for k in range(d.shape[1]):  # the chain's squares in chain order
            sums += d[:, k] ** 2
        cost = np.where(valid, sums, np.inf)
        if valid.any():
            g = int(np.argmin(cost))
            if best is None or cost[g] < best[0]:
                best = (cost[g], t_grid[g], R[g], t2[g])
        else:
            g = int(np.argmin(viol))
        if len(t_grid) == 1:
            break
        step = t_grid[1] - t_grid[0]
        t_grid = arcline._linspace(max(f.lo, t_grid[g] - step), min(f.hi, t_grid[g] + step), 17)
    return best


def _families(poly, eps, r_min):
    """The arc families of every edge out of vertex 0 (the first tangent line), as Algorithm 1 meets them."""
    d0 = (poly[1] - poly[0]) / np.linalg.norm(poly[1] - poly[0])
    out = []
    for j in range(1, len(poly) - 1):
        f = arcline.arc_family(poly[:j + 1], poly[0], d0, 0.0, poly[j], poly[j + 1], eps, r_min)
        if f is TOO_FAR:
            break
        if f is not None:
            out.append(f)
    return out


def test_batched_search_finds_the_arcs_of_the_search_one_at_a_time_bit_for_bit():
    rng = np.random.default_rng(0)
    m = make_model([[30, 0, 50, 10], [15, 70, 100, 14], [25, 0, 0, 0]], 4.0)
    c, _ = sample_centreline(m, 0.5)
    c = c + rng.normal(scale=0.01, size=c.shape)
    poly = curve.simplify(c, 0.05)
    fams = _families(poly, 0.2, 1.0)
    # chains of several lengths at once, some of 8 points or more (where numpy's own sums would go pairwise)
    assert len(fams) >= 3 and len({len(f.q) for f in fams}) >= 3 and max(len(f.q) for f in fams) >= 8
    edges = arcline.best_arcs(fams, 1.0)
    found = 0
    for f, e in zip(fams, edges):
        want = _search_alone(f, 1.0)
        assert (e is None) == (want is None)
        if e is not None:
            found += 1
            assert (e.cost, e.t1, e.radius, e.t2) == tuple(float(v) for v in want)
    assert found >= 1


def test_distances_to_the_arc_line_are_those_of_the_densely_sampled_curve():
    """The closed-form distances against the nearest of 200,000 points along the curve (ray, arc, ray), for
    turning angles below and above 180° and points on every side."""
    rng = np.random.default_rng(3)
    for phi in (0.3, 1.5, 3.0, 4.5):
        t1, R = 2.0, 3.0
        u2 = np.array([np.cos(phi), np.sin(phi)])
        n2 = np.array([-u2[1], u2[0]])
        C = np.array([t1, R])
        T2 = C - R * n2
        a2 = T2 - 5.0 * u2  # a point of l_j behind the arc end
        q = rng.uniform(-8, 12, size=(60, 2))
        qa = q - a2
        lines = (a2[None, :, None], u2[None, :, None], n2[None, :, None], np.array([[[phi]]]))
        d, t2 = arcline._dist_to_arclines(lines, q[None], np.array([[t1]]), np.array([[R]]), (qa @ u2)[None],
                                          np.abs(qa @ n2)[None])
        d = d[:, :, 0]
        s = np.linspace(0, 1, 200_000)[:, None]
        ray1 = np.column_stack([t1 - 40 * s[:, 0], 0 * s[:, 0]])
        ang = phi * s[:, 0]
        arc = C + R * np.column_stack([np.sin(ang), -np.cos(ang)])
        ray2 = T2 + 40 * s * u2
        curve_pts = np.vstack([ray1, arc, ray2])
        brute = cKDTree(curve_pts).query(q)[0]  # the nearest sample, as a brute-force search finds it
        assert np.allclose(d[0], brute, atol=5e-4)
        assert abs(t2[0, 0] - 5.0) < 1e-12


def test_plane_tests_of_several_states_are_each_states_own_bit_for_bit():
    """The plane tests of every state of a vertex, stacked, against :func:`arcline._planes` of each alone: the
    chains of a noisy two-bend centreline seen from tangent lines turned and moved as modified lines are."""
    rng = np.random.default_rng(5)
    m = make_model([[30, 0, 50, 10], [15, 70, 100, 14], [25, 0, 0, 0]], 4.0)
    c, _ = sample_centreline(m, 0.5)
    poly = curve.simplify(c + rng.normal(scale=0.01, size=c.shape), 0.05)
    last = len(poly) - 2
    for i in (0, 3, len(poly) // 2, last - 1):
        d = poly[i + 1] - poly[i]
        points = [poly[i] + rng.normal(scale=0.05, size=3) for _ in range(3)]
        directions = [(d + rng.normal(scale=0.05 * np.linalg.norm(d), size=3)) for _ in range(3)]
        directions = [u / np.linalg.norm(u) for u in directions]
        stacked = arcline._planes_of_states(poly, i, last, points, directions, 0.2)
        for got, a1, u1 in zip(stacked, points, directions):
            want = arcline._planes(poly, i, last, a1, u1, 0.2)
            assert len(got) == len(want)
            for g, w in zip(got, want):
                assert np.array_equal(np.asarray(g), np.asarray(w))


def test_arc_families_of_a_vertex_stacked_are_each_edges_own_bit_for_bit():
    """The arc families of every edge out of the states of a vertex, from the stacked chains, against
    :func:`arcline._arcs_in_plane` of each edge alone (every field, bit for bit), a chain with a repeated vertex
    among them."""
    rng = np.random.default_rng(7)
    m = make_model([[30, 0, 50, 10], [15, 70, 100, 14], [25, 0, 0, 0]], 4.0)
    c, _ = sample_centreline(m, 0.5)
    poly = curve.simplify(c + rng.normal(scale=0.01, size=c.shape), 0.05)
    poly = np.insert(poly, 5, poly[5], axis=0)  # a repeated vertex: a zero segment in the chains past it
    last, eps, compared, repeated = len(poly) - 2, 0.3, 0, 0
    for i in (0, 2, 4, len(poly) // 2):
        d = poly[i + 1] - poly[i]
        points = [poly[i] + rng.normal(scale=0.03, size=3) for _ in range(3)]
        directions = [d + rng.normal(scale=0.03 * np.linalg.norm(d), size=3) for _ in range(3)]
        directions = [u / np.linalg.norm(u) for u in directions]
        planes = arcline._planes_of_states(poly, i, last, points, directions, eps)
        asks = []
        for si, (e1, e2, along, x1, x2, K, m1, m2, off) in enumerate(planes):
            for jj, j in enumerate(range(i + 1, len(poly) - 1)):
                if off[jj] > 2 * eps:
                    break
                if off[jj] <= eps:
                    asks.append((si, j, int(K[jj]), jj, points[si], directions[si], 0.1 * si - 0.2))
        got = arcline._arcs_in_planes(planes, asks, poly, eps, 1.0)
        for (si, j, k, jj, a1, u1, t_lo), f in zip(asks, got):
            e1, e2, along, x1, x2, K, m1, m2, _ = planes[si]
            h = m1[jj] * x1[:k] + m2[jj] * x2[:k]
            want = arcline._arcs_in_plane(along[:k], x1[:k], x2[:k], h, float(m1[jj]), float(m2[jj]), e1, e2, a1, u1,
                                          t_lo, poly[j], poly[j + 1], eps, 1.0, None)
            assert (f is None) == (want is None)
            if want is not None:
                compared += 1
                repeated += i < 5 < i + k
                for name in want.__dataclass_fields__:
                    assert np.array_equal(np.asarray(getattr(f, name)), np.asarray(getattr(want, name))), name
    assert compared >= 10 and repeated >= 1


def test_an_edges_arc_in_3d_touches_both_lines_and_turns_by_its_angle():
    """The arc of every edge found out of vertex 0 (its centre, start and end computed when asked for): start and
    end at its radius from the centre, the start on l_i and the end on the modified l_j, both lines tangent to
    the arc there, and the turn from the one tangent to the other its angle."""
    rng = np.random.default_rng(0)
    m = make_model([[30, 0, 50, 10], [15, 70, 100, 14], [25, 0, 0, 0]], 4.0)
    c, _ = sample_centreline(m, 0.5)
    poly = curve.simplify(c + rng.normal(scale=0.01, size=c.shape), 0.05)
    d0 = (poly[1] - poly[0]) / np.linalg.norm(poly[1] - poly[0])
    edges = [e for e in arcline.best_arcs(_families(poly, 0.2, 1.0), 1.0) if e is not None]
    assert len(edges) >= 2
    for e in edges:
        assert abs(np.linalg.norm(e.start - e.centre) - e.radius) < 1e-9 * e.radius
        assert abs(np.linalg.norm(e.end - e.centre) - e.radius) < 1e-9 * e.radius
        np.testing.assert_allclose(e.start, poly[0] + e.t1 * d0, atol=1e-9)
        np.testing.assert_allclose(e.end, e.out_point + e.t2 * e.out_dir, atol=1e-9)
        assert abs(np.dot(e.start - e.centre, d0)) < 1e-9 and abs(np.dot(e.end - e.centre, e.out_dir)) < 1e-9
        np.testing.assert_allclose(e.normal_in, (e.centre - e.start) / e.radius, atol=1e-9)
        assert abs(np.arccos(np.clip(d0 @ e.out_dir, -1, 1)) - min(e.angle, 2 * np.pi - e.angle)) < 1e-9
