"""Cross-section weight functions in closed form (unit pipe radius, B along +y, electrodes at (+-1, 0)).

All three are W = (pi/2) Re F'(z) / I for B along +y ((pi/2) Im F'(z) / I weighs B_x), with F the
complex virtual-current potential of the disc |z| < 1 driving the current I (per unit length, conductivity 1) from the electrode at +1 to the
one at -1: U = sigma B integral v dphi/dx dA / I (seed eq. 1-2 with v x B = -v B e_x), and the
pi/2 makes S = (1/pi) integral W dA.

- Equipotential full-length electrodes of half-angle beta: on the wall dF/dtheta = i z F' must be
  imaginary on the electrodes (phi constant) and real on the insulator (no normal current), which
  F' = C / sqrt(z^4 - 2 cos(2 beta) z^2 + 1) does; the current through one electrode is
  C * integral_{-beta}^{beta} dtheta / (2 sqrt(sin^2 beta - sin^2 theta)), evaluated by Gauss-Jacobi
  quadrature that carries the inverse-square-root edge singularity (it equals C K(sin beta), so
  S = W(0) = pi / (2 K(sin beta))).
- Point electrodes: F = log((z + 1)/(z - 1)) / pi, Shercliff's W = (1 - x^2 + y^2) / |1 - z^2|^2.
- The seed's first-order iterate (section 3.1, eq. 5; weight factor section 8.1): uniform current
  density on the electrode arcs, F' from the Schwarz integral of that Neumann data. Its S is
  sin(beta)/beta (eq. 39-40; the seed's eq. 42 doubles it by a slip).
"""

from __future__ import annotations

import numpy as np
from scipy.special import roots_jacobi


def electrode_current_integral(beta: float, nodes: int = 400) -> float:
    """integral_{-beta}^{beta} dtheta / (2 sqrt(sin^2 beta - sin^2 theta)), by Gauss-Jacobi on the
    edge singularity (sin^2 beta - sin^2 theta = sin(beta - theta) sin(beta + theta))."""
    t, w = roots_jacobi(nodes, -0.5, -0.5)  # weight (1 - t)^(-1/2) (1 + t)^(-1/2) on [-1, 1]
    theta = beta * t
    d_minus, d_plus = beta - theta, beta + theta
    smooth = np.sqrt(d_minus * d_plus / (np.sin(d_minus) * np.sin(d_plus)))
    # dtheta = beta dt and (beta - theta)(beta + theta) = beta^2 (1 - t)(1 + t)
    return float(np.sum(w * smooth) / 2.0)


def weight_full_length(x: np.ndarray, y: np.ndarray, beta: float) -> np.ndarray:
    """W of equipotential full-length electrodes of half-angle ``beta`` (radians) at points inside the unit disc."""
    return np.real(complex_weight_full_length(x, y, beta))


def complex_weight_full_length(x: np.ndarray, y: np.ndarray, beta: float) -> np.ndarray:
    """(pi/2) F'(z) / I: its real part is the weight of B_y, its imaginary part that of B_x."""
    z2 = (np.asarray(x, dtype=float) + 1j * np.asarray(y, dtype=float)) ** 2
    # Each factor has a positive real part in the disc, so the product of principal roots is the
    # branch of sqrt(z^4 - 2 cos 2beta z^2 + 1) that is analytic there and 1 at the centre.
    root = np.sqrt(1 - z2 * np.exp(-2j * beta)) * np.sqrt(1 - z2 * np.exp(2j * beta))
    current = electrode_current_integral(beta)
    return (np.pi / 2) * (1.0 / root) / current


def weight_point(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Shercliff's weight function of point electrodes at (+-1, 0)."""
    z = np.asarray(x, dtype=float) + 1j * np.asarray(y, dtype=float)
    return np.real(1.0 / (1 - z * z))


def weight_first_order(x: np.ndarray, y: np.ndarray, beta: float) -> np.ndarray:
    """W of the seed's first-order potential (uniform current density on full-length electrode arcs)."""
    return np.real(complex_weight_first_order(x, y, beta))


def complex_weight_first_order(x: np.ndarray, y: np.ndarray, beta: float) -> np.ndarray:
    """(pi/2) F'(z) / I of the first-order potential."""
    z = np.asarray(x, dtype=float) + 1j * np.asarray(y, dtype=float)

    def schwarz_arc(centre: float) -> np.ndarray:
        # integral over the arc |t - centre| < beta of (e^{it} + z) / (e^{it} - z) dt, minus its value 2 beta at z = 0
        upper = np.log(1 - z * np.exp(-1j * (centre + beta)))
        lower = np.log(1 - z * np.exp(-1j * (centre - beta)))
        return -2j * (upper - lower)

    small = np.abs(z) < 1e-6
    safe = np.where(small, 0.5, z)
    # h(z) = z F'(z), the analytic function whose real part on the wall is the Neumann data
    # (+1 on the arc at theta = 0, -1 on the arc at pi); h(0) = 0, h'(0) = 4 sin(beta) / pi.
    h = (schwarz_arc(0.0) - schwarz_arc(np.pi)) / (2 * np.pi)
    h = np.where(small, 0.0, h)
    # h has odd powers only (the data changes sign under theta -> theta + pi), so near 0 the
    # cancellation-free h'(0) is off by O(|z|^2) < 1e-12.
    derivative = np.where(small, 4 * np.sin(beta) / np.pi + 0j, h / safe)
    return (np.pi / 2) * derivative / (2 * beta)


def sensitivity_first_order(beta: float) -> float:
    """sin(beta)/beta: the seed's eq. 39-40 (the factor 2 of its eq. 42 is a slip)."""
    return float(np.sin(beta) / beta)


def sensitivity_first_order_button(radius: float, nodes: int = 256) -> float:
    """The uniform-current-density iterate for a flush button of radius ``radius`` (R = 1).

    For uniform B only the z-integrated potential enters, and its weight at the centre is
    S = integral sigma cos(theta) dS / integral sigma dS (the current-weighted mean of cos theta over
    the electrode, which is sin(beta)/beta for a uniform patch and pi/(2K) for the 2-D density).
    For uniform sigma on the disc y^2 + z^2 <= r^2 of the wall (dS = dy dz / cos theta):
    S = pi r^2 / integral 2 sqrt(r^2 - y^2) / sqrt(1 - y^2) dy, with y = r cos u a smooth
    periodic integrand, integrated by the trapezoid rule."""
    u = (np.arange(nodes) + 0.5) * np.pi / nodes
    area = np.sum(2 * radius**2 * np.sin(u) ** 2 / np.sqrt(1 - (radius * np.cos(u)) ** 2)) * np.pi / nodes
    return float(np.pi * radius**2 / area)
