"""Removing superfluous bends after the least-squares fit (beyond the paper).

Algorithm 1 is minimal only for its estimated tangent lines (§4.1); a poor chord at a
junction or a noisy stretch can cost an extra arc (a tiny bend, or one bend split into two
coplanar arcs). The paper's goal is the fewest segments that explain the data, so every
bend that looks superfluous — angle under 20°, or two arcs joined without a straight in
nearly the same plane — is tried away: the reduced model is refitted by least squares and
kept when its truncated rms residual rises by less than ``rel_tol`` (a real bend, even a
3° one between long legs, raises it by far more than the few per cent of sampling noise).
"""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.geometry import rotate_about, wrap_angle
from plantsolve.solvers.tube.geometry import TubeModel


def without_bend(model: TubeModel, k: int) -> TubeModel:
    """Initial guess for the tube without bend k (its straights joined)."""
    m = model.copy()
    n = m.n_bends
    L = m.lengths
    joined = L[k] + m.radii[k] * m.angles[k] + L[k + 1]
    m.lengths = np.concatenate([L[:k], [joined], L[k + 2:]])
    rots = m.rotations.copy()
    if k + 1 < n:
        rots[k + 1] = wrap_angle(rots[k + 1] + rots[k])
    rots = np.delete(rots, k)
    if k == 0 and n > 1:
        # the start frame carries the first bend plane: turn it to the new first bend
        x = m.frame[:, 0]
        y = rotate_about(m.frame[:, 1], x, rots[0])
        m.frame = np.column_stack([x, y, np.cross(x, y)])
        rots[0] = 0.0
    if n == 1:
        rots = np.zeros(1)
    m.rotations = rots
    m.angles = np.delete(m.angles, k)
    m.radii = np.delete(m.radii, k)
    return m


def merged(model: TubeModel, k: int) -> TubeModel:
    """Bends k and k+1 as one arc (they touch and lie in nearly one plane)."""
    m = model.copy()
    a = m.angles[k] + m.angles[k + 1]
    R = (m.radii[k] * m.angles[k] + m.radii[k + 1] * m.angles[k + 1]) / a
    m.lengths = np.delete(m.lengths, k + 1)
    rots = m.rotations.copy()
    if k + 2 < m.n_bends:
        rots[k + 2] = wrap_angle(rots[k + 2] + rots[k + 1])  # keep the later bend planes in place
    m.rotations = np.delete(rots, k + 1)
    m.angles = np.concatenate([m.angles[:k], [min(a, 2 * np.pi - 1e-3)], m.angles[k + 2:]])
    m.radii = np.concatenate([m.radii[:k], [R], m.radii[k + 2:]])
    return m


def candidates(model: TubeModel, eps: float) -> list[tuple[str, int, TubeModel]]:
    """Coplanar touching arcs first, then small bends, then any bend touching another."""
    out = []
    n = model.n_bends
    # "touching": joined by a straight shorter than half a pipe radius (or ε)
    touching = [k for k in range(n - 1) if model.lengths[k + 1] < max(eps, 0.5 * model.pipe_radius)]
    for k in touching:
        if abs(wrap_angle(model.rotations[k + 1])) < np.radians(25):
            out.append(("merge", k, merged(model, k)))
    small = [int(k) for k in np.argsort(model.angles) if model.angles[k] < np.radians(20)]
    for k in small:
        out.append(("remove", k, without_bend(model, k)))
    for k in touching:
        if abs(wrap_angle(model.rotations[k + 1])) >= np.radians(25):
            out.append(("merge", k, merged(model, k)))
    near = sorted({k for t in touching for k in (t, t + 1)} - set(small), key=lambda k: model.angles[k])
    for k in near:
        out.append(("remove", k, without_bend(model, k)))
    return out


def _cap(res: np.ndarray, scale: float) -> float:
    r0 = res - np.median(res)
    return max(6.0 * 1.4826 * float(np.median(np.abs(r0))), 0.05 * scale)


def _score(res: np.ndarray, cap: float) -> float:
    return float(np.sqrt(np.mean(np.minimum(res * res, cap * cap))))


def select(fitted: list[tuple[float, TubeModel, np.ndarray]], scale: float, rel_tol: float = 0.03) -> int:
    """Index of the fitted model with the fewest bends among those whose truncated rms is
    within ``rel_tol`` of the best (residuals of the same samples for all)."""
    cap = min(_cap(r, scale) for _, _, r in fitted)
    scores = [_score(r, cap) for _, _, r in fitted]
    best = min(scores)
    ok = [i for i, s in enumerate(scores) if s <= best * (1 + rel_tol) + 1e-4 * scale]
    return min(ok, key=lambda i: (fitted[i][1].n_bends, scores[i]))


def prune(model: TubeModel, refit, eps: float, scale: float, rel_tol: float = 0.03, max_tries: int = 16):
    """Greedy pruning. ``refit(model) -> (model, residuals)`` refits a candidate and returns
    the residuals of the same fixed sample set. The score is a truncated rms (residuals
    capped at 6 σ of the starting model, at least 0.05·``scale``), so a candidate cannot look good by losing part
    of the tube to the outliers. Returns the final model, its score and the changes."""
    model, res = refit(model)
    cap = _cap(res, scale)

    def score(r):
        return _score(r, cap)

    sigma = score(res)
    changes = []
    tries = 0
    improved = True
    while improved and model.n_bends and tries < max_tries:
        improved = False
        for kind, k, cand in candidates(model, eps):
            tries += 1
            fitted, r = refit(cand)
            s = score(r)
            if sigma * (1 + rel_tol) < s <= sigma * 2.0:
                # promising but maybe not converged from its rough start: refit once more
                fitted, r = refit(fitted)
                s = score(r)
            if s <= sigma * (1 + rel_tol) + 1e-4 * scale:
                changes.append({"change": kind, "bend": k + 1, "score_before": sigma, "score_after": s})
                model, sigma = fitted, s
                improved = True
                break
            if tries >= max_tries:
                break
    return model, sigma, changes
