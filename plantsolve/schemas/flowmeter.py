"""Request and result models of the ``flowmeter`` solver (electromagnetic flow meters).

Conventions
-----------
- The pipe axis is z and the liquid flows along +z; the magnetic field B points along +y; the two
  electrodes are centred at (+R, 0) and (-R, 0) in the cross-section (R the pipe radius).
- Lengths are in the request's ``units``, angles in degrees, the field in tesla, velocities in m/s
  and the signal in volts (the signal needs the diameter in metres, so ``units`` matters there); every number
  of the result states its unit (``x-unit`` in the OpenAPI document; rows of mixed columns in a ``*_units``
  field beside them).
- Bounds: the schema holds each scalar to what is physical whatever the length unit (a field of at most 100 T,
  a mean velocity of at most 1000 m/s); the input check holds the pipe radius to 0.01 mm..1 km in any unit
  (422 naming the field), and the report warns (``implausible_*``) outside what meters are built for.
- The cross-section weight function W(x, y) is the weight vector's z-component integrated along z
  and normalised so that, for uniform B, ``S = (1/(pi R^2)) * integral W dA`` and
  ``U = 2 R B (1/(pi R^2)) * integral W v dA``; S = U / (2 R B v_mean) is the sensitivity.
- Scaling: S and W(x/R, y/R) depend only on the electrode half-angle, a/R and L/R (and the shapes
  of the field and the profile); a result for one pipe size holds for every size with the
  geometry scaled.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field

from plantsolve.schemas.common import Measured, Number, Report, StrictModel, Units, plain_numbers, unit


# a field component in tesla: the strongest magnets built reach tens of tesla
Tesla = Annotated[Number, Field(allow_inf_nan=False, ge=-100, le=100)]


# a grid field's points (a flat grid's values, a field file's rows)
GRID_POINTS_MAX = 2_000_000


class Pipe(StrictModel):
    radius: Number = Field(gt=0, le=1e9, allow_inf_nan=False, description="Inner radius R of the liner.")
    liner_length: Number | None = Field(
        default=None, gt=0, le=1e10, allow_inf_nan=False,
        description="Length L of the insulating liner (default 3 diameters, 6 R). The liner section is "
        "modelled as an insulated pipe of this length, its end cross-sections insulated too.")


class Electrodes(StrictModel):
    shape: Literal["patch", "point", "button"] = Field(
        default="patch",
        description="'patch': theta-z patches of half-angle beta and half-length a, equipotential; "
        "'point': point electrodes (Shercliff's weight function); 'button': cylindrical electrodes of "
        "radius r_e through the wall along x, protruding l_e into the flow (0: flush discs), equipotential.")
    half_angle: Number = Field(
        default=22.5, gt=0, lt=90, allow_inf_nan=False,
        description="Half-angle beta of a patch electrode, degrees, 0 < beta < 90 (not used by points and buttons).")
    half_length: Number | None = Field(
        default=None, gt=0, le=1e10, allow_inf_nan=False,
        description="Half-length a of a patch electrode along z; null means electrodes along the whole "
        "liner (the 2-D case, solved exactly). Null for points and buttons.")
    radius: Number | None = Field(
        default=None, gt=0, le=1e9, allow_inf_nan=False,
        description="Radius r_e of a button electrode (units): its face on the wall is y^2 + z^2 <= r_e^2; "
        "0.02 R <= r_e <= 0.8 R and r_e <= L/2. Required for buttons only.")
    protrusion: Number = Field(
        default=0.0, ge=0, le=1e9, allow_inf_nan=False,
        description="Length l_e by which a button enters the flow (units), 0 <= l_e <= 0.9 R (the two tips stay apart); 0 is a flush disc. "
        "Buttons only.")


class UniformField(StrictModel):
    type: Literal["uniform"] = Field(description="The field's form; it selects the model (uniform or grid).")
    magnitude: Number = Field(default=0.01, gt=0, le=100, allow_inf_nan=False,
                             description="|B| in tesla, along +y (at most 100 T; meters use a few mT).")


class GridField(StrictModel):
    """B on a rectilinear grid (from the magnet's finite-element model), trilinearly interpolated.

    ``bx``, ``by``, ``bz`` hold one value per grid point in C order (x slowest, z fastest): the value at
    (x[i], y[j], z[k]) is at index (i * len(y) + j) * len(z) + k. A tool that writes x fastest (MATLAB,
    numpy's order='F', COMSOL's grid export) gives another field, which the values alone cannot tell apart
    (a smooth field reads smooth in several orders): give such a field as ``points`` (each value with its
    coordinates), which has no order.
    The grid must cover the liner section (|x|, |y| <= R, |z| <= L/2). S is normalised by B_y at the pipe centre.
    """

    type: Literal["grid"]
    x: list[Measured] = Field(min_length=2, max_length=400, description="Grid x coordinates, increasing (units).")
    y: list[Measured] = Field(min_length=2, max_length=400, description="Grid y coordinates, increasing (units).")
    z: list[Measured] = Field(min_length=2, max_length=400, description="Grid z coordinates, increasing (units).")
    bx: list[Tesla] = Field(max_length=GRID_POINTS_MAX, description="B_x in tesla per grid point, C order: x slowest, z "
                            "fastest (index (i * len(y) + j) * len(z) + k); a field in another order is "
                            "given as type 'points', which needs none.")
    by: list[Tesla] = Field(max_length=GRID_POINTS_MAX, description="B_y in tesla per grid point (C order).")
    bz: list[Tesla] | None = Field(default=None, max_length=GRID_POINTS_MAX,
                                   description="B_z per grid point; it does not enter U (the flow is axial).")


class PointsField(StrictModel):
    """B at points, each row its coordinates and its value: the form FE tools export (a table of x, y, z, B_x,
    B_y[, B_z]), in any row order. The points must make a complete rectilinear grid (every combination of the
    x, y and z lines given once; a point given twice with the same value is kept once); they are placed on it by
    their coordinates and trilinearly interpolated, as the ``grid`` form."""

    type: Literal["points"]
    points: list[list[Measured]] = Field(
        min_length=8, max_length=1_000_000,
        description="Rows [x, y, z, bx, by] or [x, y, z, bx, by, bz]: coordinates in the request's units, B in "
        "tesla (|B| <= 100 T), in any order; together a complete rectilinear grid covering the liner section.")


class Velocity(StrictModel):
    type: Literal["uniform", "laminar", "power_law", "samples"] = Field(
        default="uniform",
        description="'uniform': v = mean; 'laminar': 2 mean (1 - r^2/R^2); 'power_law': "
        "mean (n+1)(2n+1)/(2n^2) (1 - r/R)^(1/n); 'samples': values at points of the cross-section, "
        "linearly interpolated on their Delaunay triangulation.")
    mean: Number = Field(default=1.0, ge=-1000, le=1000, allow_inf_nan=False,
                        description="Mean axial velocity (m/s), for the analytic profiles; |v| <= 1000 m/s.")
    n: Number = Field(default=7.0, ge=1, le=100, allow_inf_nan=False, description="Power-law exponent.")
    points: list[list[Measured]] | None = Field(
        default=None, max_length=100_000,
        description="Sample points [x, y] in the request's units (for 'samples'); they must cover the cross-section.")
    values: list[Annotated[Number, Field(allow_inf_nan=False, ge=-1000, le=1000)]] | None = Field(
        default=None, max_length=100_000, description="Axial velocity (m/s) at each sample point, |v| <= 1000 m/s.")


# the text of a field file: a 61 x 61 x 81 grid written at full precision by COMSOL is about 40 MB; its rows are
# at most GRID_POINTS_MAX (2,000,000), a grid's points, refused beyond
MAGNETIC_FIELD_FILE_MAX = 50_000_000


class FlowmeterOptions(StrictModel):
    _plain_numbers = plain_numbers("tolerance")

    method: Literal["auto", "integral_equation", "fem", "first_order"] = Field(
        default="auto",
        description="'auto': closed form for full-length (2-D) and point electrodes, the integral equation for "
        "finite patches and flush buttons (uniform or grid field), finite elements for protruding buttons and "
        "for patches too short for the integral equation's mode budget; "
        "'integral_equation': the Galerkin integral equation on the electrode (patches and flush buttons); 'fem': "
        "finite elements (scikit-fem) for patches and buttons; 'first_order': the uniform current-density iterate "
        "(S = sin(beta)/beta for patches).")
    tolerance: Number = Field(default=1e-3, ge=1e-6, le=0.1, allow_inf_nan=False,
                             description="Target accuracy of S; for 'fem' it sets the mesh size.")
    probe_points: list[list[Measured]] = Field(
        default_factory=list, max_length=10_000,
        description="Points [x, y] (or [x, y, z]; z is ignored, W is z-integrated) where W is reported.")
    magnetic_field_file: str | None = Field(
        default=None, min_length=1, max_length=MAGNETIC_FIELD_FILE_MAX,
        description="The magnetic field as the text of a file an FE tool exports, instead of `magnetic_field`: "
        "COMSOL's spreadsheet export ('% Length unit: mm' and '% x y z mf.Bx (T) mf.By (T) mf.Bz (T)' header "
        "lines, then rows) or a CSV whose header names the columns x, y, z, Bx, By[, Bz] with units "
        "('x [mm]', 'Bx [mT]'; T, mT, uT, G; lengths m, cm, mm, um, in, ft; converted to the request's units and "
        "tesla, and said). Rows in any order, together a complete rectilinear grid (as type 'points'); a header "
        "without units is read in the request's units and tesla.")


class FlowmeterRequest(StrictModel):
    units: Units = "mm"
    pipe: Pipe
    electrodes: Electrodes = Field(default_factory=Electrodes)
    magnetic_field: Annotated[UniformField | GridField | PointsField, Field(discriminator="type")] = Field(
        default_factory=lambda: UniformField(type="uniform"),
        description="'uniform' along +y; 'grid': a flat list per component in C order (x slowest); 'points': rows "
        "of coordinates and values in any order, the form that needs no order. An FE tool's export goes in "
        "options.magnetic_field_file instead.")
    velocity: Velocity = Field(default_factory=Velocity)
    reynolds: list[Annotated[Number, Field(allow_inf_nan=False, gt=0, le=1e9)]] = Field(
        default_factory=list, max_length=1000,
        description="Reynolds numbers for the linearity curve: laminar profile below 2300, else the power "
        "law with n = -1.7 + 1.8 log10(Re) (at least that of Re = 4000).")
    options: FlowmeterOptions = Field(default_factory=FlowmeterOptions)


ONE = unit("1")


class LinearityPoint(BaseModel):
    reynolds: float = Field(json_schema_extra=ONE, description="Reynolds number.")
    profile: str
    n: float | None = Field(default=None, json_schema_extra=ONE, description="Power-law exponent (turbulent).")
    sensitivity: float = Field(json_schema_extra=ONE, description="S for this profile.")


class FlowmeterResult(BaseModel):
    kind: Literal["flowmeter"] = Field(default="flowmeter", description="The solver kind of this result (what tells the "
                                   "results of GET /v1/jobs/{id}/result apart).")
    sensitivity: float = Field(description="S = U / (2 R B v_mean) for the request's velocity.", json_schema_extra=ONE)
    sensitivity_first_order: float = Field(
        json_schema_extra=ONE, description="The uniform current-density iterate: sin(beta)/beta for patches, 1 for points, for buttons "
        "that of the flush disc, pi r^2 / integral 2 sqrt(r^2 - y^2) / sqrt(1 - y^2) dy (R = 1).")
    signal: float = Field(description="U in volts for the field and mean velocity (signal_unit).",
                          json_schema_extra=unit("V"))
    signal_unit: Literal["V"] = Field(default="V", description="The signal's unit: volts (a meter's signal is "
                                      "microvolts to millivolts).")
    signal_mv: float = Field(default=0.0, description="The signal in millivolts (the unit meters are read in).",
                             json_schema_extra=unit("mV"))
    units: Units = Field(default="mm", description="The request's length unit: that of grid, electrode_current_map "
                         "and every length here.")
    probes: list[float] = Field(default_factory=list, description="W at each probe point.", json_schema_extra=ONE)
    linearity: list[LinearityPoint] = Field(default_factory=list)
    ideal_meter_residual: float = Field(
        json_schema_extra=ONE, description="Bevir's ideal-meter residual for rectilinear flow: curl W = 0 means W constant over the "
        "cross-section; given as (1/(pi R^2)) integral |W - S_uniform| dA / S_uniform, 0 for an ideal meter.")
    method: str
    error_estimate: float = Field(description="Estimated absolute error of S.", json_schema_extra=ONE)
    grid: list[list[float]] = Field(
        default_factory=list, json_schema_extra=unit("{grid_units}"),
        description="W on a cross-section grid reaching the wall: rows [x, y, W]; x, y in units, W dimensionless "
        "(grid_units).")
    grid_units: list[str] = Field(default_factory=list, description="Unit of each column of grid's rows.")
    electrode_current: list[list[float]] = Field(
        default_factory=list, json_schema_extra=unit("{electrode_current_units}"), description="Electrode current density across the electrode (at z = 0 for finite patches): rows "
        "[theta deg, j R^2 / I] for patches and buttons, [theta deg, j R / I'] (I' per unit length) along the whole liner. "
        "From the integral equation or the closed form; the finite elements report none.")
    electrode_current_units: list[str] = Field(default_factory=list,
                                               description="Unit of each column of electrode_current's rows.")
    electrode_current_map: list[list[float]] = Field(
        default_factory=list, json_schema_extra=unit("{electrode_current_map_units}"), description="The electrode current density over the electrode at +R (integral equation "
        "only): rows [theta deg, z (units), j R^2 / I] on Chebyshev points, the edges singular (inverse square root).")
    electrode_current_map_units: list[str] = Field(
        default_factory=list, description="Unit of each column of electrode_current_map's rows.")
    report: Report
