"""Flow profiles over the cross-section and the quadrature that weighs them with W.

Lengths are in units of the pipe radius here; velocities are relative to the mean.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator
from scipy.special import roots_legendre

LAMINAR_LIMIT = 2300.0
TURBULENT_START = 4000.0


def power_law_exponent(reynolds: float) -> float:
    """n of the turbulent power law from the Reynolds number, n = -1.7 + 1.8 log10(Re) (n = 7 near
    Re = 1e5); between the laminar limit and Re = 4000 the value at 4000."""
    return float(-1.7 + 1.8 * np.log10(max(reynolds, TURBULENT_START)))


def profile_for_reynolds(reynolds: float) -> tuple[str, float | None]:
    """('laminar', None) below Re = 2300, else ('power_law', n)."""
    if reynolds < LAMINAR_LIMIT:
        return "laminar", None
    return "power_law", power_law_exponent(reynolds)


def axisymmetric(kind: str, r: np.ndarray, n: float | None = None) -> np.ndarray:
    """v / v_mean at radius r (0 <= r <= 1)."""
    r = np.asarray(r, dtype=float)
    if kind == "uniform":
        return np.ones_like(r)
    if kind == "laminar":
        return 2.0 * (1.0 - r * r)
    if kind == "power_law":
        assert n is not None
        return (n + 1) * (2 * n + 1) / (2 * n * n) * np.clip(1.0 - r, 0.0, None) ** (1.0 / n)
    raise ValueError(f"unknown profile {kind!r}")


@dataclass
class DiscQuadrature:
    """Nodes (x, y) in the unit disc and weights summing to pi."""

    x: np.ndarray
    y: np.ndarray
    w: np.ndarray
    rings: list[tuple[float, int]]  # (radius, number of nodes) of each ring, in node order


def disc_quadrature(radial: int = 48, scale: float = 40.0, max_angular: int = 20000) -> DiscQuadrature:
    """Polar rule: Gauss-Legendre in u with r = 1 - u^3 (the power law's (1 - r)^(1/n) and the
    weight function's wall peaks become smooth in u), trapezoid in theta with about
    ``scale / (1 - r)`` points per ring, because W near an electrode varies on the scale of the
    distance to the wall."""
    u, wu = roots_legendre(radial)
    u = 0.5 * (u + 1)
    wu = 0.5 * wu
    r = 1.0 - u**3
    dr = 3 * u**2 * wu
    xs, ys, ws, rings = [], [], [], []
    for ri, dri in zip(r, dr):
        m = int(np.clip(np.ceil(scale / max(1.0 - ri, 1e-12) / 4) * 4, 64, max_angular))
        t = (np.arange(m) + 0.5) * (2 * np.pi / m)
        xs.append(ri * np.cos(t))
        ys.append(ri * np.sin(t))
        ws.append(np.full(m, ri * dri * 2 * np.pi / m))
        rings.append((float(ri), m))
    return DiscQuadrature(np.concatenate(xs), np.concatenate(ys), np.concatenate(ws), rings)


def sampled(points: np.ndarray, values: np.ndarray):
    """A velocity function from samples (points in radius units): linear on their Delaunay
    triangulation, the nearest sample outside their hull (near the wall, where samples rarely reach).
    Returns (function, fraction of the disc area inside the hull)."""
    linear = LinearNDInterpolator(points, values)
    nearest = NearestNDInterpolator(points, values)
    quadrature = disc_quadrature(radial=24, scale=4.0, max_angular=512)
    inside = np.isfinite(linear(np.column_stack([quadrature.x, quadrature.y])))
    covered = float(np.sum(quadrature.w[inside]) / np.sum(quadrature.w))

    def velocity(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        at = np.column_stack([x, y])
        v = linear(at)
        missing = ~np.isfinite(v)
        if np.any(missing):
            v[missing] = nearest(at[missing])
        return v

    return velocity, covered
