"""Pass/fail of an inspection per LRA row and field, against symmetric tolerances (defaults in
``schemas.tube.INSPECTION_DEFAULTS_MM`` / ``_DEG``, the millimetre ones converted into the request's units).

A field the samples do not determine gets no verdict (``determined`` false) unless its deviation is proven
beyond the tolerance anyway:

* a lower bound (an end straight's length is where the samples end; a bend seen from one side turns at least
  its measured angle) that falls short of the nominal by more than the tolerance: the part may be right and the
  scan short; or that lies within the tolerance but not by 3 sigmas (the part may reach past it). Beyond the
  nominal by more than the tolerance it is a proven failure (the samples are there);
* a field whose standard deviation is larger than its tolerance (the scan cannot resolve the tolerance), or that
  the reconstruction flagged undetermined (a bend radius the samples do not pin down), unless
  |deviation| > tolerance + 3 sigma."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.tube import (
    INSPECTION_DEFAULTS_DEG,
    INSPECTION_DEFAULTS_MM,
    EndPointCheck,
    AngleCheck,
    InspectionRow,
    InspectionTolerances,
    LengthCheck,
    LraRow,
)
from plantsolve.solvers.geometry import wrap_angle
from plantsolve.solvers.tube.nominal_files import UNIT_MM


PLAUSIBLE_ANGLE_DEG = 10.0  # benders hold angles and rotations to a degree or so
MIN_ANGLE_DEG = 0.1  # … no finer: a tolerance below it is radians typed as degrees (0.5° = 0.0087 rad)
PLAUSIBLE_LENGTH_RADII = 4.0  # … and lengths to a fraction of the tube's diameter
PLAUSIBLE_LENGTH_OF_PART = 0.05


def implausible(tol: InspectionTolerances | None, pipe_radius: float, nominal: list[LraRow],
                units: str) -> list[Diagnostic]:
    """Warnings on given tolerances so wide that the inspection cannot fail what they cover: a length beyond 4 tube
    radii and 5 % of the nominal part's length (a millimetre tolerance given in a metre request), an angle or
    rotation beyond 10°; and so fine that noise decides: an angle or rotation under 0.1° (radians given as degrees).
    The inspection uses them as given."""
    if tol is None:
        return []
    part = sum(r.length for r in nominal) + sum(r.bend_radius * np.radians(r.angle) for r in nominal[:-1])
    limit = max(PLAUSIBLE_LENGTH_RADII * pipe_radius, PLAUSIBLE_LENGTH_OF_PART * part)
    out = []
    for name, value in tol.model_dump(exclude_none=True).items():
        if name in INSPECTION_DEFAULTS_MM and value > limit:
            meant = "".join(f"; meant in {u} ({value:g} {u} = {value * UNIT_MM[u] / UNIT_MM[units]:g} {units})?"
                            for u in ("mm",) if UNIT_MM[u] < UNIT_MM[units])
            out.append(Diagnostic(code="implausible_inspection_tolerance", message=(
                f"inspection_tolerances.{name} {value:g} {units} is more than {PLAUSIBLE_LENGTH_RADII:g} tube radii "
                f"and {PLAUSIBLE_LENGTH_OF_PART:.0%} of the nominal part's length ({limit:.4g} {units}): every "
                f"deviation within it passes{meant or '.'}"),
                details={"field": name, "tolerance": value, "units": units, "plausible_up_to": limit}))
        elif name in INSPECTION_DEFAULTS_DEG and value > PLAUSIBLE_ANGLE_DEG:
            out.append(Diagnostic(code="implausible_inspection_tolerance", message=(
                f"inspection_tolerances.{name} {value:g}° is more than {PLAUSIBLE_ANGLE_DEG:g}°: every bend within "
                f"it passes (benders hold {name}s to about a degree); a typing slip?"),
                details={"field": name, "tolerance": value, "units": "deg", "plausible_up_to": PLAUSIBLE_ANGLE_DEG}))
        elif name in INSPECTION_DEFAULTS_DEG and value < MIN_ANGLE_DEG:
            out.append(Diagnostic(code="implausible_inspection_tolerance", message=(
                f"inspection_tolerances.{name} {value:g}° is less than {MIN_ANGLE_DEG:g}°, finer than benders hold "
                f"and scans measure {name}s: the verdict is decided by the scan's noise; meant in radians "
                f"({value:g} rad = {np.degrees(value):.3g}°)?"),
                details={"field": name, "tolerance": value, "units": "deg", "plausible_from": MIN_ANGLE_DEG}))
    return out


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


PROVEN = 3.0  # standard deviations beyond the tolerance that make a failure proven on an undetermined field


def _check(nominal: float, measured: LraRow, name: str, tolerance: float, wrap: bool = False):
    value = float(getattr(measured, name))
    dev = float(wrap_angle(value - nominal, 360.0)) if wrap else value - nominal
    # a relative slack so that a deviation equal to the tolerance, up to rounding, passes
    ok = bool(abs(dev) <= tolerance * (1 + 1e-9))
    sigma = getattr(measured, f"sigma_{name}", None)
    bound = getattr(measured, f"{name}_bound", None)
    determined = True
    if bound == "lower":
        # the part reaches the bound or past it: an end straight's cut end lies one to three sigmas (the samples'
        # spacing) beyond the last sample. Past the nominal by more than the tolerance is a proven failure; within
        # it, a pass only when three sigmas further still are (before, a bound within the tolerance passed
        # whatever its sigma: a sparse scan 0.36 ± 0.48 mm past a straight made 1.8 mm long passed the part)
        limit = tolerance * (1 + 1e-9)
        determined = dev > limit or -limit <= dev and dev + PROVEN * (sigma or 0.0) <= limit
    elif name in measured.undetermined or (sigma is not None and sigma > tolerance):
        determined = abs(dev) > tolerance + PROVEN * (sigma or 0.0)
    model = AngleCheck if name in ("rotation", "angle") else LengthCheck
    return model(nominal=nominal, measured=value, deviation=dev, tolerance=tolerance, ok=ok if determined else None,
                 determined=determined, sigma=sigma, bound=bound)


def row_ok(failed: list[str], undetermined: list[str]) -> bool | None:
    """A row's verdict from its fields': failed when a determined field is out of tolerance, none (null) when no
    field failed but one is not determined, passed only when every field is determined and within tolerance."""
    return False if failed else None if undetermined else True


def check_rows(nominal: list[LraRow], measured: list[LraRow], tol: InspectionTolerances) -> list[InspectionRow]:
    """Rows of equal bend counts, in the nominal's order: length on every row, rotation on rows 2..n (the first
    and last rotation are 0 by convention), angle and CLR on the bend rows. ``measured`` rows carry what the
    samples determine (sigmas, bounds, ``undetermined``) in the nominal's order."""
    n = len(nominal) - 1
    out = []
    for i, (nr, mr) in enumerate(zip(nominal, measured)):
        fields = {"length": _check(nr.length, mr, "length", tol.length)}
        if 0 < i < n:
            fields["rotation"] = _check(nr.rotation, mr, "rotation", tol.rotation, wrap=True)
        if i < n:
            fields["angle"] = _check(nr.angle, mr, "angle", tol.angle)
            fields["bend_radius"] = _check(nr.bend_radius, mr, "bend_radius", tol.bend_radius)
        failed = [k for k, v in fields.items() if v.ok is False]
        undetermined = [k for k, v in fields.items() if not v.determined]
        out.append(InspectionRow(row=i + 1, failed=failed, undetermined=undetermined, ok=row_ok(failed, undetermined),
                                 **fields))
    return out


def stops_short(length: LengthCheck) -> bool:
    """Whether the samples may stop short of an end straight's end by an unknown amount, so that its end point is no
    verdict: a lower bound short of the nominal by more than the tolerance, or a length not determined otherwise (a
    gap, a sigma beyond the tolerance). A lower bound within the tolerance but not by three sigmas is no such case:
    the part's end lies at most three sigmas further on (``reach`` of :func:`check_end_points`), and an end point
    off by more than the tolerance plus that is a proven failure."""
    if length.determined:
        return False
    return length.bound != "lower" or length.deviation < -length.tolerance * (1 + 1e-9)


def check_end_points(nominal_ends: np.ndarray, measured_ends: np.ndarray, tol: InspectionTolerances,
                     short: tuple[bool, bool] = (False, False),
                     reach: tuple[float, float] = (0.0, 0.0)) -> list[EndPointCheck]:
    """Both ends (start, end), each a distance after the best-fit alignment; an end whose straight the samples
    stop short on (``short``, :func:`stops_short`) is no verdict unless it passes. ``reach``: how far past the last
    samples the part's end may lie (three sigmas of an end straight that is a lower bound); an end passes only when
    that far still is within the tolerance, and fails only when it lies beyond the tolerance even that much nearer."""
    out = []
    for name, a, b, s, r in zip(("start", "end"), nominal_ends, measured_ends, short, reach):
        d = float(np.linalg.norm(np.asarray(a) - np.asarray(b)))
        passed = bool(d + r <= tol.end_point)
        failed = bool(d - r > tol.end_point) and not s
        out.append(EndPointCheck(end=name, deviation=d, tolerance=tol.end_point,
                                 ok=passed if passed or failed else None, determined=passed or failed))
    return out
