"""The weight function of an integral-equation solution in a magnetic field given on a grid.

The integral equation gives the electrode current sigma, hence the potential everywhere in the
liner section (seed eq. 9, 20-24): with s_mn = w_n T[m, n] the wall data of mode (m, n),
phi = sum_mn s_mn G_m(k_n) I_m(k_n r) / I_m(k_n) cos(m theta) cos(k_n z). The weight of seed eq. 2,
W_z = B_y d(phi)/dx - B_x d(phi)/dy, integrated along z is, mode by mode in z,

    W(x, y) = (pi / 2) sum_n [b_y,n(x, y) phi_x,n(x, y) - b_x,n(x, y) phi_y,n(x, y)],

b_n = integral_{-L_c}^{L_c} B cos(k_n z) dz / B_ref. The trilinear field is piecewise linear in z along
each grid column and bilinear across, so b_n is exact at the grid columns (the integral of a linear
function times cos in closed form) and bilinear in between. The n = 0 term is the z-mean of B
times the z-integrated current, harmonic, evaluated on the fine polar rule like the uniform case
(a uniform grid has b_n = 0 for n > 0 and gives exactly the uniform answer); the terms n >= 1 (the
field's variation along z) go on a lighter polar rule, as the complex gradient
phi_x - i phi_y = sum_m f_m [(2m/r + k rho_m) e^{i(m-1)theta} + k rho_m e^{-i(m+1)theta}] / 2,
f_m = s_mn G_m I_m(kr)/I_m(k), rho_m = I_{m+1}(kr)/I_m(kr), summed by FFT on each ring. The field's
z-modes are truncated at n < 97 (WALL_MODES); the change from half as many is the error estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RegularGridInterpolator
from scipy.special import ive

from plantsolve.solvers.flowmeter.field import FieldGrid
from plantsolve.solvers.flowmeter.integral_equation import IntegralEquationSolution, bessel_ratio_table
from plantsolve.solvers.flowmeter.profiles import DiscQuadrature, disc_quadrature


BLOCK = 1 << 20  # floats in one working buffer (8 MB): the (columns x knots x modes) terms go through it in blocks


def field_modes(grid: FieldGrid, cut: float, count: int, block: int = BLOCK) -> tuple[np.ndarray, np.ndarray]:
    """b_x,n and b_y,n = integral_{-cut}^{cut} B cos(k_n z) dz at the grid columns, shape (nx, ny, count).
    The terms of n > 0 are made about ``block`` floats at a time (:func:`add_wave_modes`)."""
    k = np.arange(count) * np.pi / cut
    inner = grid.z[(grid.z > -cut) & (grid.z < cut)]
    knots = np.concatenate([[-cut], inner, [cut]])
    z0, z1 = knots[:-1], knots[1:]
    out = []
    for values in (grid.bx, grid.by):
        columns = values.reshape(-1, len(grid.z))
        at = np.stack([np.interp(knots, grid.z, c) for c in columns])  # (columns, knots)
        slope = (at[:, 1:] - at[:, :-1]) / (z1 - z0)
        offset = at[:, :-1] - slope * z0
        total = np.zeros((len(columns), count))
        # n = 0: the plain integral; n > 0: (a + s z) sin(kz)/k + s cos(kz)/k^2 between the knots
        total[:, 0] = np.sum(offset * (z1 - z0) + slope * (z1**2 - z0**2) / 2, axis=1)
        add_wave_modes(total[:, 1:], offset, slope, z0, z1, k[1:], block)
        out.append(total.reshape(len(grid.x), len(grid.y), count))
    return out[0], out[1]


def add_wave_modes(total: np.ndarray, offset: np.ndarray, slope: np.ndarray, z0: np.ndarray, z1: np.ndarray,
                   k: np.ndarray, block: int) -> None:
    """total[c, n] += sum_j [(a + s z) sin(k_n z)/k_n + s cos(k_n z)/k_n^2] from z0_j to z1_j, a and s each
    column c's offset and slope on knot interval j; total (columns, modes), offset and slope (columns, knots).

    The (columns x knots x modes) terms are made in blocks of at most about ``block`` floats (some columns,
    some knots) in two preallocated buffers, so the working memory does not grow with the grid (beyond one sum
    per column and mode when the knots take several blocks: a grid with that many planes has few columns). Each
    term is the same sequence of operations as one array expression over everything, and the knots are summed
    in the same order (one after another: row 0 of the buffer carries each column's sum over the knots before),
    so the result is the same to the last bit whatever the block."""
    columns, intervals = offset.shape
    modes = len(k)
    if modes == 0 or columns == 0:
        return
    k2 = k**2
    span = max(1, min(intervals, block // modes))  # knots per block
    width = max(1, min(columns, block // (span * modes)))  # columns per block
    # the sines and cosines are the same for every column: with every knot in one block they are made once;
    # else (a grid with many planes along z, hence few columns) all columns take each knot block in turn
    one_block = span == intervals
    group = width if one_block else columns
    terms = np.empty((width, span + 1, modes))  # row 0: the sum over the knots so far
    second = np.empty((width, span, modes))
    sums = np.empty((group, modes))

    def waves(zb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """sin(k z) and cos(k z) at the knots zb, (knots, modes)."""
        phase = k[None, :] * zb[:, None]
        return np.sin(phase), np.cos(phase)

    ends = ((z1, 1.0), (z0, -1.0))
    kept = [waves(zb) for zb, _ in ends] if one_block else None
    for g0 in range(0, columns, group):
        g1 = min(g0 + group, columns)
        for end, (zb, sign) in enumerate(ends):
            sums[:g1 - g0] = 0.0
            for j0 in range(0, intervals, span):
                j1 = min(j0 + span, intervals)
                s = j1 - j0
                zz = zb[j0:j1, None]
                sine, cosine = kept[end] if one_block else waves(zb[j0:j1])
                for c0 in range(g0, g1, width):
                    c1 = min(c0 + width, g1)
                    w = c1 - c0
                    a, b = offset[c0:c1, j0:j1, None], slope[c0:c1, j0:j1, None]
                    part, tail = terms[:w, 1:s + 1], second[:w, :s]
                    np.multiply(a + b * zz, sine, out=part)
                    np.divide(part, k, out=part)
                    np.multiply(b, cosine, out=tail)
                    np.divide(tail, k2, out=tail)
                    np.add(part, tail, out=part)
                    terms[:w, 0] = sums[c0 - g0:c1 - g0]
                    np.sum(terms[:w, :s + 1], axis=1, out=sums[c0 - g0:c1 - g0])
            total[g0:g1] += sign * sums[:g1 - g0]


def all_ratios(x: np.ndarray, top: int) -> np.ndarray:
    """I_{v+1}(x)/I_v(x) for v = 0..top-1 (rows) and every x > 0 (columns), by the backward recurrence."""
    start = top + 60 + int(2 * np.max(x))
    rho = np.zeros_like(x)
    out = np.zeros((top, len(x)))
    for v in range(start, -1, -1):
        rho = x / (2 * (v + 1) + x * rho)
        if v < top:
            out[v] = rho
    return out


def bessel_quotients(k: np.ndarray, radii: np.ndarray, orders: int,
                     at_1: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """For odd m = 1, 3, ..., 2 orders - 1, k > 0 and each radius: I_m(kr)/I_m(k) (a product of ratio
    quotients, so neither Bessel function over- or underflows) and rho_m(kr) = I_{m+1}(kr)/I_m(kr);
    both shaped (radii, orders, k). ``at_1`` is all_ratios(k, 2 orders), shared by every call."""
    top = 2 * orders
    x = (radii[:, None] * k[None, :]).ravel()
    at_r = all_ratios(x, top).reshape(top, len(radii), len(k)).transpose(1, 0, 2)
    if at_1 is None:
        at_1 = all_ratios(k, top)
    with np.errstate(divide="ignore"):
        logs = np.log(at_r) - np.log(at_1)[None]
    # log(I_m(kr)/I_m(k)) = log(I_0(kr)/I_0(k)) + sum_{v<m} log(rho_v(kr)/rho_v(k))
    base = np.log(ive(0, radii[:, None] * k[None]) / ive(0, k)[None]) + k[None] * (radii[:, None] - 1)
    cumulative = base[:, None, :] + np.concatenate([np.zeros((len(radii), 1, len(k))), np.cumsum(logs, axis=1)], axis=1)
    odd = np.arange(1, top, 2)
    return np.exp(cumulative[:, odd]), at_r[:, odd]


def ring_gradient(wall: np.ndarray, green: np.ndarray, weight_n: np.ndarray, k: np.ndarray, r: float, count: int,
                  quotient: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """phi_x - i phi_y of each z mode n >= 1 at the ``count`` points theta_j = (j + 1/2) 2 pi / count of
    the ring of radius r: shape (modes n >= 1, count). ``quotient`` and ``rho`` from bessel_quotients."""
    orders = wall.shape[0]
    m = np.arange(1, 2 * orders, 2).astype(float)
    f = wall[:, 1:] * weight_n[None, 1:] * green[:, 1:] * quotient  # (M, n)
    kr = k[None, 1:] * rho
    up = f * (2 * m[:, None] / r + kr) / 2  # frequency m - 1
    down = f * kr / 2  # frequency -(m + 1)
    folded = np.zeros((len(k) - 1, count), dtype=complex)
    for frequency, coefficient in ((m - 1, up), (-(m + 1), down)):
        phase = np.exp(1j * frequency * np.pi / count)
        np.add.at(folded.T, frequency.astype(int) % count, (coefficient * phase[:, None]))
    return np.fft.ifft(folded, axis=1) * count


@dataclass
class GridWeight:
    """W of the terms n >= 1 on a polar rule, and the z-mean field for the n = 0 term."""

    quadrature: DiscQuadrature
    values: np.ndarray  # W_(n >= 1) at the rule's nodes
    half_values: np.ndarray  # the same with half the z modes (error estimate)
    mean_bx: RegularGridInterpolator
    mean_by: RegularGridInterpolator


def grid_weight(solution: IntegralEquationSolution, grid: FieldGrid, progress=None) -> GridWeight:
    """The field's z-mean (for n = 0) and the weight of the modes n >= 1 on a polar rule."""
    wall, cut = solution.wall, solution.cut
    orders, modes = wall.shape
    k = np.arange(modes) * np.pi / cut
    m = np.arange(1, 2 * orders, 2).astype(float)
    ratios = bessel_ratio_table(m, k)
    green = 1.0 / (m[:, None] + k[None, :] * ratios)
    n = np.arange(modes)
    weight_n = np.where(n == 0, 1.0, 2.0) / (2 * cut) * (2 / np.pi)
    bx, by = field_modes(grid, cut, modes)
    axes = (grid.x, grid.y)
    mean_bx = RegularGridInterpolator(axes, bx[:, :, 0] / (2 * cut))
    mean_by = RegularGridInterpolator(axes, by[:, :, 0] / (2 * cut))
    modes_bx = RegularGridInterpolator(axes, bx[:, :, 1:])
    modes_by = RegularGridInterpolator(axes, by[:, :, 1:])
    quadrature = disc_quadrature(radial=40, scale=10.0, max_angular=4096)
    values, half_values = [], []
    start = 0
    half = (modes - 1) // 2
    at_1 = all_ratios(k[1:], 2 * orders)
    chunk = 8  # rings whose Bessel quotients share one backward recurrence
    for index, (r, count) in enumerate(quadrature.rings):
        if index % chunk == 0:
            if progress is not None:
                progress(0.6 + 0.2 * index / len(quadrature.rings), f"grid field: ring {index + 1} of {len(quadrature.rings)}")
            radii = np.array([rr for rr, _ in quadrature.rings[index:index + chunk]])
            quotients, rhos = bessel_quotients(k[1:], radii, orders, at_1)
        gradient = ring_gradient(wall, green, weight_n, k, r, count, quotients[index % chunk], rhos[index % chunk])
        pts = np.column_stack([quadrature.x[start:start + count], quadrature.y[start:start + count]])
        start += count
        fx, fy = modes_bx(pts).T, modes_by(pts).T  # (modes - 1, count)
        terms = (np.pi / 2) * (fy * gradient.real + fx * gradient.imag)
        values.append(terms.sum(axis=0))
        half_values.append(terms[:half].sum(axis=0))
    return GridWeight(quadrature, np.concatenate(values), np.concatenate(half_values), mean_bx, mean_by)


def interpolate_rings(quadrature: DiscQuadrature, values: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Values on the polar rule's rings, linear in theta along the two rings around each point and
    linear in r between them (clamped beyond the outermost and innermost rings)."""
    radii = np.array([r for r, _ in quadrature.rings])
    order = np.argsort(radii)
    offsets = np.concatenate([[0], np.cumsum([c for _, c in quadrature.rings])])
    r = np.hypot(x, y)
    theta = np.mod(np.arctan2(y, x), 2 * np.pi)

    def on_ring(i, t):
        count = quadrature.rings[i][1]
        ring = values[offsets[i]:offsets[i] + count]
        position = t / (2 * np.pi) * count - 0.5
        lo = np.floor(position).astype(int)
        frac = position - lo
        return (1 - frac) * ring[lo % count] + frac * ring[(lo + 1) % count]

    sorted_r = radii[order]
    upper = np.clip(np.searchsorted(sorted_r, r), 1, len(sorted_r) - 1)
    lower = upper - 1
    r0, r1 = sorted_r[lower], sorted_r[upper]
    frac = np.clip((r - r0) / (r1 - r0), 0.0, 1.0)
    out = np.empty_like(r)
    for j in np.unique(upper):
        mine = upper == j
        a = on_ring(order[j - 1], theta[mine])
        b = on_ring(order[j], theta[mine])
        out[mine] = (1 - frac[mine]) * a + frac[mine] * b
    return out
