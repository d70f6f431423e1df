"""The integral equation on the electrode for flush button electrodes (discs on the wall).

The same Neumann Green's function of the insulated liner section as for patches (module
integral_equation: odd theta modes m, cosine modes k_n = n pi / L_c in z, wall potential
G_m(k) = I_m(k) / (k I_m'(k)) per unit normal current), on the seed's button: the face
y^2 + z^2 <= r^2 (y = sin theta, R = 1) of a cylinder of radius r through the wall along x.

Unknown: the current per unit projected area sigma'(y, z) = sigma dS / (dy dz), in the basis
(y/r)^2p (z/r)^2q / sqrt(1 - (y^2 + z^2)/r^2), whose inverse square root is the edge singularity of an
equipotential disc (exactly the flat disc's density for p = q = 0). Its transforms
T[m, n] = integral sigma' cos(m asin y) cos(k_n z) dy dz have the inner z integral in closed form
(z = Z t, Z = sqrt(r^2 - y^2): t^2q in Chebyshev polynomials T_2j, and
integral T_2j(t) cos(w t) / sqrt(1 - t^2) dt = pi (-1)^j J_2j(w)), an analytic function of Z^2, so
Gauss-Legendre in y converges exponentially. Galerkin sets phi = 1 on the disc; the truncation in
the modes leaves an error proportional to 1/M, removed by Richardson extrapolation as for patches.

S = integral sigma cos(theta) dS / I (the z-integrated weight at the centre, W harmonic),
W(z) = sum_m T[m, 0] Re(z^(m-1)) / I.
"""

from __future__ import annotations

import numpy as np
from scipy.special import binom, jv, roots_legendre

from plantsolve.solvers.flowmeter.integral_equation import (DECAY_LENGTH, WALL_MODES, IntegralEquationSolution,
                                                            bessel_ratio_table)

LEVEL_SPAN = 10.0  # M asin(r) of the coarsest level (200 modes for a 22.5 degree patch is 78); doubled below 1e-4
BUDGET = 2_500_000  # (theta modes) x (z modes) of the finest level, per basis function (16 of them: 320 MB)


def chebyshev_of_power(q: int) -> np.ndarray:
    """alpha_j with t^2q = sum_j alpha_j T_2j(t), j = 0..q."""
    alpha = np.array([2.0 ** (1 - 2 * q) * binom(2 * q, q - j) for j in range(q + 1)])
    alpha[0] /= 2
    return alpha


def levels(radius: float, tolerance: float = 1e-3) -> list[int]:
    """Theta-mode counts of the three levels."""
    span = LEVEL_SPAN if tolerance >= 1e-4 else 2 * LEVEL_SPAN
    base = int(np.ceil(span / np.arcsin(radius) / 10) * 10)
    return [base, 2 * base, 4 * base]


def z_modes(radius: float, half_liner: float, modes: int) -> int:
    """Cosine modes in z: k up to the largest m times asin(r)/r, the disc's aspect in theta and z."""
    cut = min(half_liner, radius + DECAY_LENGTH)
    return int(np.ceil((2 * modes - 1) * np.arcsin(radius) / radius * cut / np.pi)) + 1


def feasible(radius: float, half_liner: float, tolerance: float = 1e-3) -> bool:
    finest = levels(radius, tolerance)[-1]
    return finest * z_modes(radius, half_liner, finest) <= BUDGET


def transforms(radius: float, half_liner: float, modes: int, p: int, q: int):
    """T[b, m, n] for the basis b = (i, j) (i < p, j < q), the total current I_b of each, and k_n."""
    cut = min(half_liner, radius + DECAY_LENGTH)
    m = np.arange(1, 2 * modes, 2).astype(float)
    count = z_modes(radius, half_liner, modes)
    k = np.arange(count) * np.pi / cut
    # y in (0, r) (the integrand is even in y); enough nodes for the fastest oscillation m_max asin(r)
    nodes = int(0.5 * (2 * modes) * np.arcsin(radius) / np.pi * 2.5) + 40
    t, w = roots_legendre(nodes)
    y = 0.5 * radius * (t + 1)
    w = radius * w  # both halves of (-r, r)
    big_z = np.sqrt(radius * radius - y * y)
    angular = np.cos(m[:, None] * np.arcsin(y)[None]) * w[None]  # (M, Ny)
    bessel = {j: jv(2 * j, k[None, :] * big_z[:, None]) for j in range(q)}  # (Ny, N)
    out = np.empty((p * q, len(m), count))
    current = np.empty(p * q)
    for j in range(q):
        alpha = chebyshev_of_power(j)
        along = radius * (big_z / radius) ** (2 * j)
        inner = along[:, None] * np.pi * sum(alpha[i] * (-1.0) ** i * bessel[i] for i in range(j + 1))
        for i in range(p):
            across = (y / radius) ** (2 * i)
            out[i * q + j] = (angular * across[None]) @ inner
            current[i * q + j] = np.sum(w * across * along * np.pi * alpha[0])
    return out, current, k, cut


def galerkin(table: np.ndarray, current: np.ndarray, ratios: np.ndarray, k: np.ndarray, cut: float,
             modes: int, count: int):
    """S, W's series and the basis coefficients (for I = 1) on the leading ``modes`` x ``count`` modes."""
    m = np.arange(1, 2 * modes, 2).astype(float)
    kk = k[:count]
    green = 1.0 / (m[:, None] + kk[None, :] * ratios[:modes, :count])
    n = np.arange(count)
    weight_n = np.where(n == 0, 1.0, 2.0) / (2 * cut) * (2 / np.pi)
    t = table[:, :modes, :count]
    flat = t.reshape(len(t), -1)
    matrix = flat @ (t * (green * weight_n[None])[None]).reshape(len(t), -1).T
    c = np.linalg.solve(matrix, current)  # phi = 1 tested with each basis function
    total = float(c @ current)
    series = (c @ t[:, :, 0]) / total
    return float(series[0]), series, c / total


def solve_button(radius: float, half_liner: float, tolerance: float = 1e-4, p: int = 3, q: int = 3,
                 progress=None) -> IntegralEquationSolution:
    """S (Richardson-extrapolated over three mode levels) and W's series for a flush button of radius
    ``radius`` (R = 1) on an insulated liner of half-length ``half_liner``. The error estimate is the
    extrapolation's change plus the change from one more basis function each way."""
    counts = levels(radius, tolerance)
    finest, rows = counts[-1], z_modes(radius, half_liner, counts[-1])
    table, current, k, cut = transforms(radius, half_liner, finest, p + 1, q + 1)
    m = np.arange(1, 2 * finest, 2).astype(float)
    ratios = bessel_ratio_table(m, k)
    keep = [i * (q + 1) + j for i in range(p) for j in range(q)]
    results = []
    for level, modes in enumerate(counts):
        if progress is not None:
            progress(0.2 + 0.2 * level, f"integral equation (button), {modes} theta modes")
        count = z_modes(radius, half_liner, modes)
        results.append(galerkin(table[keep], current[keep], ratios, k, cut, modes, count))
    s = [r[0] for r in results]
    extrapolated = [2 * s[1] - s[0], 2 * s[2] - s[1]]
    richer = galerkin(table, current, ratios, k, cut, finest, rows)[0]
    error = abs(extrapolated[1] - extrapolated[0]) + abs(richer - s[2])
    scale = extrapolated[1] / s[2]
    series = results[-1][1] * scale
    wall = np.tensordot(results[-1][2], table[keep][:, :, :WALL_MODES], axes=1) * scale
    return IntegralEquationSolution(extrapolated[1], error, series, results[-1][2],
                                    [(mm, sv) for mm, sv in zip(counts, s)], (p, q), wall, cut, results[-2][2])


def current_density(solution: IntegralEquationSolution, radius: float, theta: np.ndarray, z: np.ndarray | None = None,
                    coefficients: np.ndarray | None = None) -> np.ndarray:
    """The current per unit wall area sigma = sigma' cos(theta) (R = 1, current 1) at points
    (theta, z) of the disc sin^2 theta + z^2 < r^2 (z = 0 without ``z``); ``coefficients`` replaces
    the solution's (another level's)."""
    y = np.sin(np.asarray(theta, float))
    zz = np.zeros_like(y) if z is None else np.asarray(z, float)
    p, q = solution.basis
    c = solution.coefficients if coefficients is None else coefficients
    base = 1 / np.sqrt(1 - (y * y + zz * zz) / radius**2)
    total = sum(c[i * q + j] * (y / radius) ** (2 * i) * (zz / radius) ** (2 * j) for i in range(p) for j in range(q))
    return np.cos(np.asarray(theta, float)) * base * total
