"""Which order a flat grid's values were written in: the stated C order (x slowest, z fastest) or another.

A magnet's field is smooth on its grid: read in the order it was written, neighbouring values differ little;
read in another order (MATLAB's and numpy's order='F' write x fastest) the values of distant nodes land side by
side and the field turns rough. The roughness of a reading is the mean squared step between neighbours along
each axis over the values' variance. Where another order reads the values far smoother than the stated one,
the stated one is doubted. With equal axis lengths some orders read the same values as a transposed field,
just as smooth: those cannot be told apart, and nothing is said.
"""

from __future__ import annotations

import itertools

import numpy as np

AXES = "xyz"
# a reading this many times rougher than another order's is doubted. On smooth fields of many kinds (polynomials,
# Gaussians along z, coil dipoles, pole-shoe steps, noisy linear fields; grids 2x3x4 to 41x41x3) read in their own
# order the ratio stayed below 1.6; read in a wrong order it exceeded 3 in about a third of the cases (coarse grids
# and fields varying along one axis alone stay alike in every order)
ROUGHER = 3.0


def _roughness(values: np.ndarray) -> float:
    variance = float(np.var(values))
    if variance == 0:
        return 0.0
    return sum(float(np.mean(np.diff(values, axis=k) ** 2)) for k in range(3) if values.shape[k] > 1) / variance


def _reading(flat: np.ndarray, shape: tuple[int, int, int], order: tuple[int, int, int]) -> np.ndarray:
    """The flat values as if written with the axes ``order`` from slowest to fastest, as an (nx, ny, nz) array."""
    return np.transpose(flat.reshape([shape[a] for a in order]), np.argsort(order))


def smoother_order(bx: np.ndarray, by: np.ndarray, shape: tuple[int, int, int]) -> tuple[str, float] | None:
    """The axis order (e.g. 'zyx': z slowest, x fastest) in which the flat values read far smoother than in the
    stated C order, and by how much; None when the C order is as smooth as any other that differs from it."""
    flats = [np.asarray(b, dtype=float).ravel() for b in (bx, by)]
    stated = [_reading(f, shape, (0, 1, 2)) for f in flats]
    rough = sum(_roughness(s) for s in stated)
    best: tuple[str, float] | None = None
    for order in itertools.permutations(range(3)):
        if order == (0, 1, 2):
            continue
        read = [_reading(f, shape, order) for f in flats]
        if all(np.array_equal(r, s) for r, s in zip(read, stated)):
            continue
        other = sum(_roughness(r) for r in read)
        ratio = rough / other if other > 0 else (np.inf if rough > 0 else 1.0)
        if ratio > ROUGHER and (best is None or ratio > best[1]):
            best = ("".join(AXES[a] for a in order), ratio)
    return best
