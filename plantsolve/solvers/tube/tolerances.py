"""Pass/fail of an inspection per LRA row and field, against symmetric tolerances (defaults in
``schemas.tube.INSPECTION_DEFAULTS_MM`` / ``_DEG``, the millimetre ones converted into the request's units)."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.tube import (
    INSPECTION_DEFAULTS_DEG,
    INSPECTION_DEFAULTS_MM,
    EndPointCheck,
    FieldCheck,
    InspectionRow,
    InspectionTolerances,
    LraRow,
)
from plantsolve.solvers.geometry import wrap_angle
from plantsolve.solvers.tube.nominal_files import UNIT_MM


def resolved(tol: InspectionTolerances | None, units: str) -> InspectionTolerances:
    """The tolerances with every default filled in, in the request's units."""
    tol = tol or InspectionTolerances()
    values = tol.model_dump()
    for name, mm in INSPECTION_DEFAULTS_MM.items():
        if values[name] is None:
            values[name] = mm / UNIT_MM[units]
    for name, deg in INSPECTION_DEFAULTS_DEG.items():
        if values[name] is None:
            values[name] = deg
    return InspectionTolerances(**values)


def _check(nominal: float, measured: float, tolerance: float, wrap: bool = False) -> FieldCheck:
    dev = float(wrap_angle(measured - nominal, 360.0)) if wrap else measured - nominal
    # a relative slack so that a deviation equal to the tolerance, up to rounding, passes
    return FieldCheck(nominal=nominal, measured=measured, deviation=dev, tolerance=tolerance,
                      ok=bool(abs(dev) <= tolerance * (1 + 1e-9)))


def check_rows(nominal: list[LraRow], measured: list[LraRow], tol: InspectionTolerances) -> list[InspectionRow]:
    """Rows of equal bend counts, in the nominal's order: length on every row, rotation on rows 2..n (the first
    and last rotation are 0 by convention), angle and CLR on the bend rows."""
    n = len(nominal) - 1
    out = []
    for i, (nr, mr) in enumerate(zip(nominal, measured)):
        fields = {"length": _check(nr.length, mr.length, tol.length)}
        if 0 < i < n:
            fields["rotation"] = _check(nr.rotation, mr.rotation, tol.rotation, wrap=True)
        if i < n:
            fields["angle"] = _check(nr.angle, mr.angle, tol.angle)
            fields["bend_radius"] = _check(nr.bend_radius, mr.bend_radius, tol.bend_radius)
        failed = [k for k, v in fields.items() if not v.ok]
        out.append(InspectionRow(row=i + 1, failed=failed, ok=not failed, **fields))
    return out


def check_end_points(nominal_ends: np.ndarray, measured_ends: np.ndarray, tol: InspectionTolerances) -> list[EndPointCheck]:
    """Both ends (start, end), each a distance after the best-fit alignment."""
    out = []
    for name, a, b in zip(("start", "end"), nominal_ends, measured_ends):
        d = float(np.linalg.norm(np.asarray(a) - np.asarray(b)))
        out.append(EndPointCheck(end=name, deviation=d, tolerance=tol.end_point, ok=bool(d <= tol.end_point)))
    return out
