"""Max-curves ("envelopes") per theta over interpolated phi (paper section 3, eqs. 41-50)."""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.perfmap.families import CurveSet


def envelope(curves: CurveSet, members: list[int], phis: np.ndarray, n_curves: int,
             n_points: int) -> dict:
    """Max over the one-parameter family interpolating neighbouring phi settings.

    ``members`` are setting indices of one theta, sorted by phi. Between neighbours k, k+1 the
    curve with weight s is interpolated point-wise at equal t: x(t) and y(t) are convex
    combinations, which is the paper's linear interpolation of the curve data (eqs. 44-46)
    for every linear family and keeps y' <= 0, y'' <= 0 for all families. Outside its flow
    range a curve does not take part in the max (the paper's zero extension, eq. 42, but as
    'absent' so it cannot produce a false maximum).
    """
    x_lo = float(curves.x_min[members].min())
    x_hi = float(curves.x_max[members].max())
    xx = np.linspace(x_lo, x_hi, n_points)
    best_y = np.full(n_points, -np.inf)
    best_phi = np.full(n_points, np.nan)
    best_eta = np.full(n_points, np.nan)

    if len(members) == 1:
        pairs = [(members[0], members[0])]
    else:
        pairs = list(zip(members[:-1], members[1:]))
    s = np.linspace(0.0, 1.0, n_curves + 1) if len(members) > 1 else np.zeros(1)
    for i0, i1 in pairs:
        xmin = (1 - s) * curves.x_min[i0] + s * curves.x_min[i1]  # (S,)
        xmax = (1 - s) * curves.x_max[i0] + s * curves.x_max[i1]
        t = (xx[None, :] - xmin[:, None]) / (xmax - xmin)[:, None]  # (S, P)
        ok = (t >= -1e-12) & (t <= 1 + 1e-12)
        tc = np.clip(t, 0.0, 1.0)
        _, y0, e0 = curves.evaluate(np.full(tc.shape, i0), tc)
        _, y1, e1 = curves.evaluate(np.full(tc.shape, i1), tc)
        y = np.where(ok, (1 - s)[:, None] * y0 + s[:, None] * y1, -np.inf)
        k = np.argmax(y, axis=0)
        ymax = y[k, np.arange(n_points)]
        better = ymax > best_y
        best_y = np.where(better, ymax, best_y)
        sk = s[k]
        best_phi = np.where(better, (1 - sk) * phis[i0] + sk * phis[i1], best_phi)
        eta = (1 - sk) * e0[k, np.arange(n_points)] + sk * e1[k, np.arange(n_points)]
        best_eta = np.where(better, eta, best_eta)
    return {"flow": xx, "pressure": best_y, "phi": best_phi, "efficiency": best_eta}
