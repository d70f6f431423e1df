"""Stage 2 — spine point cloud by MLS projection onto locally best-fitting cylinders (paper §3).

For each seed sample p: start point x = p − r·ν, start direction t = κmin direction (§3.3,
§3.4). Then, moving least squares: the weights are centred at the current projection x of
the point onto the cylinder axis, a weighted least-squares cylinder (geometric distance,
fixed or free radius) is fitted by Gauss–Newton, x is projected onto the new axis, and the
neighbourhood is gathered again around it. All seeds are solved at once (batched 4×4 / 5×5
normal equations). A seed whose final distance to its projection differs from the pipe
radius by more than 0.1·r is an outlier (§7).

Neighbourhood: a ball of radius 1.2·r_P about the axis point. The paper says
"1.2 r_B", but the paper's own check in §3.2 — "for a cylindrical point set this
neighbourhood is a cylinder with a height of about 1.3 r_P" and the 0.038 r_P worst-case
shrinkage on a torus — only holds for a ball of 1.2 r_P: 2·sqrt(1.2² − 1) r_P = 1.33 r_P.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.tube.local_fit import mls_weights, neighbourhoods


SEED_CHUNK = 128  # seeds fitted at once


@dataclass
class SpineCloud:
    points: np.ndarray  # (M, 3) projected axis points
    tangents: np.ndarray  # (M, 3)
    radius: np.ndarray  # (M,) fitted cylinder radius
    rms: np.ndarray  # (M,) weighted rms distance of the neighbourhood to its cylinder
    proj_error: np.ndarray  # (M,) | |p − x| − r |
    ok: np.ndarray  # (M,) converged and not an outlier


def _basis(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.where(np.abs(t[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    e1 = np.cross(t, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(t, e1)


def fit_cylinders(nb: np.ndarray, w0: np.ndarray, x: np.ndarray, t: np.ndarray, r: np.ndarray,
                  free_radius: bool, iters: int = 4, robust_scale: float | None = None):
    """Batched weighted Gauss–Newton cylinder fit (geometric distance).

    With ``robust_scale`` c the distance weights are multiplied by Cauchy weights
    1/(1 + (res/c)²) (IRLS): stray samples inside the tube would otherwise drag the axis."""
    w = w0
    M = len(x)
    x = x.copy(); t = t.copy(); r = r.copy()
    npar = 5 if free_radius else 4
    # component-major (M, 3, k) and (M, npar, k): every per-neighbour array below is contiguous, and the
    # batched products take contiguous operands (a strided (M, k, 3) layout costs a third more time)
    nb_t = np.ascontiguousarray(nb.transpose(0, 2, 1))
    J = np.empty((M, npar, nb.shape[1]))
    if free_radius:
        J[:, 4] = -1.0
    for _ in range(iters):
        e1, e2 = _basis(t)
        # the neighbours in the frame (t, e1, e2) of the axis, one batched product: along the axis s, and
        # the offset from it (a1, a2), whose direction is the distance's gradient
        c = np.matmul(np.stack([t, e1, e2], 1), nb_t - x[:, :, None])
        s, a1, a2 = c[:, 0], c[:, 1], c[:, 2]
        rho = np.sqrt(a1 * a1 + a2 * a2)
        inv = 1.0 / np.maximum(rho, 1e-300)
        np.multiply(-a1, inv, out=J[:, 0])
        np.multiply(-a2, inv, out=J[:, 1])
        np.multiply(s, J[:, 0], out=J[:, 2])
        np.multiply(s, J[:, 1], out=J[:, 3])
        res = rho - r[:, None]
        if robust_scale is not None:
            w = w0 / (1.0 + (res / robust_scale) ** 2)
        # weighted normal equations as batched products (a three-operand einsum takes no BLAS path)
        A = np.matmul(J * w[:, None], J.transpose(0, 2, 1)) + 1e-9 * np.eye(npar) * (w.sum(1)[:, None, None] + 1e-300)
        b = -np.matmul(J, (w * res)[..., None])
        try:
            step = np.linalg.solve(A, b)[..., 0]
        except np.linalg.LinAlgError:  # (one singular system holds this batch of seeds, :data:`SEED_CHUNK`)
            step = np.zeros((M, npar))
        # keep steps sane: a GN step larger than r means the local model broke down
        lim = np.maximum(np.abs(step[:, :2]).max(1) / (0.5 * r), 1.0)
        step = step / lim[:, None]
        x = x + step[:, :1] * e1 + step[:, 1:2] * e2
        t = t + step[:, 2:3] * e1 + step[:, 3:4] * e2
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        if free_radius:
            r = np.maximum(r + step[:, 4], 1e-6 * r)
    e1, e2 = _basis(t)
    c = np.matmul(np.stack([e1, e2], 1), nb_t - x[:, :, None])
    rho = np.sqrt(c[:, 0] ** 2 + c[:, 1] ** 2)
    ws = np.maximum(w.sum(1), 1e-300)
    rms = np.sqrt((w * (rho - r[:, None]) ** 2).sum(1) / ws)
    return x, t, r, rms


def mls_spine(tree: cKDTree, pts: np.ndarray, seeds: np.ndarray, normals: np.ndarray, tangents: np.ndarray,
              pipe_radius: float, free_radius: bool = True, support: float = 1.2, k: int = 96,
              outer: int = 2, tick=None) -> SpineCloud:
    """Project seed samples onto the MLS spine (§3 steps i–iii); ``tick(message)`` after each pass."""
    rp = float(pipe_radius)
    x = seeds - rp * normals
    t = tangents / np.linalg.norm(tangents, axis=1, keepdims=True)
    r = np.full(len(seeds), rp)
    rms, cnt = np.empty(len(seeds)), np.empty(len(seeds), int)
    # pass 1 free radius (the curvature-based radius is biased by a few %), then the radius is
    # fixed at the median: a free radius is ill-conditioned on a one-sided patch at tube ends
    schedule = [True] * (outer - 1 if free_radius else 0) + [False] * (2 if free_radius else outer)
    for it, free in enumerate(schedule):
        if it and free != schedule[it - 1]:
            rp = float(np.median(r[np.isfinite(r)]))
            r = np.full(len(seeds), rp)
        h = support * rp
        # a few seeds at a time: each seed's neighbourhood and fit are its own, and a chunk's (k, 3) arrays per
        # seed stay in the processor's cache (all seeds' at once are megabytes: the fits took twice as long)
        for a in range(0, len(seeds), SEED_CHUNK):
            c = slice(a, a + SEED_CHUNK)
            nb, d, valid = neighbourhoods(tree, pts, x[c], h, k)
            w = np.where(valid, mls_weights(np.where(valid, d, h), h), 0.0)
            x_new, t[c], r[c], rms[c] = fit_cylinders(nb, w, x[c], t[c], r[c], free, robust_scale=0.1 * rp)
            # MLS: project the current point onto the axis of its best cylinder
            x[c] = x_new + np.einsum("mi,mi->m", x[c] - x_new, t[c])[:, None] * t[c]
            cnt[c] = valid.sum(1)
        if tick is not None:
            tick(f"MLS spine projection, pass {it + 1} of {len(schedule)}")
    off = seeds - x
    dist = np.linalg.norm(off, axis=1)
    proj_error = np.abs(dist - rp)
    # the sample must also lie on the side its normal points to (a fit that jumped to another
    # part of the tube can still be r away)
    facing = np.einsum("ij,ij->i", off, normals) > 0.7 * np.maximum(dist, 1e-300)
    ok = (np.isfinite(x).all(1) & (cnt >= 10) & (proj_error <= 0.1 * rp)
          & (np.abs(r - rp) <= 0.25 * rp) & facing)
    return SpineCloud(x, t, r, rms, proj_error, ok)
