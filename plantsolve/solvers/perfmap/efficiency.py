"""Efficiency curves eta(t), with the physical bounds 0 <= eta <= 1 holding exactly on [0, 1].

Families: the paper's linear ones (parabola, cubic, spline2, spline3; section 2) and, beyond
the paper, ``parabola_log``: eta(t) = sum_k c_k B_k^2(t) + a log(beta - t), a >= 0, beta > 1.
Near choke a speed line turns vertical: the flow hardly changes while the efficiency
collapses (N+3 fan map: 0.68 -> 0.26 over 2 % of the flow range). Polynomials in the flow
cannot follow that and overshoot at the peak (an efficiency of 1.02 on the real map); the log
term has exactly that singular slope a / (beta - t), the same mechanism as the paper's log
pressure family (eq. 9). For fixed beta the family is linear, so beta is profiled.

Bounds on the control values alone (convex-hull property) would be sufficient but far too
strict: a peaked curve needs control values above its peak (on the N+3 map they double the
error of the settings near choke). So the bounds are imposed on the curve itself by an
exchange (cutting-plane) method: fit, find the curve's exact extrema (piece ends and roots of
the derivative, which is a polynomial of degree <= 2 for every family, after multiplying by
(beta - t) for parabola_log), add each violated extremum as a constraint 0 <= d(t_k) . c <= 1
and refit. Each refit is a least-squares problem with linear inequality constraints, solved
exactly by Lawson & Hanson's LSI -> LDP -> NNLS reduction (Solving Least Squares Problems,
1974, ch. 23), or a linear programme (HiGHS) for minimax. Optional concavity (second
differences of the polynomial control values <= 0) enters the same constraint matrix. A last
shift by at most the solver tolerance makes the bounds hold to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, linprog, minimize_scalar, nnls

from plantsolve.solvers.perfmap.families import basis, bernstein

ETA_LO, ETA_HI = 0.0, 1.0
LINEAR_EFFICIENCY = ("parabola", "cubic", "spline2", "spline3")
EFFICIENCY_FAMILIES = LINEAR_EFFICIENCY + ("parabola_log",)
N_EFF_COEFFICIENTS = {"parabola": 3, "cubic": 4, "spline2": 4, "spline3": 5, "parabola_log": 5}
_BOUND_MARGIN = 1e-12  # the final curve stays inside [lo + m, hi - m]: round-off safe
_MAX_CUTS = 40
_BETA_GRID = 1.0 + np.logspace(-6.0, 3.0, 181)  # beta - 1, in units of the flow span


@dataclass
class EfficiencyFit:
    family: str
    params: np.ndarray  # control values; parabola_log: (c0, c1, c2, a, beta)
    active_bounds: int = 0  # bound cuts used (the physical bounds pushed back the fit)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        return design(self.family, t, self._beta()) @ self._linear()

    def _beta(self):
        return self.params[4] if self.family == "parabola_log" else None

    def _linear(self):
        return self.params[:4] if self.family == "parabola_log" else self.params


def design(family: str, t: np.ndarray, beta: float | None = None) -> np.ndarray:
    """Matrix whose product with the linear coefficients gives eta(t)."""
    t = np.asarray(t, dtype=float).ravel()
    if family == "parabola_log":
        return np.column_stack([bernstein(2, t), np.log(beta - t)])
    return basis(family, t)


# ---------------------------------------------------------------- exact extrema


def _roots_quadratic(A: float, B: float, C: float) -> np.ndarray:
    """Real roots of A t^2 + B t + C (any of A, B may vanish)."""
    scale = max(abs(A), abs(B), abs(C), 1e-300)
    if abs(A) <= 1e-14 * scale:
        return np.array([-C / B]) if abs(B) > 1e-14 * scale else np.zeros(0)
    disc = B * B - 4.0 * A * C
    if disc < 0:
        return np.zeros(0)
    q = -0.5 * (B + np.copysign(np.sqrt(disc), B))  # stable form
    return np.array([q / A, C / q]) if q != 0 else np.array([0.0])


def _stationary_points(family: str, c: np.ndarray) -> list[float]:
    """Parameters in (0, 1) where d eta / dt = 0, plus the knots."""
    out: list[float] = []
    if family == "parabola":
        out += list(_roots_quadratic(0.0, c[2] - 2 * c[1] + c[0], c[1] - c[0]))
    elif family == "cubic":
        d = np.diff(c)
        out += list(_roots_quadratic(d[0] - 2 * d[1] + d[2], 2 * (d[1] - d[0]), d[0]))
    elif family in ("spline2", "spline3"):
        K = 2 if family == "spline2" else 3
        out += [j / K for j in range(1, K)]
        for j in range(K):  # piece j: derivative (c_{j+1} - c_j) + u (c_j - 2 c_{j+1} + c_{j+2})
            for u in _roots_quadratic(0.0, c[j] - 2 * c[j + 1] + c[j + 2], c[j + 1] - c[j]):
                if 0.0 < u < 1.0:
                    out.append((j + u) / K)
    else:  # (p + q t)(beta - t) - a = 0 with eta' = p + q t - a / (beta - t)
        c0, c1, c2, a, beta = c
        p, q = 2 * (c1 - c0), 2 * (c2 - 2 * c1 + c0)
        out += list(_roots_quadratic(-q, q * beta - p, p * beta - a))
    return [float(v) for v in out if 0.0 < v < 1.0]


def curve_extrema(family: str, params: np.ndarray) -> tuple[float, float, float, float]:
    """Exact (t_min, min, t_max, max) of the efficiency curve over t in [0, 1]."""
    params = np.asarray(params, dtype=float)
    tc = np.array([0.0, 1.0] + _stationary_points(family, params))
    beta = params[4] if family == "parabola_log" else None
    lin = params[:4] if family == "parabola_log" else params
    v = design(family, tc, beta) @ lin
    i, k = int(np.argmin(v)), int(np.argmax(v))
    return float(tc[i]), float(v[i]), float(tc[k]), float(v[k])


# ---------------------------------------------------------------- constrained solvers


def lsi(A: np.ndarray, b: np.ndarray, G: np.ndarray, h: np.ndarray) -> np.ndarray | None:
    """argmin ||A x - b|| subject to G x >= h (Lawson & Hanson ch. 23); None if infeasible.

    With A = Q R and u = R x - Q^T b the problem is the least-distance programme
    min ||u|| s.t. (G R^-1) u >= h - G R^-1 Q^T b, whose solution is the normalised residual
    of one non-negative least-squares problem. A (numerically) rank-deficient A gets a tiny
    ridge towards its minimum-norm least-squares solution so that R is invertible.
    """
    n = A.shape[1]
    if len(h) == 0:  # (scipy's nnls aborts the process on an empty matrix)
        return np.linalg.lstsq(A, b, rcond=None)[0]
    Q, R = np.linalg.qr(A)
    diag = np.abs(np.diag(R))
    if A.shape[0] < n or diag.min() <= 1e-10 * max(diag.max(), 1e-300):
        lam = 1e-8 * max(float(np.linalg.norm(A)), 1.0)
        x0 = np.linalg.lstsq(A, b, rcond=None)[0]
        A = np.vstack([A, lam * np.eye(n)])
        b = np.concatenate([b, lam * x0])
        Q, R = np.linalg.qr(A)
    f = Q.T @ b
    Rinv = np.linalg.solve(R, np.eye(n))  # (n <= 5; scipy's solve_triangular costs ms per call)
    E = G @ Rinv
    g = h - E @ f
    M = np.vstack([E.T, g[None, :]])
    d = np.zeros(n + 1)
    d[-1] = 1.0
    w = nnls(M, d, maxiter=50 * max(M.shape))[0]
    r = M @ w - d
    if abs(r[-1]) <= 1e-14:
        return None
    return Rinv @ (-r[:n] / r[-1] + f)


def _minimax_constrained(B, y, w, G, h) -> np.ndarray | None:
    """argmin max_i w_i |B c - y|_i subject to G c >= h (LP in (c, e))."""
    n = B.shape[1]
    ones = np.ones((len(y), 1))
    WB = B * w[:, None]
    A_ub = np.vstack([np.hstack([WB, -ones]), np.hstack([-WB, -ones]),
                      np.hstack([-G, np.zeros((len(h), 1))])])
    b_ub = np.concatenate([y * w, -y * w, -h])
    cost = np.zeros(n + 1)
    cost[-1] = 1.0
    res = linprog(cost, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * n + [(0.0, None)],
                  method="highs")
    return res.x[:n] if res.status == 0 else None


def _shape_constraints(family: str, concave: bool) -> np.ndarray:
    """Rows G with G c >= 0: concavity of the (polynomial part's) control values, a >= 0."""
    n_lin = 4 if family == "parabola_log" else N_EFF_COEFFICIENTS[family]
    n_poly = 3 if family == "parabola_log" else n_lin
    rows = []
    if concave:
        for i in range(n_poly - 2):
            r = np.zeros(n_lin)
            r[i : i + 3] = (-1.0, 2.0, -1.0)
            rows.append(r)
    if family == "parabola_log":
        r = np.zeros(n_lin)
        r[3] = 1.0
        rows.append(r)
    return np.array(rows).reshape(-1, n_lin)


def _squeeze_inside(family: str, params: np.ndarray, extrema=None) -> np.ndarray:
    """Shift (or, if both bounds are violated, shrink about the middle) the polynomial part
    by the solvers' tolerance so the exact extrema lie in [lo + margin, hi - margin].
    Partition of unity makes a shift of the control values a shift of the curve (shape,
    concavity, the log term unchanged)."""
    lo_m, hi_m = ETA_LO + _BOUND_MARGIN, ETA_HI - _BOUND_MARGIN
    _, vmin, _, vmax = curve_extrema(family, params) if extrema is None else extrema
    if lo_m <= vmin and vmax <= hi_m:
        return params
    p = params.copy()
    k = 3 if family == "parabola_log" else len(p)
    if vmax > hi_m and vmin - (vmax - hi_m) >= lo_m:
        p[:k] -= vmax - hi_m
    elif vmin < lo_m and vmax + (lo_m - vmin) <= hi_m:
        p[:k] += lo_m - vmin
    elif vmax > hi_m or vmin < lo_m:  # pathological; shrink the whole curve about the middle
        mid = 0.5 * (lo_m + hi_m)
        s = min(1.0, (hi_m - mid) / max(vmax - mid, 1e-300), (mid - lo_m) / max(mid - vmin, 1e-300))
        p[:k] = mid + s * (p[:k] - mid)
        if family == "parabola_log":
            p[3] *= s
    return p


def _fit_fixed(family: str, t, eta, minimax: bool, concave: bool, beta=None, D=None):
    """Bounded fit for a linear family (or parabola_log at fixed beta).
    Returns (params, n_cuts, objective)."""
    D = design(family, t, beta) if D is None else D
    n = D.shape[1]
    G0 = _shape_constraints(family, concave)
    w = 1.0 / np.abs(eta)

    def solve(G, h):
        if minimax:
            return _minimax_constrained(D, eta, w, G, h)
        return lsi(D, eta, G, h)

    def full(lin):
        return lin if beta is None else np.concatenate([lin, [beta]])

    c = None
    if not minimax:  # usually the shape constraints are inactive: plain least squares
        c = np.linalg.lstsq(D, eta, rcond=None)[0]
        if len(G0) and (G0 @ c).min() < 0:
            c = None
    if c is None:
        c = solve(G0, np.zeros(len(G0)))
    if c is None:
        c = np.linalg.lstsq(D, eta, rcond=None)[0]
    cuts_lo: list[float] = []
    cuts_hi: list[float] = []
    ext = None
    for _ in range(_MAX_CUTS):
        ext = tmin, vmin, tmax, vmax = curve_extrema(family, full(c))
        new = False
        if vmax > ETA_HI + 1e-12:
            cuts_hi.append(tmax)
            new = True
        if vmin < ETA_LO - 1e-12:
            cuts_lo.append(tmin)
            new = True
        if not new:
            break
        Dh = design(family, np.array(cuts_hi), beta) if cuts_hi else np.zeros((0, n))
        Dl = design(family, np.array(cuts_lo), beta) if cuts_lo else np.zeros((0, n))
        G = np.vstack([G0, -Dh, Dl])
        h = np.concatenate([np.zeros(len(G0)), -ETA_HI * np.ones(len(Dh)),
                            ETA_LO * np.ones(len(Dl))])
        nxt = solve(G, h)
        if nxt is None:  # cannot happen for [0, 1] (a constant is feasible); be safe
            break
        c = nxt
        ext = None
    params = _squeeze_inside(family, full(c), ext)
    r = D @ (params[:4] if beta is not None else params) - eta
    obj = float(np.max(np.abs(r) * w)) if minimax else float(r @ r)
    return params, len(cuts_lo) + len(cuts_hi), obj


def _beta_profile(t: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """SSE of the least-squares parabola_log fit (a >= 0, no bounds) for every beta of the grid,
    vectorised: project the log column and the data on the complement of the parabola."""
    Q, _ = np.linalg.qr(bernstein(2, t))
    r0 = eta - Q @ (Q.T @ eta)
    L = np.log(_BETA_GRID[:, None] - t[None, :])
    L = L - (L @ Q) @ Q.T
    ll = np.einsum("ij,ij->i", L, L)
    lr = L @ r0
    a = np.where(ll > 0, lr / np.where(ll > 0, ll, 1.0), 0.0)
    gain = np.where(a > 0, a * lr, 0.0)  # a < 0 is infeasible: the constraint is active, a = 0
    return float(r0 @ r0) - gain


def fit_parabola_log(t, eta, minimax: bool, concave: bool, polish: bool = True):
    sse = _beta_profile(t, eta)
    k = int(np.argmin(sse))
    if not polish:
        return _fit_fixed("parabola_log", t, eta, minimax, concave, _BETA_GRID[k])
    best = _fit_fixed("parabola_log", t, eta, minimax, concave, _BETA_GRID[k])
    if not minimax and best[1] == 0:
        polished = _gauss_newton_polish(t, eta, concave, best)
        if polished is not best:  # converged to an admissible optimum: done
            return polished
    lo = np.log(_BETA_GRID[max(k - 1, 0)] - 1.0)
    hi = np.log(_BETA_GRID[min(k + 1, len(_BETA_GRID) - 1)] - 1.0)
    res = minimize_scalar(
        lambda s: _fit_fixed("parabola_log", t, eta, minimax, concave, 1.0 + np.exp(s))[2],
        bounds=(lo, hi), method="bounded", options={"xatol": 1e-6})
    cand = _fit_fixed("parabola_log", t, eta, minimax, concave, 1.0 + np.exp(res.x))
    best = cand if cand[2] < best[2] else best
    if not minimax and best[1] == 0:
        best = _gauss_newton_polish(t, eta, concave, best)
    return best


def _gauss_newton_polish(t, eta, concave: bool, fit):
    """Levenberg-Marquardt on (c0, c1, c2, a, log(beta - 1)) from the profiled fit: the
    bounded scalar search in beta stops at ~sqrt(eps), this converges quadratically, so data
    from the family are recovered to round-off. Kept only if it stays admissible."""
    params, cuts, sse = fit
    B = bernstein(2, t)

    def resid(q):
        return B @ q[:3] + q[3] * np.log(1.0 + np.exp(q[4]) - t) - eta

    def jac(q):
        bb = 1.0 + np.exp(q[4])
        return np.column_stack([B, np.log(bb - t), q[3] * np.exp(q[4]) / (bb - t)])

    q0 = np.concatenate([params[:4], [np.log(params[4] - 1.0)]])
    try:
        with np.errstate(all="ignore"):  # trial steps may leave beta > 1: rejected below
            sol = least_squares(resid, q0, jac=jac, method="lm", xtol=1e-15, ftol=1e-15,
                                gtol=1e-15, max_nfev=100)
    except (ValueError, FloatingPointError):
        return fit
    q = sol.x
    cand = np.concatenate([q[:4], [1.0 + np.exp(q[4])]])
    if not (np.all(np.isfinite(cand)) and cand[3] >= 0 and cand[4] > 1.0):
        return fit
    if concave and cand[0] - 2 * cand[1] + cand[2] > 0:
        return fit
    _, vmin, _, vmax = curve_extrema("parabola_log", cand)
    cand_sse = float(np.sum(resid(q) ** 2))
    if not (np.isfinite(cand_sse) and vmin >= ETA_LO + _BOUND_MARGIN
            and vmax <= ETA_HI - _BOUND_MARGIN and cand_sse <= sse):
        return fit
    return cand, cuts, cand_sse


def fit_eta(family: str, t, eta, minimax: bool, concave: bool, B=None,
            polish: bool = True) -> EfficiencyFit:
    """Efficiency curve of one setting with 0 <= eta <= 1 exactly (and concave if asked)."""
    if family == "parabola_log":
        params, cuts, _ = fit_parabola_log(t, eta, minimax, concave, polish)
    else:
        params, cuts, _ = _fit_fixed(family, t, eta, minimax, concave, D=B)
    return EfficiencyFit(family, params, cuts)


def _closed_form_loo(family: str, B: np.ndarray, eta: np.ndarray, concave: bool,
                     left_out: np.ndarray) -> dict[int, float]:
    """Predictions at the left-out points whose unconstrained leave-one-out fit (hat-matrix
    identity c_(i) = c - (B^T B)^-1 b_i r_i / (1 - h_ii)) already satisfies the bounds and
    the shape constraints: then it IS the constrained fit. Others are left to refits."""
    BtB = B.T @ B
    try:
        M = np.linalg.inv(BtB)
    except np.linalg.LinAlgError:
        return {}
    c = M @ (B.T @ eta)
    r = eta - B @ c
    MB = B @ M  # rows: (M b_i)^T
    h = np.einsum("ij,ij->i", MB, B)
    out = {}
    G0 = _shape_constraints(family, concave)
    for i in left_out:
        if h[i] >= 1.0 - 1e-10:
            continue
        ci = c - MB[i] * (r[i] / (1.0 - h[i]))
        if len(G0) and (G0 @ ci).min() < 0:
            continue
        if ci.min() < ETA_LO or ci.max() > ETA_HI:  # convex hull inconclusive: exact check
            _, vmin, _, vmax = curve_extrema(family, ci)
            if vmin < ETA_LO + _BOUND_MARGIN or vmax > ETA_HI - _BOUND_MARGIN:
                continue
        out[int(i)] = float(B[i] @ ci)
    return out


def eta_leave_one_out(family: str, t, eta, concave: bool, left_out: np.ndarray):
    """(max relative, max absolute) error of each left-out point predicted by a bounded
    least-squares fit to the others (same parametrisation t); None when too few points."""
    n = len(t)
    if n - 1 < N_EFF_COEFFICIENTS[family]:
        return None, None
    B = None if family == "parabola_log" else basis(family, t)
    known = {} if B is None else _closed_form_loo(family, B, eta, concave, left_out)
    rel = ab = 0.0
    for i in left_out:
        if i in known:
            pred = known[i]
        else:
            keep = np.arange(n) != i
            f = fit_eta(family, t[keep], eta[keep], False, concave,
                        None if B is None else B[keep], polish=False)
            pred = float(f(t[i : i + 1])[0])
        err = abs(pred - eta[i])
        rel, ab = max(rel, err / abs(eta[i])), max(ab, err)
    return rel, ab
