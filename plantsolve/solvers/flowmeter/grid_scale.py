"""Whether a grid field's coordinates are in the unit they are read in, judged from the field's own structure.

A meter's coils sit on the pipe: their field changes by half of its centre value within about the liner section
(beyond the coils' ends along z, next to their windings across). A field that keeps within half of its centre
value over a box many times the liner section, and changes by half only far beyond it, is a field whose
coordinates were written in a smaller unit than they are read in (millimetres under ``[in]``, ``cm`` or ``m``):
the pipe then sees the middle of one or two grid cells, a nearly uniform field, and S comes out near the uniform
field's without a word. A field that nowhere changes by half has no structure to judge by and is left alone, and so
is one that reading in the likely unit would leave as uniform over the liner section as it is read (a magnet far
larger than its pipe by design: S is the same in either unit, and the unit is not in doubt for S).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from plantsolve.solvers.length_units import SIZES

# the field differs from its centre value by this fraction of it: the coils' structure (their ends, their windings)
CHANGE = 0.5
# the field first changes by half this many times farther than the liner section reaches (in the box norm
# max(|x|/R, |y|/R, |z|/(L/2))): no meter's coils are so large for their pipe (the example's field: 1.07)
STRUCTURE_REACH = 5.0
# reading the grid in the likely unit changes the field's largest relative change over the liner section by more
# than this: S would change with the unit. A magnet far larger than its pipe (a wide-gap Helmholtz pair) is uniform
# over the liner section in either unit, and is left alone
MATERIAL = 0.05
# points per axis of the lattice on which a field's change over the liner section is sampled
SAMPLES = 9


@dataclass(frozen=True)
class FarStructure:
    """Where the field first changes by half, far beyond the liner section."""

    point: tuple[float, float, float]  # the grid node nearest the pipe where it does (request units)
    reach: float  # its box-norm distance in liner sections
    likely_unit: str  # the length unit that brings the structure to the pipe with the grid covering it


def far_structure(x: np.ndarray, y: np.ndarray, z: np.ndarray, bx: np.ndarray, by: np.ndarray,
                  radius: float, half_liner: float, stated_unit: str) -> FarStructure | None:
    """The field's nearest change by half when it lies more than STRUCTURE_REACH liner sections out and reading the
    grid in a likely smaller unit changes the field over the liner section materially (by MATERIAL), else None.
    Coordinates in the request's units; ``stated_unit``: the unit they were read in (the file's, or the request's)."""
    # extrapolating: the liner section in the likely unit reaches the grid's edge to within rounding
    field = RegularGridInterpolator((x, y, z), np.stack([bx, by], axis=-1), bounds_error=False, fill_value=None)
    centre = field([[0.0, 0.0, 0.0]])[0]
    size = float(np.hypot(*centre))
    if size == 0:
        return None
    changed = np.hypot(bx - centre[0], by - centre[1]) >= CHANGE * size
    if not np.any(changed):
        return None
    i, j, k = np.nonzero(changed)
    reach = np.maximum(np.maximum(np.abs(x[i]), np.abs(y[j])) / radius, np.abs(z[k]) / half_liner)
    nearest = int(np.argmin(reach))
    if reach[nearest] <= STRUCTURE_REACH:
        return None
    point = (float(x[i[nearest]]), float(y[j[nearest]]), float(z[k[nearest]]))
    cover = min(min(-x[0], x[-1], -y[0], y[-1]) / radius, min(-z[0], z[-1]) / half_liner)
    likely = likely_unit(stated_unit, float(reach[nearest]), cover)
    if likely is None:
        return None
    widen = SIZES[stated_unit] / SIZES[likely]  # the liner section in the likely unit, in the stated unit's numbers
    as_read = liner_change(field, centre, size, radius, half_liner)
    in_likely = liner_change(field, centre, size, radius * widen, half_liner * widen)
    if in_likely - as_read <= MATERIAL:
        return None
    return FarStructure(point, float(reach[nearest]), likely)


def liner_change(field: RegularGridInterpolator, centre: np.ndarray, size: float, radius: float,
                 half_liner: float) -> float:
    """The field's largest change relative to its centre value over the liner section |x|, |y| <= radius,
    |z| <= half_liner (sampled on a lattice of it, the grid's nodes within it included)."""
    x, y, z = (np.unique(np.concatenate([np.linspace(-reach, reach, SAMPLES), nodes[np.abs(nodes) <= reach]]))
               for reach, nodes in ((radius, field.grid[0]), (radius, field.grid[1]), (half_liner, field.grid[2])))
    points = np.stack(np.meshgrid(x, y, z, indexing="ij"), axis=-1).reshape(-1, 3)
    values = field(points)
    return float(np.max(np.hypot(values[:, 0] - centre[0], values[:, 1] - centre[1])) / size)


def likely_unit(stated: str, reach: float, cover: float) -> str | None:
    """The unit nearest below ``stated`` in which the structure lies within STRUCTURE_REACH liner sections while the
    grid still covers the pipe (``cover``: how many times over it does now), or None when no unit does both."""
    smaller = sorted((unit for unit in SIZES if SIZES[unit] < SIZES[stated]), key=lambda unit: -SIZES[unit])
    for unit in smaller:
        factor = SIZES[unit] / SIZES[stated]
        if reach * factor <= STRUCTURE_REACH and cover * factor >= 1 - 1e-9:
            return unit
    return None
