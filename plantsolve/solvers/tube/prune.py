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
from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.model import TubeModel, control_polygon, model_from_control_polygon, with_radii


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


def merged_at_corner(model: TubeModel, k: int) -> TubeModel:
    """Bends k and k+1 as one arc tangent to the straight before k and the one after k+1: the two corners of
    the control polygon replaced by the point where those lines meet (nearest point of the two lines), the
    radius as in :func:`merged`. Every other corner stays, so the tube after the pair does not move, as it
    does when the straight between the two arcs is dropped (:func:`merged`, also used when a bend of 170° or
    more has no corner)."""
    if np.any(model.angles >= np.radians(170.0)):
        return merged(model, k)
    pts, clr = control_polygon(model)
    a, b = pts[k + 1], pts[k + 2]
    u = (a - pts[k]) / max(np.linalg.norm(a - pts[k]), 1e-300)
    v = (pts[k + 3] - b) / max(np.linalg.norm(pts[k + 3] - b), 1e-300)
    w = a - b
    den = 1.0 - float(u @ v) ** 2
    if den < 1e-12:
        return merged(model, k)
    s = (float(u @ v) * float(v @ w) - float(u @ w)) / den
    t = (float(v @ w) - float(u @ v) * float(u @ w)) / den
    corner = 0.5 * ((a + s * u) + (b + t * v))
    m = model_from_control_polygon(np.vstack([pts[:k + 1], corner, pts[k + 3:]]),
                                   np.concatenate([clr[:k], [merged(model, k).radii[k]], clr[k + 2:]]), model.pipe_radius)
    if not np.all(np.isfinite(m.lengths)) or m.lengths[1:-1].min(initial=0.0) < -model.pipe_radius:
        return merged(model, k)
    m.lengths = np.maximum(m.lengths, 0.0)
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


def evidence_tolerance(n_samples: int, extra_parameters: int = 4) -> float:
    """The relative drop of the rms residual that the Bayesian information criterion asks of a model with
    ``extra_parameters`` more parameters (a bend's length, rotation, angle and radius):
    n ln(RSS/RSS') > dp ln n, i.e. rms/rms' > exp(dp ln n / 2n)."""
    n = max(n_samples, 2)
    return float(np.expm1(extra_parameters * np.log(n) / (2.0 * n)))


def split(model: TubeModel, k: int, fraction: float, radius: float, gap: float) -> TubeModel:
    """Initial guess for bend k as two bends in its plane: angles fraction and 1 - fraction of it, both of
    ``radius``, with a straight of ``gap`` between them (the rest of its arc length when the radius is
    smaller, so the tube keeps its extent)."""
    m = model.copy()
    A, R = m.angles[k], m.radii[k]
    L = list(m.lengths)
    mid = max(gap, R * A - radius * A) if radius < R else gap
    m.lengths = np.array(L[:k + 1] + [mid] + L[k + 1:])
    rots = list(m.rotations)
    m.rotations = np.array(rots[:k + 1] + [0.0] + rots[k + 1:])
    m.angles = np.concatenate([m.angles[:k], [A * fraction, A * (1 - fraction)], m.angles[k + 1:]])
    m.radii = np.concatenate([m.radii[:k], [radius, radius], m.radii[k + 1:]])
    return m


def split_candidates(model: TubeModel) -> list[tuple[str, int, TubeModel, bool]]:
    """Bends the spline stage may have merged: a large one (two nearly coplanar back-to-back bends) and one
    whose radius is far beyond the others' or the pipe's (two small bends far apart on one long arc). The
    last item marks a fallback: the same large bend split off-centre (0.4, 0.6), tried only when the even
    split before it showed some gain (:func:`split_by_evidence`)."""
    n = model.n_bends
    rp = model.pipe_radius
    out = []
    for k in range(n):
        others = np.delete(model.radii, k)
        typical = float(np.median(others)) if len(others) else 4.0 * rp
        if model.angles[k] > np.radians(150):
            for f in (0.5, 0.4, 0.6):
                out.append(("split", k, split(model, k, f, model.radii[k], 0.25 * rp), f != 0.5))
        if model.radii[k] > 3.0 * typical or (len(others) == 0 and model.radii[k] > 25.0 * rp):
            out.append(("split", k, split(model, k, 0.5, min(model.radii[k], max(typical, 4.0 * rp)), rp), False))
    return out


def split_by_evidence(model: TubeModel, refit, scale: float, max_tries: int = 8):
    """Splits of suspect bends (:func:`split_candidates`), each refitted in LRA parameters and kept when the
    Bayesian information criterion prefers the model with the extra bend (same samples for both)."""
    changes = []
    model, res = refit(model)
    model, res = refit(model)  # as converged as the candidates below (each refitted twice)
    cap = _cap(res, scale)
    sigma = _score(res, cap)
    tries = 0
    improved = True
    while improved and tries < max_tries:
        improved = False
        hopeless = set()  # bends whose even split gained under a quarter of the evidence at its first refit
        for kind, k, cand, fallback in split_candidates(model):
            if fallback and k in hopeless:
                continue
            tries += 1
            fitted, r = refit(cand)
            tol = evidence_tolerance(len(r))
            s = _score(r, cap)
            # the second refit settles a candidate that the first has brought near the evidence asked for;
            # one whose first refit gained less than half of it is no split (a split the spline stage merged
            # gains over ten times that at once, a bend that is one arc a few hundredths of it), and a bend
            # whose even split gains less than a quarter of it is one arc: its off-centre splits start no
            # nearer two bends (each costs a refit)
            if not fallback and s * (1 + 0.25 * tol) >= sigma:
                hopeless.add(k)
            if s * (1 + 0.5 * tol) < sigma:
                fitted, r = refit(fitted)
            s = _score(r, cap)
            if s * (1 + tol) + 1e-4 * scale < sigma:
                changes.append({"change": kind, "bend": k + 1, "score_before": sigma, "score_after": s})
                model, sigma = fitted, s
                improved = True
                break
            if tries >= max_tries:
                break
    return model, changes


def off_die(model: TubeModel, factor: float = 3.0) -> list[int]:
    """Bends whose radius is more than ``factor`` times off the die the other bends share (the median of
    their radii), farthest first. A bender has few dies; such a radius is what a fit gives a bend that
    the samples do not hold (a sliver left by a split, half of a bend cut in two)."""
    n = model.n_bends
    if n < 2:
        return []
    off = [(abs(float(np.log(model.radii[k] / np.median(np.delete(model.radii, k))))), k) for k in range(n)]
    return [k for d, k in sorted(off, reverse=True) if d > np.log(factor)]


def adjacent_small_pairs(model: TubeModel, eps: float, small_deg: float = 20.0, factor: float = 3.0) -> list[int]:
    """Each k where bends k and k+1 are both under ``small_deg``, joined by a straight shorter than a pipe
    radius (or ε), and on one die: neither off the others' die (:func:`off_die`) and their radii within
    ``factor`` of each other. A bend cut in two by a split on the subsample leaves such a pair, both halves
    near the die, so the off-die re-check does not see it."""
    off = set(off_die(model, factor))
    small = model.angles < np.radians(small_deg)
    gap = max(eps, model.pipe_radius)
    return [k for k in range(model.n_bends - 1)
            if small[k] and small[k + 1] and model.lengths[k + 1] < gap and not {k, k + 1} & off
            and abs(float(np.log(model.radii[k] / model.radii[k + 1]))) <= np.log(factor)]


def recheck_candidates(model: TubeModel, eps: float) -> list[tuple[str, int, TubeModel]]:
    """The model without each off-die bend (:func:`off_die`) of under 20 degrees, with each off-die bend
    merged into a neighbour it touches (a straight shorter than half a pipe radius, or ε, between), and with
    each pair of adjacent small bends on one die merged (:func:`adjacent_small_pairs`)."""
    out, seen = [], set()
    n = model.n_bends
    for k in off_die(model):
        if model.angles[k] < np.radians(20):
            out.append(("remove", k, without_bend(model, k)))
        for j in (k - 1, k):
            if 0 <= j < n - 1 and j not in seen and model.lengths[j + 1] < max(eps, 0.5 * model.pipe_radius):
                seen.add(j)
                out.append(("merge", j, merged_at_corner(model, j)))
    for j in adjacent_small_pairs(model, eps):
        if j not in seen:
            seen.add(j)
            out.append(("merge", j, merged_at_corner(model, j)))
    return out


def pair_merge_candidates(model: TubeModel, eps: float) -> list[tuple[str, int, TubeModel]]:
    """Each pair of adjacent small bends on one die (:func:`adjacent_small_pairs`) merged into one arc."""
    return [("merge", j, merged_at_corner(model, j)) for j in adjacent_small_pairs(model, eps)]


def nearest_die(radii: np.ndarray, die_radii) -> tuple[int, ...]:
    """The die (index into ``die_radii``) nearest each radius, in log radius."""
    logd = np.log(np.asarray(die_radii, float))
    return tuple(int(np.argmin(np.abs(np.log(r) - logd))) for r in np.asarray(radii, float))


def recheck_by_bic(fitted: tuple, refit, bic, eps: float, max_tries: int = 6, candidates=recheck_candidates):
    """Every split and merge decision taken on the subsample, re-checked on the final fit: each of
    ``candidates(model, eps)`` (by default :func:`recheck_candidates`) is refitted and kept when the Bayesian
    information criterion of the model with one bend fewer is no worse (``bic(model)``: the same samples
    for every model). ``fitted`` and ``refit(model)`` are tuples whose first item is the model (the rest
    travels with it). Returns the kept tuple and the changes."""
    model = fitted[0]
    b = bic(model)
    changes = []
    tries = 0
    improved = True
    while improved and tries < max_tries:
        improved = False
        for kind, k, cand in candidates(model, eps):
            tries += 1
            out = refit(cand)
            bc = bic(out[0])
            if bc <= b:
                changes.append({"change": kind, "bend": k + 1, "bic_before": b, "bic_after": bc})
                fitted, model, b = out, out[0], bc
                improved = True
                break
            if tries >= max_tries:
                break
    return fitted, changes


def recheck_on_fit(fitted: tuple, P: np.ndarray, thr: float, margin: float, fit_pipe_radius: bool, rounds, eps: float,
                   radius_mode: str = "free", assignment=None):
    """The bend count re-checked on a fit of the samples ``P`` (:func:`recheck_by_bic`): BIC n ln(RSS/n) + p ln n
    over the samples within ``thr`` of the fit so far, each candidate refitted by ``rounds`` (two rounds of
    at most 30 evaluations) as that fit was.

    ``radius_mode`` is the fit's bend radius model. 'free' (a radius per bend) re-checks every split and merge
    taken on the subsample (:func:`recheck_candidates`). 'common' or 'dies' (one or two shared radii)
    re-checks adjacent small bends on one die as one bend (:func:`pair_merge_candidates`), each candidate
    refitted with its radii held to the die(s), so that no free radius of a bend of a few degrees can run off
    during the comparison. ``fitted`` is the fit's tuple (model first); returns the kept tuple and the changes
    (the tuple's last item is the candidate's radius mode when the radii are held). ``assignment(m, P)``:
    ``fit.assign(m, P, margin)`` (the caller's, which may have it at hand)."""
    model = fitted[0]
    held = radius_mode in ("common", "dies")
    die_radii = []
    if held:
        die_radii = sorted({round(float(r), 9) for r in model.radii}) if radius_mode == "dies" else [float(model.radii[0])]
    keep = np.abs((assignment or (lambda m, Q: fit.assign(m, Q, margin)))(model, P)[0]) <= thr
    N = int(keep.sum())

    def dies_of(m: TubeModel) -> tuple[int, ...]:
        return nearest_die(m.radii, die_radii) if radius_mode == "dies" else ()

    def bic(m: TubeModel) -> float:
        r = fit.assign(m, P[keep], margin)[0]
        p = fit.Layout(m.n_bends, radius_mode, None, fit_pipe_radius, dies_of(m)).size
        return float(N * np.log(max(float(r @ r), 1e-300) / N) + p * np.log(N))

    def refit(m: TubeModel):
        if not held:
            return rounds(m, P, thr, 2, 30)
        d = dies_of(m)
        m_held = with_radii(m, np.asarray(die_radii)[list(d)] if d else np.full(m.n_bends, die_radii[0]))
        mode = {"radius_mode": radius_mode, "dies": d} if d else {"radius_mode": radius_mode}
        m2, info, t2, _ = rounds(m_held, P, thr, 2, 30, **mode)
        return m2, info, t2, mode

    return recheck_by_bic(fitted, refit, bic, eps, candidates=pair_merge_candidates if held else recheck_candidates)
