"""Curve families of the paper (section 2) on the normalised parameter t in [0, 1].

Every linear family is written as ``y(t) = basis(t) @ c``. Their side conditions
(y' <= 0, y'' <= 0: decreasing and *concave*; the paper says "convex" by mistake) become
simple bounds after the change of variables ``c = T z`` with
``z = (c_0, c_1 - c_0, second differences...)`` because

- y'' is piecewise linear (Bezier, sections 2.1/2.3) or piecewise constant (quadratic
  B-spline, section 2.4) with control values proportional to the second differences, so
  y'' <= 0 on [0, 1] iff every second difference is <= 0;
- for a concave curve y' is non-increasing, so y' <= 0 on [0, 1] iff y'(0) <= 0, and y'(0)
  is proportional to c_1 - c_0 in both bases.

This is the same feasible set as the paper's eqs. (21)-(24) and (37)-(40) (their extra
first-difference rows are implied by concavity), with the inequalities closed (<= 0).
"""

from __future__ import annotations


import numpy as np

LINEAR_FAMILIES = ("parabola", "cubic", "spline2", "spline3")
# 'concave' (beyond the paper): the piecewise-linear decreasing concave curve with a knot at every
# measured flow of its setting; it reaches any data a decreasing concave curve can (see fitting)
FAMILIES = ("parabola", "log", "cubic", "spline2", "spline3", "concave")
PAPER_FAMILIES = FAMILIES[:5]
N_COEFFICIENTS = {"parabola": 3, "log": 3, "cubic": 4, "spline2": 4, "spline3": 5, "concave": 3}
# the paper's pairing of pressure and efficiency families (it has no log efficiency)
EFFICIENCY_FAMILY = {"parabola": "parabola", "log": "cubic", "cubic": "cubic",
                     "spline2": "spline2", "spline3": "spline3", "concave": "spline3"}
# every family a curve can have (pressure: FAMILIES; efficiency: also parabola_log, see
# solvers.perfmap.efficiency)
ALL_FAMILIES = FAMILIES + ("parabola_log",)


def bernstein(degree: int, t: np.ndarray) -> np.ndarray:
    """Bernstein basis B_k^n(t) as a (len(t), n+1) matrix, by the recursion of paper
    eqs. (17)-(18) (products only: faster and more accurate than powers)."""
    t = np.asarray(t, dtype=float).reshape(-1, 1)
    s = 1.0 - t
    B = np.ones((t.shape[0], 1))
    for i in range(degree):
        nxt = np.zeros((t.shape[0], i + 2))
        nxt[:, :-1] = s * B
        nxt[:, 1:] += t * B
        B = nxt
    return B


def uniform_quadratic_bspline(segments: int, t: np.ndarray) -> np.ndarray:
    """Uniform quadratic B-splines on knots -2..K+2 (paper eq. 27) at parameter K*t.

    Closed form of the recursion (30)-(31) for unit knot spacing: on piece j with local
    u in [0, 1] the non-zero functions are (1-u)^2/2, (1 + 2u - 2u^2)/2, u^2/2.
    (Cross-checked against scipy's BSpline.design_matrix in the tests.)
    """
    tau = np.clip(np.asarray(t, dtype=float).ravel() * segments, 0.0, float(segments))
    j = np.minimum(np.floor(tau), segments - 1).astype(int)
    u = tau - j
    N = np.zeros((tau.shape[0], segments + 2))
    rows = np.arange(tau.shape[0])
    N[rows, j] = 0.5 * (1.0 - u) ** 2
    N[rows, j + 1] = 0.5 + u - u * u
    N[rows, j + 2] = 0.5 * u * u
    return N


def basis(family: str, t: np.ndarray) -> np.ndarray:
    if family == "parabola":
        return bernstein(2, t)
    if family == "cubic":
        return bernstein(3, t)
    if family == "spline2":
        return uniform_quadratic_bspline(2, t)
    if family == "spline3":
        return uniform_quadratic_bspline(3, t)
    raise ValueError(f"no linear basis for family {family!r}")


def difference_transform(n: int) -> np.ndarray:
    """T with c = T z, z = (c_0, c_1 - c_0, c_2 - 2c_1 + c_0, ..., c_{n-1} - 2c_{n-2} + c_{n-3})."""
    T = np.zeros((n, n))
    # Column j is the coefficient sequence produced by a unit z_j: constant, ramp, and
    # ramps starting later (discrete double integration of the second differences).
    idx = np.arange(n)
    T[:, 0] = 1.0
    if n > 1:
        T[:, 1] = idx
    for j in range(2, n):
        T[:, j] = np.maximum(idx - j + 1, 0)
    return T


def coefficients_from_z(z: np.ndarray) -> np.ndarray:
    return difference_transform(len(z)) @ z


def log_eval(params: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Log family in t: y = a*log(beta - t) + c, params (a, beta, c), beta > 1."""
    a, beta, c = params
    return a * np.log(beta - t) + c


def log_params_to_public(params: np.ndarray, x_min: float, x_max: float) -> list[float]:
    """(a, beta, c) in t  ->  paper's (a, b, c) with y = a log(b - x) + c (eq. 9)."""
    a, beta, c = params
    span = x_max - x_min
    return [float(a), float(x_min + beta * span), float(c - a * np.log(span))]


def log_params_from_public(coef: list[float], x_min: float, x_max: float) -> np.ndarray:
    a, b, c = coef
    span = x_max - x_min
    return np.array([a, (b - x_min) / span, c + a * np.log(span)])


def concave_knots(coefficients: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """'concave' public coefficients [x_1..x_n, y_1..y_n] -> (knot flows, values)."""
    c = np.asarray(coefficients, dtype=float)
    n = len(c) // 2
    return c[:n], c[n:]


def _eval_rows(family: str, c: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Row-wise evaluation: curve with coefficients c[j] at t[j] (no basis matrices)."""
    if family == "concave":  # evaluated per setting from its knots (CurveSet.evaluate_xy)
        return np.zeros(len(t))
    if family == "log":
        return c[:, 0] * np.log(c[:, 1] - t) + c[:, 2]
    if family == "parabola_log":  # quadratic Bezier + a log(beta - t)
        s = 1.0 - t
        return (s * (s * c[:, 0] + t * c[:, 1]) + t * (s * c[:, 1] + t * c[:, 2])
                + c[:, 3] * np.log(c[:, 4] - t))
    if family in ("parabola", "cubic"):
        # de Casteljau on contiguous rows: stable and allocation-light
        n = 3 if family == "parabola" else 4
        b = [c[:, k].copy() for k in range(n)]
        s = 1.0 - t
        for r in range(1, n):
            for k in range(n - r):
                b[k] = s * b[k] + t * b[k + 1]
        return b[0]
    K = 2 if family == "spline2" else 3
    tau = np.clip(t * K, 0.0, float(K))
    j = np.minimum(np.floor(tau), K - 1).astype(int)
    u = tau - j
    rows = np.arange(len(t))
    return (0.5 * (1.0 - u) ** 2 * c[rows, j] + (0.5 + u - u * u) * c[rows, j + 1]
            + 0.5 * u * u * c[rows, j + 2])


class CurveSet:
    """The fitted curves of all settings, evaluable at any t (vectorised).

    ``evaluate(idx, t)`` returns (x, y, eta) for setting ``idx[j]`` at ``t[j]``; arrays of
    indices and parameters of the same shape. Built from public coefficients only, so a
    stored result can be re-evaluated (inverse query).
    """

    def __init__(self, families: list[str], eff_families: list[str], x_min, x_max,
                 p_coef: list[list[float]], e_coef: list[list[float]]):
        self.n = len(families)
        self.families = list(families)
        self.eff_families = list(eff_families)
        self.x_min = np.asarray(x_min, dtype=float)
        self.x_max = np.asarray(x_max, dtype=float)
        self.p = np.zeros((self.n, 5))
        self.e = np.zeros((self.n, 5))
        self.knots: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # 'concave': (t of the knots, values)
        for i in range(self.n):
            pc = list(p_coef[i])
            if families[i] == "log":
                pc = list(log_params_from_public(pc, self.x_min[i], self.x_max[i]))
            if families[i] == "concave":
                xk, vk = concave_knots(pc)
                self.knots[i] = ((xk - self.x_min[i]) / (self.x_max[i] - self.x_min[i]), vk)
            else:
                self.p[i, : len(pc)] = pc
            self.e[i, : len(e_coef[i])] = e_coef[i]
        self.fam_id = np.array([ALL_FAMILIES.index(f) for f in families])
        self.eff_id = np.array([ALL_FAMILIES.index(f) for f in eff_families])

    @staticmethod
    def _eval(fam_ids: np.ndarray, coefs: np.ndarray, t: np.ndarray) -> np.ndarray:
        out = np.empty(t.shape)
        uniform = len(fam_ids) and (fam_ids == fam_ids[0]).all()
        for fid in (fam_ids[:1] if uniform else np.unique(fam_ids)):
            m = slice(None) if uniform else fam_ids == fid
            out[m] = _eval_rows(ALL_FAMILIES[fid], coefs[m], t[m])
        return out

    def evaluate(self, idx: np.ndarray, t: np.ndarray):
        """(x, y, eta) of characteristics ``idx`` at parameters ``t`` (broadcast together)."""
        x, y = self.evaluate_xy(idx, t)
        idx = np.asarray(idx)
        t = np.broadcast_to(np.asarray(t, dtype=float), idx.shape)
        eta = self._eval(self.eff_id[idx.ravel()], self.e[idx.ravel()], t.ravel())
        return x, y, eta.reshape(idx.shape)

    def evaluate_xy(self, idx: np.ndarray, t: np.ndarray):
        """(x, y) only: for root finding, where the efficiency is not needed."""
        idx = np.asarray(idx)
        t = np.broadcast_to(np.asarray(t, dtype=float), idx.shape)
        shape = idx.shape
        idx, t = idx.ravel(), t.ravel()
        x = self.x_min[idx] + (self.x_max[idx] - self.x_min[idx]) * t
        y = self._eval(self.fam_id[idx], self.p[idx], t)
        for i, (tk, vk) in self.knots.items():
            rows = idx == i
            if rows.any():
                y[rows] = np.interp(t[rows], tk, vk)
        return x.reshape(shape), y.reshape(shape)

    def sample(self, t: np.ndarray):
        """(x, y, eta), each (n_settings, len(t)): every curve at the same parameters."""
        t = np.asarray(t, dtype=float)
        idx = np.repeat(np.arange(self.n)[:, None], len(t), axis=1)
        return self.evaluate(idx, np.broadcast_to(t, idx.shape))


def curveset_from_fits(settings) -> CurveSet:
    """The :class:`CurveSet` of a result's settings (``SettingFit`` objects: public
    coefficients), as the solver, the inverse query and the plots all evaluate it."""
    return CurveSet([s.family for s in settings], [s.efficiency_family for s in settings],
                    [s.x_min for s in settings], [s.x_max for s in settings],
                    [s.pressure_coefficients for s in settings],
                    [s.efficiency_coefficients for s in settings])
