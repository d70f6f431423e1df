"""Stage 1 — local weighted polynomial fits (paper §2, outlier rules of §7).

For each probe point: weighted PCA of its neighbourhood gives a reference plane, a weighted
quadric z = ax² + by² + cxy + dx + ey + f over that plane gives the normal (of the graph at
the origin) and the shape operator S = G⁻¹H (§2.2), whose eigenpairs are the principal
curvatures and directions. The pipe radius is the median of 1/κmax (§3.1); probes whose
κmax is more than 10 % off 1/r, whose fit residual is abnormal or whose neighbourhood holds
fewer than 10 samples are classified as outliers (§7). All probes are solved at once
(batched numpy), neighbourhoods come from a k-d tree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


@dataclass
class LocalFits:
    normal: np.ndarray  # (M, 3) outward unit normals
    kmax: np.ndarray  # (M,) larger principal curvature (>0 on a tube)
    kmin: np.ndarray  # (M,)
    dir_min: np.ndarray  # (M, 3) principal direction of kmin (≈ spine tangent)
    sigma: np.ndarray  # (M,) weighted rms of the quadric fit
    count: np.ndarray  # (M,) neighbours inside the support
    ok: np.ndarray  # (M,) solvable fit


def mls_weights(d: np.ndarray, h: np.ndarray | float) -> np.ndarray:
    """Wendland-like monotone weight with support [0, h]."""
    u = np.clip(d / h, 0.0, 1.0)
    return (1.0 - u * u) ** 2


def neighbourhoods(tree: cKDTree, pts: np.ndarray, centres: np.ndarray, h: float, k: int):
    """Up to k nearest samples within h of each centre: (M, k, 3) points, distances, mask."""
    k = max(2, min(k, len(pts)))
    d, idx = tree.query(centres, k=k, distance_upper_bound=float(h))
    valid = np.isfinite(d)
    idx = np.where(valid, idx, 0)
    # (np.take gathers the rows several times faster than pts[idx]: the same copy)
    return np.take(pts, idx, axis=0), np.where(valid, d, np.inf), valid


def _weighted_gram(X: np.ndarray, w: np.ndarray, chunk: int = 1024) -> np.ndarray:
    """Σ_k w_mk X_mk X_mkᵀ for every m: (M, K, p), (M, K) -> (M, p, p), as batched products over a few probes
    at a time (the weighted copy of X stays small)."""
    out = np.empty((len(X), X.shape[2], X.shape[2]))
    for a in range(0, len(X), chunk):
        Xc = X[a:a + chunk]
        out[a:a + chunk] = np.matmul((Xc * w[a:a + chunk, :, None]).transpose(0, 2, 1), Xc)
    return out


def fit_quadrics(nb: np.ndarray, w: np.ndarray, centres: np.ndarray) -> LocalFits:
    """Batched weighted quadric fits; ``nb`` (M, K, 3), ``w`` (M, K) zero for absent points."""
    M = len(nb)
    count = (w > 0).sum(1)
    ws = w.sum(1, keepdims=True)
    ws_safe = np.where(ws > 0, ws, 1.0)
    bary = (w[..., None] * nb).sum(1) / ws_safe
    rel_b = nb - bary[:, None]
    # weighted scatter and normal equations as batched products (a three-operand einsum takes no BLAS path)
    cov = _weighted_gram(rel_b, w)
    _, vec = np.linalg.eigh(cov)  # ascending: vec[..., 0] = normal of the PCA plane
    e1, e2, e3 = vec[..., 2], vec[..., 1], vec[..., 0]
    rel = nb - centres[:, None]
    x = np.einsum("mki,mi->mk", rel, e1)
    y = np.einsum("mki,mi->mk", rel, e2)
    z = np.einsum("mki,mi->mk", rel, e3)
    A = np.stack([x * x, y * y, x * y, x, y, np.ones_like(x)], -1)  # (M, K, 6)
    AtA = _weighted_gram(A, w)
    Atz = np.einsum("mki,mk->mi", A, w * z)
    # a ridge on each column by its own size: the quadratic columns are h² times the linear ones, so a ridge
    # sized by the largest column would swamp them in metres (h ~ 1e-3) and not in millimetres
    diag = np.einsum("mii->mi", AtA)
    reg = 1e-10 * np.maximum(diag, 1e-300 + 1e-300 * diag.max(1, keepdims=True))[:, :, None] * np.eye(6)
    ok = count >= 6
    try:
        coef = np.linalg.solve(AtA + reg, Atz[..., None])[..., 0]
    except np.linalg.LinAlgError:
        coef = np.zeros((M, 6))
        for m in range(M):
            try:
                coef[m] = np.linalg.solve(AtA[m] + reg[m], Atz[m])
            except np.linalg.LinAlgError:
                ok[m] = False
    a, b, c, d, e, f = coef.T
    res = np.einsum("mki,mi->mk", A, coef) - z
    sigma = np.sqrt((w * res * res).sum(1) / ws_safe[:, 0])
    # §2.2: G = [[1+d², de], [de, 1+e²]], H = [[2a, c], [c, 2b]] / sqrt(1+d²+e²); S = G⁻¹H
    G = np.stack([np.stack([1 + d * d, d * e], -1), np.stack([d * e, 1 + e * e], -1)], -2)
    H = np.stack([np.stack([2 * a, c], -1), np.stack([c, 2 * b], -1)], -2) / np.sqrt(1 + d * d + e * e)[:, None, None]
    S = np.linalg.solve(G, H)
    tr = S[:, 0, 0] + S[:, 1, 1]
    det = S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
    disc = np.sqrt(np.maximum(tr * tr / 4 - det, 0.0))
    l1, l2 = tr / 2 + disc, tr / 2 - disc
    # dominant curvature = larger magnitude; the tube surface bends away from an outward normal
    dom = np.where(np.abs(l1) >= np.abs(l2), l1, l2)
    sub = np.where(np.abs(l1) >= np.abs(l2), l2, l1)
    nrm = np.stack([-d, -e, np.ones_like(d)], -1)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    n_world = nrm[:, :1] * e1 + nrm[:, 1:2] * e2 + nrm[:, 2:] * e3
    flip = dom > 0
    n_world[flip] *= -1
    kmax = np.abs(dom)
    kmin = np.where(flip, -sub, sub)
    # eigenvector of S for the subdominant eigenvalue, in the (∂x, ∂y) basis
    vx = S[:, 0, 1]
    vy = sub - S[:, 0, 0]
    alt = np.abs(vx) + np.abs(vy) < 1e-12 * (np.abs(S).sum((1, 2)) + 1e-300)
    vx = np.where(alt, sub - S[:, 1, 1], vx)
    vy = np.where(alt, S[:, 1, 0], vy)
    both0 = np.abs(vx) + np.abs(vy) < 1e-300
    vx = np.where(both0, 1.0, vx)
    dmin = vx[:, None] * (e1 + d[:, None] * e3) + vy[:, None] * (e2 + e[:, None] * e3)
    dmin /= np.linalg.norm(dmin, axis=1, keepdims=True)
    ok &= np.isfinite(kmax) & np.isfinite(dmin).all(1) & np.isfinite(n_world).all(1)
    return LocalFits(n_world, kmax, kmin, dmin, sigma, count, ok)


def fit_at(tree: cKDTree, pts: np.ndarray, probes: np.ndarray, h: float, k: int = 96) -> LocalFits:
    nb, d, valid = neighbourhoods(tree, pts, probes, h, k)
    w = np.where(valid, mls_weights(np.where(valid, d, h), h), 0.0)
    return fit_quadrics(nb, w, probes)


def knn_fit(tree: cKDTree, pts: np.ndarray, probes: np.ndarray, k: int = 40) -> LocalFits:
    """Scale-free first pass: support = distance to the k-th neighbour."""
    d, idx = tree.query(probes, k=min(k, len(pts)))
    h = d[:, -1:] * 1.0001 + 1e-300
    w = mls_weights(d, h)
    return fit_quadrics(np.take(pts, idx, axis=0), w, probes)


def classify(fits: LocalFits, pipe_radius: float) -> np.ndarray:
    """§7 outlier labels per probe: 0 ok, 1 too few neighbours, 2 curvature, 3 fit residual."""
    lab = np.zeros(len(fits.kmax), int)
    good = fits.ok & (fits.count >= 10)
    lab[~good] = 1
    dev = np.abs(fits.kmax * pipe_radius - 1.0)
    lab[good & (dev > 0.1)] = 2
    s_ref = np.median(fits.sigma[good]) if good.any() else 0.0
    mad = np.median(np.abs(fits.sigma[good] - s_ref)) if good.any() else 0.0
    lab[good & (dev <= 0.1) & (fits.sigma > s_ref + 6 * 1.4826 * mad + 1e-3 * pipe_radius)] = 3
    return lab
