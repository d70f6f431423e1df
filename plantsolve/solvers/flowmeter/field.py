"""The magnetic field: uniform along +y, or a user's grid (trilinear interpolation).

With W_z = B_x j_y - B_y j_x and j = -grad(phi), the weight is B_y phi_x - B_x phi_y; for a
current that does not vary along z (electrodes along the whole liner) only the z-average of B
over the liner enters. Lengths here are in units of the pipe radius; fields are divided by the
reference B_y at the pipe centre, the B of S = U / (2 R B v_mean).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from plantsolve.schemas.flowmeter import FlowmeterRequest


@dataclass
class FieldGrid:
    """B / B_ref on a grid in radius units."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    bx: np.ndarray  # (nx, ny, nz)
    by: np.ndarray
    reference: float  # B_y at the centre, tesla

    def at(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B_x, B_y) / B_ref at points (n, 3)."""
        grid = (self.x, self.y, self.z)
        return (RegularGridInterpolator(grid, self.bx)(points), RegularGridInterpolator(grid, self.by)(points))

    def liner_average(self, half_liner: float):
        """A function (x, y) -> (mean B_x, mean B_y) / B_ref over |z| < half_liner: each grid column's
        piecewise-linear profile averaged exactly, then bilinear in x and y (what the trilinear
        interpolant's z-average is)."""
        inner = self.z[(self.z > -half_liner) & (self.z < half_liner)]
        knots = np.concatenate([[-half_liner], inner, [half_liner]])
        columns = []
        for values in (self.bx, self.by):
            along = np.stack([np.interp(knots, self.z, values[i, j]) for i in range(len(self.x)) for j in range(len(self.y))])
            mean = np.trapezoid(along, knots, axis=1) / (2 * half_liner)
            columns.append(RegularGridInterpolator((self.x, self.y), mean.reshape(len(self.x), len(self.y))))

        def average(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            pts = np.column_stack([np.ravel(x), np.ravel(y)])
            return columns[0](pts).reshape(np.shape(x)), columns[1](pts).reshape(np.shape(x))

        return average


def field_grid(request: FlowmeterRequest) -> FieldGrid | None:
    """The request's grid field in radius units, or None for a uniform field."""
    f = request.magnetic_field
    if f.type != "grid":
        return None
    radius = request.pipe.radius
    x, y, z = (np.asarray(v, dtype=float) / radius for v in (f.x, f.y, f.z))
    shape = (len(x), len(y), len(z))
    bx = np.asarray(f.bx, dtype=float).reshape(shape)
    by = np.asarray(f.by, dtype=float).reshape(shape)
    reference = float(RegularGridInterpolator((x, y, z), by)([[0.0, 0.0, 0.0]])[0])
    return FieldGrid(x, y, z, bx / reference, by / reference, reference)
