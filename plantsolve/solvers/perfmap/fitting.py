"""Fitting one characteristic (paper section 2) with exact side conditions.

Least squares (paper eq. 3) for the linear families is solved after the change of variables
of :mod:`families` as a bound-constrained problem: the free variables are projected out and
the rest is a non-negative least-squares problem (``scipy.optimize.nnls``, an active-set
method, so the result satisfies the side conditions exactly and is exact to round-off).
Minimax (beyond the paper) is a linear programme (``scipy.optimize.linprog``/HiGHS).

The log family (paper section 2.2, eqs. 9-13) is linear in (a, c) for fixed b, so b is found by
profiling as in the paper — but on a log-spaced grid of ``b - x_max`` refined by a bounded
scalar search and polished by Gauss-Newton (``scipy.optimize.least_squares``) instead of the
paper's 1000 uniform samples in ]x_n, x_n + 1].

Efficiency curves (bounded 0 <= eta <= 1, their own family, the parabola_log family) live in
:mod:`solvers.perfmap.efficiency`; this module wraps them per setting with their errors.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, linprog, minimize_scalar, nnls

from plantsolve.solvers.perfmap.efficiency import EfficiencyFit, curve_extrema, eta_leave_one_out, fit_eta
from plantsolve.solvers.perfmap.families import (
    EFFICIENCY_FAMILY,
    N_COEFFICIENTS,
    basis,
    difference_transform,
    log_eval,
)

_LOO_MAX = 20
_LOG_GRID = np.logspace(-6.0, 3.0, 181)  # beta - 1, in units of the flow span


@dataclass
class CurveFit:
    family: str
    params: np.ndarray  # linear: control values c; log: (a, beta, c) in t; concave: values at the knots
    active: int = 0  # side conditions active at the solution
    knots: np.ndarray | None = None  # concave: the knots' t
    minimax: bool = False  # the criterion that ran: a minimax whose linear programme failed is least squares

    def __call__(self, t: np.ndarray) -> np.ndarray:
        if self.family == "log":
            return log_eval(self.params, t)
        if self.family == "concave":
            return np.interp(t, self.knots, self.params)
        return basis(self.family, t) @ self.params


def max_rel_error(fit: np.ndarray, data: np.ndarray) -> float:
    return float(np.max(np.abs(fit - data) / np.abs(data)))


# ---------------------------------------------------------------- linear families


def _bounded_lsq(A: np.ndarray, b: np.ndarray, n_free: int) -> np.ndarray:
    """argmin ||A z - b|| subject to z[n_free:] <= 0, exactly (projection + NNLS)."""
    AF, AB = A[:, :n_free], -A[:, n_free:]
    if n_free:
        Q, _ = np.linalg.qr(AF)
        M, r = AB - Q @ (Q.T @ AB), b - Q @ (Q.T @ b)
    else:
        M, r = AB, b
    w = nnls(M, r, maxiter=50 * max(M.shape[1], 1))[0] if AB.shape[1] else np.zeros(0)
    zF = np.linalg.lstsq(AF, b - AB @ w, rcond=None)[0] if n_free else np.zeros(0)
    return np.concatenate([zF, -w])


def _minimax_lp(A: np.ndarray, b: np.ndarray, n_free: int, weights: np.ndarray) -> tuple[np.ndarray, bool]:
    """(argmin max_i w_i |A z - b|_i subject to z[n_free:] <= 0 (LP in (z, e)), True); (the least-squares
    solution, False) where HiGHS fails, so that the fit states the criterion that ran."""
    n = A.shape[1]
    WA = A * weights[:, None]
    Wb = b * weights
    ones = np.ones((len(b), 1))
    A_ub = np.vstack([np.hstack([WA, -ones]), np.hstack([-WA, -ones])])
    b_ub = np.concatenate([Wb, -Wb])
    bounds = [(None, None)] * n_free + [(None, 0.0)] * (n - n_free) + [(0.0, None)]
    cost = np.zeros(n + 1)
    cost[-1] = 1.0
    res = linprog(cost, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs")
    if res.status != 0:  # numerically hopeless LP
        return _bounded_lsq(A, b, n_free), False
    return res.x[:n], True


def fit_linear(family: str, t: np.ndarray, y: np.ndarray, shape: str, minimax: bool,
               B: np.ndarray | None = None) -> CurveFit:
    """shape: 'decreasing_concave' (pressure), 'concave' or 'free' (efficiency)."""
    B = basis(family, t) if B is None else B
    n = B.shape[1]
    if shape == "free":
        if minimax:
            c, minimax = _minimax_lp(B, y, n, 1.0 / np.abs(y))
        else:
            c = np.linalg.lstsq(B, y, rcond=None)[0]
        return CurveFit(family, c, 0, minimax=minimax)
    T = difference_transform(n)
    n_free = 1 if shape == "decreasing_concave" else 2
    A = B @ T
    z, minimax = _minimax_lp(A, y, n_free, 1.0 / np.abs(y)) if minimax else (_bounded_lsq(A, y, n_free), False)
    z[n_free:] = np.minimum(z[n_free:], 0.0)  # LP solvers may return +1e-17
    scale = max(float(np.max(np.abs(y))), 1e-300)
    active = int(np.sum(z[n_free:] > -1e-12 * scale))
    return CurveFit(family, T @ z, active, minimax=minimax)


# ---------------------------------------------------------------- concave (piecewise linear)


def concave_transform(t: np.ndarray) -> np.ndarray:
    """F with f = F z, z = (f_0, s_1, s_2 - s_1, ..., s_{n-1} - s_{n-2}): values at the knots t from the
    first value, the first slope and the slope changes. f is decreasing and concave iff z[1:] <= 0."""
    h = np.diff(t)
    n = len(t)
    L = np.tril(np.ones((n - 1, n - 1)))  # slopes from the first slope and the changes
    C = np.tril(np.ones((n, n - 1)), -1) * h[None, :]  # values from the slopes
    return np.hstack([np.ones((n, 1)), C @ L])


def fit_concave(t: np.ndarray, y: np.ndarray, minimax: bool) -> CurveFit:
    """The decreasing concave piecewise-linear curve with a knot at every measured point: least squares
    (or minimax) over the convex set of such curves, exactly (NNLS or LP after :func:`concave_transform`).
    Its minimax error is the setting's floor: no decreasing concave curve does better."""
    F = concave_transform(t)
    z, minimax = _minimax_lp(F, y, 1, 1.0 / np.abs(y)) if minimax else (_bounded_lsq(F, y, 1), False)
    z[1:] = np.minimum(z[1:], 0.0)
    scale = max(float(np.max(np.abs(y))), 1e-300)
    return CurveFit("concave", F @ z, int(np.sum(z[1:] > -1e-12 * scale)), knots=np.array(t, dtype=float),
                    minimax=minimax)


# ---------------------------------------------------------------- log family


def _log_profile(beta: np.ndarray, t: np.ndarray, y: np.ndarray):
    """For each beta: the LS (a >= 0, c) of y = a log(beta - t) + c and its SSE."""
    L = np.log(beta[:, None] - t[None, :])
    Lm = L.mean(axis=1, keepdims=True)
    ym = y.mean()
    dL = L - Lm
    var = np.einsum("ij,ij->i", dL, dL)
    a = np.where(var > 0, (dL @ (y - ym)) / np.where(var > 0, var, 1.0), 0.0)
    a = np.maximum(a, 0.0)  # a >= 0 <=> y' <= 0 and y'' <= 0
    c = ym - a * Lm[:, 0]
    r = a[:, None] * L + c[:, None] - y[None, :]
    return a, c, np.einsum("ij,ij->i", r, r)


def _log_minimax_at(beta: float, t: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray, bool]:
    A = np.column_stack([-np.log(beta - t), np.ones_like(t)])  # z = (-a, c): -a <= 0
    A = A[:, ::-1]  # free variable first
    z, solved = _minimax_lp(A, y, 1, 1.0 / np.abs(y))
    params = np.array([-z[1], beta, z[0]])
    return max_rel_error(log_eval(params, t), y), params, solved


def fit_log(t: np.ndarray, y: np.ndarray, minimax: bool, polish: bool = True) -> CurveFit:
    grid = 1.0 + _LOG_GRID
    if minimax:
        coarse = grid[::9]
        errs = [_log_minimax_at(b, t, y)[0] for b in coarse]
        k = int(np.argmin(errs))
        lo = np.log(coarse[max(k - 1, 0)] - 1.0)
        hi = np.log(coarse[min(k + 1, len(coarse) - 1)] - 1.0)
        res = minimize_scalar(lambda s: _log_minimax_at(1.0 + np.exp(s), t, y)[0],
                              bounds=(lo, hi), method="bounded", options={"xatol": 1e-6})
        best = min([_log_minimax_at(1.0 + np.exp(res.x), t, y), _log_minimax_at(coarse[k], t, y)],
                   key=lambda p: p[0])
        params = best[1]
        return CurveFit("log", params, int(params[0] <= 0.0), minimax=best[2])

    a, c, sse = _log_profile(grid, t, y)
    k = int(np.argmin(sse))
    if not polish:  # leave-one-out refits: the grid optimum is close enough (ratio 1.12 in b)
        return CurveFit("log", np.array([a[k], grid[k], c[k]]), int(a[k] <= 0.0))
    s_lo = np.log(grid[max(k - 1, 0)] - 1.0)
    s_hi = np.log(grid[min(k + 1, len(grid) - 1)] - 1.0)

    def profile(s: float) -> float:
        return float(_log_profile(np.array([1.0 + np.exp(s)]), t, y)[2][0])

    res = minimize_scalar(profile, bounds=(s_lo, s_hi), method="bounded", options={"xatol": 1e-10})
    beta = 1.0 + np.exp(res.x) if res.fun < sse[k] else grid[k]
    a1, c1, sse1 = _log_profile(np.array([beta]), t, y)
    params = np.array([a1[0], beta, c1[0]])
    best_sse = sse1[0]
    if polish and params[0] > 0:
        # Gauss-Newton on (a, log(beta - 1), c): quadratic convergence, so data from the
        # family are recovered to round-off (the profile search alone stops at ~sqrt(eps)).
        def resid(p):
            return p[0] * np.log(1.0 + np.exp(p[1]) - t) + p[2] - y

        def jac(p):
            bb = 1.0 + np.exp(p[1])
            dbeta = p[0] * np.exp(p[1]) / (bb - t)
            return np.column_stack([np.log(bb - t), dbeta, np.ones_like(t)])

        # LM may try log(beta - 1) so negative that beta == 1 in floating point (log 0 at
        # t = 1): such trial points are non-finite and rejected below, silently.
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            try:
                sol = least_squares(resid, [params[0], np.log(beta - 1.0), params[2]],
                                    jac=jac, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15,
                                    max_nfev=200)
                cand = np.array([sol.x[0], 1.0 + np.exp(sol.x[1]), sol.x[2]])
                cand_sse = float(np.sum(resid(sol.x) ** 2))
            except ValueError:  # non-finite residuals at the start: keep the profile fit
                cand, cand_sse = np.full(3, np.nan), np.inf
        if np.all(np.isfinite(cand)) and cand[0] >= 0 and cand[1] > 1 and cand_sse <= best_sse:
            params = cand
    return CurveFit("log", params, int(params[0] <= 0.0))


# ---------------------------------------------------------------- per family / setting


def fit_pressure(family: str, t, y, minimax: bool, polish: bool = True, B=None) -> CurveFit:
    if family == "log":
        return fit_log(t, y, minimax, polish)
    if family == "concave":
        return fit_concave(t, y, minimax)
    return fit_linear(family, t, y, "decreasing_concave", minimax, B)


def fit_efficiency(family: str, t, eta, minimax: bool, concave: bool, B=None) -> EfficiencyFit:
    """Efficiency curve with 0 <= eta <= 1 exactly. ``family`` is an efficiency family, or a
    pressure family mapped by the paper's pairing (log -> cubic)."""
    return fit_eta(EFFICIENCY_FAMILY.get(family, family), t, eta, minimax, concave, B)


def left_out_points(n: int) -> np.ndarray:
    """Long characteristics: leave out at most _LOO_MAX evenly spread points (O(n) refits each)."""
    return np.unique(np.linspace(0, n - 1, min(n, _LOO_MAX)).round().astype(int))


def pressure_loo(family: str, t, y) -> float | None:
    """Max relative error of each point predicted by a least-squares fit to the others.

    The parametrisation t of the full data set is kept, so no prediction is an
    extrapolation outside the fitted curve's domain of definition. Settings with more than
    20 points leave out 20 evenly spread points (cost).
    """
    n = len(t)
    if n - 1 < N_COEFFICIENTS[family]:
        return None
    By = None if family in ("log", "concave") else basis(family, t)
    ey = 0.0
    for i in left_out_points(n):
        keep = np.arange(n) != i
        fy = fit_pressure(family, t[keep], y[keep], False, polish=False,
                          B=None if By is None else By[keep])
        pred = fy(t[i : i + 1])[0] if By is None else By[i] @ fy.params
        ey = max(ey, abs(float(pred) - y[i]) / abs(y[i]))
    return ey


def leave_one_out(family: str, t, y, eta, concave_eta: bool) -> tuple[float | None, float | None]:
    """(pressure, efficiency) leave-one-out max relative errors; the efficiency with the
    paper's paired family and the physical bounds (see :mod:`efficiency`)."""
    efam = EFFICIENCY_FAMILY.get(family, family)
    return (pressure_loo(family, t, y),
            eta_leave_one_out(efam, t, eta, concave_eta, left_out_points(len(t)))[0])


@dataclass
class PressureResult:
    family: str
    fit: CurveFit
    err: float
    loo: float | None
    minimax: bool = False  # the criterion of this fit (False: least squares)


def fit_pressure_setting(family: str, t, y, minimax: bool, with_loo: bool = True) -> PressureResult:
    fy = fit_pressure(family, t, y, minimax)
    return PressureResult(family, fy, max_rel_error(fy(t), y),
                          pressure_loo(family, t, y) if with_loo else None, fy.minimax)


@dataclass
class EtaResult:
    family: str
    fit: EfficiencyFit
    rel_err: float
    abs_err: float
    loo_rel: float | None
    loo_abs: float | None
    peak: float  # exact max of the fitted curve over the setting's flow range
    worst: int  # index (sorted points) of the largest relative error


def fit_eta_setting(family: str, t, eta, minimax: bool, concave: bool,
                    with_loo: bool = True) -> EtaResult:
    fe = fit_eta(family, t, eta, minimax, concave)
    err = np.abs(fe(t) - eta)
    loo = (eta_leave_one_out(family, t, eta, concave, left_out_points(len(t))) if with_loo
           else (None, None))
    return EtaResult(family, fe, float(np.max(err / np.abs(eta))), float(np.max(err)), loo[0],
                     loo[1], curve_extrema(family, fe.params)[3],
                     int(np.argmax(err / np.abs(eta))))


def concave_floor(x: np.ndarray, y: np.ndarray, decreasing: bool = True) -> float:
    """Smallest max relative error any decreasing concave function can reach on (x_i, y_i).

    A function through values f_i extends to a (decreasing) concave function iff the chord
    slopes m_i = (f_{i+1} - f_i)/(x_{i+1} - x_i) are non-increasing (and m_1 <= 0): an LP in
    (f, e). 0 means the data are consistent with the side conditions; a positive floor
    means no model can do better — the data violate the physics, not the model.
    """
    n = len(x)
    if n < 3 and not decreasing:
        return 0.0
    # Concavity and monotonicity are invariant under x -> affine and y -> positive multiple,
    # and the relative error too: solve on t in [0, 1] and y / max|y| so that rigs in Pa and
    # m3/h (1e5, 1e4) give the LP the same numbers as dimensionless data.
    x = (x - x[0]) / (x[-1] - x[0])
    y = y / np.max(np.abs(y))
    h = np.diff(x)
    D = np.zeros((n - 1, n))  # slopes
    D[np.arange(n - 1), np.arange(n - 1)] = -1.0 / h
    D[np.arange(n - 1), np.arange(1, n)] = 1.0 / h
    rows = [D[1:] - D[:-1]]  # m_{i+1} - m_i <= 0
    if decreasing:
        rows.append(D[:1])  # m_1 <= 0
    G = np.vstack(rows)
    w = 1.0 / np.abs(y)
    I = np.eye(n) * w[:, None]
    ones = np.ones((n, 1))
    A_ub = np.vstack([
        np.hstack([G, np.zeros((G.shape[0], 1))]),
        np.hstack([I, -ones]),
        np.hstack([-I, -ones]),
    ])
    b_ub = np.concatenate([np.zeros(G.shape[0]), y * w, -y * w])
    cost = np.zeros(n + 1)
    cost[-1] = 1.0
    res = linprog(cost, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * n + [(0, None)],
                  method="highs")
    if res.status != 0:  # numerically failed LP: the best constant is an upper bound
        lo, hi = float(np.min(np.abs(y))), float(np.max(np.abs(y)))
        return (hi - lo) / (hi + lo)
    # below the LP tolerance (HiGHS: 1e-7) a "violation" is round-off, not data
    return float(res.x[-1]) if res.x[-1] > 1e-7 else 0.0
