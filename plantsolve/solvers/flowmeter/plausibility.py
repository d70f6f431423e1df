"""Plausibility of an electromagnetic flow meter's request and signal: warnings ``implausible_<quantity>`` naming
the quantity, its value, the range meters are built for and the likely mix-up (the README's flowmeter section lists
them), and what a field file leaves unsaid: its units (``field_file_unit_not_stated``) or its end
(``truncated_file``, cut inside its last number). Outside these ranges the physics still holds (S depends on shape
only), so nothing is refused here; the hard bounds are the schema's and the input check's."""

from __future__ import annotations

import math

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.flowmeter.field import FILE, RequestField, request_field
from plantsolve.solvers.flowmeter.grid_scale import far_structure
from plantsolve.solvers.length_units import METRES

BORE_M = (0.002, 3.2)  # inner diameter: DN2 to DN3200, the electromagnetic meters made
FIELD_T = (1e-4, 0.5)  # |B| at the pipe centre: a meter's coils give a few mT
VELOCITY_M_S = (1e-3, 20.0)  # |mean velocity| of liquids in a meter
SIGNAL_V = (1e-7, 0.1)  # |U|: 0.1 µV to 100 mV across the electrodes
PROBE_SPREAD = 1e-3  # probe points all within this fraction of R of the centre: written in a unit 1000x larger
RADIAN_HALF_ANGLE = math.pi / 2  # a patch's half-angle in radians is at most this; in degrees no patch is this narrow
# a magnet's finite-element box reaches a few radii past the pipe: one that reaches 50 radii was written in a length
# unit 1000 times smaller than the request's (mm with units 'm'), and the pipe then lies inside one cell of it
GRID_REACH = 50.0
# a protruding button enters the flow by a visible fraction of R; less than this is metres written with units 'mm'
PROTRUSION_MIN = 1e-3


def _outside(value: float, bounds: tuple[float, float]) -> bool:
    return not bounds[0] <= abs(value) <= bounds[1]


def request_warnings(request: FlowmeterRequest, field_tesla: float,
                     sampled_mean: float | None = None, grid: RequestField | None = None) -> list[Diagnostic]:
    """Bore, field and velocity against what meters are built for; sampled profiles are judged on the mean of
    their interpolated field (``sampled_mean``), as mm/s samples written as m/s mislead just as a mean does.
    ``grid``: the request's field on its grid when already read."""
    out = []
    grid = grid if grid is not None else request_field(request)
    diameter = 2 * request.pipe.radius * METRES[request.units]
    if _outside(diameter, BORE_M):
        big = diameter > BORE_M[1]
        out.append(Diagnostic(
            code="implausible_meter_bore",
            message=f"Meter bore: a pipe radius of {request.pipe.radius:g} {request.units} is a {diameter:.4g} m bore; "
            f"electromagnetic meters are {BORE_M[0] * 1000:g} mm to {BORE_M[1]:g} m: "
            + (f"the numbers of a pipe in mm with units '{request.units}'?" if big else
               "a radius in m with units 'mm'?") + " The signal scales with the bore.",
            details={"quantity": "pipe.radius", "value": request.pipe.radius, "units": request.units,
                     "diameter_m": diameter, "range_m": list(BORE_M)}))
    if _outside(field_tesla, FIELD_T):
        out.append(Diagnostic(
            code="implausible_magnetic_field",
            message=f"Magnetic field: |B| = {field_tesla:g} T at the pipe centre; a meter's coils give "
            f"{FIELD_T[0]:g} to {FIELD_T[1]:g} T: " + ("mT written as T?" if abs(field_tesla) > FIELD_T[1]
                                                         else "gauss or µT written as T?")
            + (" The field file's header states no unit for B: its values were read as tesla."
               if grid is not None and grid.field_unit is None else ""),
            details={"quantity": "magnetic_field", "value": field_tesla, "range_t": list(FIELD_T)}))
    v = request.velocity
    samples = v.type == "samples"
    mean = sampled_mean if samples else v.mean
    if mean is not None and mean != 0 and _outside(mean, VELOCITY_M_S):
        quantity = "velocity.values" if samples else "velocity.mean"
        out.append(Diagnostic(
            code="implausible_velocity",
            message=f"Mean velocity{' of the samples' if samples else ''} ({quantity}): {mean:g} m/s; liquids pass "
            f"meters at {VELOCITY_M_S[0]:g} to {VELOCITY_M_S[1]:g} m/s: "
            + ("mm/s or cm/s written as m/s?" if abs(mean) > VELOCITY_M_S[1] else "a flow rate instead of a velocity?"),
            details={"quantity": quantity, "value": mean, "range_m_s": list(VELOCITY_M_S)}))
    out += (_file_unit_warnings(request, grid) + _cut_file_warning(grid) + _probe_warnings(request)
            + _grid_warnings(request, grid) + _protrusion_warnings(request))
    e = request.electrodes
    if e.shape == "patch" and e.half_angle <= RADIAN_HALF_ANGLE:
        out.append(Diagnostic(
            code="implausible_electrode_half_angle",
            message=f"Electrode half-angle: {e.half_angle:g} degrees, a patch {2 * e.half_angle:g} degrees wide; "
            f"the field is in degrees: radians written as degrees? ({e.half_angle:g} rad = "
            f"{math.degrees(e.half_angle):.4g} degrees) The sensitivity depends on the half-angle.",
            details={"quantity": "electrodes.half_angle", "value": e.half_angle, "units": "deg",
                     "as_radians_deg": math.degrees(e.half_angle)}))
    return out


def _cut_file_warning(f: RequestField | None) -> list[Diagnostic]:
    """A field file cut inside its last number (``truncated_file``): it was read as written, the number short."""
    if f is None or f.loc != FILE or f.cut is None:
        return []
    return [Diagnostic(
        code="truncated_file",
        message=f"Magnetic field file: it has no line ending after its last row, and {f.cut}: the file was cut "
        "inside that number? It was read as written; check the file's end against the export.",
        details={"quantity": ".".join(FILE), "reason": f.cut})]


def _file_unit_warnings(request: FlowmeterRequest, f: RequestField | None) -> list[Diagnostic]:
    """A field file whose header states no length unit or no unit of B is read in the request's units and in tesla:
    said, naming what was assumed, since a file in m read as mm (or in mT read as T) passes the range checks when
    its numbers happen to fit them, and the answer would not show the assumption."""
    if f is None or f.loc != FILE or (f.length_unit is not None and f.field_unit is not None):
        return []
    missing = [what for what, unit in (("length", f.length_unit), ("field", f.field_unit)) if unit is None]
    assumed = {"length": f"its coordinates were read in the request's units ('{request.units}')",
               "field": "its B values were read as tesla"}
    return [Diagnostic(
        code="field_file_unit_not_stated",
        message="Magnetic field file: its header states no " + " and no ".join(
            {"length": "length unit", "field": "unit of B"}[m] for m in missing) + ": "
        + " and ".join(assumed[m] for m in missing)
        + ". State them in the header ('% Length unit: mm' or 'x [mm]'; 'Bx [T]') if the file is in other units: "
        "the sensitivity depends on the grid's lengths and the signal on B.",
        details={"quantity": ".".join(FILE), "not_stated": missing, "read_in": {
            **({"length": request.units} if "length" in missing else {}), **({"field": "T"} if "field" in missing else {})}})
    ]


def _probe_warnings(request: FlowmeterRequest) -> list[Diagnostic]:
    """Several distinct probe points all crowded at the centre: metres given with units 'mm' (25 mm as 0.025)."""
    points = {(float(p[0]), float(p[1])) for p in request.options.probe_points}
    radius = request.pipe.radius
    spread = max((math.hypot(x, y) for x, y in points), default=0.0)
    if len(points) < 2 or spread == 0 or spread > PROBE_SPREAD * radius:
        return []
    return [Diagnostic(
        code="implausible_probe_points",
        message=f"Probe points: all {len(points)} lie within {spread:g} {request.units} of the centre of a pipe of "
        f"radius {radius:g} {request.units} (W there is its centre value): coordinates in m with units "
        f"'{request.units}'? Probe points are in the request's units.",
        details={"quantity": "options.probe_points", "largest_radius": spread, "radius": radius,
                 "units": request.units})]


def _grid_warnings(request: FlowmeterRequest, f: RequestField | None) -> list[Diagnostic]:
    """A field grid reaching far beyond the pipe across it, or whose field changes only far beyond the liner section:
    the variation of B over the cross-section, which is what a grid adds to a uniform field, falls between two grid
    nodes and is lost. Both are coordinates in a smaller unit than they are read in."""
    if f is None:
        return []
    radius = request.pipe.radius
    liner = request.pipe.liner_length if request.pipe.liner_length is not None else 6 * radius
    stated = f.length_unit or request.units
    structure = far_structure(f.x, f.y, f.z, f.bx, f.by, radius, liner / 2, stated)
    likely = structure.likely_unit if structure is not None else None
    if f.loc != FILE:
        read_as = f"the request's units ('{stated}')"
    elif f.length_unit is None:
        read_as = f"the request's units ('{stated}'): the field file's header states no length unit"
    else:
        read_as = f"'{stated}', the unit the file's header states"
    reach = {name: max(abs(float(getattr(f, name)[0])), abs(float(getattr(f, name)[-1]))) for name in ("x", "y")}
    far = {name: r for name, r in reach.items() if r > GRID_REACH * radius}
    if far:
        name, r = max(far.items(), key=lambda item: item[1])
        quantity = f"magnetic_field.{name}" if f.loc == ("magnetic_field",) else ".".join(f.loc) + f" ({name})"
        guess = (f"grid coordinates in {likely} read as '{stated}'?" if likely is not None else
                 f"grid coordinates in a unit 1000 times smaller than '{request.units}' (mm with units 'm')?")
        return [Diagnostic(
            code="implausible_field_grid",
            message=f"Magnetic field grid: {quantity} reaches {r:g} {request.units}, {r / radius:.4g} pipe radii "
            f"(radius {radius:g} {request.units}); a magnet's field is computed a few radii around the pipe: {guess} "
            f"The grid is read in {read_as}; across the pipe the field is read between grid nodes this far apart.",
            details={"quantity": quantity, "reach": r, "radius": radius, "units": request.units,
                     "radii": r / radius, "read_in": stated, "likely_unit": likely})]
    if structure is None:
        return []
    quantity = ".".join(f.loc)
    point = ", ".join(f"{v:g}" for v in structure.point)
    guess = (f"coordinates in {structure.likely_unit} read as '{stated}'? (S changes with the unit: read in "
             f"{structure.likely_unit}, the field changes across the liner section, and that variation is what a grid "
             "adds to a uniform field)")
    return [Diagnostic(
        code="implausible_field_grid",
        message=f"Magnetic field grid: the field of {quantity} first differs by half from its centre value at ({point}) "
        f"{request.units}, {structure.reach:.3g} times as far as the liner section reaches (radius {radius:g}, "
        f"half-length {liner / 2:g} {request.units}); a meter's coils sit on the pipe and their field changes within "
        f"about the liner section, so across the pipe this field is read nearly uniform. The grid is read in "
        f"{read_as}: {guess}",
        details={"quantity": quantity, "read_in": stated, "likely_unit": structure.likely_unit,
                 "structure_point": list(structure.point), "structure_reach": structure.reach,
                 "radius": radius, "half_liner": liner / 2, "units": request.units})]


def _protrusion_warnings(request: FlowmeterRequest) -> list[Diagnostic]:
    """A button protruding by a hair of the radius: a protrusion in metres written with units 'mm'."""
    e = request.electrodes
    radius = request.pipe.radius
    if e.shape != "button" or not 0 < e.protrusion < PROTRUSION_MIN * radius:
        return []
    return [Diagnostic(
        code="implausible_electrode_protrusion",
        message=f"Electrode protrusion: {e.protrusion:g} {request.units}, {e.protrusion / radius:.2g} of the radius "
        f"{radius:g} {request.units}: a flush button in effect. A length in a unit 1000 times larger than "
        f"'{request.units}' (metres with units 'mm')? The protrusion is in the request's units, and a protruding "
        "button's sensitivity falls with it.",
        details={"quantity": "electrodes.protrusion", "value": e.protrusion, "radius": radius, "units": request.units})]


def signal_warnings(signal: float, request: FlowmeterRequest) -> list[Diagnostic]:
    """The signal against what a meter's electrodes give."""
    if signal == 0 or not _outside(signal, SIGNAL_V):
        return []
    return [Diagnostic(
        code="implausible_signal",
        message=f"Signal: U = {signal:.4g} V ({signal * 1000:.4g} mV); a meter's electrodes give {SIGNAL_V[0] * 1e6:g} µV "
        f"to {SIGNAL_V[1] * 1000:g} mV: " + (f"a length unit too large (units '{request.units}' for numbers in mm?), "
                                            "or the field or velocity too large?" if abs(signal) > SIGNAL_V[1] else
                                            "a length unit too small, or the field or velocity too small?"),
        details={"quantity": "signal", "value_v": signal, "range_v": list(SIGNAL_V), "units": request.units})]
