"""The magnetic field: uniform along +y, or a user's grid (trilinear interpolation): given as a flat grid
(C order), as points with their values, or as the text of an FE tool's export (modules field_points,
field_file).

With W_z = B_x j_y - B_y j_x and j = -grad(phi), the weight is B_y phi_x - B_x phi_y; for a
current that does not vary along z (electrodes along the whole liner) only the z-average of B
over the liner enters. Lengths here are in units of the pipe radius; fields are divided by the
reference B_y at the pipe centre, the B of S = U / (2 R B v_mean).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from plantsolve.schemas.flowmeter import GRID_POINTS_MAX, FlowmeterRequest
from plantsolve.solvers.base import FieldError, InputRejected
from plantsolve.solvers.flowmeter.field_file import FieldFileError, read_field_file
from plantsolve.solvers.flowmeter.field_points import PlacedField, PointsNotAGrid, place_on_grid

B_MAX = 100.0  # tesla, as the schema holds a grid's values
FILE = ("options", "magnetic_field_file")
POINTS = ("magnetic_field", "points")


@dataclass
class RequestField:
    """The request's field on its rectilinear grid, in the request's units and tesla."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    bx: np.ndarray  # (nx, ny, nz)
    by: np.ndarray
    loc: tuple[str, ...]  # the request's field that gave it, for errors
    conversions: list[dict]
    # the units a file's header states, each on its own (None: not stated, read as the request's units or tesla);
    # the request's forms state theirs by the schema
    length_unit: str | None
    field_unit: str | None
    description: str
    cut: str | None = None  # a file's: why its last value may be cut


def _placed(rows: np.ndarray, where, label) -> PlacedField:
    """Rows on their grid; ``where(row, message)`` is the error naming a row, ``label(row)`` a row in a message."""
    too_strong = np.flatnonzero(np.any(np.abs(rows[:, 3:]) > B_MAX, axis=1))
    if len(too_strong):
        raise InputRejected(where(int(too_strong[0]), f"|B| above {B_MAX:g} T ({', '.join(f'{v:g}' for v in rows[too_strong[0], 3:])}): "
                                                      "no magnet makes it (a field in gauss or mT read as tesla?)"))
    try:
        return place_on_grid(rows, label)
    except PointsNotAGrid as exc:
        raise InputRejected(where(exc.row, str(exc))) from None


def request_field(request: FlowmeterRequest) -> RequestField | None:
    """The request's field on its grid, or None for a uniform field. Raises :class:`InputRejected` naming the
    field (and the row or line) when points or a file do not make a complete grid. The flat ``grid`` form is
    taken as checked (``validation.grid_errors``)."""
    f = request.magnetic_field
    text = request.options.magnetic_field_file
    if text is not None:
        if "magnetic_field" in request.model_fields_set:
            raise InputRejected(FieldError(FILE, "the field is given twice, as magnetic_field and as this file: "
                                                 "give one"))
        try:
            table = read_field_file(text, request.units)
        except FieldFileError as exc:
            raise InputRejected(FieldError(FILE, str(exc))) from None
        if len(table.rows) > GRID_POINTS_MAX:
            raise InputRejected(FieldError(FILE, f"the file holds {len(table.rows)} rows; a field has at most "
                                                 f"{GRID_POINTS_MAX:,} points (a grid's)"))

        def where(row, msg):
            return FieldError(FILE, msg if row is None else f"line {int(table.lines[row])}: {msg}")

        placed = _placed(table.rows, where, lambda row: f"line {int(table.lines[row])}")
        return RequestField(placed.x, placed.y, placed.z, placed.bx, placed.by, FILE, table.conversions,
                            table.length_unit, table.field_unit, table.description, table.cut)
    if f.type == "points":
        bad = [k for k, row in enumerate(f.points) if len(row) not in (5, 6)]
        if bad:
            raise InputRejected(FieldError((*POINTS, bad[0]), f"a row is [x, y, z, bx, by] or [x, y, z, bx, by, bz]; "
                                                              f"got {len(f.points[bad[0]])} numbers"))
        if len({len(row) for row in f.points}) > 1:
            raise InputRejected(FieldError(POINTS, "some rows give bz, some not: give it in every row or in none"))

        def where(row, msg):
            return FieldError(POINTS if row is None else (*POINTS, row), msg)

        placed = _placed(np.asarray(f.points, dtype=float), where, lambda row: f"points[{row}]")
        return RequestField(placed.x, placed.y, placed.z, placed.bx, placed.by, POINTS, [], request.units, "T",
                            f"points, {len(f.points)} rows")
    if f.type == "grid":
        shape = (len(f.x), len(f.y), len(f.z))
        return RequestField(*(np.asarray(v, dtype=float) for v in (f.x, f.y, f.z)),
                            np.asarray(f.bx, dtype=float).reshape(shape), np.asarray(f.by, dtype=float).reshape(shape),
                            ("magnetic_field",), [], request.units, "T", "grid (C order)")
    return None


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


def field_grid(request: FlowmeterRequest, given: RequestField | None = None) -> FieldGrid | None:
    """The request's grid field in radius units (``given``: its :func:`request_field`, if read), or None for a
    uniform field."""
    f = given if given is not None else request_field(request)
    if f is None:
        return None
    radius = request.pipe.radius
    x, y, z = (v / radius for v in (f.x, f.y, f.z))
    bx, by = f.bx, f.by
    reference = float(RegularGridInterpolator((x, y, z), by)([[0.0, 0.0, 0.0]])[0])
    return FieldGrid(x, y, z, bx / reference, by / reference, reference)
