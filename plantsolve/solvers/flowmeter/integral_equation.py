"""The integral equation on the electrode for equipotential patches (production method, uniform field).

The seed's Neumann Green's function of the cylinder (section 5, eq. 20-24; on the wall
g_m(k, R, R) ~ I_m(kR) / (kR I_m'(kR))) turns the electrode current density sigma(theta, z) into
the wall potential mode by mode. On the insulated liner section |z| < L/2 (ends insulated, as in
the finite-element model) the z-transform is the cosine series k_n = n pi / (L/2), and by the
seed's symmetries (section 4.2) only odd m appear. With R = 1 and conductivity 1 a mode
cos(m theta) cos(k z) of the normal current gives the wall potential times
G_m(k) = I_m(k) / (k I_m'(k)) = 1 / (m + k I_{m+1}(k)/I_m(k)) (1/m at k = 0); the Bessel ratio comes
from the backward recurrence I_{v+1}/I_v = k / (2(v+1) + k I_{v+2}/I_{v+1}), which cannot overflow
or underflow (unlike I_m itself at large order).

Galerkin with a basis that carries the square-root edge singularity on all four edges:
sigma = sum c_pq T_2p(theta/beta) T_2q(z/a) / sqrt((1 - (theta/beta)^2)(1 - (z/a)^2)); its transforms
are Bessel functions, integral T_2p(t) cos(w t) / sqrt(1 - t^2) dt = pi (-1)^p J_2p(w). The system
sets phi = V on the electrode (the seed's Dirichlet condition, eq. 4) in the Galerkin sense.
Truncating the modes at m < M (and k a < M beta) leaves an error proportional to 1/M, removed by
Richardson extrapolation over M/2 and M; the change of the extrapolated S from the level below is
the error estimate.

The cross-section weight function is the z-integrated (n = 0) part: with d_m = sum_p c_p0 A_mp,
W(z) = (a pi / I) sum_{m odd} d_m Re(z^(m-1)), harmonic, so S = W(0) for every axisymmetric profile.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import jv


@dataclass
class IntegralEquationSolution:
    sensitivity: float
    error_estimate: float
    series: np.ndarray  # e_l for l = 0, 2, 4, ...: W(z) = sum_l e_l Re(z^l)
    coefficients: np.ndarray  # c_pq of the finest level, for the current I = 1
    levels: list[tuple[int, float]]  # (M, S) of each truncation
    basis: tuple[int, int]
    # the wall transform T[m, n] = integral sigma cos(m theta) cos(k_n z) dS of the finest level (I = 1,
    # rescaled like ``series``), odd m, k_n = n pi / cut for n < WALL_MODES: what a grid field needs
    wall: np.ndarray | None = None
    cut: float = 0.0
    previous_coefficients: np.ndarray | None = None  # the level below's (the density's error estimate)


WALL_MODES = 97  # z modes kept for a field that varies along z (module grid_weight)


def bessel_ratio_table(orders: np.ndarray, k: np.ndarray) -> np.ndarray:
    """I_{m+1}(k) / I_m(k) for the (increasing, odd) ``orders`` m and wavenumbers k >= 0."""
    top = int(orders.max() + 60 + 2 * k.max())
    wanted = {int(m): i for i, m in enumerate(orders)}
    out = np.zeros((len(orders), len(k)))
    rho = np.zeros_like(k)
    for v in range(top, 0, -1):
        rho = k / (2 * (v + 1) + k * rho)
        if v in wanted:
            out[wanted[v]] = rho
    return out


BUDGET = 10_000_000  # (theta modes) x (z modes) of the largest level: about 80 MB per table
DECAY_LENGTH = 8.0  # the potential decays like exp(-1.84 |z| / R) beyond the electrode: e^-14.7 at 8 R


def z_modes(beta: float, a: float, half_liner: float, modes: int) -> int:
    """Number of cosine modes in z for ``modes`` theta modes (k a up to the largest m beta)."""
    return int(np.ceil((2 * modes - 1) * beta / a * min(half_liner, a + DECAY_LENGTH) / np.pi)) + 1


def feasible(beta: float, a: float, half_liner: float) -> bool:
    """Whether the three levels the extrapolation needs (200, 400, 800 theta modes) fit the budget."""
    return 800 * z_modes(beta, a, half_liner, 800) <= BUDGET


def ratio_table(beta: float, a: float, half_liner: float, modes: int) -> np.ndarray:
    """The Bessel ratios of a level; the levels below use its leading rows and columns."""
    half_liner = min(half_liner, a + DECAY_LENGTH)
    m = np.arange(1, 2 * modes, 2).astype(float)
    k = np.arange(z_modes(beta, a, half_liner, modes)) * np.pi / half_liner
    return bessel_ratio_table(m, k)


def galerkin(beta: float, a: float, half_liner: float, modes: int, p: int = 6, q: int = 6,
             ratios: np.ndarray | None = None):
    """S and the coefficients d_m (m = 1, 3, ...) for ``modes`` odd orders. Beyond a + 8 R the liner is
    cut (its end insulated there): the virtual current has decayed to below 1e-6 of its value."""
    half_liner = min(half_liner, a + DECAY_LENGTH)
    m = np.arange(1, 2 * modes, 2).astype(float)
    count = z_modes(beta, a, half_liner, modes)
    n = np.arange(count)
    k = n * np.pi / half_liner
    table = bessel_ratio_table(m, k) if ratios is None else ratios[:modes, :count]
    green = 1.0 / (m[:, None] + k[None, :] * table)
    weight_n = np.where(n == 0, 1.0, 2.0) / (2 * half_liner) * (2 / np.pi)
    pi_, qi = np.arange(p), np.arange(q)
    big_a = beta * np.pi * (-1.0) ** pi_[None] * jv(2 * pi_[None], m[:, None] * beta)
    big_b = a * np.pi * (-1.0) ** qi[None] * jv(2 * qi[None], k[:, None] * a)
    pairs = (big_b[:, :, None] * big_b[:, None, :]).reshape(len(k), q * q)
    h = ((green * weight_n[None]) @ pairs).reshape(len(m), q, q)  # one BLAS product over the z modes
    matrix = np.einsum("mp,ms,mqr->pqsr", big_a, big_a, h).reshape(p * q, p * q)
    rhs = np.zeros(p * q)
    rhs[0] = np.pi * beta * np.pi * a  # V = 1 tested with each basis function
    c = np.linalg.solve(matrix, rhs).reshape(p, q)
    current = c[0, 0] * np.pi**2 * beta * a
    d = big_a @ c[:, 0]
    sensitivity = float(a * np.pi * d[0] / current)
    return sensitivity, a * np.pi * d / current, c / current


def solve_patch(beta: float, a: float, half_liner: float, tolerance: float = 1e-4, progress=None) -> IntegralEquationSolution:
    """S (Richardson-extrapolated) and W's series for a patch of half-angle ``beta`` (radians) and
    half-length ``a`` on an insulated liner of half-length ``half_liner`` (R = 1)."""
    modes = 200
    shared = ratio_table(beta, a, half_liner, 800)  # the first three levels read one table
    levels = [(modes, *galerkin(beta, a, half_liner, modes, ratios=shared))]
    extrapolated: list[float] = []
    while True:
        modes *= 2
        if progress is not None:
            progress(min(0.15 + 0.1 * len(levels), 0.55), f"integral equation, {modes} theta modes")
        table = shared if modes <= 800 else None
        s, series, coefficients = galerkin(beta, a, half_liner, modes, ratios=table)
        levels.append((modes, s, series, coefficients))
        extrapolated.append(2 * levels[-1][1] - levels[-2][1])
        if len(extrapolated) >= 2:
            error = abs(extrapolated[-1] - extrapolated[-2])
            if error < tolerance / 10 or modes >= 3200 or 2 * modes * z_modes(beta, a, half_liner, 2 * modes) > BUDGET:
                break
    # truncation in the modes (Richardson's change) plus in the basis (two more functions each way)
    richer = galerkin(beta, a, half_liner, modes, 8, 8, ratios=shared if modes <= 800 else None)[0]
    error = abs(extrapolated[-1] - extrapolated[-2]) + abs(richer - levels[-1][1])
    # the series of the finest level, rescaled so that W(0) is the extrapolated S
    scale = extrapolated[-1] / levels[-1][1]
    series = levels[-1][2] * scale
    cut = min(half_liner, a + DECAY_LENGTH)
    m = np.arange(1, 2 * modes, 2).astype(float)
    k = np.arange(min(WALL_MODES, z_modes(beta, a, half_liner, modes))) * np.pi / cut
    p, q = coefficients.shape
    big_a = beta * np.pi * (-1.0) ** np.arange(p)[None] * jv(2 * np.arange(p)[None], m[:, None] * beta)
    big_b = a * np.pi * (-1.0) ** np.arange(q)[None] * jv(2 * np.arange(q)[None], k[:, None] * a)
    wall = big_a @ coefficients @ big_b.T * scale
    return IntegralEquationSolution(extrapolated[-1], error, series, coefficients, [(lv[0], lv[1]) for lv in levels], (6, 6),
                                    wall, cut, levels[-2][3])


def current_density(solution: IntegralEquationSolution, beta: float, theta: np.ndarray, z: np.ndarray | None = None,
                    a: float = 1.0, coefficients: np.ndarray | None = None) -> np.ndarray:
    """The electrode current density sigma (per unit wall area, R = 1, current 1) at angles inside
    (-beta, beta) and, with ``z`` (same shape as theta) and the half-length ``a``, at heights inside
    (-a, a); at z = 0 without. ``coefficients`` replaces the solution's (another level's)."""
    c = solution.coefficients if coefficients is None else coefficients
    t = np.asarray(theta, float) / beta
    s = np.zeros_like(t) if z is None else np.asarray(z, float) / a
    p, q = c.shape
    across = [np.cos(2 * i * np.arccos(t)) for i in range(p)]
    along = [np.cos(2 * j * np.arccos(s)) for j in range(q)]
    total = sum(c[i, j] * across[i] * along[j] for i in range(p) for j in range(q))
    return total / np.sqrt((1 - t * t) * (1 - s * s))


def weight_at(series: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """W(z) = sum_l e_l Re(z^l), l = 0, 2, 4, ... (Horner in z^2)."""
    return np.real(complex_weight_at(series, x, y))


def complex_weight_at(series: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """sum_l e_l z^l: its real part weighs B_y, its imaginary part B_x (phi_x - i phi_y of the
    z-integrated potential, times pi/2)."""
    z2 = (np.asarray(x, float) + 1j * np.asarray(y, float)) ** 2
    total = np.zeros_like(z2)
    for coefficient in series[::-1]:
        total = total * z2 + coefficient
    return total


def weight_on_ring(series: np.ndarray, r: float, count: int) -> np.ndarray:
    """W at theta_j = (j + 1/2) 2 pi / count on the ring of radius r, exactly for the truncated series:
    orders beyond the ring's resolution fold onto it (what evaluating them there gives)."""
    return np.real(complex_on_ring(series, r, count))


def complex_on_ring(series: np.ndarray, r: float, count: int) -> np.ndarray:
    """sum_l e_l z^l at the ring's points (see weight_on_ring)."""
    orders = 2 * np.arange(len(series))
    with np.errstate(under="ignore"):
        terms = series * r ** orders.astype(float) * np.exp(1j * orders * np.pi / count)
    folded = np.zeros(count, dtype=complex)
    np.add.at(folded, orders % count, terms)
    return np.fft.ifft(folded) * count
