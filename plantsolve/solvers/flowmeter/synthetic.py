"""Requests with known answers, and the small example request.

Known answers (uniform field, R the pipe radius):
- equipotential full-length electrodes of half-angle beta: S = pi / (2 K(sin beta)) (K: complete
  elliptic integral of the first kind, ``scipy.special.ellipk(m = sin^2 beta)``);
- point electrodes: Shercliff's W = R^2 (R^2 - x^2 + y^2) / (R^4 - 2 R^2 (x^2 - y^2) + (x^2 + y^2)^2), S = 1;
- any axisymmetric profile gives the same S (W is harmonic, so its mean over every circle about
  the axis is W(0));
- the seed's first-order iterate: S = sin(beta) / beta;
- a small flush button of radius r_e: S = 1 - (r_e/R)^2 / 6 + O((r_e/R)^3) (S is the current-weighted
  mean of cos(theta) over the electrode, and a small disc carries the flat disc's density
  1/sqrt(r_e^2 - rho^2), whose mean of y^2 is r_e^2/3).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.special import ellipk


def exact_full_length(half_angle_deg: float) -> float:
    """S of equipotential full-length electrodes."""
    beta = np.radians(half_angle_deg)
    return float(np.pi / (2 * ellipk(np.sin(beta) ** 2)))


def shercliff(x: np.ndarray, y: np.ndarray, radius: float = 1.0) -> np.ndarray:
    """Shercliff's point-electrode weight function, electrodes at (+-R, 0), B along +y."""
    x, y, r2 = np.asarray(x, float), np.asarray(y, float), radius * radius
    return r2 * (r2 - x * x + y * y) / (r2 * r2 - 2 * r2 * (x * x - y * y) + (x * x + y * y) ** 2)


def meter(radius: float = 50.0, half_angle: float = 22.5, half_length: float | None = None,
          shape: str = "patch", liner_length: float | None = None, velocity: dict | None = None,
          method: str = "auto", probes: list | None = None, reynolds: list | None = None,
          units: str = "mm", tolerance: float = 1e-3, button_radius: float | None = None,
          protrusion: float = 0.0) -> dict[str, Any]:
    """A request body."""
    electrodes: dict[str, Any] = {"shape": shape}
    if shape == "patch":
        electrodes.update(half_angle=half_angle, half_length=half_length)
    if shape == "button":
        electrodes.update(radius=button_radius, protrusion=protrusion)
    return {"units": units,
            "pipe": {"radius": radius, "liner_length": liner_length if liner_length is not None else 6 * radius},
            "electrodes": electrodes,
            "magnetic_field": {"type": "uniform", "magnitude": 0.01},
            "velocity": velocity or {"type": "power_law", "mean": 2.0, "n": 7},
            "reynolds": reynolds or [],
            "options": {"method": method, "tolerance": tolerance, "probe_points": probes or []}}


def example() -> dict[str, Any]:
    """A DN100 meter with 22.5 degree electrodes along the liner: solved exactly in well under a second."""
    return meter(radius=50.0, half_angle=22.5, half_length=None,
                 probes=[[0.0, 0.0], [25.0, 0.0], [0.0, 25.0]],
                 reynolds=[1000.0, 5000.0, 20000.0, 100000.0, 1000000.0])


def grid_field(radius: float, liner_length: float, bx, by, nx: int = 21, nz: int = 13) -> dict[str, Any]:
    """A ``magnetic_field`` of type grid sampling ``bx(x, y, z)``, ``by(x, y, z)`` (tesla; lengths in
    radius units) on a grid that just covers the liner section (a node at z = 0)."""
    x = np.linspace(-radius, radius, nx)
    z = np.linspace(-liner_length / 2, liner_length / 2, nz)
    gx, gy, gz = np.meshgrid(x / radius, x / radius, z / radius, indexing="ij")
    return {"type": "grid", "x": x.tolist(), "y": x.tolist(), "z": z.tolist(),
            "bx": np.broadcast_to(bx(gx, gy, gz), gx.shape).ravel().tolist(),
            "by": np.broadcast_to(by(gx, gy, gz), gx.shape).ravel().tolist()}


def small_button(radius_ratio: float) -> float:
    """The leading terms of S for a flush button of radius r_e = ``radius_ratio`` R."""
    return 1 - radius_ratio**2 / 6
