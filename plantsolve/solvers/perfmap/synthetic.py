"""Synthetic rig data with a known performance map (tests and benchmark).

Every curve datum (x_min, x_max, cubic Bezier control values of pressure and efficiency) is an
affine function of the normalised settings (a, b) = (theta/theta_max, phi/phi_max). Linear
interpolation over any triangulation reproduces such a family exactly, so the true map is
available independently of the triangulation: for each t, flow and pressure are affine in
(a, b) over the whole rectangle of settings, one 2x2 solve per (node, t).
"""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.perfmap.families import bernstein, difference_transform

THETA_MAX = 30.0
PHI_MAX = 60.0


def family_curves(a, b):
    """Curve data at normalised settings (arrays): x_min, x_max, pressure c (.., 4), eta d."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    x_min = 0.30 + 0.20 * a + 0.30 * b
    x_max = x_min + 0.40 + 0.10 * a + 0.15 * b
    z = np.stack([0.80 + 0.35 * b - 0.10 * a,  # y at surge end
                  -(0.01 + 0.02 * a),  # c1 - c0 < 0: decreasing
                  -(0.04 + 0.03 * b),  # second differences < 0: concave
                  -(0.10 + 0.05 * a + 0.02 * b)], axis=-1)
    c = z @ difference_transform(4).T
    d = np.stack([0.60 + 0.10 * a + 0.05 * b,
                  0.92 - 0.08 * a + 0.04 * b,
                  0.95 - 0.10 * a + 0.03 * b,
                  0.55 + 0.10 * b - 0.05 * a], axis=-1)
    return x_min, x_max, c, d


def request_body(n_theta: int = 4, n_phi: int = 7, n_points: int = 6, noise: float = 0.0,
                 seed: int = 0, options: dict | None = None) -> dict:
    """A PerfmapRequest body: n_theta x n_phi settings with n_points measured points each."""
    rng = np.random.default_rng(seed)
    positions = []
    t = np.linspace(0.0, 1.0, n_points)
    for th in np.linspace(0.0, THETA_MAX, n_theta):
        for ph in np.linspace(0.0, PHI_MAX, n_phi):
            x_min, x_max, c, d = family_curves(th / THETA_MAX, ph / PHI_MAX)
            B = bernstein(3, t)
            y, eta = B @ c, B @ d
            if noise:
                y = y * (1 + noise * rng.standard_normal(n_points))
                eta = eta * (1 + noise * rng.standard_normal(n_points))
            positions.append({"theta": float(th), "phi": float(ph),
                              "flow": (x_min + t * (x_max - x_min)).tolist(),
                              "pressure": y.tolist(), "efficiency": eta.tolist()})
    return {"positions": positions, "options": {"model": "cubic", **(options or {})}}


def true_map(gx: np.ndarray, gy: np.ndarray, n_t: int = 20001, chunk: int = 256):
    """Max efficiency, theta, phi on the grid (rows = pressure) by a dense search over t
    with the exact (a, b) solve; NaN where unreachable."""
    XX, YY = np.meshgrid(gx, gy)
    X, Y = XX.ravel(), YY.ravel()
    # Affine decomposition f(a, b) = f0 + a fa + b fb of every datum.
    x0, x1, c0, d0 = family_curves(0.0, 0.0)
    xa, xa1, ca, da = (v - w for v, w in zip(family_curves(1.0, 0.0), (x0, x1, c0, d0)))
    xb, xb1, cb, db = (v - w for v, w in zip(family_curves(0.0, 1.0), (x0, x1, c0, d0)))
    best = np.full(X.shape, -np.inf)
    bt = np.full(X.shape, np.nan)
    bp = np.full(X.shape, np.nan)
    ts = np.linspace(0.0, 1.0, n_t)
    for s in range(0, n_t, chunk):
        t = ts[s : s + chunk]
        B = bernstein(3, t)
        # x = (1-t) x_min + t x_max ; y = B c ; eta = B d, each f0 + a fa + b fb
        fx0, fxa, fxb = (1 - t) * x0 + t * x1, (1 - t) * xa + t * xa1, (1 - t) * xb + t * xb1
        fy0, fya, fyb = B @ c0, B @ ca, B @ cb
        fe0, fea, feb = B @ d0, B @ da, B @ db
        det = fxa * fyb - fxb * fya
        rx = X[None, :] - fx0[:, None]
        ry = Y[None, :] - fy0[:, None]
        a = (fyb[:, None] * rx - fxb[:, None] * ry) / det[:, None]
        b = (fxa[:, None] * ry - fya[:, None] * rx) / det[:, None]
        ok = (a >= -1e-12) & (a <= 1 + 1e-12) & (b >= -1e-12) & (b <= 1 + 1e-12)
        eta = np.where(ok, fe0[:, None] + a * fea[:, None] + b * feb[:, None], -np.inf)
        m = np.argmax(eta, axis=0)
        col = np.arange(len(X))
        e = eta[m, col]
        upd = e > best
        best[upd] = e[upd]
        bt[upd] = a[m, col][upd] * THETA_MAX
        bp[upd] = b[m, col][upd] * PHI_MAX
    best[~np.isfinite(best)] = np.nan
    shape = XX.shape
    return best.reshape(shape), bt.reshape(shape), bp.reshape(shape)


def example() -> dict:
    """A small request for the API docs and the contract test: 2 × 3 settings of the synthetic
    family, 6 points each, a 24 × 24 map (about a second)."""
    return request_body(n_theta=2, n_phi=3, n_points=6, options={"grid": [24, 24]})


def speed_lines(n_lines: int = 24, n_points: int = 12, steep: float = 10.0, noise: float = 0.0,
                seed: int = 0, options: dict | None = None) -> dict:
    """A cycle-code style map: speed lines (one setting parameter, the corrected speed) whose
    pressure ratio falls off a cliff at choke (a decreasing concave line
    1 - 0.04 t - 0.55 t^p with p rising with speed), points evenly spread along the flow."""
    rng = np.random.default_rng(seed)
    positions = []
    t = np.linspace(0.0, 1.0, n_points)
    for k, speed in enumerate(np.linspace(0.5, 1.1, n_lines)):
        p = steep * (0.6 + 0.8 * k / max(n_lines - 1, 1))
        pr0 = 1.0 + 2.5 * speed ** 2
        flow = 20.0 * speed * (0.75 + 0.35 * t)
        pressure = pr0 * (1.0 - 0.04 * t - 0.35 * t ** p)
        efficiency = 0.86 - 0.05 * (speed - 0.9) ** 2 - 0.25 * (t - 0.45) ** 2 - 0.2 * t ** 8
        if noise:
            pressure = pressure * (1 + noise * rng.standard_normal(n_points))
            efficiency = efficiency * (1 + noise * rng.standard_normal(n_points))
        positions.append({"setting": [float(speed)], "flow": flow.tolist(),
                          "pressure": pressure.tolist(), "efficiency": efficiency.tolist()})
    return {"setting_names": ["Nc"], "setting_units": ["-"], "positions": positions, "options": dict(options or {})}
