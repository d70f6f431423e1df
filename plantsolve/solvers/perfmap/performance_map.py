"""The performance map (paper section 4): max efficiency over all settings through a point.

Exact method (this module's :func:`max_efficiency`): the characteristic of the setting with
barycentric weights w in a triangle of settings is, point-wise in t, the convex combination
of the three vertex curves (paper eqs. 56-59 with the curve data interpolated linearly).
For a fixed t the flow and pressure are therefore affine in w, so the settings whose
characteristic passes through a node (X, Y) at parameter t are the solution of a 2x2 linear
system — the node's barycentric coordinates in the triangle spanned by the three vertex
curve points at t. Feasible iff all weights are >= 0; the efficiency there is the same
combination of the vertex efficiencies. The max over (triangle, t) is taken per node.
No binning, so no raggedness and no upward bias; unreachable nodes are NaN, never 0.

:func:`binned_map` is the paper's scatter-and-bin (eqs. 62-71, with eq. 67's weight fixed
to (2s - 1) and NaN initialisation), kept as a baseline for the benchmark.
"""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.base import Progress, no_progress
from plantsolve.solvers.perfmap.families import CurveSet

_INSIDE_TOL = 1e-10
_DET_TOL = 1e-14
_T_BLOCK = 8
_NODE_CHUNK = 65536


def curve_ranges(curves: CurveSet) -> tuple[float, float, float, float]:
    """Bounding box of all characteristics (every interpolated curve lies inside it).

    Curves are decreasing, so y ranges from min y(1) to max y(0).
    """
    idx = np.arange(curves.n)
    _, y0, _ = curves.evaluate(idx, np.zeros(curves.n))
    _, y1, _ = curves.evaluate(idx, np.ones(curves.n))
    return (float(curves.x_min.min()), float(curves.x_max.max()),
            float(min(y1.min(), y0.min())), float(max(y0.max(), y1.max())))


def grid_axes(ranges, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell-centred grid (paper eqs. 66-67, with (2s - 1) in eq. 67)."""
    x0, x1, y0, y1 = ranges
    r = np.arange(1, nx + 1)
    s = np.arange(1, ny + 1)
    gx = ((2 * nx - 2 * r + 1) * x0 + (2 * r - 1) * x1) / (2 * nx)
    gy = ((2 * ny - 2 * s + 1) * y0 + (2 * s - 1) * y1) / (2 * ny)
    return gx, gy


def _dot3(W: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Column-wise sum_i W[i] * v[i] over the 3 vertices, as explicit element-wise products:
    einsum/matmul may pick a different summation kernel for different batch sizes, and a
    per-point answer must not depend on the other points queried with it."""
    return W[0] * v[0] + W[1] * v[1] + W[2] * v[2]


class _Normaliser:
    def __init__(self, ranges):
        x0, x1, y0, y1 = ranges
        self.x0, self.sx = x0, (x1 - x0) or 1.0
        self.y0, self.sy = y0, (y1 - y0) or 1.0

    def __call__(self, x, y):
        return (np.asarray(x) - self.x0) / self.sx, (np.asarray(y) - self.y0) / self.sy


def _solve_in_triangles(curves: CurveSet, tri: np.ndarray, t: np.ndarray, Xn, Yn, norm):
    """Per node j: weights of (Xn_j, Yn_j) in the triangle of settings tri[:, j] at t_j, and
    the efficiency there (-inf when outside or degenerate)."""
    x, y, e = curves.evaluate(tri, np.broadcast_to(t, tri.shape))
    x, y = norm(x, y)
    a, b, c, d = x[0] - x[2], x[1] - x[2], y[0] - y[2], y[1] - y[2]
    det = a * d - b * c
    ok = np.abs(det) > _DET_TOL
    det = np.where(ok, det, 1.0)
    dx, dy = Xn - x[2], Yn - y[2]
    u = (d * dx - b * dy) / det
    v = (a * dy - c * dx) / det
    W = np.stack([u, v, 1.0 - u - v])
    ok &= np.all(W >= -_INSIDE_TOL, axis=0)
    return np.where(ok, _dot3(W, e), -np.inf), W


def _refine_interior(curves, triangles, t, Xn, Yn, norm, best, b_tri, b_m, iterations=32):
    """Golden-section search in t around each node's best sample (same triangle); keeps only
    feasible improvements. Returns improved (eta, W, t) for all nodes given."""
    tri = triangles[b_tri].T  # (3, G)
    lo = t[np.maximum(b_m - 1, 0)]
    hi = t[np.minimum(b_m + 1, len(t) - 1)]
    g = (np.sqrt(5.0) - 1.0) / 2.0
    c1, c2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, W1 = _solve_in_triangles(curves, tri, c1, Xn, Yn, norm)
    f2, W2 = _solve_in_triangles(curves, tri, c2, Xn, Yn, norm)
    e_best, t_best = best.copy(), t[b_m].copy()
    W_best = _solve_in_triangles(curves, tri, t_best, Xn, Yn, norm)[1]
    for _ in range(iterations):
        for f, W, c in ((f1, W1, c1), (f2, W2, c2)):
            upd = f > e_best
            e_best = np.where(upd, f, e_best)
            t_best = np.where(upd, c, t_best)
            W_best = np.where(upd, W, W_best)
        left = f1 >= f2  # max lies in [lo, c2]
        hi = np.where(left, c2, hi)
        lo = np.where(left, lo, c1)
        n1, n2 = hi - g * (hi - lo), lo + g * (hi - lo)
        c1, c2 = n1, n2
        f1, W1 = _solve_in_triangles(curves, tri, c1, Xn, Yn, norm)
        f2, W2 = _solve_in_triangles(curves, tri, c2, Xn, Yn, norm)
    return e_best, W_best, t_best


def _edge_candidates(curves, i, j, t, Xs, Ys, Es, Xn, Yn, norm, iterations=14):
    """Nodes on the segment between the curve points of settings i and j at some t.

    The max efficiency is often reached where a barycentric weight hits 0, i.e. on an edge
    of the triangulation; there the node lies on the moving segment P_i(t) P_j(t). The
    crossing parameter is bracketed on the t samples and found by Illinois regula falsi,
    so these maxima are exact instead of off by one t step.
    Returns (nodes, eta, s, t) of feasible crossings.
    """
    P, Q = Xs[[i, j]], Ys[[i, j]]
    empty = (np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros(0))
    M = len(t)
    dxe, dye = P[1] - P[0], Q[1] - Q[0]
    found_nodes, found_lo, found_hi, found_flo, found_fhi = [], [], [], [], []
    for m0 in range(0, M - 1, _T_BLOCK):
        blk = np.arange(m0, min(m0 + _T_BLOCK, M - 1) + 1)  # overlapping by one sample
        Pb, Qb = P[:, blk], Q[:, blk]
        in_box = np.flatnonzero((Xn >= Pb.min() - 1e-12) & (Xn <= Pb.max() + 1e-12)
                                & (Yn >= Qb.min() - 1e-12) & (Yn <= Qb.max() + 1e-12))
        for n0 in range(0, len(in_box), _NODE_CHUNK):
            sel = in_box[n0 : n0 + _NODE_CHUNK]
            f = (dxe[blk][:, None] * (Yn[sel][None, :] - Qb[0][:, None])
                 - dye[blk][:, None] * (Xn[sel][None, :] - Pb[0][:, None]))
            sc = (f[:-1] * f[1:] <= 0) & ~((f[:-1] == 0) & (f[1:] == 0))
            mm, gg = np.nonzero(sc)
            if len(mm):
                found_nodes.append(sel[gg])
                found_lo.append(t[blk[mm]])
                found_hi.append(t[blk[mm + 1]])
                found_flo.append(f[mm, gg])
                found_fhi.append(f[mm + 1, gg])
    if not found_nodes:
        return empty
    nodes = np.concatenate(found_nodes)
    X, Y = Xn[nodes], Yn[nodes]
    lo, hi = np.concatenate(found_lo), np.concatenate(found_hi)
    flo, fhi = np.concatenate(found_flo), np.concatenate(found_fhi)
    idx = np.stack([np.full(len(nodes), i), np.full(len(nodes), j)])

    def cross(tt):
        x, y = curves.evaluate_xy(idx, np.broadcast_to(tt, idx.shape))
        x, y = norm(x, y)
        return (x[1] - x[0]) * (Y - y[0]) - (y[1] - y[0]) * (X - x[0])

    for _ in range(iterations):
        den = fhi - flo
        tn = np.where(den != 0, hi - fhi * (hi - lo) / np.where(den != 0, den, 1.0), hi)
        tn = np.clip(tn, np.minimum(lo, hi), np.maximum(lo, hi))
        fn = cross(tn)
        flip = fn * fhi < 0
        lo = np.where(flip, hi, lo)
        flo = np.where(flip, fhi, flo * 0.5)
        hi, fhi = tn, fn
    x, y, e = curves.evaluate(idx, np.broadcast_to(hi, idx.shape))
    x, y = norm(x, y)
    ex, ey = x[1] - x[0], y[1] - y[0]
    L2 = ex * ex + ey * ey
    s = ((X - x[0]) * ex + (Y - y[0]) * ey) / np.where(L2 > 0, L2, 1.0)
    ok = (L2 > _DET_TOL) & (s >= -_INSIDE_TOL) & (s <= 1 + _INSIDE_TOL) & (np.abs(fhi) <= 1e-9)
    s = np.clip(s, 0.0, 1.0)
    eta = (1 - s) * e[0] + s * e[1]
    return nodes[ok], eta[ok], s[ok], hi[ok]


def max_efficiency(curves: CurveSet, triangles: np.ndarray, values: np.ndarray,
                   t: np.ndarray, X: np.ndarray, Y: np.ndarray, ranges,
                   progress: Progress = no_progress, p0: float = 0.0, p1: float = 1.0):
    """Exact max efficiency at points (X, Y) (1-D arrays); returns eta, the optimal setting values
    (len(X), d) interpolated from ``values`` (n_settings, d), and t (NaN where no setting reaches
    the point).

    Three passes: (1) every (triangle, t sample): 2x2 solve per node; (2) golden-section
    refinement in t of each node's best sample; (3) crossings of every edge of the
    triangulation, where maxima on the boundary of a triangle's feasible set sit.
    """
    norm = _Normaliser(ranges)
    Xn, Yn = norm(X, Y)
    Xs, Ys, Es = curves.sample(t)
    Xs, Ys = norm(Xs, Ys)
    G = len(Xn)
    best = np.full(G, -np.inf)
    b_tri = np.zeros(G, dtype=int)
    b_m = np.zeros(G, dtype=int)
    n_tri = len(triangles)
    M = len(t)
    for k, tri in enumerate(triangles):
        P, Q, H = Xs[tri], Ys[tri], Es[tri]  # (3, M)
        a, b = P[0] - P[2], P[1] - P[2]
        c, d = Q[0] - Q[2], Q[1] - Q[2]
        det = a * d - b * c
        # Blocks of consecutive t: the triangles of a block sweep a thin band, so only the
        # nodes in the block's bounding box are solved for (not the whole sweep's box).
        for m0 in range(0, M, _T_BLOCK):
            blk = np.arange(m0, min(m0 + _T_BLOCK, M))
            blk = blk[np.abs(det[blk]) > _DET_TOL]
            if not len(blk):
                continue
            Pb, Qb = P[:, blk], Q[:, blk]
            in_box = np.flatnonzero((Xn >= Pb.min() - 1e-12) & (Xn <= Pb.max() + 1e-12)
                                    & (Yn >= Qb.min() - 1e-12) & (Yn <= Qb.max() + 1e-12))
            ab, bb, cb, db, detb = a[blk], b[blk], c[blk], d[blk], det[blk]
            Hb = H[:, blk]
            for n0 in range(0, len(in_box), _NODE_CHUNK):  # bounded memory on huge grids
                nodes = in_box[n0 : n0 + _NODE_CHUNK]
                dx = Xn[nodes][None, :] - Pb[2][:, None]  # (m, g)
                dy = Yn[nodes][None, :] - Qb[2][:, None]
                u = (db[:, None] * dx - bb[:, None] * dy) / detb[:, None]
                v = (ab[:, None] * dy - cb[:, None] * dx) / detb[:, None]
                w = 1.0 - u - v
                inside = (u >= -_INSIDE_TOL) & (v >= -_INSIDE_TOL) & (w >= -_INSIDE_TOL)
                eta = np.where(inside, u * Hb[0][:, None] + v * Hb[1][:, None] + w * Hb[2][:, None],
                               -np.inf)
                m = np.argmax(eta, axis=0)
                e = eta[m, np.arange(len(nodes))]
                upd = e > best[nodes]
                best[nodes[upd]] = e[upd]
                b_tri[nodes[upd]] = k
                b_m[nodes[upd]] = blk[m[upd]]
        progress(p0 + (p1 - p0) * 0.6 * (k + 1) / n_tri, "performance map: triangles")

    values = np.asarray(values, dtype=float).reshape(curves.n, -1)
    b_val = np.full((G, values.shape[1]), np.nan)
    b_t = np.full(G, np.nan)
    hit = np.flatnonzero(np.isfinite(best))
    if len(hit):
        e, W, tb = _refine_interior(curves, triangles, t, Xn[hit], Yn[hit], norm, best[hit],
                                    b_tri[hit], b_m[hit])
        W = np.clip(W, 0.0, None)
        W /= W.sum(axis=0)
        tri = triangles[b_tri[hit]].T
        best[hit] = e
        for col in range(values.shape[1]):
            b_val[hit, col] = _dot3(W, values[tri, col])
        b_t[hit] = tb
    progress(p0 + (p1 - p0) * 0.7, "performance map: refinement")

    edges = np.unique(np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]],
                                              triangles[:, [0, 2]]]), axis=1), axis=0)
    for k, (i, j) in enumerate(edges):
        nodes, eta, s, te = _edge_candidates(curves, i, j, t, Xs, Ys, Es, Xn, Yn, norm)
        if len(nodes):
            order = np.argsort(-eta, kind="stable")
            nodes, eta, s, te = nodes[order], eta[order], s[order], te[order]
            _, first = np.unique(nodes, return_index=True)  # best crossing per node
            nodes, eta, s, te = nodes[first], eta[first], s[first], te[first]
            upd = eta > best[nodes]
            n = nodes[upd]
            best[n] = eta[upd]
            b_val[n] = (1 - s[upd])[:, None] * values[i] + s[upd][:, None] * values[j]
            b_t[n] = te[upd]
        progress(p0 + (p1 - p0) * (0.7 + 0.3 * (k + 1) / len(edges)), "performance map: edges")
    best[~np.isfinite(best)] = np.nan
    return best, b_val, b_t


def exact_map(curves, triangles, values, t, gx, gy, ranges, progress=no_progress, p0=0.0, p1=1.0):
    """Max efficiency (ny, nx) and the optimal setting values (d, ny, nx) on the grid."""
    XX, YY = np.meshgrid(gx, gy)  # rows = pressure, columns = flow
    eta, val, _ = max_efficiency(curves, triangles, values, t, XX.ravel(), YY.ravel(),
                                 ranges, progress, p0, p1)
    shape = XX.shape
    return eta.reshape(shape), val.T.reshape((-1,) + shape)


def binned_map(curves, triangles, values, gx, gy, ranges, n_bary: int = 64, m_t: int = 128):
    """The paper's scatter-and-bin map (eqs. 62-71), NaN-initialised: baseline only."""
    t = np.linspace(0.0, 1.0, m_t + 1)
    Xs, Ys, Es = curves.sample(t)
    i, j = np.meshgrid(np.arange(n_bary + 1), np.arange(n_bary + 1), indexing="ij")
    keep = i + j <= n_bary
    U = np.stack([i[keep], j[keep], n_bary - i[keep] - j[keep]]).astype(float) / n_bary  # (3, K)
    nx, ny = len(gx), len(gy)
    x0, x1, y0, y1 = ranges
    best = np.full(nx * ny, -np.inf)
    values = np.asarray(values, dtype=float).reshape(curves.n, -1)
    b_val = np.full((nx * ny, values.shape[1]), np.nan)
    for tri in triangles:
        x = U.T @ Xs[tri]  # (K, M)
        y = U.T @ Ys[tri]
        e = U.T @ Es[tri]
        r = np.clip(np.floor((x - x0) / (x1 - x0) * nx), 0, nx - 1).astype(int)
        s = np.clip(np.floor((y - y0) / (y1 - y0) * ny), 0, ny - 1).astype(int)
        node = (s * nx + r).ravel()
        e = e.ravel()
        local = np.full(nx * ny, -np.inf)
        np.maximum.at(local, node, e)
        upd = local > best
        best[upd] = local[upd]
        winner = np.flatnonzero(upd[node] & (e == local[node]))
        kk = winner // x.shape[1]
        b_val[node[winner]] = U[:, kk].T @ values[tri]
    best[~np.isfinite(best)] = np.nan
    shape = (ny, nx)
    return best.reshape(shape), b_val.T.reshape((-1,) + shape)


def cross2(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _segment_distance(p: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Distance from points p (..., 2) to the closed triangles A (..., 3, 2) (0 inside)."""
    d = np.full(p.shape[:-1], np.inf)
    for e0, e1 in ((0, 1), (1, 2), (2, 0)):
        s0, ab = A[..., e0, :], A[..., e1, :] - A[..., e0, :]
        L2 = ab[..., 0] * ab[..., 0] + ab[..., 1] * ab[..., 1]
        ps = p - s0
        h = np.clip((ps[..., 0] * ab[..., 0] + ps[..., 1] * ab[..., 1])
                    / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        r = ps - h[..., None] * ab
        d = np.minimum(d, np.hypot(r[..., 0], r[..., 1]))
    a, b, c = A[..., 0, :], A[..., 1, :], A[..., 2, :]
    s1, s2, s3 = cross2(b - a, p - a), cross2(c - b, p - b), cross2(a - c, p - c)
    inside = (((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0)))
    inside &= np.abs(cross2(b - a, c - a)) > 0
    return np.where(inside, 0.0, d)


def distance_to_region(curves, triangles, t, X, Y, ranges) -> np.ndarray:
    """Distance (range-normalised units) from points to the reachable region, i.e. to the
    union over (triangle, t) of the triangles spanned by the vertex curve points.

    Branch and bound over blocks of consecutive t per triangle of settings: the distance to
    a block's bounding box is a lower bound, the exact distance to the few nearest blocks an
    upper bound, and only blocks whose lower bound beats a point's upper bound are
    evaluated exactly (10,000 points in well under a second instead of a dense sweep).
    """
    norm = _Normaliser(ranges)
    Xn, Yn = norm(np.asarray(X, float), np.asarray(Y, float))
    P = np.stack([Xn, Yn], axis=-1)
    Xs, Ys, _ = curves.sample(t)
    Xs, Ys = norm(Xs, Ys)
    M = len(t)
    nb = -(-M // _T_BLOCK)
    pad = nb * _T_BLOCK - M
    m_idx = np.concatenate([np.arange(M), np.full(pad, M - 1)])  # repeat the last sample
    A = np.stack([Xs[triangles][:, :, m_idx], Ys[triangles][:, :, m_idx]], axis=-1)
    A = A.transpose(0, 2, 1, 3).reshape(len(triangles) * nb, _T_BLOCK, 3, 2)  # blocks
    lo, hi = A.min(axis=(1, 2)), A.max(axis=(1, 2))  # (B, 2)
    out = np.empty(len(P))
    chunk = max(1, 2_000_000 // max(len(A), 1))
    for q0 in range(0, len(P), chunk):
        p = P[q0 : q0 + chunk]
        gap = np.maximum(lo[None] - p[:, None], 0.0) + np.maximum(p[:, None] - hi[None], 0.0)
        lb = np.hypot(gap[..., 0], gap[..., 1])  # (q, B) lower bounds
        k = min(3, lb.shape[1])
        near = np.argpartition(lb, k - 1, axis=1)[:, :k]
        ub = _segment_distance(p[:, None, None, :], A[near]).min(axis=(1, 2))
        qi, bi = np.nonzero(lb < ub[:, None])  # a block whose bound is the best found cannot lower it (inside: 0)
        best = ub.copy()
        for c0 in range(0, len(qi), 100_000):
            qq, bb = qi[c0 : c0 + 100_000], bi[c0 : c0 + 100_000]
            d = _segment_distance(p[qq][:, None, :], A[bb]).min(axis=1)
            np.minimum.at(best, qq, d)
        out[q0 : q0 + chunk] = best
    return out
